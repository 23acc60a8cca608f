//! The unidirectional path tracer.
//!
//! Per camera sample: next-event estimation at every scattering vertex (one
//! light picked by power, one point on it), BSDF sampling to continue the
//! path, multiple importance sampling of the two strategies with the power
//! heuristic (Veach 1997), and Russian roulette by throughput (times `η²`
//! of the refractions so far) from [`RenderJob::rr_depth`] scattering events
//! on (4 by default).
//! `max_depth` counts scattering events, as pbrt's `maxdepth` does: a path of
//! `max_depth = 1` is direct lighting only.
//!
//! The work is organised as a small wavefront per image tile: all paths of
//! one sample pass over a tile advance together, so their rays go to Embree in
//! batches: camera rays as a coherent stream, then each bounce's continuation
//! rays and shadow rays as streams. Every path draws from its own random
//! stream ([`PathSampler::for_sample`]) and every pixel adds its samples in sample
//! order, so an image is bit-identical whatever the number of threads.
//!
//! Every scene runs on a vectorised version of the same wavefront
//! ([`soa`]): structure-of-arrays lanes, compiled for AVX-512, AVX2 and
//! the baseline and picked at run time ([`Isa`]); Lambert surfaces are
//! shaded in its branch-free loop, the other models by this module's
//! [`scatter`] lane by lane. It performs the same floating-point
//! operations in the same order with the same random numbers, so it
//! renders the same image bit for bit; `RenderOptions::vectorised`
//! (`plsr render --scalar`) turns it off, leaving this general integrator
//! as the reference.

pub mod gradient;
pub mod soa;
mod spawn;

pub use soa::{Isa, SoaScene};

use crate::accel::{Ray, RayHit, ShadowRay};
use crate::bsdf::Bsdf;
pub use crate::film::{PixelSums, Tile};
use crate::job::RenderJob;
use crate::light::{Light, LightSample};
use crate::prefetch::prefetch;
use crate::sampler::PathSampler;
use crate::scene::Scene;
use crate::warp::{power_heuristic, Frame};
use glam::{Vec2, Vec3};
use spawn::{ray_epsilon, shadow_segment, spawn_origin};
use std::time::Instant;

/// Whether Russian roulette spins for a path that has reached
/// [`RenderJob::rr_depth`] (`at_depth`), judged by `rr_beta`, its
/// throughput `β` times `η²` of the refractions it went through (see
/// [`PathState::eta_scale`]): only where the largest channel `q` of
/// `rr_beta` is below 1, and only then does it draw a number.
#[inline(always)]
pub(crate) fn roulette_spins(rr_beta: Vec3, at_depth: bool) -> bool {
    at_depth && rr_beta.max_element() < 1.0
}

/// The roulette's outcome for the uniform number `u`: the path survives
/// with probability `q` (the largest channel of `rr_beta`), its throughput
/// `beta` divided by `q` so the estimate stays unbiased.
#[inline(always)]
pub(crate) fn roulette(beta: Vec3, rr_beta: Vec3, u: f32) -> (bool, Vec3) {
    let q = rr_beta.max_element();
    (u < q, beta / q)
}

const COHERENT_CAMERA: bool = true;

/// Counts of rays traced and the time spent tracing them, for throughput
/// reports (not comparable between runs: it holds a timing).
#[derive(Debug, Clone, Copy, Default)]
pub struct RayStats {
    /// Camera rays (closest hit).
    pub camera: u64,
    /// Continuation rays after scattering (closest hit).
    pub bounce: u64,
    /// Shadow rays of next-event estimation (any hit).
    pub shadow: u64,
    /// Nanoseconds spent inside Embree's queries, summed over threads (the
    /// rest of a render's CPU time is shading and bookkeeping). Timed per
    /// batch of a wavefront, so the clock costs nothing measurable.
    pub trace_nanos: u64,
}

impl RayStats {
    /// All rays.
    pub fn total(&self) -> u64 {
        self.camera + self.bounce + self.shadow
    }

    /// Adds another count.
    pub fn add(&mut self, o: &RayStats) {
        self.camera += o.camera;
        self.bounce += o.bounce;
        self.shadow += o.shadow;
        self.trace_nanos += o.trace_nanos;
    }
}

/// The result of rendering one tile.
#[derive(Debug, Clone)]
pub struct TileResult {
    /// The tile.
    pub tile: Tile,
    /// Per-pixel sums, row-major within the tile.
    pub pixels: Vec<PixelSums>,
    /// Rays traced.
    pub rays: RayStats,
}

#[derive(Clone)]
struct PathState {
    pixel: u32,
    rng: PathSampler,
    beta: Vec3,
    radiance: Vec3,
    /// Solid-angle pdf of the BSDF sample that produced the current ray;
    /// 0 after a delta lobe (which light sampling could not have found).
    prev_pdf: f32,
    prev_point: Vec3,
    /// Scattering events so far.
    depth: u32,
    /// The product of `η²` over the refractions so far (`η` the relative
    /// index across each): refraction scales radiance by `1/η²`, which
    /// the roulette must not mistake for lost energy, or paths inside
    /// glass (β × 1/1.5² on the way in) would be ended needlessly; the
    /// roulette judges `β · eta_scale` (pbrt-v4's `etaScale`, Mitsuba's
    /// `eta`).
    eta_scale: f32,
    alive: bool,
}

/// A shadow ray's pending contribution: path index and radiance if unoccluded.
struct PendingLight {
    path: u32,
    radiance: Vec3,
}

/// Scratch buffers reused across the sample passes of a tile.
#[derive(Default)]
struct Wavefront {
    paths: Vec<PathState>,
    rays: Vec<RayHit>,
    shadow_rays: Vec<ShadowRay>,
    pending: Vec<PendingLight>,
    /// What was looked up ahead of each path's shading for this bounce
    /// (see [`sample_environment_ahead`]).
    ahead: Vec<Ahead>,
    /// The paths that sample the environment, and their numbers.
    env_paths: Vec<u32>,
    env_us: Vec<Vec2>,
    env_samples: Vec<Option<LightSample>>,
    /// The paths whose rays left the scene, and their directions.
    escaped_paths: Vec<u32>,
    escaped_dirs: Vec<Vec3>,
    escaped_values: Vec<(Vec3, f32)>,
}

/// A sample of the environment light taken ahead of a path's shading: the
/// numbers it was taken with and the result; used only if the path draws
/// the same numbers and picks the environment.
#[derive(Clone, Copy)]
struct EnvAhead {
    u: Vec2,
    sample: Option<LightSample>,
}

/// Whether a mesh has vertex attributes (normals or texture coordinates)
/// that `SurfacePoint::new` reads at its hits.
#[inline]
fn attributes(m: &crate::scene::Mesh) -> bool {
    !m.normals.is_empty() || !m.uvs.is_empty()
}

/// Prefetches what `SurfacePoint::new` will read of each hit's mesh (its
/// triangle, then the triangle's vertex normals and texture coordinates),
/// in two loops over all hits, so that the cache misses on large meshes
/// overlap instead of stalling each shading in turn.
fn prefetch_surfaces(scene: &Scene, rays: &[RayHit]) {
    let meshes = scene.meshes();
    for rh in rays {
        if let Some(hit) = rh.hit() {
            let mesh = &meshes[hit.geom_id as usize];
            if attributes(mesh) {
                prefetch(&mesh.triangles[hit.prim_id as usize]);
            }
        }
    }
    for rh in rays {
        if let Some(hit) = rh.hit() {
            let mesh = &meshes[hit.geom_id as usize];
            if !attributes(mesh) {
                continue;
            }
            for i in mesh.triangles[hit.prim_id as usize] {
                if let Some(n) = mesh.normals.get(i as usize) {
                    prefetch(n);
                }
                if let Some(uv) = mesh.uvs.get(i as usize) {
                    prefetch(uv);
                }
            }
        }
    }
}

/// What was looked up ahead of one path's shading for its bounce (see
/// [`sample_environment_ahead`]); nothing where the scene has no
/// environment.
#[derive(Clone, Copy, Default)]
struct Ahead {
    /// An environment light sample.
    light: Option<EnvAhead>,
    /// The environment's radiance and density along the path's ray, if it
    /// left the scene.
    seen: Option<(Vec3, f32)>,
}

/// Takes the environment-light samples that this bounce's next-event
/// estimation will take, all together ([`EnvironmentLight::sample_li_many`]
/// overlaps their cache misses on a large map), into `wf.ahead`. For
/// each path whose ray hit something it repeats, on a copy of the path's
/// random stream, the draws `shade` makes before sampling a light (the
/// light pick, then the light sample's numbers): the same numbers, so
/// `shade` finds its sample here, unless the path does not sample a light
/// at all (the copy is then simply dropped). For each path whose ray left
/// the scene it looks up the environment's radiance and density along it.
/// Images do not change.
fn sample_environment_ahead(pass: &Pass, wf: &mut Wavefront, env: usize) {
    let scene = pass.scene;
    let Light::Environment { light, .. } = &scene.lights().lights[env] else {
        unreachable!("Scene::environment indexes an environment light")
    };
    wf.env_paths.clear();
    wf.env_us.clear();
    wf.escaped_paths.clear();
    wf.escaped_dirs.clear();
    for (i, (path, rh)) in wf.paths.iter().zip(&wf.rays).enumerate() {
        let Some(hit) = rh.hit() else {
            wf.escaped_paths.push(i as u32);
            wf.escaped_dirs.push(rh.ray().dir);
            continue;
        };
        if path.depth >= pass.job.max_depth {
            continue;
        }
        let ray = rh.ray();
        // As `shade` computes the point, bit for bit.
        let p = ray.org + hit.t * ray.dir;
        let mut rng = path.rng.clone();
        if let Some((li, _)) = scene.lights().pick(p, rng.next_2d()) {
            if li == env {
                wf.env_us.push(rng.next_2d());
                wf.env_paths.push(i as u32);
            }
        }
    }
    light.sample_li_many(&wf.env_us, &mut wf.env_samples);
    light.radiance_pdf_many(&wf.escaped_dirs, &mut wf.escaped_values);
    wf.ahead.clear();
    wf.ahead.resize(wf.paths.len(), Ahead::default());
    for ((&i, &u), &sample) in wf.env_paths.iter().zip(&wf.env_us).zip(&wf.env_samples) {
        wf.ahead[i as usize].light = Some(EnvAhead { u, sample });
    }
    for (&i, &seen) in wf.escaped_paths.iter().zip(&wf.escaped_values) {
        wf.ahead[i as usize].seen = Some(seen);
    }
}

/// The light-leak guard of shading normals: a direction pair must be a
/// reflection (or a transmission) both for the geometric normal `ng` and in
/// the shading frame (`*_local`), or it is discarded; otherwise a bent
/// shading normal would let light through opaque surfaces.
#[inline(always)]
pub(crate) fn sides_agree(wo: Vec3, wi: Vec3, ng: Vec3, wo_local: Vec3, wi_local: Vec3) -> bool {
    (wo.dot(ng) * wi.dot(ng) > 0.0) == (wo_local.z * wi_local.z > 0.0)
}

/// What a hit knows of its surface beyond the geometric normal: texture
/// coordinates and the shading normal.
struct SurfacePoint {
    /// Texture coordinates (zero where the mesh has none or none are needed).
    uv: Vec2,
    /// Unit shading normal: interpolated where the mesh has vertex normals,
    /// tilted by the material's normal map where it has one and the mesh
    /// has texture coordinates.
    normal: Option<Vec3>,
}

impl SurfacePoint {
    /// Interpolates the mesh's vertex attributes at the hit (Embree's
    /// barycentrics: `p = (1 − u − v)·p0 + u·p1 + v·p2`); `uv` only when
    /// `material` is textured; then applies its normal map.
    #[inline]
    fn new(
        mesh: &crate::scene::Mesh,
        hit: &crate::accel::Hit,
        material: &crate::scene::Material,
    ) -> SurfacePoint {
        let has_uv = !material.textures.is_empty() && !mesh.uvs.is_empty();
        if !has_uv && mesh.normals.is_empty() {
            return SurfacePoint {
                uv: Vec2::ZERO,
                normal: None,
            };
        }
        let [i0, i1, i2] = mesh.triangles[hit.prim_id as usize].map(|i| i as usize);
        let (b1, b2) = (hit.u, hit.v);
        let b0 = 1.0 - b1 - b2;
        let uv = if has_uv {
            mesh.uvs[i0] * b0 + mesh.uvs[i1] * b1 + mesh.uvs[i2] * b2
        } else {
            Vec2::ZERO
        };
        let normal = if mesh.normals.is_empty() {
            None
        } else {
            (mesh.normals[i0] * b0 + mesh.normals[i1] * b1 + mesh.normals[i2] * b2).try_normalize()
        };
        let normal = match &material.textures.normal {
            Some(map) if has_uv => {
                Self::normal_mapped(mesh, [i0, i1, i2], [b0, b1, b2], uv, normal, map)
            }
            _ => normal,
        };
        SurfacePoint { uv, normal }
    }

    /// The shading normal tilted by a normal map at `uv`: the map's
    /// tangent-space direction in a frame around the interpolated normal
    /// `normal` (the triangle's own, by its winding, where there is none).
    /// Where the mesh has tangents (glTF's `TANGENT`), the frame is the
    /// interpolated tangent, made orthogonal to the normal, and the
    /// bitangent `w·(n × t)`; otherwise the triangle's ∂p/∂u and ∂p/∂v
    /// (Gram–Schmidt against the normal, so mirrored texture coordinates
    /// mirror the tilt). The untilted normal where the frame is degenerate.
    #[cold]
    fn normal_mapped(
        mesh: &crate::scene::Mesh,
        [i0, i1, i2]: [usize; 3],
        [b0, b1, b2]: [f32; 3],
        uv: Vec2,
        normal: Option<Vec3>,
        map: &crate::texture::ImageTexture,
    ) -> Option<Vec3> {
        let (p0, p1, p2) = (mesh.positions[i0], mesh.positions[i1], mesh.positions[i2]);
        let (dp1, dp2) = (p1 - p0, p2 - p0);
        let n = normal.or_else(|| dp1.cross(dp2).try_normalize())?;
        if !mesh.tangents.is_empty() {
            let (t0, t1, t2) = (mesh.tangents[i0], mesh.tangents[i1], mesh.tangents[i2]);
            let t = t0.truncate() * b0 + t1.truncate() * b1 + t2.truncate() * b2;
            let Some(t) = (t - n * n.dot(t)).try_normalize() else {
                return Some(n);
            };
            let b = n.cross(t) * if t0.w < 0.0 { -1.0 } else { 1.0 };
            let m = map.eval(uv);
            return (t * m.x + b * m.y + n * m.z).try_normalize().or(Some(n));
        }
        let (d1, d2) = (mesh.uvs[i1] - mesh.uvs[i0], mesh.uvs[i2] - mesh.uvs[i0]);
        let det = d1.x * d2.y - d1.y * d2.x;
        if det.abs() <= 1e-20 {
            return Some(n);
        }
        let dpdu = (dp1 * d2.y - dp2 * d1.y) / det;
        let dpdv = (dp2 * d1.x - dp1 * d2.x) / det;
        let Some(t) = (dpdu - n * n.dot(dpdu)).try_normalize() else {
            return Some(n);
        };
        let Some(b) = (dpdv - n * n.dot(dpdv) - t * t.dot(dpdv)).try_normalize() else {
            return Some(n);
        };
        let m = map.eval(uv);
        (t * m.x + b * m.y + n * m.z).try_normalize().or(Some(n))
    }

    /// The normal of the shading frame: the interpolated normal turned to the
    /// side of `n` (the geometric normal as the BSDF sees it), or `n` itself
    /// where there is none or where `wo` lies on different sides of the two.
    #[inline]
    fn shading_normal(&self, n: Vec3, wo: Vec3) -> Vec3 {
        match self.normal {
            Some(ns) => shading_normal_towards(ns, n, wo),
            None => n,
        }
    }

    /// The first tangent for anisotropic BSDFs: ∂p/∂u where the mesh has
    /// texture coordinates, else the triangle's first edge.
    fn tangent(mesh: &crate::scene::Mesh, hit: &crate::accel::Hit) -> Vec3 {
        let [i0, i1, i2] = mesh.triangles[hit.prim_id as usize].map(|i| i as usize);
        let (p0, p1, p2) = (mesh.positions[i0], mesh.positions[i1], mesh.positions[i2]);
        let (dp1, dp2) = (p1 - p0, p2 - p0);
        if !mesh.uvs.is_empty() {
            let (d1, d2) = (mesh.uvs[i1] - mesh.uvs[i0], mesh.uvs[i2] - mesh.uvs[i0]);
            let det = d1.x * d2.y - d1.y * d2.x;
            if det.abs() > 1e-12 {
                return (dp1 * d2.y - dp2 * d1.y) / det;
            }
        }
        dp1
    }
}

/// The normal of the shading frame for the interpolated unit normal `ns`:
/// `ns` turned to the side of `n` (the geometric normal as the BSDF sees
/// it), or `n` where `wo` lies on different sides of the two. Branch-free
/// (both integrators call it).
#[inline(always)]
pub(crate) fn shading_normal_towards(ns: Vec3, n: Vec3, wo: Vec3) -> Vec3 {
    let ns = if ns.dot(n) < 0.0 { -ns } else { ns };
    if ns.dot(wo) * n.dot(wo) > 0.0 {
        ns
    } else {
        n
    }
}

/// The scattering vertex a path's current ray left from.
pub(crate) struct PrevVertex {
    /// Scattering events before it (0: the ray is the camera's).
    pub depth: u32,
    /// Solid-angle density of the BSDF sample that chose the ray; 0 after a
    /// delta lobe.
    pub pdf: f32,
    /// Its position.
    pub point: Vec3,
}

/// MIS weight of emission from triangle light `li` at `p` found along `dir`
/// by a BSDF sample (power heuristic against light sampling, which could
/// have found it too); 1 for the camera ray or after a delta lobe.
#[inline]
pub(crate) fn emission_weight(
    scene: &Scene,
    li: usize,
    prev: &PrevVertex,
    p: Vec3,
    dir: Vec3,
) -> f32 {
    if prev.depth == 0 || prev.pdf == 0.0 {
        1.0
    } else {
        let light = &scene.lights().lights[li];
        let light_pdf = scene.lights().pick_pmf(li, prev.point) * light.pdf_li(prev.point, p, dir);
        power_heuristic(prev.pdf, light_pdf)
    }
}

/// MIS weight of the environment (light `env`) seen along a ray that left
/// the scene, whose direction the environment samples with density `pdf()`
/// (asked only when needed): power heuristic against light sampling; 1 for
/// the camera ray or after a delta lobe.
#[inline]
pub(crate) fn environment_weight(
    scene: &Scene,
    env: usize,
    prev: &PrevVertex,
    pdf: impl FnOnce() -> f32,
) -> f32 {
    if prev.depth == 0 || prev.pdf == 0.0 {
        1.0
    } else {
        let light_pdf = scene.lights().pick_pmf(env, prev.point) * pdf();
        power_heuristic(prev.pdf, light_pdf)
    }
}

/// Camera sample `sample` of pixel `(x, y)`: its random stream, after the
/// numbers the filter and (when `lens_sample`) the lens took, and the camera
/// ray, if the camera has one there.
#[inline(always)]
fn camera_sample(
    scene: &Scene,
    seed: u64,
    lens_sample: bool,
    x: u32,
    y: u32,
    sample: u32,
) -> (PathSampler, Option<Ray>) {
    let mut rng = PathSampler::for_sample(seed, x, y, sample);
    // Filter importance sampling: the filter places the sample, which keeps
    // weight 1 (see `crate::filter`).
    let film = Vec2::new(x as f32, y as f32) + scene.film().filter.sample(rng.next_2d());
    let lens = if lens_sample {
        rng.next_2d()
    } else {
        Vec2::ZERO
    };
    let ray = scene.camera().generate_ray(film, lens);
    (rng, ray)
}

/// Renders the job's samples of every pixel of `tile`; with `kernel` (the
/// scene's [`SoaScene`] and an instruction set), by the vectorised
/// kernel, which gives the same image.
pub fn render_tile(
    scene: &Scene,
    job: &RenderJob,
    kernel: Option<(&SoaScene, Isa)>,
    tile: Tile,
) -> TileResult {
    let samples = job.samples();
    let n = (tile.width * tile.height) as usize;
    let mut pixels = vec![
        PixelSums {
            samples: job.spp,
            ..Default::default()
        };
        n
    ];
    let mut rays = RayStats::default();
    let first_sample = samples.start;
    if let Some((kernel, isa)) = kernel {
        let mut lanes = soa::SoaLanes::default();
        for s in samples {
            let pass = soa::Pass {
                kernel,
                scene,
                job,
                tile,
                sample: s,
                first: s == first_sample,
            };
            soa::trace_pass(isa, &pass, &mut lanes, &mut pixels, &mut rays);
        }
        return TileResult { tile, pixels, rays };
    }
    let mut wf = Wavefront::default();
    for s in samples {
        let pass = Pass {
            scene,
            job,
            tile,
            sample: s,
            first: s == first_sample,
        };
        trace_pass(&pass, &mut wf, &mut pixels, &mut rays);
    }
    TileResult { tile, pixels, rays }
}

/// One sample pass of the general integrator over a tile.
struct Pass<'a> {
    scene: &'a Scene,
    job: &'a RenderJob,
    tile: Tile,
    /// The sample index of this pass.
    sample: u32,
    /// Whether this is the render's first pass over the tile (it records
    /// the object id).
    first: bool,
}

fn trace_pass(pass: &Pass, wf: &mut Wavefront, pixels: &mut [PixelSums], stats: &mut RayStats) {
    let &Pass {
        scene,
        job,
        tile,
        sample,
        first,
    } = pass;
    // Exposure and white balance, applied to each sample (cheap next to a pass).
    let response = scene.film().response();
    let lens_sample = scene.camera().needs_lens_sample();
    wf.paths.clear();
    wf.rays.clear();
    for py in 0..tile.height {
        for px in 0..tile.width {
            let (x, y) = (tile.x0 + px, tile.y0 + py);
            // No ray (outside a fisheye's circles): a black sample that hit
            // nothing; it still counts towards spp.
            let (rng, Some(ray)) = camera_sample(scene, job.seed, lens_sample, x, y, sample) else {
                continue;
            };
            wf.rays.push(RayHit::masked(ray, job.ray_mask()));
            wf.paths.push(PathState {
                pixel: py * tile.width + px,
                rng,
                beta: Vec3::ONE,
                radiance: Vec3::ZERO,
                prev_pdf: 0.0,
                prev_point: ray.org,
                depth: 0,
                eta_scale: 1.0,
                alive: true,
            });
        }
    }
    stats.camera += wf.rays.len() as u64;
    let clock = Instant::now();
    scene
        .accel()
        .intersect_stream(&mut wf.rays, COHERENT_CAMERA);
    stats.trace_nanos += clock.elapsed().as_nanos() as u64;

    let mut camera_vertex = true;
    let has_attributes = scene.meshes().iter().any(attributes);
    while !wf.paths.is_empty() {
        wf.shadow_rays.clear();
        wf.pending.clear();
        if has_attributes {
            prefetch_surfaces(scene, &wf.rays);
        }
        match scene.environment_index() {
            Some(env) => sample_environment_ahead(pass, wf, env),
            None => {
                wf.ahead.clear();
                wf.ahead.resize(wf.paths.len(), Ahead::default());
            }
        }
        for (i, ((path, rh), &ahead)) in wf
            .paths
            .iter_mut()
            .zip(wf.rays.iter_mut())
            .zip(&wf.ahead)
            .enumerate()
        {
            let pixel = &mut pixels[path.pixel as usize];
            let queue = (&mut wf.shadow_rays, &mut wf.pending);
            shade(
                pass,
                path,
                rh,
                i as u32,
                camera_vertex && first,
                pixel,
                queue,
                ahead,
            );
        }
        stats.shadow += wf.shadow_rays.len() as u64;
        let clock = Instant::now();
        scene.accel().occluded_stream(&mut wf.shadow_rays, false);
        stats.trace_nanos += clock.elapsed().as_nanos() as u64;
        for (ray, p) in wf.shadow_rays.iter().zip(&wf.pending) {
            if !ray.occluded() {
                wf.paths[p.path as usize].radiance += p.radiance;
            }
        }
        // Retire finished paths (in order) and compact the live ones.
        let mut live = 0;
        for i in 0..wf.paths.len() {
            if wf.paths[i].alive {
                wf.paths.swap(live, i);
                wf.rays.swap(live, i);
                live += 1;
            } else {
                let path = &wf.paths[i];
                pixels[path.pixel as usize].add_radiance(response.apply(path.radiance));
            }
        }
        wf.paths.truncate(live);
        wf.rays.truncate(live);
        stats.bounce += live as u64;
        let clock = Instant::now();
        scene.accel().intersect_stream(&mut wf.rays, false);
        stats.trace_nanos += clock.elapsed().as_nanos() as u64;
        camera_vertex = false;
    }
}

/// Processes the hit of one path: emission, next-event estimation, and the
/// next ray (written back into `rh`), or ends the path.
#[inline]
#[allow(clippy::too_many_arguments)] // the path, its pixel, its queues, what was looked up ahead
fn shade(
    pass: &Pass,
    path: &mut PathState,
    rh: &mut RayHit,
    index: u32,
    record_aovs_first: bool,
    pixel: &mut PixelSums,
    (shadow_rays, pending): (&mut Vec<ShadowRay>, &mut Vec<PendingLight>),
    ahead: Ahead,
) {
    let Ahead {
        light: env_ahead,
        seen: env_seen,
    } = ahead;
    let (scene, max_depth) = (pass.scene, pass.job.max_depth);
    let ray = rh.ray();
    let Some(hit) = rh.hit() else {
        // The ray leaves the scene: it sees the environment, MIS-weighted
        // against light sampling (which could have picked that direction).
        if let Some(env) = scene.environment_index() {
            let Light::Environment { light, .. } = &scene.lights().lights[env] else {
                unreachable!("Scene::environment indexes an environment light")
            };
            // Looked up ahead where the scene has an environment.
            let (le, seen_pdf) = match env_seen {
                Some((le, pdf)) => (le, Some(pdf)),
                None => (light.radiance(ray.dir), None),
            };
            if le != Vec3::ZERO {
                let prev = PrevVertex {
                    depth: path.depth,
                    pdf: path.prev_pdf,
                    point: path.prev_point,
                };
                let weight = environment_weight(scene, env, &prev, || {
                    seen_pdf.unwrap_or_else(|| light.pdf(ray.dir))
                });
                path.radiance += path.beta * le * weight;
            }
        }
        path.alive = false;
        return;
    };
    let mesh = &scene.meshes()[hit.geom_id as usize];
    let material = &scene.materials()[mesh.material as usize];
    let surface = SurfacePoint::new(mesh, &hit, material);
    let at = SurfaceHit::new(scene, &ray, &hit, surface);

    if path.depth == 0 {
        pixel.add_first_hit(
            scene.camera().depth(ray.dir, hit.t),
            at.aov_normal(),
            at.bsdf.albedo(),
        );
        if record_aovs_first {
            pixel.object_id = mesh.object_layer();
        }
        if mesh.is_virtual {
            pixel.virtual_hits += 1;
        }
    }

    // Emission found by the camera ray or by BSDF sampling, MIS-weighted
    // against next-event estimation (which could have found it too).
    if let Some(li) = scene.light_index(hit.geom_id, hit.prim_id) {
        let light = &scene.lights().lights[li];
        if let Light::Triangle(tl) = light {
            let le = tl.emitted(at.wo);
            if le != Vec3::ZERO {
                let prev = PrevVertex {
                    depth: path.depth,
                    pdf: path.prev_pdf,
                    point: path.prev_point,
                };
                let weight = emission_weight(scene, li, &prev, at.p, ray.dir);
                path.radiance += path.beta * le * weight;
            }
        }
    }

    if path.depth >= max_depth {
        path.alive = false;
        return;
    }

    let bounce = Bounce {
        // The ray after the last light sample only matters if it can hit a light.
        continue_path: path.depth + 1 < max_depth || scene.has_hittable_lights(),
        roulette: path.depth + 1 >= pass.job.rr_depth,
    };
    let lights = scene.lights();
    let scattered = scatter(
        &at,
        &mut path.rng,
        &mut path.beta,
        &mut path.eta_scale,
        bounce,
        |p, u| lights.pick(p, u),
        |li, p, u| match env_ahead {
            Some(ahead) if scene.environment_index() == Some(li) && ahead.u == u => ahead.sample,
            _ => lights.lights[li].sample_li(p, u),
        },
    );
    if let Some((shadow, radiance)) = scattered.shadow {
        shadow_rays.push(ShadowRay::masked(shadow, pass.job.ray_mask()));
        pending.push(PendingLight {
            path: index,
            radiance,
        });
    }
    match scattered.next {
        Some((next, pdf)) => {
            path.prev_pdf = pdf;
            path.prev_point = at.p;
            path.depth += 1;
            *rh = RayHit::masked(next, pass.job.ray_mask());
        }
        None => path.alive = false,
    }
}

/// A path's hit as scattering sees it: the point, the directions and
/// normals, and the BSDF of the material there.
struct SurfaceHit<'a> {
    /// The hit point (scene units).
    p: Vec3,
    /// Unit direction towards the ray's origin.
    wo: Vec3,
    /// Unit geometric normal, as the mesh winds it.
    ng: Vec3,
    /// `ng` turned towards `wo`.
    facing: Vec3,
    /// The BSDF's outside: `facing` for an opaque BSDF (two-sided), `ng`
    /// for a transmissive one.
    n: Vec3,
    /// The normal of the shading frame (see [`SurfacePoint::shading_normal`]).
    shading_n: Vec3,
    /// Whether the mesh has vertex normals (then the light-leak guard
    /// applies, see [`sides_agree`]).
    guard: bool,
    /// The material's BSDF at the hit (its textures looked up).
    bsdf: Bsdf,
    mesh: &'a crate::scene::Mesh,
    hit: crate::accel::Hit,
}

impl<'a> SurfaceHit<'a> {
    /// The hit `hit` of `ray`, whose surface attributes are `surface`.
    #[inline]
    fn new(
        scene: &'a Scene,
        ray: &Ray,
        hit: &crate::accel::Hit,
        surface: SurfacePoint,
    ) -> SurfaceHit<'a> {
        let mesh = &scene.meshes()[hit.geom_id as usize];
        let material = &scene.materials()[mesh.material as usize];
        let p = ray.org + hit.t * ray.dir;
        let wo = -ray.dir;
        let ng = hit.ng.normalize_or_zero();
        let facing = if ng.dot(wo) >= 0.0 { ng } else { -ng };
        let bsdf = if material.textures.is_empty() {
            material.bsdf
        } else {
            material.bsdf_at(surface.uv)
        };
        // Opaque surfaces are two-sided: shade in the frame facing the viewer.
        // Transmissive ones keep the geometric normal as their outside.
        let n = if bsdf.transmits() { ng } else { facing };
        SurfaceHit {
            p,
            wo,
            ng,
            facing,
            n,
            shading_n: surface.shading_normal(n, wo),
            // Without shading normals the frame's normal is ±ng and the
            // light-leak guard cannot fail.
            guard: surface.normal.is_some(),
            bsdf,
            mesh,
            hit: *hit,
        }
    }

    /// The normal the normal layer records: the shading normal, or for a
    /// transmissive BSDF the geometric normal facing the viewer.
    #[inline]
    fn aov_normal(&self) -> Vec3 {
        if self.bsdf.transmits() {
            self.facing
        } else {
            self.shading_n
        }
    }

    /// The local shading frame (with the tangent anisotropic BSDFs need).
    #[inline]
    fn frame(&self) -> Frame {
        if self.bsdf.is_anisotropic() {
            Frame::from_normal_tangent(self.shading_n, SurfacePoint::tangent(self.mesh, &self.hit))
        } else {
            Frame::from_normal(self.shading_n)
        }
    }
}

/// What is decided for a whole bounce before a path scatters.
#[derive(Debug, Clone, Copy)]
struct Bounce {
    /// Whether the path goes on after the light sample (BSDF sampling).
    continue_path: bool,
    /// Whether Russian roulette applies after this scattering.
    roulette: bool,
}

/// What one scattering decides: the light sample's shadow ray with the
/// radiance it adds if unoccluded, and the next ray with the density of
/// the BSDF sample that chose it (0 after a delta lobe), or `None` where
/// the path ends.
struct Scattered {
    shadow: Option<(Ray, Vec3)>,
    next: Option<(Ray, f32)>,
}

/// One scattering at `at`: next-event estimation (a light picked by
/// `pick(p, u)`, a point on it by `sample(light, p, u)`, MIS-weighted),
/// then BSDF sampling of the next direction and Russian roulette, drawing
/// from `rng` and updating the path's throughput `beta` and `η²` product
/// `eta_scale`. Both integrators call it (the vectorised kernel for the
/// lanes whose material it does not vectorise), so they trace the same
/// paths.
#[inline]
fn scatter(
    at: &SurfaceHit,
    rng: &mut PathSampler,
    beta: &mut Vec3,
    eta_scale: &mut f32,
    bounce: Bounce,
    pick: impl FnOnce(Vec3, Vec2) -> Option<(usize, f32)>,
    sample: impl FnOnce(usize, Vec3, Vec2) -> Option<LightSample>,
) -> Scattered {
    let (p, wo, ng, n, bsdf) = (at.p, at.wo, at.ng, at.n, &at.bsdf);
    let mut out = Scattered {
        shadow: None,
        next: None,
    };
    let frame = at.frame();
    let wo_local = frame.to_local(wo);
    let eps = ray_epsilon(p);
    // Reflected rays leave on the side of `n`; only a transmissive BSDF can
    // send a ray out on the other side.
    let transmits = bsdf.transmits();
    let origin_for = |dir: Vec3| {
        if transmits {
            spawn_origin(p, n, eps, dir)
        } else {
            p + n * eps
        }
    };

    // Next-event estimation (pointless when every lobe is a delta).
    let light_pick = if bsdf.is_delta() {
        None
    } else {
        pick(p, rng.next_2d())
    };
    if let Some((li, pick_pmf)) = light_pick {
        let u = rng.next_2d();
        if let Some(ls) = sample(li, p, u) {
            let wi_local = frame.to_local(ls.wi);
            // A delta light needs no MIS weight, so no BSDF density.
            let (f, bsdf_pdf) = if at.guard && !sides_agree(wo, ls.wi, ng, wo_local, wi_local) {
                (Vec3::ZERO, 0.0)
            } else if ls.delta {
                (bsdf.eval(wo_local, wi_local), 0.0)
            } else {
                bsdf.eval_pdf(wo_local, wi_local)
            };
            let f = f * wi_local.z.abs();
            if f != Vec3::ZERO {
                let light_pdf = pick_pmf * ls.pdf;
                let weight = if ls.delta {
                    1.0
                } else {
                    power_heuristic(light_pdf, bsdf_pdf)
                };
                // The shadow ray runs from the offset origin to just short
                // of the light point: t ∈ [0, tfar] along d = target − origin;
                // towards the environment (at infinity), unbounded.
                let origin = origin_for(ls.wi);
                let (dir, tfar) = shadow_segment(origin, p, ls.wi, ls.dist);
                if tfar > 0.0 {
                    let shadow = Ray {
                        org: origin,
                        dir,
                        tnear: 0.0,
                        tfar,
                    };
                    out.shadow = Some((shadow, *beta * f * ls.radiance * (weight / light_pdf)));
                }
            }
        }
    }

    if !bounce.continue_path {
        return out;
    }

    // BSDF sampling for the next ray.
    let uc = rng.next_f32();
    let Some(bs) = bsdf.sample(wo_local, uc, rng.next_2d()) else {
        return out;
    };
    let wi = frame.to_world(bs.wi);
    if at.guard && !sides_agree(wo, wi, ng, wo_local, bs.wi) {
        return out;
    }
    *beta *= bs.weight;
    *eta_scale *= bsdf.eta_scale(wo_local, bs.wi);
    let rr_beta = *beta * *eta_scale;
    if roulette_spins(rr_beta, bounce.roulette) {
        let (survives, survivor) = roulette(*beta, rr_beta, rng.next_f32());
        if !survives {
            return out;
        }
        *beta = survivor;
    }
    if *beta == Vec3::ZERO {
        return out;
    }
    let pdf = if bs.delta { 0.0 } else { bs.pdf };
    out.next = Some((Ray::new(origin_for(wi), wi), pdf));
    out
}
