// Four translated copies of one mesh as four meshes against four instances
// of one acceleration structure (Debian's Embree 3): random-ray throughput,
// 2 threads, rtcIntersect1, three rounds. The spheres sit where `plsr bench
// peers` puts them. Not part of the build; the README's measurement of
// 2026-11-29 came from it.
//
//   g++ -O2 -std=c++17 instances.cpp -o instances -lembree3 -lpthread
//   ./instances out/bench-peers/sphere.obj out/bench-peers/ground.obj        # origins over the ground
//   ./instances out/bench-peers/sphere.obj out/bench-peers/ground.obj near   # origins among the spheres
#include <embree3/rtcore.h>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <vector>
#include <thread>
#include <chrono>
#include <fstream>
#include <sstream>
#include <string>
#include <algorithm>
#include <xmmintrin.h>
#include <pmmintrin.h>
struct Mesh{std::vector<float> v; std::vector<unsigned> t;};
Mesh load(const char* path){Mesh m; std::ifstream f(path); std::string line;
  while(std::getline(f,line)){
    if(line.size()>2&&line[0]=='v'&&line[1]==' '){std::istringstream is(line.substr(2)); float a,b,c; is>>a>>b>>c; m.v.push_back(a);m.v.push_back(b);m.v.push_back(c);}
    else if(line.size()>2&&line[0]=='f'&&line[1]==' '){std::istringstream is(line.substr(2)); std::string w; std::vector<unsigned> idx; while(is>>w) idx.push_back(std::stoul(w.substr(0,w.find('/')))-1);
      for(size_t k=1;k+1<idx.size();k++){m.t.push_back(idx[0]);m.t.push_back(idx[k]);m.t.push_back(idx[k+1]);}}}
  return m;}
RTCGeometry geom(RTCDevice d,const Mesh&m,float dx,float dy,float dz){
  RTCGeometry g=rtcNewGeometry(d,RTC_GEOMETRY_TYPE_TRIANGLE);
  float* vb=(float*)rtcSetNewGeometryBuffer(g,RTC_BUFFER_TYPE_VERTEX,0,RTC_FORMAT_FLOAT3,12,m.v.size()/3+1);
  for(size_t i=0;i<m.v.size();i+=3){vb[i]=m.v[i]+dx;vb[i+1]=m.v[i+1]+dy;vb[i+2]=m.v[i+2]+dz;}
  unsigned* ib=(unsigned*)rtcSetNewGeometryBuffer(g,RTC_BUFFER_TYPE_INDEX,0,RTC_FORMAT_UINT3,12,m.t.size()/3);
  std::copy(m.t.begin(),m.t.end(),ib); rtcCommitGeometry(g); return g;}
static unsigned long long st=88172645463325252ull;
float rnd(){st^=st<<13;st^=st>>7;st^=st<<17;return (st>>40)*(1.0f/16777216.0f);}
int main(int argc,char**argv){
  Mesh sphere=load(argv[1]), ground=load(argv[2]); float tx[4]={-3.3f,-1.1f,1.1f,3.3f};
  RTCDevice d=rtcNewDevice(nullptr);
  RTCScene copies=rtcNewScene(d); rtcSetSceneBuildQuality(copies,RTC_BUILD_QUALITY_HIGH);
  { RTCGeometry g=geom(d,ground,0,0,0); rtcAttachGeometry(copies,g); rtcReleaseGeometry(g);
    for(int i=0;i<4;i++){RTCGeometry s=geom(d,sphere,tx[i],1,0); rtcAttachGeometry(copies,s); rtcReleaseGeometry(s);} }
  rtcCommitScene(copies);
  RTCScene proto=rtcNewScene(d); rtcSetSceneBuildQuality(proto,RTC_BUILD_QUALITY_HIGH);
  { RTCGeometry s=geom(d,sphere,0,0,0); rtcAttachGeometry(proto,s); rtcReleaseGeometry(s);} rtcCommitScene(proto);
  RTCScene inst=rtcNewScene(d); rtcSetSceneBuildQuality(inst,RTC_BUILD_QUALITY_HIGH);
  { RTCGeometry g=geom(d,ground,0,0,0); rtcAttachGeometry(inst,g); rtcReleaseGeometry(g);
    for(int i=0;i<4;i++){RTCGeometry I=rtcNewGeometry(d,RTC_GEOMETRY_TYPE_INSTANCE); rtcSetGeometryInstancedScene(I,proto);
      float xf[12]={1,0,0, 0,1,0, 0,0,1, tx[i],1,0}; rtcSetGeometryTransform(I,0,RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR,xf); rtcCommitGeometry(I); rtcAttachGeometry(inst,I); rtcReleaseGeometry(I);} }
  rtcCommitScene(inst);
  float lo[3]={-20,0,-20},hi[3]={20,2.1f,20}; if(argc>3){lo[0]=-4.4f;lo[2]=-1.1f;hi[0]=4.4f;hi[2]=1.1f;}
  const int N=2000000; std::vector<float> o(3*N),dir(3*N);
  for(int i=0;i<N;i++){for(int k=0;k<3;k++)o[3*i+k]=lo[k]+(hi[k]-lo[k])*rnd();
    float z=1-2*rnd(),ph=6.2831853f*rnd(),r=std::sqrt(std::max(0.f,1-z*z)); dir[3*i]=r*std::cos(ph);dir[3*i+1]=r*std::sin(ph);dir[3*i+2]=z;}
  auto run=[&](RTCScene s){
    auto t0=std::chrono::steady_clock::now(); std::vector<std::thread> th; std::vector<long> hits(2);
    for(int w=0;w<2;w++) th.emplace_back([&,w]{
      _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON); _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
      RTCIntersectContext c; rtcInitIntersectContext(&c); long h=0;
      for(int i=w*N/2;i<(w+1)*N/2;i++){RTCRayHit rh; rh.ray.org_x=o[3*i];rh.ray.org_y=o[3*i+1];rh.ray.org_z=o[3*i+2];rh.ray.dir_x=dir[3*i];rh.ray.dir_y=dir[3*i+1];rh.ray.dir_z=dir[3*i+2];
        rh.ray.tnear=0;rh.ray.tfar=INFINITY;rh.ray.mask=-1;rh.ray.flags=0;rh.ray.time=0;rh.hit.geomID=RTC_INVALID_GEOMETRY_ID;rh.hit.instID[0]=RTC_INVALID_GEOMETRY_ID; rtcIntersect1(s,&c,&rh); h+=rh.hit.geomID!=RTC_INVALID_GEOMETRY_ID;}
      hits[w]=h;});
    for(auto&t:th)t.join();
    return std::make_pair(N/std::chrono::duration<double>(std::chrono::steady_clock::now()-t0).count()/1e6,hits[0]+hits[1]);};
  for(int r=0;r<3;r++){auto a=run(copies); auto b=run(inst); printf("copies %.2f (hits %ld)  instances %.2f (hits %ld)\n",a.first,a.second,b.first,b.second);}
}
