//! Fitting a PLS light's window — its divergence `a` and soft-edge width
//! `w` — and its brightness `b` from photos of the surfaces it lights.
//!
//! The window moves where the beam's edge falls, which no gradient of a
//! hard step can see; plsr therefore searches `(a, w)` with Nelder–Mead
//! (derivative-free) and solves `b` exactly at every point of the search:
//! a render is linear in emission, `I = b·U(a, w) + R`, where `U` is the
//! image of the light alone at `b = 1` and `R` that of every other light
//! (rendered once). With the target `T` over the mask, the best brightness
//! is `b* = Σ U·(T − R) / Σ U·U` (variable projection), and the search
//! minimises the squared error at `b*`. Every render of the search uses the
//! same seed (common random numbers), so the objective is deterministic
//! and its differences are not noise.

use super::View;
use crate::error::{Error, Result};
use crate::job::RenderJob;
use crate::light::Light;
use crate::render::{render_sums, RenderOptions};
use crate::scene::Scene;
use glam::Vec3;

/// What a window fit found.
#[derive(Debug, Clone, PartialEq)]
pub struct WindowFit {
    /// Divergence half-angle `a`, degrees.
    pub a_deg: f32,
    /// Soft-edge width `w`, degrees.
    pub penumbra_deg: f32,
    /// Brightness `b` (the light's units).
    pub b: f32,
    /// The light's unit normal `n` (changed only when the direction is
    /// fitted).
    pub n: Vec3,
    /// The ends `e1`, `e2` of its outline's axis (turned with `n`, scaled
    /// with the size).
    pub e: [Vec3; 2],
    /// The outline's half-widths `d` (scaled with the size).
    pub d: [f32; 4],
    /// The outline's scale against the start (1 unless the size is fitted).
    pub size: f32,
    /// The mean squared error at the fitted values (render units).
    pub loss: f64,
    /// Renders of the light alone the search took.
    pub evaluations: u32,
}

/// How to search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowFitOptions {
    /// Samples per pixel of each render.
    pub spp: u32,
    /// Seed of every render (common random numbers).
    pub seed: u64,
    /// The most renders of the light alone.
    pub max_evaluations: u32,
    /// Whether `w` is searched too (otherwise it keeps its value).
    pub fit_penumbra: bool,
    /// Whether the direction `n` is searched too (two tilts about the
    /// outline's centre; each evaluation rebuilds the scene).
    pub fit_direction: bool,
    /// Whether the outline's size is searched too (its distances `d` and
    /// axis scaled together about its centre; each evaluation rebuilds the
    /// scene). From photos of lit surfaces it shows only as the blur of
    /// the beam's edge, as a soft edge does: hold the penumbra fixed.
    pub fit_size: bool,
    /// Worker threads.
    pub threads: Option<usize>,
}

impl Default for WindowFitOptions {
    fn default() -> Self {
        WindowFitOptions {
            spp: 64,
            seed: 0x9e37,
            max_evaluations: 80,
            fit_penumbra: true,
            fit_direction: false,
            fit_size: false,
            threads: None,
        }
    }
}

/// Renders every view; each pixel's mean.
fn render_views(
    scene: &mut Scene,
    views: &[View],
    job: &RenderJob,
    options: &RenderOptions,
) -> Result<Vec<Vec<Vec3>>> {
    let mut out = Vec::with_capacity(views.len());
    for v in views {
        scene.set_camera(v.camera.clone());
        let (sums, _) = render_sums(scene, job, options, &|_, _| true)?;
        out.push(sums.means());
    }
    Ok(out)
}

/// The light `start` turned about its outline's centre so that its normal
/// tilts by `u` degrees towards `t1` and `v` degrees towards `t2` (unit
/// vectors perpendicular to its normal).
fn tilted(
    start: &crate::light::pls::Pls,
    t: (Vec3, Vec3),
    u: f64,
    v: f64,
) -> crate::light::pls::Pls {
    if u == 0.0 && v == 0.0 {
        return start.clone();
    }
    let n0 = start.normal();
    let n = (n0 + (u.to_radians().tan() as f32) * t.0 + (v.to_radians().tan() as f32) * t.1)
        .normalize();
    let c = start.centre();
    let m = glam::Mat4::from_translation(c)
        * glam::Mat4::from_quat(glam::Quat::from_rotation_arc(n0, n))
        * glam::Mat4::from_translation(-c);
    let mut l = start.transform(&m);
    l.n = n;
    l
}

/// Fits the window and brightness of the PLS light of mesh `mesh` to the
/// views (and, with `options.fit_direction`, its direction: then `desc`,
/// the scene's description, rebuilds the scene for each tilt); leaves the
/// scene with the fitted values.
pub fn fit_window(
    scene: &mut Scene,
    desc: Option<&crate::scene::SceneDescription>,
    views: &[View],
    mesh: usize,
    options: &WindowFitOptions,
) -> Result<WindowFit> {
    let Some(emitter) = scene.meshes().get(mesh).and_then(|m| m.pls.clone()) else {
        return Err(Error::InvalidArgument(format!(
            "mesh {mesh} is not a PLS light"
        )));
    };
    let Some(range) = scene.mesh_lights(mesh) else {
        return Err(Error::InvalidArgument(format!(
            "{}: the light emits nothing (b or c is 0)",
            scene.meshes()[mesh].name
        )));
    };
    let desc = match (options.fit_direction || options.fit_size, desc) {
        (true, None) => {
            return Err(Error::InvalidArgument(
                "fitting a light's direction or size needs the scene's description".into(),
            ))
        }
        (true, Some(d)) => Some(d),
        (false, _) => None,
    };
    let start = emitter.light.clone();
    let all = scene.lights().lights.clone();
    let job = RenderJob {
        spp: options.spp,
        seed: options.seed,
        hide_virtual: true,
        ..scene.default_job()
    };
    let render_options = RenderOptions {
        threads: options.threads,
        ..RenderOptions::default()
    };
    // R: every other light.
    scene.edit_lights(|lights| {
        for l in &mut lights[range.clone()] {
            if let Light::Triangle(t) = l {
                t.radiance = Vec3::ZERO;
            }
        }
    });
    let rest = render_views(scene, views, &job, &render_options)?;
    // U(a, w[, tilt]): the light alone at b = 1.
    let mut unit = start.clone();
    unit.b = 1.0;
    scene.edit_lights(|lights| {
        for (i, l) in lights.iter_mut().enumerate() {
            if range.contains(&i) {
                continue;
            }
            match l {
                Light::Point(p) => p.intensity = Vec3::ZERO,
                Light::Triangle(t) => t.radiance = Vec3::ZERO,
                Light::Environment { light, .. } => light.scale_radiance(0.0),
            }
        }
    });
    // The description with only this light, for tilts.
    let alone = desc.map(|d| {
        let mut d = d.clone();
        for p in &mut d.point_lights {
            p.intensity = Vec3::ZERO;
        }
        for (i, m) in d.meshes.iter_mut().enumerate() {
            if i != mesh {
                m.emission = None;
            }
        }
        d.environment = None;
        d
    });
    let frame = crate::warp::Frame::from_normal(start.normal());
    let axes = (frame.s, frame.t);
    let evaluations = std::cell::Cell::new(0u32);
    let terms: f64 = 3.0 * views.iter().map(View::pixels).sum::<usize>() as f64;
    // Coordinates: a, w (degrees), tilts u, v (degrees), size s (log₂ of
    // the outline's scale about its centre).
    let light_at = |x: &[f64]| {
        let mut l = tilted(&unit, axes, x[2], x[3]);
        if x[4] != 0.0 {
            let c = l.centre();
            let m = glam::Mat4::from_translation(c)
                * glam::Mat4::from_scale(Vec3::splat(2f32.powf(x[4] as f32)))
                * glam::Mat4::from_translation(-c);
            let n = l.n;
            l = l.transform(&m);
            l.n = n;
        }
        l.a_deg = x[0] as f32;
        l.penumbra_deg = x[1] as f32;
        l
    };
    let objective = |x: &[f64], scene: &mut Scene| -> Result<(f64, f64)> {
        evaluations.set(evaluations.get() + 1);
        let l = light_at(x);
        let u = match &alone {
            Some(d) => {
                let mut d = d.clone();
                let old = &d.meshes[mesh];
                let (nf, mode, material, name) =
                    (emitter.nf, emitter.mode, old.material, old.name.clone());
                d.meshes[mesh] = crate::scene::pls_mesh(&l, mode, nf, material, name);
                let mut s = Scene::build(d)?;
                render_views(&mut s, views, &job, &render_options)?
            }
            None => {
                scene.set_pls_window_and_brightness(mesh, &l)?;
                render_views(scene, views, &job, &render_options)?
            }
        };
        let (mut ut, mut uu) = (0.0f64, 0.0f64);
        for (k, v) in views.iter().enumerate() {
            for i in 0..v.target.len() {
                if v.mask[i] {
                    let (ui, ri, ti) = (
                        u[k][i].as_dvec3(),
                        rest[k][i].as_dvec3(),
                        v.target[i].as_dvec3(),
                    );
                    ut += ui.dot(ti - ri);
                    uu += ui.dot(ui);
                }
            }
        }
        let b = if uu > 0.0 { (ut / uu).max(0.0) } else { 0.0 };
        let mut loss = 0.0;
        for (k, v) in views.iter().enumerate() {
            for i in 0..v.target.len() {
                if v.mask[i] {
                    let d = u[k][i].as_dvec3() * b + rest[k][i].as_dvec3() - v.target[i].as_dvec3();
                    loss += d.dot(d);
                }
            }
        }
        Ok((loss / terms, b))
    };
    // Bounds: a in [0.5°, 89.5°], 0 ≤ w ≤ 2·min(a, 90° − a), tilts within
    // ±45°, the size within 2^±3.
    let dims = 5;
    let clamp = |x: &[f64]| -> Vec<f64> {
        let a = x[0].clamp(0.5, 89.5);
        let w = if options.fit_penumbra {
            x[1].clamp(0.0, 2.0 * a.min(90.0 - a))
        } else {
            start.penumbra_deg as f64
        };
        vec![
            a,
            w,
            x[2].clamp(-45.0, 45.0),
            x[3].clamp(-45.0, 45.0),
            x[4].clamp(-3.0, 3.0),
        ]
    };
    let mut x0 = vec![start.a_deg as f64, start.penumbra_deg as f64];
    x0.resize(dims, 0.0);
    let x0 = clamp(&x0);
    let step: Vec<f64> = (0..dims)
        .map(|d| match d {
            0 => (0.1 * x0[0]).clamp(1.0, 5.0),
            4 => 0.5,
            _ => 2.0,
        })
        .collect();
    // The coordinates the search moves (the others keep their start).
    let moving: Vec<usize> = (0..dims)
        .filter(|&d| match d {
            1 => options.fit_penumbra,
            2 | 3 => options.fit_direction,
            4 => options.fit_size,
            _ => true,
        })
        .collect();
    let eval = |x: Vec<f64>, scene: &mut Scene| -> Result<(Vec<f64>, f64)> {
        let x = clamp(&x);
        let f = objective(&x, scene)?.0;
        Ok((x, f))
    };
    let mut simplex: Vec<(Vec<f64>, f64)> = vec![eval(x0.clone(), scene)?];
    for &d in &moving {
        let mut x = x0.clone();
        x[d] += step[d];
        simplex.push(eval(x, scene)?);
    }
    let n = moving.len();
    // Nelder–Mead (standard coefficients: reflection 1, expansion 2,
    // contraction ½, shrink ½), until the simplex is below 0.02° or the
    // budget is spent.
    loop {
        simplex.sort_by(|p, q| p.1.total_cmp(&q.1));
        let size = simplex[1..]
            .iter()
            .map(|p| {
                moving
                    .iter()
                    .map(|&d| (p.0[d] - simplex[0].0[d]).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        if size < 0.02 || evaluations.get() >= options.max_evaluations {
            break;
        }
        let worst = simplex[n].clone();
        let mut centroid = vec![0.0; dims];
        for p in &simplex[..n] {
            for (c, x) in centroid.iter_mut().zip(&p.0) {
                *c += x / n as f64;
            }
        }
        let along = |t: f64| -> Vec<f64> {
            centroid
                .iter()
                .zip(&worst.0)
                .map(|(c, w)| c + t * (w - c))
                .collect()
        };
        let reflected = eval(along(-1.0), scene)?;
        if reflected.1 < simplex[0].1 {
            let expanded = eval(along(-2.0), scene)?;
            simplex[n] = if expanded.1 < reflected.1 {
                expanded
            } else {
                reflected
            };
        } else if reflected.1 < simplex[n - 1].1 {
            simplex[n] = reflected;
        } else {
            let contracted = if reflected.1 < worst.1 {
                eval(along(-0.5), scene)?
            } else {
                eval(along(0.5), scene)?
            };
            if contracted.1 < worst.1.min(reflected.1) {
                simplex[n] = contracted;
            } else {
                let best = simplex[0].0.clone();
                for p in simplex.iter_mut().skip(1) {
                    let x: Vec<f64> = best
                        .iter()
                        .zip(&p.0)
                        .map(|(b, q)| b + 0.5 * (q - b))
                        .collect();
                    *p = eval(x, scene)?;
                }
            }
        }
    }
    simplex.sort_by(|p, q| p.1.total_cmp(&q.1));
    let best = simplex[0].0.clone();
    let (loss, b_unit) = objective(&best, scene)?;
    // Back to every light, with the fitted window and brightness (b* was
    // found for the light's own colour at b = 1).
    scene.edit_lights(|lights| lights.clone_from_slice(&all));
    let mut fitted = light_at(&best);
    fitted.b = b_unit as f32;
    match desc {
        Some(d) => {
            let mut d = d.clone();
            let old = &d.meshes[mesh];
            let (material, name) = (old.material, old.name.clone());
            d.meshes[mesh] =
                crate::scene::pls_mesh(&fitted, emitter.mode, emitter.nf, material, name);
            let camera = scene.camera().clone();
            *scene = Scene::build(d)?;
            scene.set_camera(camera);
        }
        None => scene.set_pls_window_and_brightness(mesh, &fitted)?,
    }
    Ok(WindowFit {
        a_deg: fitted.a_deg,
        penumbra_deg: fitted.penumbra_deg,
        b: fitted.b,
        n: fitted.n,
        e: [fitted.g.e1, fitted.g.e2],
        d: fitted.g.d,
        size: 2f32.powf(best[4] as f32),
        loss,
        evaluations: evaluations.get(),
    })
}
