//! Fitting a PLS light's window — its divergence `a` and soft-edge width
//! `w`, optionally its direction `n` and its outline's size or shape — and
//! its brightness `b` from photos of the surfaces it lights.
//!
//! The window moves where the beam's edge falls, which no gradient of a
//! hard step can see; plsr therefore searches with Nelder–Mead
//! (derivative-free, restarted while restarts help) and solves `b` exactly
//! at every point of the search: a render is linear in emission,
//! `I = b·U + R`, where `U` is the image of the light alone at `b = 1` and
//! `R` that of every other light (rendered once). `U` is rendered twice
//! per step with independent seeds at half the samples, `U1` and `U2`;
//! with `E = T − R` over the mask, `b²·ΣU1·U2 − b·Σ(U1 + U2)·E + ΣE·E` is
//! an unbiased estimate of the noise-free squared error (one render's
//! squared error would add its variance, which depends on the window and
//! would bias the search), least at `b* = Σ(U1 + U2)·E / (2·ΣU1·U2)`
//! (variable projection). Every step uses the same two seeds (common
//! random numbers), so the objective is deterministic and its differences
//! are not noise.

use super::View;
use crate::error::{Error, Result};
use glam::Vec3;
use plsr::job::RenderJob;
use plsr::light::pls::{Pls, PlsEmitter};
use plsr::light::Light;
use plsr::render::{render_sums, RenderOptions};
use plsr::scene::Scene;
use plsr_base::Vocabulary;

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
    /// The outline's scale against the start (1 unless the size is fitted;
    /// with the shape fitted, the axis length's scale).
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
    /// Whether the outline's shape is searched too: the length of its
    /// symmetry axis (scaled about the centre) and each of its four
    /// half-widths `d` on their own (the inner axis points `α` keep their
    /// values). It includes the size, so `fit_size` is then ignored; hold
    /// the penumbra fixed, as with the size.
    pub fit_shape: bool,
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
            fit_shape: false,
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
fn tilted(start: &plsr::light::pls::Pls, t: (Vec3, Vec3), u: f64, v: f64) -> plsr::light::pls::Pls {
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
    desc: Option<&plsr::scene::SceneDescription>,
    views: &[View],
    mesh: usize,
    options: &WindowFitOptions,
) -> Result<WindowFit> {
    let (emitter, range, desc) = checked(scene, desc, mesh, options)?;
    let start = emitter.light.clone();
    let all = scene.lights().lights.clone();
    let (job, half) = jobs(scene, options);
    let render_options = RenderOptions {
        threads: options.threads,
        ..RenderOptions::default()
    };
    let rest = render_rest(scene, views, &range, &job, &render_options)?;
    // U(a, w[, tilt]): the light alone at b = 1.
    let mut unit = start.clone();
    unit.b = 1.0;
    isolate(scene, &range);
    let frame = plsr::warp::Frame::from_normal(start.normal());
    let search = Search {
        mesh,
        views,
        options,
        render_options,
        half,
        rest,
        alone: desc.map(|d| alone(d, mesh)),
        axes: (frame.s, frame.t),
        evaluations: std::cell::Cell::new(0u32),
        terms: 3.0 * views.iter().map(View::pixels).sum::<usize>() as f64,
        axis_length: (start.g.e2 - start.g.e1).length() as f64,
        unit,
        emitter: &emitter,
        start: &start,
    };
    let best = search.search(scene)?;
    let (loss, b_unit) = search.objective(&best, scene)?;
    // Back to every light, with the fitted window and brightness (b* was
    // found for the light's own colour at b = 1).
    scene.edit_lights(|lights| lights.clone_from_slice(&all));
    let mut fitted = search.light_at(&best);
    fitted.b = b_unit as f32;
    place_fitted(scene, desc, mesh, &emitter, &fitted)?;
    Ok(WindowFit {
        a_deg: fitted.a_deg,
        penumbra_deg: fitted.penumbra_deg,
        b: fitted.b,
        n: fitted.n,
        e: [fitted.g.e1, fitted.g.e2],
        d: fitted.g.d,
        size: 2f32.powf(if options.fit_shape { best[5] } else { best[4] } as f32),
        loss,
        evaluations: search.evaluations.get(),
    })
}

/// The PLS emitter of mesh `mesh`, its range of lights, and the scene's
/// description when the fit rebuilds the scene (an error if it must and
/// has none).
fn checked<'d>(
    scene: &Scene,
    desc: Option<&'d plsr::scene::SceneDescription>,
    mesh: usize,
    options: &WindowFitOptions,
) -> Result<(
    PlsEmitter,
    std::ops::Range<usize>,
    Option<&'d plsr::scene::SceneDescription>,
)> {
    let Some(emitter) = scene.meshes().get(mesh).and_then(|m| m.pls.clone()) else {
        return Err(Error::invalid_argument(format!(
            "mesh {mesh} is not a PLS light"
        )));
    };
    let Some(range) = scene.mesh_lights(mesh) else {
        return Err(Error::invalid_argument(format!(
            "{}: the light emits nothing (b or c is 0)",
            scene.meshes()[mesh].name
        )));
    };
    let rebuilds = options.fit_direction || options.fit_size || options.fit_shape;
    let desc = match (rebuilds, desc) {
        (true, None) => {
            return Err(Error::invalid_argument(
                "fitting a light's direction, size or shape needs the scene's description",
            ))
        }
        (true, Some(d)) => Some(d),
        (false, _) => None,
    };
    Ok((emitter, range, desc))
}

/// The job of the render of every other light, and the two half jobs of
/// the light alone.
fn jobs(scene: &Scene, options: &WindowFitOptions) -> (RenderJob, [RenderJob; 2]) {
    let job = RenderJob {
        spp: options.spp,
        seed: options.seed,
        hide_virtual: true,
        ..scene.default_job()
    };
    // The light alone is rendered twice per step, at half the samples and
    // with independent seeds: the product of the two renders' errors is an
    // unbiased estimate of the noise-free squared error, where one render's
    // squared error would add its variance — which depends on the window
    // (a wider beam at a lower `b` is less noisy) and would pull the
    // search towards the least noisy window instead of the true one.
    let half = [
        RenderJob {
            spp: options.spp.div_ceil(2),
            ..job
        },
        RenderJob {
            spp: options.spp.div_ceil(2),
            seed: options.seed ^ 0x5851_f42d_4c95_7f2d,
            ..job
        },
    ];
    (job, half)
}

/// R: darkens the light's triangles (`range`) and renders every view by
/// every other light.
fn render_rest(
    scene: &mut Scene,
    views: &[View],
    range: &std::ops::Range<usize>,
    job: &RenderJob,
    render_options: &RenderOptions,
) -> Result<Renders> {
    // R: every other light.
    scene.edit_lights(|lights| {
        for l in &mut lights[range.clone()] {
            if let Light::Triangle(t) = l {
                t.radiance = Vec3::ZERO;
            }
        }
    });
    render_views(scene, views, job, render_options)
}

/// Darkens every light outside `range` (the light's triangles).
fn isolate(scene: &mut Scene, range: &std::ops::Range<usize>) {
    scene.edit_lights(|lights| {
        for (i, l) in lights.iter_mut().enumerate() {
            if range.contains(&i) {
                continue;
            }
            match l {
                Light::Point(p) => p.intensity = Vec3::ZERO,
                Light::Triangle(t) => t.radiance = Vec3::ZERO,
                Light::Environment { light, .. } => light.scale_radiance(0.0),
                Light::Directional { light, .. } => light.irradiance = Vec3::ZERO,
            }
        }
    });
}

/// The description with only this light, for tilts.
fn alone(d: &plsr::scene::SceneDescription, mesh: usize) -> plsr::scene::SceneDescription {
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
    d.directional_lights.clear();
    d
}

/// Puts the fitted light into the scene: rebuilt from the description
/// (keeping the camera) when there is one, else in place.
fn place_fitted(
    scene: &mut Scene,
    desc: Option<&plsr::scene::SceneDescription>,
    mesh: usize,
    emitter: &PlsEmitter,
    fitted: &Pls,
) -> Result<()> {
    match desc {
        Some(d) => {
            let mut d = d.clone();
            let old = &d.meshes[mesh];
            let (material, name) = (old.material, old.name.clone());
            d.meshes[mesh] =
                plsr::scene::pls_mesh(fitted, emitter.mode, emitter.nf, material, name);
            let camera = scene.camera().clone();
            *scene = Scene::build(d)?;
            scene.set_camera(camera);
        }
        None => scene.set_pls_window_and_brightness(mesh, fitted)?,
    }
    Ok(())
}

/// Every view's pixel means, one list per view.
type Renders = Vec<Vec<Vec3>>;

/// Coordinates of the search (see [`Search::light_at`]).
const DIMS: usize = 10;

/// What every evaluation of a window fit shares: the light, the views,
/// the render of every other light, and the count of evaluations.
struct Search<'a> {
    /// The light's mesh.
    mesh: usize,
    /// The photos.
    views: &'a [View],
    /// How to search.
    options: &'a WindowFitOptions,
    /// Options of every render.
    render_options: RenderOptions,
    /// The two half jobs of the light alone.
    half: [RenderJob; 2],
    /// R: every view rendered by every other light.
    rest: Renders,
    /// The description with only this light, when the scene is rebuilt.
    alone: Option<plsr::scene::SceneDescription>,
    /// The directions of the tilts `u` and `v`.
    axes: (Vec3, Vec3),
    /// Evaluations so far.
    evaluations: std::cell::Cell<u32>,
    /// Terms of the mean squared error (three per pixel).
    terms: f64,
    /// Length of the start's outline axis.
    axis_length: f64,
    /// The light alone at b = 1.
    unit: Pls,
    /// The light's emitter.
    emitter: &'a PlsEmitter,
    /// The light as it was.
    start: &'a Pls,
}

impl Search<'_> {
    /// The light at a point of the search.
    ///
    /// Coordinates: a, w (degrees), tilts u, v (degrees), size s (log₂ of
    /// the outline's scale about its centre), and for the shape: the axis
    /// length's scale L (log₂, about the centre), and the half-widths as
    /// their means and half-differences (metres): the middle m = (d2 + d3)/2,
    /// the ends e = (d1 + d4)/2, then δm = (d3 − d2)/2, δe = (d4 − d1)/2.
    fn light_at(&self, x: &[f64]) -> Pls {
        let mut l = tilted(&self.unit, self.axes, x[2], x[3]);
        if x[4] != 0.0 {
            let c = l.centre();
            let m = glam::Mat4::from_translation(c)
                * glam::Mat4::from_scale(Vec3::splat(2f32.powf(x[4] as f32)))
                * glam::Mat4::from_translation(-c);
            let n = l.n;
            l = l.transform(&m);
            l.n = n;
        }
        if self.options.fit_shape {
            let (c, k) = (l.centre(), 2f32.powf(x[5] as f32));
            l.g.e1 = c + k * (l.g.e1 - c);
            l.g.e2 = c + k * (l.g.e2 - c);
            l.g.d = half_widths(&x[6..10]);
        }
        l.a_deg = x[0] as f32;
        l.penumbra_deg = x[1] as f32;
        l
    }

    /// One evaluation: renders the light alone at `x` (twice) and returns
    /// the mean squared error at the best brightness, and that brightness.
    fn objective(&self, x: &[f64], scene: &mut Scene) -> Result<(f64, f64)> {
        self.evaluations.set(self.evaluations.get() + 1);
        let (u1, u2) = self.render_alone(&self.light_at(x), scene)?;
        // With E = T − R: the loss b²·U1·U2 − b·(U1 + U2)·E + E·E, whose
        // expectation is the noise-free loss, is least at
        // b* = Σ (U1 + U2)·E / (2 Σ U1·U2).
        let (mut ue, mut uu, mut ee) = (0.0f64, 0.0f64, 0.0f64);
        for (k, v) in self.views.iter().enumerate() {
            for i in 0..v.target.len() {
                if v.mask[i] {
                    let (p, q) = (u1[k][i].as_dvec3(), u2[k][i].as_dvec3());
                    let e = v.target[i].as_dvec3() - self.rest[k][i].as_dvec3();
                    ue += (p + q).dot(e);
                    uu += p.dot(q);
                    ee += e.dot(e);
                }
            }
        }
        let b = if uu > 0.0 {
            (0.5 * ue / uu).max(0.0)
        } else {
            0.0
        };
        let loss = b * b * uu - b * ue + ee;
        Ok((loss / self.terms, b))
    }

    /// U1 and U2: every view by the light `l` alone, once per half job (in
    /// a scene rebuilt from the description when there is one).
    fn render_alone(&self, l: &Pls, scene: &mut Scene) -> Result<(Renders, Renders)> {
        let (views, half, render_options) = (self.views, &self.half, &self.render_options);
        Ok(match &self.alone {
            Some(d) => {
                let mut d = d.clone();
                let old = &d.meshes[self.mesh];
                let (nf, mode, material, name) = (
                    self.emitter.nf,
                    self.emitter.mode,
                    old.material,
                    old.name.clone(),
                );
                d.meshes[self.mesh] = plsr::scene::pls_mesh(l, mode, nf, material, name);
                let mut s = Scene::build(d)?;
                (
                    render_views(&mut s, views, &half[0], render_options)?,
                    render_views(&mut s, views, &half[1], render_options)?,
                )
            }
            None => {
                scene.set_pls_window_and_brightness(self.mesh, l)?;
                (
                    render_views(scene, views, &half[0], render_options)?,
                    render_views(scene, views, &half[1], render_options)?,
                )
            }
        })
    }

    /// A point moved into the bounds.
    ///
    /// Bounds: a in [0.5°, 89.5°], 0 ≤ w ≤ 2·min(a, 90° − a), tilts within
    /// ±45°, the size and the axis length within 2^±3 of the start, every
    /// d ≥ 0 and at least one of them above 1 % of the axis length (an
    /// outline of no area emits nothing).
    fn clamp(&self, x: &[f64]) -> Vec<f64> {
        let a = x[0].clamp(0.5, 89.5);
        let w = if self.options.fit_penumbra {
            x[1].clamp(0.0, 2.0 * a.min(90.0 - a))
        } else {
            self.start.penumbra_deg as f64
        };
        let mut out = vec![
            a,
            w,
            x[2].clamp(-45.0, 45.0),
            x[3].clamp(-45.0, 45.0),
            x[4].clamp(-3.0, 3.0),
            x[5].clamp(-3.0, 3.0),
        ];
        let (m, e) = (x[6].max(0.0), x[7].max(0.0));
        let least = 0.01 * self.axis_length * 2f64.powf(out[5]);
        let (m, e) = if m.max(e) < least {
            (m.max(least), e.max(least))
        } else {
            (m, e)
        };
        out.extend([m, e, x[8].clamp(-m, m), x[9].clamp(-e, e)]);
        out
    }

    /// The search from the start, stage by stage; its best point.
    fn search(&self, scene: &mut Scene) -> Result<Vec<f64>> {
        let start = self.start;
        let d_max = start.g.d.iter().fold(0f32, |m, &d| m.max(d)) as f64;
        let mut x0 = vec![start.a_deg as f64, start.penumbra_deg as f64];
        x0.resize(6, 0.0);
        let d0 = start.g.d.map(|d| d as f64);
        x0.extend([
            0.5 * (d0[1] + d0[2]),
            0.5 * (d0[0] + d0[3]),
            0.5 * (d0[2] - d0[1]),
            0.5 * (d0[3] - d0[0]),
        ]);
        let x0 = self.clamp(&x0);
        let step = first_steps(&x0, d_max);
        let tolerance = tolerances(d_max);
        let stages = stages(self.options);
        let max_evaluations = self.options.max_evaluations;
        let mut eval = |x: &[f64]| -> Result<(Vec<f64>, f64)> {
            let x = self.clamp(x);
            let f = self.objective(&x, scene)?.0;
            Ok((x, f))
        };
        // Restarted from its best point (with fresh steps) while that still
        // helps: a collapsed simplex is the usual way Nelder–Mead stalls in
        // more than a few coordinates.
        // Restarts stop once one gains less than 0.1 % of the starting loss
        // (the loss is an unbiased estimate and may dip below zero near the
        // optimum, so no relative test), and after three.
        let mut best = eval(&x0)?;
        let gain = 1e-3 * best.1.abs();
        for moving in &stages {
            for _ in 0..4 {
                let before = best.1;
                best = nelder_mead(best, &step, &tolerance, moving, &mut eval, &|| {
                    self.evaluations.get() >= max_evaluations
                })?;
                if before - best.1 < gain || self.evaluations.get() >= max_evaluations {
                    break;
                }
            }
        }
        Ok(best.0)
    }
}

/// The search's first steps from `x0`.
fn first_steps(x0: &[f64], d_max: f64) -> Vec<f64> {
    (0..DIMS)
        .map(|d| match d {
            0 => (0.1 * x0[0]).clamp(1.0, 5.0),
            4 | 5 => 0.5,
            6.. => 0.25 * d_max,
            _ => 2.0,
        })
        .collect()
}

/// The simplex has converged when it is smaller than this in every
/// coordinate: 0.02° for angles, 0.02 in log₂ scales, 0.2 % of the
/// largest half-width for the d's.
fn tolerances(d_max: f64) -> Vec<f64> {
    (0..DIMS)
        .map(|d| match d {
            6.. => 0.002 * d_max,
            _ => 0.02,
        })
        .collect()
}

/// The coordinates each stage of the search moves (the others keep their
/// start): the shape in two stages, first the axis length and the
/// symmetric widths m and e, then their asymmetries too.
fn stages(options: &WindowFitOptions) -> Vec<Vec<usize>> {
    let stage = |shape: usize| -> Vec<usize> {
        (0..DIMS)
            .filter(|&d| match d {
                1 => options.fit_penumbra,
                2 | 3 => options.fit_direction,
                4 => options.fit_size && !options.fit_shape,
                5 => options.fit_shape,
                6 | 7 => options.fit_shape,
                8 | 9 => options.fit_shape && shape == 2,
                _ => true,
            })
            .collect()
    };
    if options.fit_shape {
        vec![stage(1), stage(2)]
    } else {
        vec![stage(0)]
    }
}

/// A point of a search and its objective.
type Point = (Vec<f64>, f64);

/// Nelder–Mead (standard coefficients: reflection 1, expansion 2,
/// contraction ½, shrink ½) from `start`, moving only the coordinates
/// `moving` (first steps `step`), until the simplex is smaller than
/// `tolerance` in every coordinate or `spent` says the budget is gone.
/// `eval` clamps a point to the bounds and returns it with its objective.
fn nelder_mead(
    start: Point,
    step: &[f64],
    tolerance: &[f64],
    moving: &[usize],
    eval: &mut dyn FnMut(&[f64]) -> Result<Point>,
    spent: &dyn Fn() -> bool,
) -> Result<Point> {
    let dims = start.0.len();
    let mut simplex = vec![start.clone()];
    for &d in moving {
        let mut x = start.0.clone();
        x[d] += step[d];
        simplex.push(eval(&x)?);
    }
    let n = moving.len();
    loop {
        simplex.sort_by(|p, q| p.1.total_cmp(&q.1));
        let size = simplex[1..]
            .iter()
            .map(|p| {
                moving
                    .iter()
                    .map(|&d| (p.0[d] - simplex[0].0[d]).abs() / tolerance[d])
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        if n == 0 || size < 1.0 || spent() {
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
        let reflected = eval(&along(-1.0))?;
        if reflected.1 < simplex[0].1 {
            let expanded = eval(&along(-2.0))?;
            simplex[n] = if expanded.1 < reflected.1 {
                expanded
            } else {
                reflected
            };
        } else if reflected.1 < simplex[n - 1].1 {
            simplex[n] = reflected;
        } else {
            let contracted = if reflected.1 < worst.1 {
                eval(&along(-0.5))?
            } else {
                eval(&along(0.5))?
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
                    *p = eval(&x)?;
                }
            }
        }
    }
    simplex.sort_by(|p, q| p.1.total_cmp(&q.1));
    Ok(simplex.swap_remove(0))
}

/// The half-widths `d1..d4` of the shape coordinates `[m, e, δm, δe]`
/// (the middle and end means and half-differences, metres).
fn half_widths(x: &[f64]) -> [f32; 4] {
    let (m, e, dm, de) = (x[0], x[1], x[2], x[3]);
    [e - de, m - dm, m + dm, e + de].map(|d| d.max(0.0) as f32)
}
