// Raw random-ray throughput of one Embree 3 build on OBJ meshes: the same
// 2 million random rays (origins uniform in the meshes' bounds, directions
// uniform), 2 threads, best of 3, through rtcIntersect1, rtcIntersect16,
// rtcIntersectNp (chunks of 256) and rtcIntersect8. Not part of the build;
// the README's measurements of 2026-11-29 came from it. Build and run:
//
//   g++ -O2 -std=c++17 raw_rays.cpp -o raw_rays_debian -lembree3 -lpthread
//   ./raw_rays_debian out/bench-peers/glossy-env-meshes/*.obj
//
// and, against the Embree that Mitsuba's wheel bundles (its API lives in a
// C++ namespace, which RTC_NAMESPACE_USE opens), with M its package folder:
//
//   g++ -O2 -std=c++17 -I$M/include raw_rays.cpp -o raw_rays_mitsuba -L$M -lembree3 -Wl,-rpath,$M -lpthread
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
#include <xmmintrin.h>
#include <pmmintrin.h>
RTC_NAMESPACE_USE
struct V{float x,y,z;};
static float lo[3]={1e30f,1e30f,1e30f}, hi[3]={-1e30f,-1e30f,-1e30f};
void load(RTCDevice d, RTCScene s, const char* path){
  std::ifstream f(path); std::string line; std::vector<float> v; std::vector<unsigned> t;
  while(std::getline(f,line)){
    if(line.size()>2&&line[0]=='v'&&line[1]==' '){std::istringstream is(line.substr(2)); float a,b,c; is>>a>>b>>c; v.push_back(a);v.push_back(b);v.push_back(c);
      float p[3]={a,b,c}; for(int k=0;k<3;k++){lo[k]=std::min(lo[k],p[k]);hi[k]=std::max(hi[k],p[k]);}}
    else if(line.size()>2&&line[0]=='f'&&line[1]==' '){std::istringstream is(line.substr(2)); std::string w; std::vector<unsigned> idx; while(is>>w) idx.push_back(std::stoul(w.substr(0,w.find('/')))-1);
      for(size_t k=1;k+1<idx.size();k++){t.push_back(idx[0]);t.push_back(idx[k]);t.push_back(idx[k+1]);}}
  }
  RTCGeometry g=rtcNewGeometry(d,RTC_GEOMETRY_TYPE_TRIANGLE);
  float* vb=(float*)rtcSetNewGeometryBuffer(g,RTC_BUFFER_TYPE_VERTEX,0,RTC_FORMAT_FLOAT3,12,v.size()/3+1);
  std::copy(v.begin(),v.end(),vb);
  unsigned* ib=(unsigned*)rtcSetNewGeometryBuffer(g,RTC_BUFFER_TYPE_INDEX,0,RTC_FORMAT_UINT3,12,t.size()/3);
  std::copy(t.begin(),t.end(),ib);
  rtcCommitGeometry(g); rtcAttachGeometry(s,g); rtcReleaseGeometry(g);
}
static unsigned long long st=88172645463325252ull;
float rnd(){st^=st<<13;st^=st>>7;st^=st<<17;return (st>>40)*(1.0f/16777216.0f);}
int main(int argc,char**argv){
  RTCDevice d=rtcNewDevice(getenv("CFG")); RTCScene s=rtcNewScene(d);
  rtcSetSceneBuildQuality(s,RTC_BUILD_QUALITY_HIGH);
  for(int i=1;i<argc;i++) load(d,s,argv[i]);
  rtcCommitScene(s);
  const int N=2000000; std::vector<float> o(3*N),dir(3*N);
  for(int i=0;i<N;i++){for(int k=0;k<3;k++)o[3*i+k]=lo[k]+(hi[k]-lo[k])*rnd();
    float z=1-2*rnd(),ph=6.2831853f*rnd(),r=std::sqrt(std::max(0.f,1-z*z)); dir[3*i]=r*std::cos(ph);dir[3*i+1]=r*std::sin(ph);dir[3*i+2]=z;}
  auto run=[&](int mode){
    auto t0=std::chrono::steady_clock::now(); std::vector<std::thread> th; std::vector<long> hits(2);
    for(int w=0;w<2;w++) th.emplace_back([&,w]{
      _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON); _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
      RTCIntersectContext c; rtcInitIntersectContext(&c); long h=0;
      int a=w*N/2,b=(w+1)*N/2;
      if(mode==0){ for(int i=a;i<b;i++){RTCRayHit rh; rh.ray.org_x=o[3*i];rh.ray.org_y=o[3*i+1];rh.ray.org_z=o[3*i+2];rh.ray.dir_x=dir[3*i];rh.ray.dir_y=dir[3*i+1];rh.ray.dir_z=dir[3*i+2];
        rh.ray.tnear=0;rh.ray.tfar=INFINITY;rh.ray.mask=-1;rh.ray.flags=0;rh.ray.time=0;rh.hit.geomID=RTC_INVALID_GEOMETRY_ID; rtcIntersect1(s,&c,&rh); h+=rh.hit.geomID!=RTC_INVALID_GEOMETRY_ID;}}
      else if(mode==2){ const int C=256; std::vector<float> ox(C),oy(C),oz(C),dx(C),dy(C),dz(C),tn(C),tf(C),tm(C),u(C),v(C),nx(C),ny(C),nz(C); std::vector<unsigned> mk(C),id(C),fl(C),gi(C),pi(C),ii(C);
        for(int i=a;i<b;i+=C){int n=std::min(C,b-i); for(int j=0;j<n;j++){int q=i+j; ox[j]=o[3*q];oy[j]=o[3*q+1];oz[j]=o[3*q+2];dx[j]=dir[3*q];dy[j]=dir[3*q+1];dz[j]=dir[3*q+2];tn[j]=0;tf[j]=INFINITY;tm[j]=0;mk[j]=-1;fl[j]=0;id[j]=j;gi[j]=RTC_INVALID_GEOMETRY_ID;}
          RTCRayHitNp rh; rh.ray.org_x=ox.data();rh.ray.org_y=oy.data();rh.ray.org_z=oz.data();rh.ray.dir_x=dx.data();rh.ray.dir_y=dy.data();rh.ray.dir_z=dz.data();rh.ray.tnear=tn.data();rh.ray.tfar=tf.data();rh.ray.time=tm.data();rh.ray.mask=mk.data();rh.ray.id=id.data();rh.ray.flags=fl.data();
          rh.hit.Ng_x=nx.data();rh.hit.Ng_y=ny.data();rh.hit.Ng_z=nz.data();rh.hit.u=u.data();rh.hit.v=v.data();rh.hit.primID=pi.data();rh.hit.geomID=gi.data();rh.hit.instID[0]=ii.data();
          rtcIntersectNp(s,&c,&rh,n); for(int j=0;j<n;j++) h+=gi[j]!=RTC_INVALID_GEOMETRY_ID;}}
      else if(mode==3){ for(int i=a;i<b;i+=8){ alignas(64) RTCRayHit8 rh; alignas(64) int valid[8];
        for(int j=0;j<8;j++){int q=i+j; valid[j]=q<b?-1:0; if(q>=b) q=b-1; rh.ray.org_x[j]=o[3*q];rh.ray.org_y[j]=o[3*q+1];rh.ray.org_z[j]=o[3*q+2];rh.ray.dir_x[j]=dir[3*q];rh.ray.dir_y[j]=dir[3*q+1];rh.ray.dir_z[j]=dir[3*q+2];
        rh.ray.tnear[j]=0;rh.ray.tfar[j]=INFINITY;rh.ray.mask[j]=-1;rh.ray.flags[j]=0;rh.ray.time[j]=0;rh.hit.geomID[j]=RTC_INVALID_GEOMETRY_ID;}
        rtcIntersect8(valid,s,&c,&rh); for(int j=0;j<8;j++) h+=valid[j]&&rh.hit.geomID[j]!=RTC_INVALID_GEOMETRY_ID;}}
      else { for(int i=a;i<b;i+=16){ alignas(64) RTCRayHit16 rh; alignas(64) int valid[16];
        for(int j=0;j<16;j++){int q=i+j; valid[j]=q<b?-1:0; if(q>=b) q=b-1; rh.ray.org_x[j]=o[3*q];rh.ray.org_y[j]=o[3*q+1];rh.ray.org_z[j]=o[3*q+2];rh.ray.dir_x[j]=dir[3*q];rh.ray.dir_y[j]=dir[3*q+1];rh.ray.dir_z[j]=dir[3*q+2];
        rh.ray.tnear[j]=0;rh.ray.tfar[j]=INFINITY;rh.ray.mask[j]=-1;rh.ray.flags[j]=0;rh.ray.time[j]=0;rh.hit.geomID[j]=RTC_INVALID_GEOMETRY_ID;}
        rtcIntersect16(valid,s,&c,&rh); for(int j=0;j<16;j++) h+=valid[j]&&rh.hit.geomID[j]!=RTC_INVALID_GEOMETRY_ID;}}
      hits[w]=h;});
    for(auto&t:th)t.join();
    double sec=std::chrono::duration<double>(std::chrono::steady_clock::now()-t0).count();
    return std::make_pair(N/sec/1e6,hits[0]+hits[1]);
  };
  for(int mode=0;mode<4;mode++){double best=0;long h=0;for(int r=0;r<3;r++){auto p=run(mode);best=std::max(best,p.first);h=p.second;}
    printf("%s %s: %.2f Mrays/s (hits %ld)\n", RTC_VERSION_STRING, mode==0?"rtcIntersect1":mode==1?"rtcIntersect16":mode==2?"rtcIntersectNp(256)":"rtcIntersect8", best, h);}
}
