//! The differentiable path tracer: the gradient of a loss over a rendered
//! image with respect to material and light parameters.
//!
//! # The estimator
//!
//! A loss `ℒ(I)` of the image `I` has the gradient
//! `∂ℒ/∂θ = Σ_p ∂ℒ/∂I_p · ∂I_p/∂θ`; the caller renders `I` (the *primal*),
//! computes the per-pixel adjoint `∂ℒ/∂I_p`, and this module estimates
//! `Σ_p adjoint_p · ∂I_p/∂θ` from paths drawn with a **different seed** (for
//! the squared error, using the primal's own paths would correlate the two
//! factors and bias the gradient).
//!
//! The paths are those of the general integrator (same next-event
//! estimation, BSDF sampling, MIS and Russian roulette, the same random
//! numbers in the same order: [`gradient_tile`] renders the same image bit
//! for bit, which `crates/cli/tests/it/gradients.rs` checks). Every choice the sampler
//! makes (directions, light picks, MIS weights, roulette probabilities) is
//! treated as a constant of the parameters: *detached sampling*. Each path
//! contribution `c = L_e · Π_k f_k cos θ_k / p_k · w` is then a product of
//! factors that depend on the parameters only through the BSDF values `f_k`
//! and the emitted radiance `L_e`, and differentiating it under the expected
//! value keeps the estimator unbiased, provided the densities `p_k` stay
//! positive wherever `∂f_k/∂θ` is not zero (true of every model that has
//! derivatives: their sampling covers their support) and the geometry does
//! not move (it does not: only materials and emission are parameters).
//!
//! The pass runs as the general integrator's wavefront: the paths of one
//! sample pass over a tile advance together, their camera rays, bounce
//! rays and shadow rays going to Embree as streams; a next-event
//! contribution's gradient terms wait with its shadow ray and count only
//! if it is not blocked.
//!
//! The derivative of the path throughput `β` travels forward with the path,
//! one RGB vector per parameter (forward mode): at a vertex whose material
//! has parameters, `∂β' = ∂β·w + β·∂f·|cos θ|/p`; elsewhere `∂β' = ∂β·w`.
//! Every contribution `c = β·x` adds `adjoint · (∂β·x + β·∂x)` to the
//! gradient, where `∂x` holds the BSDF derivative of next-event estimation
//! and the light's own terms (emission is linear in each light parameter,
//! so `∂c/∂b = c/b`). The memory is one RGB vector per parameter per path,
//! independent of the path's length; the work per bounce grows with the
//! number of parameters, which suits the tens of parameters of a room's
//! materials and lights (textures, with a parameter per texel, would need
//! path replay backpropagation instead).

use super::spawn::{ray_epsilon, shadow_segment, spawn_origin};
use super::steps::{
    camera_sample, emission_weight, roulette, roulette_spins, sides_agree, PrevVertex, SurfacePoint,
};
use crate::accel::{Ray, RayHit, ShadowRay};
use crate::bsdf::BSDF_PARAMS;
use crate::film::{PixelSums, Tile};
use crate::job::RenderJob;
use crate::light::Light;
use crate::scene::Scene;
use crate::warp::{power_heuristic, Frame};
use glam::{Vec2, Vec3};

/// The gradient slots a light's emission parameters feed.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LightSlots {
    /// A scalar multiplier of the light's emission (a PLS light's `b`, the
    /// environment's `scale`): its slot and current value (> 0).
    pub scalar: Option<(u32, f32)>,
    /// An RGB factor of the emission (a PLS light's `c`, a point light's
    /// `intensity`, a shape's `emission`): the first of its three slots and
    /// its current value; a channel at 0 gets no derivative.
    pub colour: Option<(u32, Vec3)>,
}

/// Where the derivative of each parameter goes: slots of the gradient
/// vector, per material and per light of the scene.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GradientMap {
    /// Per material (index into `Scene::materials`): the slot of each
    /// [`crate::bsdf::BsdfParam`], if it is a parameter.
    pub materials: Vec<[Option<u32>; BSDF_PARAMS]>,
    /// Per light (index into `Scene::lights().lights`).
    pub lights: Vec<LightSlots>,
    /// Number of slots.
    pub len: usize,
}

impl GradientMap {
    /// A map with no parameters for `scene`.
    pub fn empty(scene: &Scene) -> GradientMap {
        GradientMap {
            materials: vec![[None; BSDF_PARAMS]; scene.materials().len()],
            lights: vec![LightSlots::default(); scene.lights().lights.len()],
            len: 0,
        }
    }

    fn material_has_slots(&self, material: u32) -> bool {
        self.materials[material as usize]
            .iter()
            .any(Option::is_some)
    }
}

/// The result of differentiating one tile.
#[derive(Debug, Clone)]
pub struct TileGradient {
    /// The tile.
    pub tile: Tile,
    /// The radiance sums of the paths traced (only `sum`, `sum_sq` and
    /// `samples`; no AOVs), row-major within the tile; with `all_paths`,
    /// the image the general integrator renders for the same job.
    pub pixels: Vec<PixelSums>,
    /// `Σ_p adjoint_p · ∂I_p/∂θ` per slot, over this tile's pixels.
    pub gradient: Vec<f64>,
}

/// Everything a path of the gradient pass reads.
struct Context<'a> {
    scene: &'a Scene,
    job: &'a RenderJob,
    map: &'a GradientMap,
}

/// Estimates the tile's share of the gradient for `adjoint` (the loss's
/// derivative with respect to each pixel's recorded value, row-major over
/// the whole image). Pixels whose adjoint is zero are skipped unless
/// `all_paths`, which traces every pixel (for checking the primal).
pub fn gradient_tile(
    scene: &Scene,
    job: &RenderJob,
    map: &GradientMap,
    adjoint: &[Vec3],
    tile: Tile,
    all_paths: bool,
) -> TileGradient {
    let width = scene.camera().width();
    let n = (tile.width * tile.height) as usize;
    let mut pixels = vec![
        PixelSums {
            samples: job.spp,
            ..Default::default()
        };
        n
    ];
    let mut gradient = vec![0.0f64; map.len];
    let ctx = Context { scene, job, map };
    // The sensor response is linear (`s·W·L`), so the adjoint of a path's
    // radiance is `s·Wᵀ·adjoint`, over the samples it is averaged with.
    let response = scene.film().response();
    let lens_sample = scene.camera().needs_lens_sample();
    // A wavefront per sample pass, as the general integrator's: camera rays
    // as a coherent stream, then each bounce's rays and shadow rays as
    // streams. Each path keeps its own ∂β (a pool, reused).
    let mut paths: Vec<GradientPath> = Vec::new();
    let mut dbetas: Vec<ThroughputDerivative> = Vec::new();
    let mut rays: Vec<RayHit> = Vec::new();
    let mut shadow_rays: Vec<ShadowRay> = Vec::new();
    let mut pending: Vec<PendingContribution> = Vec::new();
    let mut terms: Vec<(u32, f64)> = Vec::new();
    for s in job.samples() {
        paths.clear();
        rays.clear();
        for py in 0..tile.height {
            for px in 0..tile.width {
                let (x, y) = (tile.x0 + px, tile.y0 + py);
                let a = adjoint[(y * width + x) as usize];
                if a == Vec3::ZERO && !all_paths {
                    continue;
                }
                let a = match response.white_balance {
                    Some(m) => m.transpose() * a,
                    None => a,
                } * (response.scale / job.spp as f32);
                let (rng, Some(ray)) = camera_sample(scene, job.seed, lens_sample, x, y, s) else {
                    continue;
                };
                if dbetas.len() <= paths.len() {
                    dbetas.push(ThroughputDerivative::new(map.len));
                }
                dbetas[paths.len()].clear();
                paths.push(GradientPath {
                    pixel: py * tile.width + px,
                    rng,
                    adjoint: a,
                    beta: Vec3::ONE,
                    radiance: Vec3::ZERO,
                    prev_pdf: 0.0,
                    prev_point: ray.org,
                    depth: 0,
                    eta_scale: 1.0,
                    alive: true,
                });
                rays.push(RayHit::masked(ray, job.ray_mask()));
            }
        }
        scene.accel().intersect_stream(&mut rays, true);
        while !paths.is_empty() {
            shadow_rays.clear();
            pending.clear();
            terms.clear();
            for (i, (path, rh)) in paths.iter_mut().zip(rays.iter_mut()).enumerate() {
                let queues = Queues {
                    shadow_rays: &mut shadow_rays,
                    pending: &mut pending,
                    terms: &mut terms,
                };
                step(
                    &ctx,
                    path,
                    i as u32,
                    rh,
                    &mut dbetas[i],
                    &mut gradient,
                    queues,
                );
            }
            scene.accel().occluded_stream(&mut shadow_rays, false);
            for (ray, p) in shadow_rays.iter().zip(&pending) {
                if !ray.occluded() {
                    paths[p.path as usize].radiance += p.radiance;
                    for &(slot, v) in &terms[p.terms.clone()] {
                        gradient[slot as usize] += v;
                    }
                }
            }
            // Retire finished paths (in order) and compact the live ones,
            // each with its ∂β.
            let mut live = 0;
            for i in 0..paths.len() {
                if paths[i].alive {
                    paths.swap(live, i);
                    rays.swap(live, i);
                    dbetas.swap(live, i);
                    live += 1;
                } else {
                    let path = &paths[i];
                    pixels[path.pixel as usize].add_radiance(response.apply(path.radiance));
                }
            }
            paths.truncate(live);
            rays.truncate(live);
            scene.accel().intersect_stream(&mut rays, false);
        }
    }
    TileGradient {
        tile,
        pixels,
        gradient,
    }
}

/// `∂β` of one path per gradient slot, sparse: only the slots the path's
/// vertices have touched are visited (a path over surfaces without
/// parameters costs nothing).
struct ThroughputDerivative {
    d: Vec<Vec3>,
    touched: Vec<u32>,
    is_touched: Vec<bool>,
}

impl ThroughputDerivative {
    fn new(len: usize) -> ThroughputDerivative {
        ThroughputDerivative {
            d: vec![Vec3::ZERO; len],
            touched: Vec::new(),
            is_touched: vec![false; len],
        }
    }

    /// Back to zero, for the next path.
    fn clear(&mut self) {
        for &s in &self.touched {
            self.d[s as usize] = Vec3::ZERO;
            self.is_touched[s as usize] = false;
        }
        self.touched.clear();
    }

    #[inline]
    fn add(&mut self, slot: u32, v: Vec3) {
        if !self.is_touched[slot as usize] {
            self.is_touched[slot as usize] = true;
            self.touched.push(slot);
        }
        self.d[slot as usize] += v;
    }

    /// `∂β ← ∂β·w`.
    #[inline]
    fn scale(&mut self, w: Vec3) {
        for &s in &self.touched {
            self.d[s as usize] *= w;
        }
    }

    fn is_zero(&self) -> bool {
        self.touched
            .iter()
            .all(|&s| self.d[s as usize] == Vec3::ZERO)
    }

    /// Adds `adjoint · (∂β·x)` for every touched slot: the part of a
    /// contribution `β·x` that the earlier vertices' parameters change.
    #[inline]
    fn contribute(&self, x: Vec3, adjoint: Vec3, gradient: &mut (impl GradientSink + ?Sized)) {
        let ax = adjoint * x;
        for &s in &self.touched {
            gradient.add(s, ax.dot(self.d[s as usize]) as f64);
        }
    }
}

/// Where gradient terms go: straight into the gradient, or (for a
/// contribution that waits on its shadow ray) into a list of terms applied
/// if the ray is not blocked.
trait GradientSink {
    fn add(&mut self, slot: u32, value: f64);
}

impl GradientSink for [f64] {
    #[inline]
    fn add(&mut self, slot: u32, value: f64) {
        self[slot as usize] += value;
    }
}

impl GradientSink for Vec<(u32, f64)> {
    #[inline]
    fn add(&mut self, slot: u32, value: f64) {
        self.push((slot, value));
    }
}

/// Adds the light's own terms for a contribution `c` of light `li`
/// (emission is linear in each of its parameters).
#[inline]
fn add_light_terms(
    map: &GradientMap,
    li: usize,
    c: Vec3,
    adjoint: Vec3,
    gradient: &mut (impl GradientSink + ?Sized),
) {
    let slots = &map.lights[li];
    if let Some((slot, value)) = slots.scalar {
        if value > 0.0 {
            gradient.add(slot, (adjoint.dot(c) / value) as f64);
        }
    }
    if let Some((slot, value)) = slots.colour {
        for ch in 0..3 {
            if value[ch] > 0.0 {
                gradient.add(slot + ch as u32, (adjoint[ch] * c[ch] / value[ch]) as f64);
            }
        }
    }
}

/// One path of the gradient pass's wavefront.
struct GradientPath {
    /// Pixel index within the tile.
    pixel: u32,
    rng: crate::sampler::PathSampler,
    /// `s·Wᵀ·∂ℒ/∂I` of the pixel, over its samples.
    adjoint: Vec3,
    beta: Vec3,
    radiance: Vec3,
    prev_pdf: f32,
    prev_point: Vec3,
    depth: u32,
    /// `η²` of the refractions so far, for the roulette (as the general
    /// integrator's `PathState::eta_scale`).
    eta_scale: f32,
    alive: bool,
}

/// A next-event contribution waiting on its shadow ray: its radiance and
/// its gradient terms (a range of the pass's term list).
struct PendingContribution {
    path: u32,
    radiance: Vec3,
    terms: std::ops::Range<usize>,
}

/// What one vertex of a path queues: a shadow ray and its contribution.
struct Queues<'a> {
    shadow_rays: &'a mut Vec<ShadowRay>,
    pending: &'a mut Vec<PendingContribution>,
    terms: &'a mut Vec<(u32, f64)>,
}

/// Processes the hit of one path (as the general integrator's `shade`,
/// with the gradient terms): emission, next-event estimation (queued on
/// its shadow ray), and the next ray, written back into `rh`, or ends the
/// path.
#[allow(clippy::too_many_arguments)]
fn step(
    ctx: &Context,
    path: &mut GradientPath,
    index: u32,
    rh: &mut RayHit,
    dbeta: &mut ThroughputDerivative,
    gradient: &mut [f64],
    queues: Queues,
) {
    let Context { scene, job, map } = *ctx;
    let mask = job.ray_mask();
    let max_depth = job.max_depth;
    let adjoint = path.adjoint;
    let ray = rh.ray();
    let Some(hit) = rh.hit() else {
        escaped(ctx, path, ray, dbeta, gradient);
        path.alive = false;
        return;
    };
    let (beta, depth) = (path.beta, path.depth);
    let on = scene.mesh_hit(&hit);
    let hit = on.world(hit);
    let mesh = on.mesh;
    let p = ray.org + hit.t * ray.dir;
    let wo = -ray.dir;
    let ng = hit.ng.normalize_or_zero();
    let facing = if ng.dot(wo) >= 0.0 { ng } else { -ng };
    let material = &scene.materials()[mesh.material as usize];
    let surface = SurfacePoint::new(on, &hit, material);
    let textured;
    let bsdf = if material.textures.is_empty() {
        &material.bsdf
    } else {
        textured = material.bsdf_at(surface.uv, surface.color);
        &textured
    };
    let guard = surface.normal.is_some();
    let n = if bsdf.transmits() { ng } else { facing };
    let shading_n = surface.shading_normal(n, wo);
    let shading_n = match material.textures.valid_reflection && !bsdf.transmits() {
        true => crate::integrator::steps::valid_reflection_normal(shading_n, n, wo),
        false => shading_n,
    };

    if let Some(li) = scene.hit_light(&hit) {
        if let Light::Triangle(tl) = &scene.lights().lights[li] {
            let le = tl.emitted_at(wo, Vec2::new(hit.u, hit.v));
            if le != Vec3::ZERO {
                let prev = PrevVertex {
                    depth,
                    pdf: path.prev_pdf,
                    point: path.prev_point,
                };
                let weight = emission_weight(scene, li, &prev, p, ray.dir);
                let contribution = beta * le * weight;
                path.radiance += contribution;
                dbeta.contribute(le * weight, adjoint, gradient);
                add_light_terms(map, li, contribution, adjoint, gradient);
            }
        }
    }

    if depth >= max_depth || material.black_from(hit.ng, ray.dir) {
        path.alive = false;
        return;
    }
    let slots = &map.materials[mesh.material as usize];
    let differentiable = map.material_has_slots(mesh.material);
    // The derivatives this material needs (bit k: slot k).
    let wanted = slots
        .iter()
        .enumerate()
        .filter(|(_, s)| s.is_some())
        .fold(0u8, |m, (k, _)| m | 1 << k);
    // A material whose anisotropy is a parameter needs its tangent frame
    // even while the anisotropy is 0.
    let frame =
        if bsdf.is_anisotropic() || slots[crate::bsdf::BsdfParam::Anisotropic as usize].is_some() {
            Frame::from_normal_tangent(shading_n, SurfacePoint::tangent(on, &hit))
        } else {
            Frame::from_normal(shading_n)
        };
    let wo_local = frame.to_local(wo);
    let v = Vertex {
        p,
        wo,
        ng,
        n,
        eps: ray_epsilon(p),
        guard,
        bsdf,
        frame,
        wo_local,
        slots,
        differentiable,
        wanted,
    };

    next_event(ctx, path, index, &v, dbeta, queues);
    if depth + 1 == max_depth && !scene.has_hittable_lights() {
        path.alive = false;
        return;
    }
    match continue_path(ctx, path, &v, dbeta) {
        Some(wi) => *rh = RayHit::masked(Ray::new(v.origin_for(wi), wi), mask),
        None => path.alive = false,
    }
}

/// A hit point and what the steps after the hit share: its frames, its
/// BSDF (textures applied) and the gradient slots of its material.
struct Vertex<'a> {
    p: Vec3,
    wo: Vec3,
    ng: Vec3,
    /// The normal rays leave by (geometric, facing `wo` unless the BSDF transmits).
    n: Vec3,
    eps: f32,
    /// Whether shading normals may disagree with the geometry (so leaks are checked).
    guard: bool,
    bsdf: &'a crate::bsdf::Bsdf,
    frame: Frame,
    wo_local: Vec3,
    slots: &'a [Option<u32>; BSDF_PARAMS],
    differentiable: bool,
    /// The derivatives the material needs (bit k: slot k).
    wanted: u8,
}

impl Vertex<'_> {
    /// Where a ray leaving towards `dir` starts.
    fn origin_for(&self, dir: Vec3) -> Vec3 {
        if self.bsdf.transmits() {
            spawn_origin(self.p, self.n, self.eps, dir)
        } else {
            self.p + self.n * self.eps
        }
    }
}

/// A path that left the scene: the environment's radiance, MIS-weighted
/// against the last BSDF sample, and its gradient terms.
fn escaped(
    ctx: &Context,
    path: &mut GradientPath,
    ray: Ray,
    dbeta: &mut ThroughputDerivative,
    gradient: &mut [f64],
) {
    let Context { scene, map, .. } = *ctx;
    let adjoint = path.adjoint;
    if let Some(env) = scene.environment_index() {
        let Light::Environment { light, .. } = &scene.lights().lights[env] else {
            unreachable!("Scene::environment indexes an environment light")
        };
        let le = light.radiance(ray.dir);
        if le != Vec3::ZERO {
            let weight = if path.depth == 0 || path.prev_pdf == 0.0 {
                1.0
            } else {
                let light_pdf = scene.lights().pick_pmf(env, path.prev_point) * light.pdf(ray.dir);
                power_heuristic(path.prev_pdf, light_pdf)
            };
            let contribution = path.beta * le * weight;
            path.radiance += contribution;
            dbeta.contribute(le * weight, adjoint, gradient);
            add_light_terms(map, env, contribution, adjoint, gradient);
        }
    }
}

/// Next-event estimation at `v`: a light sample whose contribution and
/// gradient terms are queued on its shadow ray.
fn next_event(
    ctx: &Context,
    path: &mut GradientPath,
    index: u32,
    v: &Vertex,
    dbeta: &mut ThroughputDerivative,
    queues: Queues,
) {
    let Context { scene, job, map } = *ctx;
    let mask = job.ray_mask();
    let (adjoint, beta) = (path.adjoint, path.beta);
    let light_pick = if v.bsdf.is_delta() {
        None
    } else {
        scene.lights().pick(v.p, path.rng.next_2d())
    };
    if let Some((li, pick_pmf)) = light_pick {
        let u = path.rng.next_2d();
        if let Some(ls) = super::steps::sample_light(scene, li, v.p, u, mask) {
            let wi_local = v.frame.to_local(ls.wi);
            let leaks = v.guard && !sides_agree(v.wo, ls.wi, v.ng, v.wo_local, wi_local);
            // A zero BSDF value may still have a derivative (a black
            // albedo): the differentiable case goes on to its shadow ray.
            // Towards a delta light the derivatives' value is `eval`'s,
            // bit for bit, and stands for it.
            let dfc = (v.differentiable && !leaks)
                .then(|| v.bsdf.eval_gradient_of(v.wo_local, wi_local, v.wanted));
            let (f, bsdf_pdf) = match dfc {
                _ if leaks => (Vec3::ZERO, 0.0),
                Some(g) if ls.delta => (g.f, 0.0),
                _ if ls.delta => (v.bsdf.eval(v.wo_local, wi_local), 0.0),
                _ => v.bsdf.eval_pdf(v.wo_local, wi_local),
            };
            let cos = wi_local.z.abs();
            let fc = f * cos;
            let any_derivative = dfc.is_some_and(|g| g.d.iter().any(|d| *d != Vec3::ZERO));
            if fc != Vec3::ZERO || any_derivative {
                let light_pdf = pick_pmf * ls.pdf;
                let weight = if ls.delta {
                    1.0
                } else {
                    power_heuristic(light_pdf, bsdf_pdf)
                };
                let origin = v.origin_for(ls.wi);
                let (dir, tfar) = shadow_segment(origin, v.p, ls.wi, ls.dist);
                let shadow = Ray {
                    org: origin,
                    dir,
                    tnear: 0.0,
                    tfar,
                };
                if shadow.tfar > 0.0 {
                    // As the general integrator: β·f·L·(w/p), and its terms
                    // with this vertex's ∂β, applied if the ray is clear.
                    let scale = weight / light_pdf;
                    let contribution = beta * fc * ls.radiance * scale;
                    let start = queues.terms.len();
                    dbeta.contribute(fc * ls.radiance * scale, adjoint, queues.terms);
                    add_light_terms(map, li, contribution, adjoint, queues.terms);
                    if let Some(g) = dfc {
                        let ax = adjoint * beta * ls.radiance * (cos * scale);
                        for (k, slot) in v.slots.iter().enumerate() {
                            if let Some(slot) = slot {
                                queues.terms.push((*slot, ax.dot(g.d[k]) as f64));
                            }
                        }
                    }
                    queues.shadow_rays.push(ShadowRay::masked(shadow, mask));
                    queues.pending.push(PendingContribution {
                        path: index,
                        radiance: contribution,
                        terms: start..queues.terms.len(),
                    });
                }
            }
        }
    }
}

/// The BSDF sample at `v`: updates the path's throughput, its derivative
/// and Russian roulette; the direction of the next ray, or `None` if the
/// path ends.
fn continue_path(
    ctx: &Context,
    path: &mut GradientPath,
    v: &Vertex,
    dbeta: &mut ThroughputDerivative,
) -> Option<Vec3> {
    let job = ctx.job;
    let beta = path.beta;
    let uc = path.rng.next_f32();
    let Some(bs) = v.bsdf.sample(v.wo_local, uc, path.rng.next_2d()) else {
        path.alive = false;
        return None;
    };
    let wi = v.frame.to_world(bs.wi);
    if v.guard && !sides_agree(v.wo, wi, v.ng, v.wo_local, bs.wi) {
        path.alive = false;
        return None;
    }
    // ∂β' = ∂β·w + β·∂f·|cos θ|/p (detached p), with the old β.
    dbeta.scale(bs.weight);
    if v.differentiable && !bs.delta && bs.pdf > 0.0 {
        let g = v.bsdf.eval_gradient_of(v.wo_local, bs.wi, v.wanted);
        let k = bs.wi.z.abs() / bs.pdf;
        for (slot, d) in v.slots.iter().zip(g.d) {
            if let Some(slot) = slot {
                dbeta.add(*slot, beta * d * k);
            }
        }
    }
    path.beta *= bs.weight;
    path.prev_pdf = if bs.delta { 0.0 } else { bs.pdf };
    path.prev_point = v.p;
    path.depth += 1;
    path.eta_scale *= v.bsdf.eta_scale(v.wo_local, bs.wi);
    let rr_beta = path.beta * path.eta_scale;
    if roulette_spins(rr_beta, path.depth >= job.rr_depth) {
        let q = rr_beta.max_element();
        let (survives, b) = roulette(path.beta, rr_beta, path.rng.next_f32());
        if !survives {
            path.alive = false;
            return None;
        }
        path.beta = b;
        dbeta.scale(Vec3::splat(1.0 / q));
    }
    if path.beta == Vec3::ZERO && dbeta.is_zero() {
        path.alive = false;
        return None;
    }
    Some(wi)
}
