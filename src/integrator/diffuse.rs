//! A vectorised wavefront for the commonest kind of scene: every material
//! plain Lambert (no textures), meshes without vertex normals, lit by point
//! lights only (no area lights, no environment, no reach limits).
//!
//! It computes what the general integrator ([`super::render_tile`])
//! computes, in the same floating-point operations in the same order, with
//! the same random numbers; Rust never contracts `a·b + c` into a fused
//! multiply-add, so every lane rounds exactly as the scalar code does and
//! the images are bit-identical (tested in `tests/vectorised.rs`). What
//! differs is the layout: the paths of a tile live in structure-of-arrays
//! lanes ([`RayBatch`] and the arrays of [`DiffuseLanes`]), and one bounce of
//! all of them is a single loop without branches (`shade_lane` per lane),
//! which the compiler turns into AVX-512 or AVX2 code, picked at run time.
//! Rays go to Embree as SoA streams (`rtcIntersectNp`, `rtcOccludedNp`).
//!
//! [`DiffuseScene::new`] decides whether a scene qualifies; a scene that
//! does not is rendered by the general integrator.

// Lane loops index a dozen arrays by lane; iterator chains would hide that.
#![allow(clippy::needless_range_loop)]

use super::{PixelSums, RayStats, Tile, RUSSIAN_ROULETTE_DEPTH};
use crate::accel::{gather_lanes, RayBatch, INVALID_ID};
use crate::bsdf::Bsdf;
use crate::camera::{Camera, PinholeCamera};
use crate::filter::PixelFilter;
use crate::light::Light;
use crate::sampler::Rng;
use crate::sampling::{sin_cos_quarter, Frame};
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};
use std::time::Instant;

/// What the vectorised kernel needs of a scene it can render.
#[derive(Debug, Clone)]
pub struct DiffuseScene {
    /// Lambert albedo per Embree geometry id (linear RGB, one array per
    /// channel), with one extra zero entry that lanes without a hit read.
    albedo: [Vec<f32>; 3],
    /// The one light, when there is exactly one: position, intensity and
    /// the probability of picking it.
    single_light: Option<(Vec3, Vec3, f32)>,
}

impl DiffuseScene {
    /// The kernel's view of `scene`, or `None` when the scene needs the
    /// general integrator: a material that is not untextured Lambert, vertex
    /// normals, an emissive mesh, an environment, a light that is not a point
    /// light, reach-limited light groups, or no light that can be picked.
    pub fn new(scene: &Scene) -> Option<DiffuseScene> {
        if scene.environment.is_some()
            || scene.has_hittable_lights
            || scene.first_light.iter().any(Option::is_some)
            || !scene.lights.is_spatially_uniform()
            || scene
                .lights
                .lights
                .iter()
                .any(|l| !matches!(l, Light::Point(_)))
        {
            return None;
        }
        // Light picking must always succeed, as the scalar path assumes when
        // it draws the light sample's numbers.
        let (first, pmf) = scene.lights.pick(Vec3::ZERO, Vec2::splat(0.5))?;
        let mut albedo = [Vec::new(), Vec::new(), Vec::new()];
        for mesh in &scene.meshes {
            if !mesh.normals.is_empty() || mesh.emission.is_some() {
                return None;
            }
            let material = scene.materials.get(mesh.material as usize)?;
            let Bsdf::Diffuse(d) = material.bsdf else {
                return None;
            };
            if !material.textures.is_empty() {
                return None;
            }
            for (c, a) in albedo.iter_mut().enumerate() {
                a.push(d.reflectance[c]);
            }
        }
        for a in &mut albedo {
            a.push(0.0);
        }
        let single_light = match scene.lights.lights.as_slice() {
            [Light::Point(l)] if first == 0 => Some((l.position, l.intensity, pmf)),
            _ => None,
        };
        Some(DiffuseScene {
            albedo,
            single_light,
        })
    }
}

/// The paths of one tile pass in structure-of-arrays form, reused from pass
/// to pass (allocation-free after the first).
#[derive(Default)]
pub struct DiffuseLanes {
    rays: RayBatch,
    shadow: RayBatch,
    pixel: Vec<u32>,
    rng_state: Vec<u64>,
    rng_inc: Vec<u64>,
    beta: [Vec<f32>; 3],
    radiance: [Vec<f32>; 3],
    pending: [Vec<f32>; 3],
    light_pos: [Vec<f32>; 3],
    light_intensity: [Vec<f32>; 3],
    light_pmf: Vec<f32>,
    /// Lanes whose paths go on, ascending (rebuilt every bounce).
    kept: Vec<u32>,
    /// Lanes whose paths have ended, ascending (rebuilt every bounce).
    ended: Vec<u32>,
}

impl DiffuseLanes {
    #[inline(always)]
    fn resize(&mut self, n: usize) {
        self.rays.resize(n);
        self.shadow.resize(n);
        self.pixel.resize(n, 0);
        self.rng_state.resize(n, 0);
        self.rng_inc.resize(n, 0);
        for c in 0..3 {
            self.beta[c].resize(n, 0.0);
            self.radiance[c].resize(n, 0.0);
            self.pending[c].resize(n, 0.0);
            self.light_pos[c].resize(n, 0.0);
            self.light_intensity[c].resize(n, 0.0);
        }
        self.light_pmf.resize(n, 0.0);
    }

    /// Keeps the lanes listed in `self.kept`, in order.
    #[inline(always)]
    fn retain(&mut self) {
        let kept = &self.kept;
        self.rays.retain(kept);
        gather_lanes(&mut self.pixel, kept);
        gather_lanes(&mut self.rng_state, kept);
        gather_lanes(&mut self.rng_inc, kept);
        for c in 0..3 {
            gather_lanes(&mut self.beta[c], kept);
            gather_lanes(&mut self.radiance[c], kept);
        }
        let live = self.rays.len();
        self.resize(live);
    }
}

/// Adds the radiance of the paths of `ended` (lane indices) to their
/// pixels, as the general integrator retires a path.
#[inline(always)]
fn retire(lanes: &DiffuseLanes, ended: &[u32], scene: &Scene, pixels: &mut [PixelSums]) {
    let response = scene.film.response();
    for &i in ended {
        let i = i as usize;
        let radiance = Vec3::new(
            lanes.radiance[0][i],
            lanes.radiance[1][i],
            lanes.radiance[2][i],
        );
        let l = response.apply(radiance).as_dvec3();
        let px = &mut pixels[lanes.pixel[i] as usize];
        px.sum += l;
        px.sum_sq += l * l;
    }
}

/// The arguments of one tile pass.
pub struct Pass<'a> {
    /// The kernel's view of the scene.
    pub kernel: &'a DiffuseScene,
    /// The scene.
    pub scene: &'a Scene,
    /// The tile.
    pub tile: Tile,
    /// The sample index of this pass.
    pub sample: u32,
    /// Whether this is the first pass of the render over this tile (it
    /// records the object id).
    pub first: bool,
}

/// An instruction set the vectorised kernel is compiled for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Isa {
    /// The target's baseline (SSE2 on x86-64): 4 lanes per instruction.
    Baseline,
    /// AVX2 (x86-64): 8 lanes per instruction.
    Avx2,
    /// AVX-512 F/DQ/VL/BW (x86-64): 16 lanes per instruction.
    Avx512,
}

impl Isa {
    /// Whether this CPU can run the kernel compiled for `self`.
    pub fn is_available(self) -> bool {
        match self {
            Isa::Baseline => true,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma"),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                is_x86_feature_detected!("avx512f")
                    && is_x86_feature_detected!("avx512dq")
                    && is_x86_feature_detected!("avx512vl")
                    && is_x86_feature_detected!("avx512bw")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The best instruction set this CPU has.
    pub fn best() -> Isa {
        [Isa::Avx512, Isa::Avx2]
            .into_iter()
            .find(|isa| isa.is_available())
            .unwrap_or(Isa::Baseline)
    }

    /// Its name, as `plsr render` reports it.
    pub fn name(self) -> &'static str {
        match self {
            Isa::Baseline => "baseline",
            Isa::Avx2 => "AVX2",
            Isa::Avx512 => "AVX-512",
        }
    }
}

/// Renders sample `pass.sample` of every pixel of `pass.tile`, as
/// the general integrator does. The whole pass is compiled
/// for AVX-512, for AVX2 and for the baseline instruction set; `isa` picks
/// one, or the baseline where the CPU lacks it. Every variant gives the same
/// result: no instruction set changes how an operation rounds, and Rust
/// fuses no multiply-add by itself.
pub fn trace_pass(
    isa: Isa,
    pass: &Pass,
    lanes: &mut DiffuseLanes,
    pixels: &mut [PixelSums],
    stats: &mut RayStats,
) {
    #[cfg(target_arch = "x86_64")]
    {
        if isa == Isa::Avx512 && isa.is_available() {
            // SAFETY: the CPU has the features `trace_pass_avx512` is
            // compiled for (checked just above).
            return unsafe { trace_pass_avx512(pass, lanes, pixels, stats) };
        }
        if isa == Isa::Avx2 && isa.is_available() {
            // SAFETY: the CPU has the features `trace_pass_avx2` is compiled
            // for (checked just above).
            return unsafe { trace_pass_avx2(pass, lanes, pixels, stats) };
        }
    }
    let _ = isa;
    trace_pass_body(pass, lanes, pixels, stats)
}

/// [`trace_pass_body`] compiled for AVX-512 (16 lanes per instruction).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx512bw,avx2,fma")]
unsafe fn trace_pass_avx512(
    pass: &Pass,
    lanes: &mut DiffuseLanes,
    pixels: &mut [PixelSums],
    stats: &mut RayStats,
) {
    trace_pass_body(pass, lanes, pixels, stats)
}

/// [`trace_pass_body`] compiled for AVX2 (8 lanes per instruction). `fma`
/// only makes the instructions available: Rust never fuses `a·b + c` itself.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn trace_pass_avx2(
    pass: &Pass,
    lanes: &mut DiffuseLanes,
    pixels: &mut [PixelSums],
    stats: &mut RayStats,
) {
    trace_pass_body(pass, lanes, pixels, stats)
}

/// One tile pass; inlined into each instruction-set variant of [`trace_pass`].
#[inline(always)]
fn trace_pass_body(
    pass: &Pass,
    lanes: &mut DiffuseLanes,
    pixels: &mut [PixelSums],
    stats: &mut RayStats,
) {
    let (kernel, scene) = (pass.kernel, pass.scene);

    // Camera rays: vectorised for a pinhole camera with the box filter,
    // otherwise one by one through the general code's camera and filter.
    lanes.resize((pass.tile.width * pass.tile.height) as usize);
    let n = match (&scene.camera, &scene.film.filter) {
        (Camera::Pinhole(pinhole), PixelFilter::Box) => {
            pinhole_camera_rays(pinhole, pass, lanes);
            lanes.rays.len()
        }
        _ => general_camera_rays(pass, lanes),
    };
    lanes.resize(n);
    stats.camera += n as u64;
    let clock = Instant::now();
    scene.accel.intersect_batch(&mut lanes.rays, true);
    stats.trace_nanos += clock.elapsed().as_nanos() as u64;

    // The camera vertex's auxiliary layers.
    camera_vertex_layers(pass, lanes, pixels);

    let max_depth = scene.settings.max_depth;
    let mut depth = 0;
    while depth < max_depth && !lanes.rays.is_empty() {
        let n = lanes.rays.len();
        let uniform = Uniform {
            // The ray after the last light sample could only find a light,
            // and these scenes have none to find.
            continue_paths: depth + 1 < max_depth,
            roulette: depth + 1 >= RUSSIAN_ROULETTE_DEPTH,
        };
        pick_lights(kernel, scene, lanes);
        shade_lanes(kernel, lanes, uniform);

        let shadow_tfar = lanes.shadow.tfar.as_slice();
        stats.shadow += shadow_tfar.iter().filter(|&&t| t > 0.0).count() as u64;
        let clock = Instant::now();
        scene.accel.occluded_batch(&mut lanes.shadow, false);
        stats.trace_nanos += clock.elapsed().as_nanos() as u64;
        let live = add_unoccluded(lanes);
        stats.bounce += live as u64;

        // Retire finished paths; compact once enough lanes are idle.
        if live == 0 {
            break;
        }
        if live * 3 <= n * 2 {
            retire(lanes, &lanes.ended, scene, pixels);
            lanes.retain();
        }
        let clock = Instant::now();
        scene.accel.intersect_batch(&mut lanes.rays, false);
        stats.trace_nanos += clock.elapsed().as_nanos() as u64;
        depth += 1;
    }
    // Every path still in a lane has ended now.
    lanes.ended.clear();
    lanes.ended.extend(0..lanes.rays.len() as u32);
    retire(lanes, &lanes.ended, scene, pixels);
}

/// Adds the camera vertex's auxiliary layers (hit count, depth, normal,
/// albedo, and on the first pass the object id) to the pixels, as the
/// general integrator does at a path's first hit: per-lane values in
/// vectorised chunks, then the sums lane by lane.
#[inline(always)]
fn camera_vertex_layers(pass: &Pass, lanes: &DiffuseLanes, pixels: &mut [PixelSums]) {
    let rays = &lanes.rays;
    let n = rays.len();
    let last = pass.kernel.albedo[0].len() - 1;
    for start in (0..n).step_by(W) {
        let geom = load_or(rays.geom_id.as_slice(), start, INVALID_ID);
        let t = load(rays.tfar.as_slice(), start);
        let dir = [
            load(rays.dir_x.as_slice(), start),
            load(rays.dir_y.as_slice(), start),
            load(rays.dir_z.as_slice(), start),
        ];
        let ng = [
            load(rays.ng_x.as_slice(), start),
            load(rays.ng_y.as_slice(), start),
            load(rays.ng_z.as_slice(), start),
        ];
        let mut normal = [[0.0f32; W]; 3];
        let mut depth = [0.0f32; W];
        for k in 0..W {
            let d = Vec3::new(dir[0][k], dir[1][k], dir[2][k]);
            let n = Vec3::new(ng[0][k], ng[1][k], ng[2][k]).normalize_or_zero();
            let facing = if n.dot(-d) >= 0.0 { n } else { -n };
            for c in 0..3 {
                normal[c][k] = facing[c];
            }
            depth[k] = pass.scene.camera.depth(d, t[k]);
        }
        for k in 0..(n - start).min(W) {
            if geom[k] == INVALID_ID {
                continue;
            }
            let g = (geom[k] as usize).min(last);
            let pixel = &mut pixels[lanes.pixel[start + k] as usize];
            pixel.hits += 1;
            pixel.depth += depth[k] as f64;
            pixel.normal += Vec3::new(normal[0][k], normal[1][k], normal[2][k]);
            pixel.albedo += Vec3::new(
                pass.kernel.albedo[0][g],
                pass.kernel.albedo[1][g],
                pass.kernel.albedo[2][g],
            );
            if pass.first {
                // Light fixtures (u32::MAX) are not objects.
                let mesh = &pass.scene.meshes[g];
                pixel.object_id = if mesh.object_id == u32::MAX {
                    -1.0
                } else {
                    mesh.object_id as f32
                };
            }
        }
    }
}

/// The camera rays of a tile pass through the general code's camera and
/// filter, lane by lane; a pixel the camera has no ray for (outside a
/// fisheye's circles) gets no lane. Returns the number of lanes.
#[inline(always)]
fn general_camera_rays(pass: &Pass, lanes: &mut DiffuseLanes) -> usize {
    let (scene, tile) = (pass.scene, pass.tile);
    let camera = &scene.camera;
    let lens_sample = camera.needs_lens_sample();
    let mut n = 0;
    for py in 0..tile.height {
        for px in 0..tile.width {
            let (x, y) = (tile.x0 + px, tile.y0 + py);
            let mut rng = Rng::for_sample(scene.settings.seed, x, y, pass.sample);
            let film = Vec2::new(x as f32, y as f32) + scene.film.filter.sample(rng.next_2d());
            let lens = if lens_sample {
                rng.next_2d()
            } else {
                Vec2::ZERO
            };
            let Some(ray) = camera.generate_ray(film, lens) else {
                continue;
            };
            lanes.rays.set(n, ray);
            lanes.pixel[n] = py * tile.width + px;
            (lanes.rng_state[n], lanes.rng_inc[n]) = rng.to_parts();
            for c in 0..3 {
                lanes.beta[c][n] = 1.0;
                lanes.radiance[c][n] = 0.0;
            }
            n += 1;
        }
    }
    n
}

/// The camera rays of a tile pass for a pinhole camera and the box filter,
/// one lane per pixel in row-major order, with each lane's random stream
/// after the filter's two numbers: the general integrator's camera stage,
/// vectorised.
#[inline(always)]
fn pinhole_camera_rays(camera: &PinholeCamera, pass: &Pass, lanes: &mut DiffuseLanes) {
    let (tile, seed, sample) = (pass.tile, pass.scene.settings.seed, pass.sample);
    let n = lanes.rays.len();
    for start in (0..n).step_by(W) {
        let mut dir = [[0.0f32; W]; 3];
        let mut state = [0u64; W];
        let mut inc = [0u64; W];
        for k in 0..W {
            let i = (start + k) as u32;
            let (px, py) = (i % tile.width, i / tile.width);
            let mut rng = Rng::for_sample(seed, tile.x0 + px, tile.y0 + py, sample);
            let u = rng.next_2d();
            let film = Vec2::new((tile.x0 + px) as f32, (tile.y0 + py) as f32) + u;
            let ray = camera.generate_ray(film);
            for c in 0..3 {
                dir[c][k] = ray.dir[c];
            }
            (state[k], inc[k]) = rng.to_parts();
        }
        store(lanes.rays.dir_x.as_mut_slice(), start, &dir[0]);
        store(lanes.rays.dir_y.as_mut_slice(), start, &dir[1]);
        store(lanes.rays.dir_z.as_mut_slice(), start, &dir[2]);
        store(&mut lanes.rng_state, start, &state);
        store(&mut lanes.rng_inc, start, &inc);
    }
    let origin = camera.pose.position;
    for (c, org) in [
        &mut lanes.rays.org_x,
        &mut lanes.rays.org_y,
        &mut lanes.rays.org_z,
    ]
    .into_iter()
    .enumerate()
    {
        org.as_mut_slice().fill(origin[c]);
    }
    lanes.rays.tnear.as_mut_slice().fill(0.0);
    lanes.rays.tfar.as_mut_slice().fill(f32::INFINITY);
    lanes.rays.geom_id.as_mut_slice().fill(INVALID_ID);
    lanes.rays.prim_id.as_mut_slice().fill(INVALID_ID);
    for (i, p) in lanes.pixel.iter_mut().enumerate() {
        *p = i as u32;
    }
    for c in 0..3 {
        lanes.beta[c].fill(1.0);
        lanes.radiance[c].fill(0.0);
    }
}

/// Fills each lane's light (position, intensity, pick probability) for the
/// next light sample. With several lights the pick draws the lane's next
/// two random numbers, as the general integrator does; the draw itself
/// (advancing the state) happens in [`shade_lane`]. With one light there is
/// nothing to fill: [`shade_lanes`] uses it for every lane.
#[inline(always)]
fn pick_lights(kernel: &DiffuseScene, scene: &Scene, lanes: &mut DiffuseLanes) {
    let n = lanes.rays.len();
    if kernel.single_light.is_some() {
        // `shade_lanes` uses it directly.
        return;
    }
    let geom = lanes.rays.geom_id.as_slice();
    for i in 0..n {
        if geom[i] == INVALID_ID {
            continue;
        }
        let mut rng = Rng::from_parts(lanes.rng_state[i], lanes.rng_inc[i]);
        let (li, pmf) = scene
            .lights
            .pick(Vec3::ZERO, rng.next_2d())
            .expect("DiffuseScene::new checked that picking succeeds");
        let Light::Point(l) = &scene.lights.lights[li] else {
            unreachable!("DiffuseScene::new checked that all lights are point lights")
        };
        for c in 0..3 {
            lanes.light_pos[c][i] = l.position[c];
            lanes.light_intensity[c][i] = l.intensity[c];
        }
        lanes.light_pmf[i] = pmf;
    }
}

/// Adds each unoccluded shadow ray's pending radiance to its path, and
/// lists the lanes whose paths go on in `lanes.kept`; returns their number.
#[inline(always)]
fn add_unoccluded(lanes: &mut DiffuseLanes) -> usize {
    let n = lanes.rays.len();
    lanes.kept.resize(n, 0);
    lanes.ended.resize(n, 0);
    let mut live = 0;
    for start in (0..n).step_by(W) {
        let shadow_tfar = load(lanes.shadow.tfar.as_slice(), start);
        let tfar = load(lanes.rays.tfar.as_slice(), start);
        for c in 0..3 {
            let mut radiance = load(&lanes.radiance[c], start);
            let pending = load(&lanes.pending[c], start);
            for k in 0..W {
                // Inactive lanes have tfar = −∞, as occluded ones. A select,
                // not a branch: occlusion is unpredictable.
                radiance[k] = if shadow_tfar[k] > 0.0 {
                    radiance[k] + pending[k]
                } else {
                    radiance[k]
                };
            }
            store(&mut lanes.radiance[c], start, &radiance);
        }
        for k in 0..(n - start).min(W) {
            // Branch-free too: whether a path goes on is unpredictable.
            let i = start + k;
            lanes.kept[live] = i as u32;
            lanes.ended[i - live] = i as u32;
            live += (tfar[k] > 0.0) as usize;
        }
    }
    lanes.kept.truncate(live);
    lanes.ended.truncate(n - live);
    live
}

/// What is the same for every lane of one bounce.
#[derive(Clone, Copy)]
struct Uniform {
    /// Whether paths go on after the light sample (BSDF sampling).
    continue_paths: bool,
    /// Whether Russian roulette applies after this bounce.
    roulette: bool,
}

/// One lane's inputs to a bounce.
#[derive(Clone, Copy)]
struct LaneIn {
    org: Vec3,
    dir: Vec3,
    /// Hit distance.
    t: f32,
    /// Unnormalised geometric normal.
    ng: Vec3,
    hit: bool,
    albedo: Vec3,
    beta: Vec3,
    rng: u64,
    inc: u64,
    light_pos: Vec3,
    light_intensity: Vec3,
    light_pmf: f32,
}

/// One lane's results of a bounce.
#[derive(Clone, Copy)]
struct LaneOut {
    /// Whether the path goes on (then `next_org`, `next_dir` hold its ray).
    alive: bool,
    next_org: Vec3,
    next_dir: Vec3,
    /// Whether a shadow ray is to be traced (`shadow_*` hold it).
    shadow: bool,
    shadow_org: Vec3,
    shadow_dir: Vec3,
    shadow_tfar: f32,
    /// Radiance the shadow ray adds if unoccluded.
    pending: Vec3,
    beta: Vec3,
    rng: u64,
}

/// Offset along the normal that keeps spawned rays off their surface
/// (the general integrator's `ray_epsilon`).
#[inline(always)]
fn ray_epsilon(p: Vec3) -> f32 {
    1e-4 * (1.0 + p.abs().max_element())
}

/// One bounce of one path: the general integrator's `shade` for a Lambert
/// surface and a point light, written without branches (every `if` is a
/// select) so that a loop over lanes vectorises. Same operations, same
/// order, same random numbers.
#[inline(always)]
fn shade_lane(l: LaneIn, u: Uniform) -> LaneOut {
    let mut rng = l.rng;
    let p = l.org + l.t * l.dir;
    let wo = -l.dir;
    let ng = l.ng.normalize_or_zero();
    let n = if ng.dot(wo) >= 0.0 { ng } else { -ng };
    let frame = Frame::from_normal(n);
    let wo_local = frame.to_local(wo);
    let eps = ray_epsilon(p);
    let origin = p + n * eps;

    // Next-event estimation: two numbers pick the light (see `pick_lights`),
    // two more are the light sample's (unused by a point light); they are
    // skipped below, together with the BSDF's lobe number.
    // PointLight::sample_li.
    let d = l.light_pos - p;
    let dist2 = d.length_squared();
    let inv_dist = dist2.sqrt().recip();
    let radiance = l.light_intensity * (inv_dist * inv_dist);
    let wi = d * inv_dist;
    let dist = dist2 * inv_dist;
    let wi_local = frame.to_local(wi);
    // Lambert::eval times |cos θi|.
    let above = wo_local.z > 0.0 && wi_local.z > 0.0;
    let f = if above {
        l.albedo * FRAC_1_PI
    } else {
        Vec3::ZERO
    };
    let f = f * wi_local.z.abs();
    let light_pdf = l.light_pmf * 1.0;
    let weight = 1.0f32;
    // From the offset origin to just short of the light; unbounded where
    // the distance overflows (as the general integrator does).
    let target = p + wi * dist;
    let (shadow_dir, shadow_tfar) = if dist.is_finite() {
        (target - origin, 1.0 - ray_epsilon(target) / dist)
    } else {
        (wi, f32::INFINITY)
    };
    let shadow = l.hit && dist2 != 0.0 && f != Vec3::ZERO && shadow_tfar > 0.0;
    let pending = l.beta * f * radiance * (weight / light_pdf);

    // Lambert::sample: one number picks the lobe (unused), two the direction.
    // Skip the four numbers of the light sample and the lobe's at once.
    Rng::skip::<5>(&mut rng, l.inc);
    let u1 = Rng::step_f32(&mut rng, l.inc);
    let u2 = Rng::step_f32(&mut rng, l.inc);
    let local = cosine_hemisphere(Vec2::new(u1, u2));
    let pdf = if local.z > 0.0 {
        local.z * FRAC_1_PI
    } else {
        0.0
    };
    let sampled = wo_local.z > 0.0 && pdf > 0.0;
    let next_dir = frame.to_world(local);
    let mut beta = l.beta * l.albedo;

    // Russian roulette: a number is drawn only where q < 1.
    let q = beta.max_element();
    let mut rng_rr = rng;
    let r = Rng::step_f32(&mut rng_rr, l.inc);
    let spin = u.roulette && q < 1.0;
    if spin {
        rng = rng_rr;
    }
    let survived = !spin || r < q;
    if spin {
        beta /= q;
    }
    let alive = l.hit && u.continue_paths && sampled && survived && beta != Vec3::ZERO;
    LaneOut {
        alive,
        next_org: origin,
        next_dir,
        shadow,
        shadow_org: origin,
        shadow_dir,
        shadow_tfar,
        pending,
        beta,
        rng,
    }
}

/// `square_to_cosine_hemisphere` (concentric map, Taylor sine and cosine)
/// with its branches as selects; bit-identical to it.
#[inline(always)]
fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let o = 2.0 * u - Vec2::ONE;
    let wide = o.x.abs() > o.y.abs();
    let (major, minor) = if wide { (o.x, o.y) } else { (o.y, o.x) };
    let (sin, cos) = sin_cos_quarter((PI / 4.0) * (minor / major));
    let d = if wide {
        major * Vec2::new(cos, sin)
    } else {
        major * Vec2::new(sin, cos)
    };
    let d = if o.x == 0.0 && o.y == 0.0 {
        Vec2::ZERO
    } else {
        d
    };
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Lanes per chunk of [`shade_lanes`]: one AVX-512 register of `f32`.
const W: usize = 16;

/// A component of [`W`] lanes, copied out of a lane array (zero past its end).
#[inline(always)]
fn load<T: Copy + Default>(src: &[T], start: usize) -> [T; W] {
    // A whole chunk is a fixed-size copy (register moves); only the last,
    // partial one needs a variable-length copy.
    if let Some(Ok(chunk)) = src.get(start..start + W).map(<[T; W]>::try_from) {
        return chunk;
    }
    let mut out = [T::default(); W];
    let m = (src.len() - start).min(W);
    out[..m].copy_from_slice(&src[start..start + m]);
    out
}

/// [`load`] with `fill` past the end of the lane array.
#[inline(always)]
fn load_or<T: Copy + Default>(src: &[T], start: usize, fill: T) -> [T; W] {
    let mut out = load(src, start);
    let m = (src.len() - start).min(W);
    out[m..].fill(fill);
    out
}

/// Copies a component of [`W`] lanes back (as far as the lane array goes).
#[inline(always)]
fn store<T: Copy>(dst: &mut [T], start: usize, src: &[T; W]) {
    if let Some(chunk) = dst.get_mut(start..start + W) {
        chunk.copy_from_slice(src);
        return;
    }
    let m = (dst.len() - start).min(W);
    dst[start..start + m].copy_from_slice(&src[..m]);
}

/// One bounce of every lane: reads the hits in `lanes.rays`, writes the
/// shadow rays to `lanes.shadow` and the next rays back to `lanes.rays`. Lanes
/// go through [`shade_lane`] in chunks of [`W`] copied into local arrays:
/// locals cannot alias each other, so the compiler vectorises the chunk's
/// loop without run-time overlap checks, which it could not generate for
/// some thirty lane arrays and a table lookup.
#[inline(always)]
fn shade_lanes(kernel: &DiffuseScene, lanes: &mut DiffuseLanes, u: Uniform) {
    let n = lanes.rays.len();
    let last = kernel.albedo[0].len() - 1;
    let rays = &mut lanes.rays;
    let shadow = &mut lanes.shadow;
    for start in (0..n).step_by(W) {
        let (ox, oy, oz) = (
            load(rays.org_x.as_slice(), start),
            load(rays.org_y.as_slice(), start),
            load(rays.org_z.as_slice(), start),
        );
        let (dx, dy, dz) = (
            load(rays.dir_x.as_slice(), start),
            load(rays.dir_y.as_slice(), start),
            load(rays.dir_z.as_slice(), start),
        );
        let t = load(rays.tfar.as_slice(), start);
        let (nx, ny, nz) = (
            load(rays.ng_x.as_slice(), start),
            load(rays.ng_y.as_slice(), start),
            load(rays.ng_z.as_slice(), start),
        );
        let geom = load_or(rays.geom_id.as_slice(), start, INVALID_ID);
        let (mut ar, mut ag, mut ab) = ([0.0f32; W], [0.0f32; W], [0.0f32; W]);
        for k in 0..W {
            let g = (geom[k] as usize).min(last);
            (ar[k], ag[k], ab[k]) = (
                kernel.albedo[0][g],
                kernel.albedo[1][g],
                kernel.albedo[2][g],
            );
        }
        let (br, bg, bb) = (
            load(&lanes.beta[0], start),
            load(&lanes.beta[1], start),
            load(&lanes.beta[2], start),
        );
        // One light: the same for every lane, so no per-lane arrays.
        let ([lx, ly, lz], [ir, ig, ib], lpmf) = match kernel.single_light {
            Some((p, i, pmf)) => (
                [[p.x; W], [p.y; W], [p.z; W]],
                [[i.x; W], [i.y; W], [i.z; W]],
                [pmf; W],
            ),
            None => (
                [
                    load(&lanes.light_pos[0], start),
                    load(&lanes.light_pos[1], start),
                    load(&lanes.light_pos[2], start),
                ],
                [
                    load(&lanes.light_intensity[0], start),
                    load(&lanes.light_intensity[1], start),
                    load(&lanes.light_intensity[2], start),
                ],
                load(&lanes.light_pmf, start),
            ),
        };
        let mut rng = load(&lanes.rng_state, start);
        let inc = load(&lanes.rng_inc, start);

        let mut next = [[0.0f32; W]; 6];
        let mut next_tfar = [0.0f32; W];
        let mut shadow_ray = [[0.0f32; W]; 6];
        let mut shadow_tfar = [0.0f32; W];
        let mut pending = [[0.0f32; W]; 3];
        let mut beta = [br, bg, bb];
        for k in 0..W {
            let hit = geom[k] != INVALID_ID;
            let out = shade_lane(
                LaneIn {
                    org: Vec3::new(ox[k], oy[k], oz[k]),
                    dir: Vec3::new(dx[k], dy[k], dz[k]),
                    t: t[k],
                    ng: Vec3::new(nx[k], ny[k], nz[k]),
                    hit,
                    albedo: Vec3::new(ar[k], ag[k], ab[k]),
                    beta: Vec3::new(br[k], bg[k], bb[k]),
                    rng: rng[k],
                    inc: inc[k],
                    light_pos: Vec3::new(lx[k], ly[k], lz[k]),
                    light_intensity: Vec3::new(ir[k], ig[k], ib[k]),
                    light_pmf: lpmf[k],
                },
                u,
            );
            // A lane without a hit keeps its state: its path has ended.
            if hit {
                rng[k] = out.rng;
                for c in 0..3 {
                    beta[c][k] = out.beta[c];
                }
            }
            for c in 0..3 {
                pending[c][k] = out.pending[c];
                shadow_ray[c][k] = out.shadow_org[c];
                shadow_ray[3 + c][k] = out.shadow_dir[c];
                next[c][k] = out.next_org[c];
                next[3 + c][k] = out.next_dir[c];
            }
            shadow_tfar[k] = if out.shadow {
                out.shadow_tfar
            } else {
                f32::NEG_INFINITY
            };
            next_tfar[k] = if out.alive {
                f32::INFINITY
            } else {
                f32::NEG_INFINITY
            };
        }

        store(&mut lanes.rng_state, start, &rng);
        for c in 0..3 {
            store(&mut lanes.beta[c], start, &beta[c]);
            store(&mut lanes.pending[c], start, &pending[c]);
        }
        for (dst, src) in [
            (&mut rays.org_x, &next[0]),
            (&mut rays.org_y, &next[1]),
            (&mut rays.org_z, &next[2]),
            (&mut rays.dir_x, &next[3]),
            (&mut rays.dir_y, &next[4]),
            (&mut rays.dir_z, &next[5]),
            (&mut rays.tfar, &next_tfar),
            (&mut shadow.org_x, &shadow_ray[0]),
            (&mut shadow.org_y, &shadow_ray[1]),
            (&mut shadow.org_z, &shadow_ray[2]),
            (&mut shadow.dir_x, &shadow_ray[3]),
            (&mut shadow.dir_y, &shadow_ray[4]),
            (&mut shadow.dir_z, &shadow_ray[5]),
            (&mut shadow.tfar, &shadow_tfar),
        ] {
            store(dst.as_mut_slice(), start, src);
        }
    }
    // Every ray starts at its origin and has no hit yet.
    rays.tnear.as_mut_slice().fill(0.0);
    rays.geom_id.as_mut_slice().fill(INVALID_ID);
    shadow.tnear.as_mut_slice().fill(0.0);
}
