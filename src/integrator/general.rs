//! The general integrator: the path tracer as a small wavefront per tile,
//! the reference the vectorised kernel is checked against
//! (`plsr render --scalar`). Its steps shared with the kernel are in
//! [`super::steps`].

use super::spawn::{ray_epsilon, shadow_segment, spawn_origin};
use super::split_lobes::SplitLobes;
use super::steps::*;
use crate::accel::{Ray, RayHit, ShadowRay};
use crate::bsdf::Scatter;
use crate::film::{PixelSums, Tile};
use crate::job::RenderJob;
use crate::light::{Light, LightSample};
use crate::prefetch::prefetch;
use crate::sampler::PathSampler;
use crate::scene::Scene;
use crate::warp::{power_heuristic, Frame};
use glam::{Vec2, Vec3};
use std::time::Instant;

const COHERENT_CAMERA: bool = true;

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
    for rh in rays {
        if let Some(hit) = rh.hit() {
            let mesh = scene.mesh_hit(&hit).mesh;
            if attributes(mesh) {
                prefetch(&mesh.triangles[hit.prim_id as usize]);
            }
        }
    }
    for rh in rays {
        if let Some(hit) = rh.hit() {
            let mesh = scene.mesh_hit(&hit).mesh;
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
fn sample_environment_ahead(pass: &TilePass, wf: &mut Wavefront, env: usize) {
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

/// One sample pass of the general integrator over a tile.
struct TilePass<'a> {
    scene: &'a Scene,
    job: &'a RenderJob,
    tile: Tile,
    /// The sample index of this pass.
    sample: u32,
    /// Whether this is the render's first pass over the tile (it records
    /// the object id).
    first: bool,
}

fn trace_pass(pass: &TilePass, wf: &mut Wavefront, pixels: &mut [PixelSums], stats: &mut RayStats) {
    let &TilePass {
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
    let grouped = scene.instancing().groups.iter().flat_map(|g| &g.meshes);
    let has_attributes = scene.meshes().iter().chain(grouped).any(attributes);
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
    pass: &TilePass,
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
    let on = scene.mesh_hit(&hit);
    let hit = on.world(hit);
    let mesh = on.mesh;
    let material = &scene.materials()[mesh.material as usize];
    let surface = SurfacePoint::new(on, &hit, material);
    let at = SurfaceHit::new(scene, on, &ray, &hit, surface);

    if path.depth == 0 {
        pixel.add_first_hit(
            scene.camera().depth(ray.dir, hit.t),
            at.aov_normal(),
            at.bsdf.albedo(),
        );
        if record_aovs_first {
            pixel.object_id = on.object_layer();
        }
        if mesh.is_virtual {
            pixel.virtual_hits += 1;
        }
    }

    // Emission found by the camera ray or by BSDF sampling, MIS-weighted
    // against next-event estimation (which could have found it too).
    if let Some(li) = scene.hit_light(&hit) {
        let light = &scene.lights().lights[li];
        if let Light::Triangle(tl) = light {
            let le = tl.emitted_at(at.wo, Vec2::new(hit.u, hit.v));
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

    // The back of a one-sided surface is black: the path ends (after its
    // layers and any emission were recorded).
    if path.depth >= max_depth || material.black_from(hit.ng, ray.dir) {
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
            _ => super::steps::sample_light(scene, li, p, u, pass.job.ray_mask()),
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
/// `tan²θ` for `cos θ` (infinite at 0).
#[inline]
fn tan2(cos: f32) -> f32 {
    let c2 = (cos * cos).max(1e-12);
    (1.0 - c2).max(0.0) / c2
}

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
    /// The diffuse lobe's own shading normal where it differs from
    /// `shading_n` (see [`SplitLobes`]).
    diffuse_n: Option<Vec3>,
    /// Whether the mesh has vertex normals (then the light-leak guard
    /// applies, see [`sides_agree`]).
    guard: bool,
    /// The material's scattering at the hit (its textures looked up).
    bsdf: Scatter,
    /// The normal before the normal map tilted it and `α²` of the shadow
    /// terminator's microfacets (0: no attenuation), see
    /// [`SurfaceHit::terminator`].
    terminator: (Vec3, f32),
    on: crate::scene::MeshHit<'a>,
    hit: crate::accel::Hit,
}

impl<'a> SurfaceHit<'a> {
    /// The hit `hit` of `ray`, whose surface attributes are `surface`.
    #[inline]
    fn new(
        scene: &'a Scene,
        on: crate::scene::MeshHit<'a>,
        ray: &Ray,
        hit: &crate::accel::Hit,
        surface: SurfacePoint,
    ) -> SurfaceHit<'a> {
        let mesh = on.mesh;
        let material = &scene.materials()[mesh.material as usize];
        let p = ray.org + hit.t * ray.dir;
        let wo = -ray.dir;
        let ng = hit.ng.normalize_or_zero();
        let facing = if ng.dot(wo) >= 0.0 { ng } else { -ng };
        let bsdf = if material.textures.is_empty() && material.composite.is_none() {
            Scatter::One(material.bsdf)
        } else {
            material.scatter_at(surface.uv, surface.color, ng.dot(wo) < 0.0)
        };
        // Opaque surfaces are two-sided: shade in the frame facing the viewer.
        // Transmissive ones keep the geometric normal as their outside.
        let n = if bsdf.transmits() { ng } else { facing };
        let mapped_n = surface.shading_normal(n, wo);
        let shading_n = match material.textures.valid_reflection && !bsdf.transmits() {
            true => crate::integrator::steps::valid_reflection_normal(mapped_n, n, wo),
            false => mapped_n,
        };
        // Where the correction bent the normal, a principled material's
        // diffuse lobe keeps the mapped one (see `split_lobes`).
        let diffuse_n = match bsdf {
            Scatter::One(crate::bsdf::Bsdf::Principled(p))
                if shading_n != mapped_n && p.metallic < 1.0 =>
            {
                Some(mapped_n)
            }
            _ => None,
        };
        let terminator = if material.textures.terminator() {
            // Estevez et al. 2019: the tilt of the mapped normal from the
            // unmapped one sets the roughness of a microfacet surface,
            // `α² = min(tan²θ / 8, 1)`.
            let base = match surface.base_normal {
                Some(b) => crate::integrator::steps::shading_normal_towards(b, n, wo),
                None => n,
            };
            let cos = shading_n.dot(base).clamp(-1.0, 1.0);
            (base, (0.125 * tan2(cos)).min(1.0))
        } else {
            (n, 0.0)
        };
        SurfaceHit {
            p,
            wo,
            ng,
            facing,
            n,
            shading_n,
            diffuse_n,
            terminator,
            // Without shading normals the frame's normal is ±ng and the
            // light-leak guard cannot fail.
            guard: surface.normal.is_some(),
            bsdf,
            on,
            hit: *hit,
        }
    }

    /// The shadow terminator's attenuation of light arriving along `w`
    /// (Estevez et al. 2019, as Mitsuba's `normalmap` applies it): Smith's
    /// `G1 = 2 / (1 + √(1 + α²·tan²θ))`, `θ` the angle of `w` from the
    /// unmapped normal; 1 where the material does not ask for it.
    #[inline]
    fn terminator(&self, w: Vec3) -> f32 {
        let (base, alpha2) = self.terminator;
        if alpha2 == 0.0 {
            return 1.0;
        }
        2.0 / (1.0 + (1.0 + alpha2 * tan2(w.dot(base))).sqrt())
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

    /// The BSDF with its lobes in two frames, where they have two.
    #[inline]
    fn split_lobes(&self, frame: &Frame) -> Option<SplitLobes> {
        let (nd, Scatter::One(crate::bsdf::Bsdf::Principled(params))) =
            (self.diffuse_n?, self.bsdf)
        else {
            return None;
        };
        Some(SplitLobes {
            params,
            diffuse: Frame::from_normal(nd),
            specular: *frame,
            guard: self.guard,
            ng: self.ng,
        })
    }

    /// The local shading frame (with the tangent anisotropic BSDFs need).
    #[inline]
    fn frame(&self) -> Frame {
        if self.bsdf.is_anisotropic() {
            Frame::from_normal_tangent(self.shading_n, SurfacePoint::tangent(self.on, &self.hit))
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
    let split = at.split_lobes(&frame);
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
            let (f, bsdf_pdf) = match &split {
                Some(lobes) => {
                    let (f, pdf) = lobes.eval_pdf(wo, ls.wi);
                    (f * at.terminator(ls.wi), pdf)
                }
                None => {
                    let wi_local = frame.to_local(ls.wi);
                    // A delta light needs no MIS weight, so no BSDF density.
                    let (f, pdf) = if at.guard && !sides_agree(wo, ls.wi, ng, wo_local, wi_local) {
                        (Vec3::ZERO, 0.0)
                    } else if ls.delta {
                        (bsdf.eval(wo_local, wi_local), 0.0)
                    } else {
                        bsdf.eval_pdf(wo_local, wi_local)
                    };
                    (f * (wi_local.z.abs() * at.terminator(ls.wi)), pdf)
                }
            };
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
    let (wi, pdf) = if let Some(lobes) = &split {
        let Some(s) = lobes.sample(wo, uc, rng.next_2d()) else {
            return out;
        };
        *beta *= s.weight * at.terminator(s.wi);
        (s.wi, s.pdf)
    } else {
        let Some(bs) = bsdf.sample(wo_local, uc, rng.next_2d()) else {
            return out;
        };
        let wi = frame.to_world(bs.wi);
        if at.guard && !sides_agree(wo, wi, ng, wo_local, bs.wi) {
            return out;
        }
        *beta *= bs.weight * at.terminator(wi);
        *eta_scale *= bsdf.eta_scale(wo_local, bs.wi);
        (wi, if bs.delta { 0.0 } else { bs.pdf })
    };
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
    out.next = Some((Ray::new(origin_for(wi), wi), pdf));
    out
}

/// Renders the job's samples of every pixel of `tile` into `pixels`.
pub(super) fn render_samples(
    scene: &Scene,
    job: &RenderJob,
    tile: Tile,
    pixels: &mut [PixelSums],
    rays: &mut RayStats,
) {
    let first_sample = job.samples().start;
    let mut wf = Wavefront::default();
    for s in job.samples() {
        let pass = TilePass {
            scene,
            job,
            tile,
            sample: s,
            first: s == first_sample,
        };
        trace_pass(&pass, &mut wf, pixels, rays);
    }
}

/// What the denoiser's guides see along one camera ray (see
/// [`super::guides`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum GuideHit {
    /// The first hit is not a delta surface: its albedo and normal, as the
    /// film's layers record them.
    First(Vec3, Vec3),
    /// The first hit is smooth glass: the albedo and normal of the first
    /// surface behind it that is not.
    Through(Vec3, Vec3),
    /// Through glass to the sky.
    Sky,
    /// Nothing: the camera ray missed, or the chain of glass was too long.
    Lost,
}

/// How many delta surfaces a guide ray passes through at most.
const GUIDE_CHAIN: usize = 16;

/// Follows `ray` through smooth glass (refracted, or reflected where the
/// reflection is total) to the first surface that is not a delta; rays
/// meet only the shapes `mask` shows.
pub(crate) fn guide_hit(scene: &Scene, mut ray: Ray, mask: u32) -> GuideHit {
    for bounce in 0..GUIDE_CHAIN {
        let mut rh = [RayHit::masked(ray, mask)];
        scene.accel().intersect_each(&mut rh);
        let Some(hit) = rh[0].hit() else {
            return if bounce == 0 {
                GuideHit::Lost
            } else {
                GuideHit::Sky
            };
        };
        let on = scene.mesh_hit(&hit);
        let hit = on.world(hit);
        let material = &scene.materials()[on.mesh.material as usize];
        let surface = SurfacePoint::new(on, &hit, material);
        let at = SurfaceHit::new(scene, on, &ray, &hit, surface);
        if !at.bsdf.is_delta() {
            let (albedo, normal) = (at.bsdf.albedo(), at.aov_normal());
            return if bounce == 0 {
                GuideHit::First(albedo, normal)
            } else {
                GuideHit::Through(albedo, normal)
            };
        }
        // The transmitted direction: a choice number above any Fresnel
        // reflectance short of total reflection.
        let frame = at.frame();
        let Some(bs) = at
            .bsdf
            .sample(frame.to_local(at.wo), 1.0 - f32::EPSILON, Vec2::splat(0.5))
        else {
            return GuideHit::Lost;
        };
        let wi = frame.to_world(bs.wi);
        ray = Ray::new(spawn_origin(at.p, at.n, ray_epsilon(at.p), wi), wi);
    }
    GuideHit::Lost
}
