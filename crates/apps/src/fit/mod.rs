//! Fitting materials and light brightness to photographs: the loss, its
//! gradient and projected Adam.
//!
//! A fit compares renders of the scene's real surfaces (virtual objects
//! hidden) with photos of them, each through its own camera (a *view*):
//!
//! `ℒ = 1/(3N) Σ_views Σ_{p ∈ mask} Σ_channels (I_p − P_p/k)²`,
//!
//! the mean squared error in linear radiance between the render `I` and
//! the photo `P` linearised through its response and divided by its
//! exposure `k` (`[photo] exposure`, as in compositing), over the pixels of
//! each view's mask (by default every pixel whose camera rays all meet a
//! real, non-emitting surface). Each iteration renders the primal `I` with
//! one seed, then estimates the gradient with another
//! ([`plsr::integrator::gradient`]): the two estimates are independent,
//! so the gradient of the squared error is unbiased. Adam (Kingma and Ba
//! 2015) steps every number of every parameter, and each is then clamped
//! into its bounds (projected Adam). Light parameters step in units of
//! their initial value, materials in absolute units.
//!
//! The paper's defaults (learning rate 0.05, 16 spp, 100 iterations) are
//! [`FitOptions::default`].

pub mod light;
pub mod params;
pub mod plot;
pub mod write;

use crate::composite::Photo;
use crate::error::{Error, Result};
use glam::{Vec2, Vec3};
pub use params::{Owner, Parameter};
use plsr::accel::{RayHit, REAL_MASK};
use plsr::camera::Camera;
use plsr::integrator::gradient::GradientMap;
use plsr::job::RenderJob;
use plsr::render::{render_gradient, render_sums, RenderOptions};
use plsr::scene::Scene;
use plsr_base::Vocabulary;
use std::time::Instant;

/// How to fit.
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Adam iterations.
    pub iterations: u32,
    /// Adam's learning rate (parameter units per step; light parameters
    /// in units of their initial value).
    pub learning_rate: f32,
    /// Samples per pixel of each render (the primal and the gradient each).
    pub spp: u32,
    /// Base seed; iteration `i` renders its primal with `seed + 2i` and its
    /// gradient with `seed + 2i + 1`. `None`: the scene file's `[render]
    /// seed` in [`fit_scene_file`] (as `render` and `composite` use it), 0
    /// elsewhere.
    pub seed: Option<u64>,
    /// Patterns selecting the parameters (see [`params`]); empty: the
    /// paper's choice.
    pub params: Vec<String>,
    /// Worker threads; `None`: every core.
    pub threads: Option<usize>,
    /// PLS lights (by name) whose window (`a`, `penumbra`) and brightness
    /// `b` are found first by a derivative-free search ([`light`]); with
    /// no `params` given, only they are fitted.
    pub windows: Vec<String>,
    /// Whether the window search also turns the lights' directions `n`.
    pub window_direction: bool,
    /// Whether the window search also scales the lights' outlines (and
    /// then holds their penumbra).
    pub window_size: bool,
    /// Whether the window search also fits each light's outline shape:
    /// its axis length and its four half-widths `d` on their own
    /// (includes the size).
    pub window_shape: bool,
    /// The most renders the window search makes per light; `None`: 80,
    /// 160 when it turns or scales the lights, 400 when it fits their
    /// shape.
    pub window_evaluations: Option<u32>,
}

impl FitOptions {
    /// The base seed: [`FitOptions::seed`] or 0.
    pub fn base_seed(&self) -> u64 {
        self.seed.unwrap_or(0)
    }
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            iterations: 100,
            learning_rate: 0.05,
            spp: 16,
            seed: None,
            params: Vec::new(),
            threads: None,
            windows: Vec::new(),
            window_direction: false,
            window_size: false,
            window_shape: false,
            window_evaluations: None,
        }
    }
}

/// A photo to fit against, seen through its camera.
#[derive(Debug, Clone)]
pub struct View {
    /// What to call it in messages (the photo's file).
    pub label: String,
    /// The camera that took it.
    pub camera: Camera,
    /// The photo in the render's units: linear radiance divided by the
    /// exposure `k`, row-major.
    pub target: Vec<Vec3>,
    /// Which pixels count in the loss.
    pub mask: Vec<bool>,
    /// Whether the exposure is fitted with the parameters (`exposure =
    /// "auto"`): each iteration scales `target` by the factor that fits
    /// the render best, so the loss is the least over the exposure.
    pub fitted_exposure: bool,
    /// The exposure `k` the target was divided by (`P / k`); with a fitted
    /// exposure, the last iteration's scale is [`View::scale`].
    pub k: f32,
    /// The last scale of `target` a fitted exposure found (1 otherwise):
    /// the exposure is then `k / scale`.
    pub scale: f64,
}

impl View {
    /// A view of `photo` (linear, `P ≈ k·render`) through `camera`, with
    /// the default mask (pixels whose camera rays meet real, non-emitting
    /// surfaces; see [`surface_mask`]). The photo must have the camera's
    /// size.
    pub fn new(scene: &Scene, label: &str, camera: Camera, photo: &Photo, k: f32) -> Result<View> {
        if scene.film().crop.is_some() {
            return Err(Error::invalid_argument(format!(
                "{label}: film.crop: a fit compares whole images (remove the crop)"
            )));
        }
        let (w, h) = (camera.width(), camera.height());
        if (photo.width, photo.height) != (w, h) {
            return Err(Error::invalid_argument(format!(
                "{label}: the photo is {}×{} pixels but its camera renders {w}×{h}",
                photo.width, photo.height
            )));
        }
        if !(k.is_finite() && k > 0.0) {
            return Err(Error::invalid_argument(format!(
                "{label}: exposure {k} must be positive"
            )));
        }
        let mask = surface_mask(scene, &camera);
        Ok(View {
            label: label.to_string(),
            target: photo.radiance.iter().map(|p| *p / k).collect(),
            camera,
            mask,
            fitted_exposure: false,
            k,
            scale: 1.0,
        })
    }

    /// The exposure now: `k / scale`.
    pub fn exposure(&self) -> f64 {
        self.k as f64 / self.scale
    }

    /// Pixels in the loss.
    pub fn pixels(&self) -> usize {
        self.mask.iter().filter(|m| **m).count()
    }
}

/// The default mask of a camera: pixels whose rays through four points of
/// the pixel (lens centre) all meet a real surface that does not emit.
pub fn surface_mask(scene: &Scene, camera: &Camera) -> Vec<bool> {
    pixels_where(scene, camera, |m| {
        scene.mesh_lights(m).is_none() && scene.meshes()[m].pls.is_none()
    })
}

/// Pixels whose camera rays through four points of the pixel (lens
/// centre) all meet a real mesh for which `meets(mesh index)` holds.
fn pixels_where(scene: &Scene, camera: &Camera, meets: impl Fn(usize) -> bool) -> Vec<bool> {
    let (w, h) = (camera.width(), camera.height());
    let mut mask = vec![false; (w * h) as usize];
    let offsets = [
        Vec2::new(0.25, 0.25),
        Vec2::new(0.75, 0.25),
        Vec2::new(0.25, 0.75),
        Vec2::new(0.75, 0.75),
    ];
    for y in 0..h {
        for x in 0..w {
            let all = offsets.iter().all(|o| {
                let film = Vec2::new(x as f32, y as f32) + *o;
                let Some(ray) = camera.generate_ray(film, Vec2::splat(0.5)) else {
                    return false;
                };
                let mut rh = [RayHit::masked(ray, REAL_MASK)];
                scene.accel().intersect_each(&mut rh);
                rh[0].hit().is_some_and(|hit| meets(hit.geom_id as usize))
            });
            mask[(y * w + x) as usize] = all;
        }
    }
    mask
}

/// The squared error `Σ_{p ∈ mask} |I_p − target_p|² / terms` of the
/// scene's render `I` (the primal job) and its gradient per slot of `map`
/// (from the gradient job, which must have another seed). `target` and
/// `mask` are row-major over the scene's camera.
pub fn squared_error_gradient(
    scene: &Scene,
    map: &GradientMap,
    target: &[Vec3],
    mask: &[bool],
    jobs: (&RenderJob, &RenderJob),
    options: &RenderOptions,
    terms: f64,
) -> Result<(f64, Vec<f64>)> {
    squared_error_gradient_scaled(scene, map, target, mask, false, jobs, options, terms)
        .map(|(loss, gradient, _)| (loss, gradient))
}

/// The scale `s` minimising `Σ_{p ∈ mask} |I_p − s·T_p|²`: the exposure
/// fitted to the render `I` (1 where the target is black).
fn best_scale(image: &[Vec3], target: &[Vec3], mask: &[bool]) -> f64 {
    let (mut it, mut tt) = (0.0f64, 0.0f64);
    for ((i, t), m) in image.iter().zip(target).zip(mask) {
        if *m {
            it += i.as_dvec3().dot(t.as_dvec3());
            tt += t.as_dvec3().dot(t.as_dvec3());
        }
    }
    if tt > 0.0 && it > 0.0 {
        it / tt
    } else {
        1.0
    }
}

/// [`squared_error_gradient`], with the target first scaled by the factor
/// that fits the primal render best when `fit_scale` (the exposure fitted
/// with the parameters: the gradient of the loss at its least over the
/// scale is the partial gradient there, the envelope theorem). Returns
/// the scale too.
#[allow(clippy::too_many_arguments)]
fn squared_error_gradient_scaled(
    scene: &Scene,
    map: &GradientMap,
    target: &[Vec3],
    mask: &[bool],
    fit_scale: bool,
    (primal, gradient_job): (&RenderJob, &RenderJob),
    options: &RenderOptions,
    terms: f64,
) -> Result<(f64, Vec<f64>, f64)> {
    let n = (scene.camera().width() * scene.camera().height()) as usize;
    if target.len() != n || mask.len() != n {
        return Err(Error::invalid_argument(format!(
            "the target has {} pixels and the mask {}, the camera {n}",
            target.len(),
            mask.len()
        )));
    }
    let (sums, _) = render_sums(scene, primal, options, &|_, _| true)?;
    let means = sums.means();
    let scale = if fit_scale {
        best_scale(&means, target, mask)
    } else {
        1.0
    };
    let mut loss = 0.0;
    let mut adjoint = vec![Vec3::ZERO; n];
    for (i, mean) in means.into_iter().enumerate() {
        if mask[i] {
            let d = mean - target[i] * scale as f32;
            loss += d.as_dvec3().dot(d.as_dvec3());
            adjoint[i] = d * (2.0 / terms as f32);
        }
    }
    let r = render_gradient(scene, gradient_job, options, map, &adjoint, false)?;
    Ok((loss / terms, r.gradient, scale))
}

/// Projected Adam over a flat vector of numbers.
#[derive(Debug, Clone)]
pub struct Adam {
    /// Learning rate.
    pub learning_rate: f32,
    m: Vec<f64>,
    v: Vec<f64>,
    t: i32,
}

impl Adam {
    /// β₁ = 0.9, β₂ = 0.999, ε = 1e-8, as Kingma and Ba (and Mitsuba).
    const BETA1: f64 = 0.9;
    const BETA2: f64 = 0.999;
    const EPSILON: f64 = 1e-8;

    /// An optimiser for `n` numbers.
    pub fn new(n: usize, learning_rate: f32) -> Adam {
        Adam {
            learning_rate,
            m: vec![0.0; n],
            v: vec![0.0; n],
            t: 0,
        }
    }

    /// One step of `x` down the gradient `g`, each number then clamped to
    /// `[lower, upper]`.
    pub fn step(&mut self, x: &mut [f64], g: &[f64], lower: &[f64], upper: &[f64]) {
        self.t += 1;
        let c1 = 1.0 - Self::BETA1.powi(self.t);
        let c2 = 1.0 - Self::BETA2.powi(self.t);
        for i in 0..x.len() {
            self.m[i] = Self::BETA1 * self.m[i] + (1.0 - Self::BETA1) * g[i];
            self.v[i] = Self::BETA2 * self.v[i] + (1.0 - Self::BETA2) * g[i] * g[i];
            let step = self.learning_rate as f64 * (self.m[i] / c1)
                / ((self.v[i] / c2).sqrt() + Self::EPSILON);
            x[i] = (x[i] - step).clamp(lower[i], upper[i]);
        }
    }
}

/// One iteration's numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct Iteration {
    /// Its index (0 = the starting values).
    pub index: u32,
    /// The loss at the values it started from (the primal render's).
    pub loss: f64,
    /// The gradient per gradient slot.
    pub gradient: Vec<f64>,
    /// Seconds it took (renders, gradient and step).
    pub seconds: f64,
}

/// A fit in progress: the scene, its views, the parameters and Adam.
pub struct Fit {
    scene: Scene,
    views: Vec<View>,
    params: Vec<Parameter>,
    adam: Adam,
    options: FitOptions,
    /// Per gradient slot: whether any iteration saw a non-zero derivative.
    seen: Vec<bool>,
    max_depth: u32,
    /// Sums of the values reached in the last tenth of the iterations, and
    /// their count (Polyak–Ruppert averaging, [`Fit::finish`]).
    averages: (Vec<f64>, u32),
}

impl Fit {
    /// A fit of `params` (selected by [`params::select`] on this scene)
    /// against `views`.
    pub fn new(
        scene: Scene,
        views: Vec<View>,
        params: Vec<Parameter>,
        options: FitOptions,
    ) -> Result<Fit> {
        if views.is_empty() {
            return Err(Error::invalid_argument("a fit needs at least one photo"));
        }
        if views.iter().all(|v| v.pixels() == 0) {
            return Err(Error::invalid_argument(
                "no photo pixel sees a real surface of the scene (every mask is empty)",
            ));
        }
        if options.spp == 0 || options.spp > plsr::job::MAX_SPP {
            return Err(Error::invalid_argument(format!(
                "spp {} must be in [1, {}]",
                options.spp,
                plsr::job::MAX_SPP
            )));
        }
        if !(options.learning_rate.is_finite() && options.learning_rate > 0.0) {
            return Err(Error::invalid_argument(format!(
                "learning rate {} must be positive",
                options.learning_rate
            )));
        }
        let n = params.iter().map(|p| p.value.len()).sum();
        let max_depth = scene.default_job().max_depth;
        Ok(Fit {
            adam: Adam::new(n, options.learning_rate),
            seen: vec![false; n],
            averages: (vec![0.0; n], 0),
            scene,
            views,
            params,
            options,
            max_depth,
        })
    }

    /// The parameters with their current values.
    pub fn parameters(&self) -> &[Parameter] {
        &self.params
    }

    /// The scene with the current values.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The views.
    pub fn views(&self) -> &[View] {
        &self.views
    }

    fn job(&self, seed: u64) -> RenderJob {
        RenderJob {
            spp: self.options.spp,
            sample_start: 0,
            max_depth: self.max_depth,
            seed,
            hide_virtual: true,
            ..Default::default()
        }
    }

    fn render_options(&self) -> RenderOptions {
        RenderOptions {
            threads: self.options.threads,
            ..RenderOptions::default()
        }
    }

    /// Pixels in the loss, times 3 channels.
    fn terms(&self) -> f64 {
        3.0 * self.views.iter().map(View::pixels).sum::<usize>() as f64
    }

    /// Renders view `v` with `seed`: each pixel's mean recorded value.
    fn render_view(&mut self, v: usize, seed: u64) -> Result<Vec<Vec3>> {
        self.scene.set_camera(self.views[v].camera.clone());
        let job = self.job(seed);
        let (sums, _) = render_sums(&self.scene, &job, &self.render_options(), &|_, _| true)?;
        Ok(sums.means())
    }

    /// The loss at the current values, from a render with `seed`.
    pub fn loss(&mut self, seed: u64) -> Result<f64> {
        let mut total = 0.0;
        for v in 0..self.views.len() {
            let image = self.render_view(v, seed)?;
            let view = &mut self.views[v];
            if view.fitted_exposure {
                view.scale = best_scale(&image, &view.target, &view.mask);
            }
            let scale = view.scale as f32;
            for (i, (c, t)) in image.iter().zip(&view.target).enumerate() {
                if view.mask[i] {
                    let d = (*c - *t * scale).as_dvec3();
                    total += d.dot(d);
                }
            }
        }
        Ok(total / self.terms())
    }

    /// The loss at the current values and its gradient per slot: primal
    /// renders with `seed`, the gradient with `seed + 1`.
    pub fn loss_and_gradient(&mut self, seed: u64) -> Result<(f64, Vec<f64>)> {
        let map: GradientMap = params::gradient_map(&self.scene, &self.params);
        let terms = self.terms();
        let mut loss = 0.0;
        let mut gradient = vec![0.0f64; map.len];
        let (primal, gradient_job) = (self.job(seed), self.job(seed.wrapping_add(1)));
        let options = self.render_options();
        for v in 0..self.views.len() {
            self.scene.set_camera(self.views[v].camera.clone());
            let view = &self.views[v];
            let (l, g, scale) = squared_error_gradient_scaled(
                &self.scene,
                &map,
                &view.target,
                &view.mask,
                view.fitted_exposure,
                (&primal, &gradient_job),
                &options,
                terms,
            )?;
            self.views[v].scale = scale;
            loss += l;
            for (a, b) in gradient.iter_mut().zip(&g) {
                *a += b;
            }
        }
        Ok((loss, gradient))
    }

    /// One iteration: the loss and gradient at the current values, then a
    /// projected Adam step. A gradient that is not finite is an error.
    pub fn step(&mut self, index: u32) -> Result<Iteration> {
        let start = Instant::now();
        let seed = self.options.base_seed().wrapping_add(2 * index as u64);
        let (loss, gradient) = self.loss_and_gradient(seed)?;
        if let Some(i) = gradient.iter().position(|g| !g.is_finite()) {
            let p = self
                .params
                .iter()
                .find(|p| (p.slot as usize..p.slot as usize + p.value.len()).contains(&i));
            return Err(Error::invalid_argument(format!(
                "the gradient of {} is not finite at iteration {index}",
                p.map_or("a parameter", |p| p.name.as_str())
            )));
        }
        for (s, g) in self.seen.iter_mut().zip(&gradient) {
            *s |= *g != 0.0;
        }
        // Adam in each number's own units: absolute for materials, relative
        // to the initial value for lights.
        let (mut x, mut g, mut lo, mut hi, mut unit) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for p in &self.params {
            for k in 0..p.value.len() {
                let s = if p.relative() && p.initial[k] > 0.0 {
                    p.initial[k] as f64
                } else {
                    1.0
                };
                unit.push(s);
                x.push(p.value[k] as f64 / s);
                g.push(gradient[p.slot as usize + k] * s);
                lo.push(p.bounds.0 as f64 / s);
                hi.push(p.bounds.1 as f64 / s);
            }
        }
        self.adam.step(&mut x, &g, &lo, &hi);
        let mut k = 0;
        let average = index >= self.average_from();
        for i in 0..self.params.len() {
            let n = self.params[i].value.len();
            let new: Vec<f32> = (0..n).map(|j| (x[k + j] * unit[k + j]) as f32).collect();
            if average {
                for (j, v) in new.iter().enumerate() {
                    self.averages.0[k + j] += *v as f64;
                }
            }
            k += n;
            params::apply(&mut self.scene, &self.params[i], &new)?;
            self.params[i].value = new;
        }
        if average {
            self.averages.1 += 1;
        }
        Ok(Iteration {
            index,
            loss,
            gradient,
            seconds: start.elapsed().as_secs_f64(),
        })
    }

    /// The first iteration whose values are averaged: the last tenth of
    /// `options.iterations` (at least one).
    fn average_from(&self) -> u32 {
        let n = self.options.iterations;
        n - (n / 10).max(1).min(n)
    }

    /// Ends the fit: every parameter takes the mean of the values the last
    /// tenth of the iterations reached (Polyak–Ruppert averaging), which
    /// removes most of the noise that few-sample gradients leave in the
    /// last iterate. Does nothing if those iterations have not run.
    pub fn finish(&mut self) -> Result<()> {
        let count = self.averages.1;
        if count == 0 {
            return Ok(());
        }
        let mut k = 0;
        for i in 0..self.params.len() {
            let n = self.params[i].value.len();
            let (lo, hi) = self.params[i].bounds;
            let mean: Vec<f32> = (0..n)
                .map(|j| ((self.averages.0[k + j] / count as f64) as f32).clamp(lo, hi))
                .collect();
            k += n;
            params::apply(&mut self.scene, &self.params[i], &mean)?;
            self.params[i].value = mean;
        }
        self.averages = (vec![0.0; k], 0);
        Ok(())
    }

    /// Warnings about parameters no photo pixel saw (their gradient was
    /// zero at every iteration, so they kept their value).
    pub fn warnings(&self) -> Vec<String> {
        let mut out: Vec<String> = self
            .params
            .iter()
            .filter(|p| (0..p.value.len()).all(|k| !self.seen[p.slot as usize + k]))
            .map(|p| {
                format!(
                    "{}: no photo pixel sees it (its gradient was zero), so it kept its value",
                    p.name
                )
            })
            .collect();
        for v in self.views.iter().filter(|v| v.fitted_exposure) {
            out.push(format!(
                "{}: exposure fitted with the parameters: k = {:.6}",
                v.label,
                v.exposure()
            ));
        }
        out
    }
}

/// Everything a fit of a scene file produced.
#[derive(Debug, Clone)]
pub struct FitOutcome {
    /// The parameters with their fitted values (and where they started).
    pub parameters: Vec<Parameter>,
    /// The loss after each number of steps (`iterations + 1` values; the
    /// last is measured at the fitted values, after [`Fit::finish`]).
    pub losses: Vec<f64>,
    /// Parameters no photo pixel saw, exposures fitted, …
    pub warnings: Vec<String>,
    /// Mean seconds per iteration.
    pub seconds_per_iteration: f64,
    /// Pixels in the loss, over all views.
    pub pixels: usize,
    /// The windows fitted: the light's name and what was found.
    pub windows: Vec<(String, light::WindowFit)>,
    /// The fitted scene file (and PLS files), ready to write.
    pub fitted: write::FittedFiles,
}

/// Fits the parameters `options.params` select to the scene file's
/// `[photo]` and `[[views]]`, and prepares the fitted scene file that
/// `out` will be. `progress` sees every iteration and the values it
/// reached; returning `false` cancels ([`Error::Cancelled`]).
pub fn fit_scene_file(
    path: &std::path::Path,
    out: &std::path::Path,
    options: &FitOptions,
    progress: &mut dyn FnMut(&Iteration, &[Parameter]) -> bool,
) -> Result<FitOutcome> {
    let contents = plsr::scene::file::load_contents(path)?;
    // One rule for seeds: the scene's, unless given.
    let options = &FitOptions {
        seed: Some(options.seed.unwrap_or(contents.description.job.seed)),
        ..options.clone()
    };
    // A direction or size search rebuilds the scene from its description.
    let rebuilds = options.window_direction || options.window_size || options.window_shape;
    let description =
        (rebuilds && !options.windows.is_empty()).then(|| contents.description.clone());
    let mut scene = Scene::build(contents.description)?;
    let scale = write::environment_scale(path)?;
    let adam = !options.params.is_empty() || options.windows.is_empty();
    let mut params = if adam {
        params::select(&scene, &options.params, scale)?
    } else {
        Vec::new()
    };
    let window_lights = window_lights(&scene, &options.windows)?;
    let fits_lights = params.iter().any(Parameter::relative) || !window_lights.is_empty();
    let mut warnings = Vec::new();
    let views = load_views(
        path,
        &mut scene,
        contents.photo,
        contents.views,
        fits_lights,
        &params,
        options,
        &mut warnings,
    )?;
    let pixels = views.iter().map(View::pixels).sum();
    if views.iter().all(|v| v.pixels() == 0) {
        return Err(Error::invalid_argument(
            "no photo pixel sees a real surface of the scene (every mask is empty)",
        ));
    }
    // The windows first: Adam then starts from their brightness.
    let (windows, mut written) = fit_windows(
        &mut scene,
        description.as_ref(),
        &views,
        window_lights,
        options,
        rebuilds,
        &mut params,
    )?;
    if !adam {
        let fitted = write::fitted_files(path, &scene, &written, out)?;
        let loss = windows.last().map_or(0.0, |w| w.1.loss);
        return Ok(FitOutcome {
            parameters: written,
            losses: vec![loss],
            warnings,
            seconds_per_iteration: 0.0,
            pixels,
            windows,
            fitted,
        });
    }
    let (fit, losses, seconds) = run_adam(scene, views, params, options, progress)?;
    warnings.extend(fit.warnings());
    // A light's b fitted by Adam replaces the window search's.
    written.retain(|w| {
        !fit.parameters()
            .iter()
            .any(|p| p.owner == w.owner && p.field == w.field)
    });
    let mut parameters = written;
    parameters.extend(fit.parameters().iter().cloned());
    let fitted = write::fitted_files(path, fit.scene(), &parameters, out)?;
    Ok(FitOutcome {
        windows,
        parameters,
        losses,
        warnings,
        seconds_per_iteration: seconds / options.iterations.max(1) as f64,
        pixels,
        fitted,
    })
}

/// The PLS lights whose windows are fitted, by name: (name, mesh, table,
/// index); an error names the scene's PLS lights if one is not found.
fn window_lights(scene: &Scene, windows: &[String]) -> Result<Vec<(String, usize, usize, usize)>> {
    let pls = params::pls_lights(scene);
    let mut window_lights = Vec::new();
    for name in windows {
        let found = pls.iter().find(|(m, _, _)| {
            let mesh = &scene.meshes()[*m];
            mesh.pls.as_ref().and_then(|p| p.light.name.as_deref()) == Some(name.as_str())
                || mesh.name == *name
        });
        match found {
            Some(&(m, table, light)) => window_lights.push((name.clone(), m, table, light)),
            None => {
                let names: Vec<String> = pls
                    .iter()
                    .map(|(m, _, _)| {
                        let mesh = &scene.meshes()[*m];
                        mesh.pls
                            .as_ref()
                            .and_then(|p| p.light.name.clone())
                            .unwrap_or_else(|| mesh.name.clone())
                    })
                    .collect();
                return Err(Error::invalid_argument(format!(
                    "--window {name}: no PLS light of that name (the scene's: {})",
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                )));
            }
        }
    }
    Ok(window_lights)
}

/// The views to fit against: the scene file's `[photo]` (through the
/// scene's camera) and `[[views]]`, each with its exposure: an `"auto"`
/// one is fitted with the parameters, and needs a `reference` to pin the
/// scale when albedos or lights are fitted too.
#[allow(clippy::too_many_arguments)]
fn load_views(
    path: &std::path::Path,
    scene: &mut Scene,
    photo: Option<plsr::scene::photo::PhotoSpec>,
    view_specs: Vec<plsr::scene::photo::ViewSpec>,
    fits_lights: bool,
    params: &[Parameter],
    options: &FitOptions,
    warnings: &mut Vec<String>,
) -> Result<Vec<View>> {
    let mut specs = Vec::new();
    if let Some(photo) = photo {
        specs.push(("photo".to_string(), scene.camera().clone(), photo));
    }
    for (i, v) in view_specs.into_iter().enumerate() {
        specs.push((format!("views[{i}]"), v.camera, v.photo));
    }
    if specs.is_empty() {
        return Err(Error::input(
            path,
            "photo",
            "is missing: a fit needs a [photo] (or [[views]]) of the real scene to fit against",
        ));
    }
    let mut views = Vec::new();
    for (field, camera, spec) in specs {
        let photo = Photo::load(&spec)?;
        let label = format!("{field} ({})", spec.file.display());
        let k = match photo.exposure {
            Some(k) => k,
            None => auto_exposure(scene, &camera, &photo, options, &label)?,
        };
        if let Some(source) = &photo.exposure_source {
            warnings.push(format!("{label}: exposure k = {k:.5} from {source}"));
        }
        let mut view = View::new(scene, &label, camera, &photo, k)?;
        if photo.exposure.is_none() {
            view.fitted_exposure = true;
            let pin = pin_scale(path, scene, &mut view, &photo, &spec, &field, params)?;
            if pin.is_none() && (fits_lights || params.iter().any(scales_radiance)) {
                return Err(Error::input(
                    path,
                    format!("{field}.exposure"),
                    "is \"auto\", but albedos or lights are fitted too: the exposure trades \
                     against them and nothing pins the scale. Give what is known: a grey card in \
                     view (`reference = { shape = \"card\", reflectance = 0.18 }`), a light of \
                     measured brightness in view (`reference = { light = \"lamp\" }`), or the \
                     exposure as a number",
                ));
            }
            warnings.push(match pin {
                Some(pin) => format!(
                    "{label}: exposure fitted with the parameters, its scale pinned by {pin}"
                ),
                None => format!(
                    "{label}: exposure fitted with the parameters (no albedo or light is fitted)"
                ),
            });
        }
        views.push(view);
    }
    Ok(views)
}

/// Whether a parameter scales the light the photo records (an albedo, a
/// light's brightness or colour, the environment's scale): such a
/// parameter trades against a fitted exposure.
fn scales_radiance(p: &Parameter) -> bool {
    matches!(
        p.field,
        "reflectance" | "base_color" | "b" | "c" | "intensity" | "emission" | "scale"
    )
}

/// Fewest pixels of a reference that pin the scale.
const MIN_REFERENCE_PIXELS: usize = 8;

/// Checks the photo's `reference` (a grey card or a light of known
/// brightness) and makes it count in the view: a card's reflectance is
/// set, a light's pixels join the loss. Returns what pins the scale, for
/// the report; `None` without a reference.
fn pin_scale(
    path: &std::path::Path,
    scene: &mut Scene,
    view: &mut View,
    photo: &Photo,
    spec: &plsr::scene::photo::PhotoSpec,
    field: &str,
    params: &[Parameter],
) -> Result<Option<String>> {
    use plsr::scene::photo::ScaleReference;
    let Some(reference) = &spec.reference else {
        return Ok(None);
    };
    let at = format!("{field}.reference");
    let meshes_named = |name: &str| -> Vec<usize> {
        (0..scene.meshes().len())
            .filter(|&m| scene.meshes()[m].name == name)
            .collect()
    };
    match reference {
        ScaleReference::Card { shape, reflectance } => {
            let meshes = meshes_named(shape);
            let Some(&first) = meshes.first() else {
                return Err(Error::input(
                    path,
                    format!("{at}.shape"),
                    format!("no shape named `{shape}`"),
                ));
            };
            let material = scene.meshes()[first].material as usize;
            let material_name = scene.materials()[material].name.clone();
            if params.iter().any(|p| p.owner == Owner::Material(material)) {
                return Err(Error::input(
                    path,
                    format!("{at}.shape"),
                    format!(
                        "the card's material `{material_name}` is being fitted: a reference is \
                         known, not fitted (leave it out of --param)"
                    ),
                ));
            }
            if let Some(r) = reflectance {
                let shared = (0..scene.meshes().len()).any(|m| {
                    scene.meshes()[m].material as usize == material && !meshes.contains(&m)
                });
                let selected =
                    params::select(scene, &[format!("{material_name}.reflectance")], 1.0);
                let param = match selected {
                    Ok(mut p) if p.len() == 1 && !shared => p.remove(0),
                    _ => {
                        return Err(Error::input(
                            path,
                            format!("{at}.reflectance"),
                            format!(
                            "the card's material `{material_name}` must be a `diffuse` material \
                                 of its own for its reflectance to be set"
                        ),
                        ))
                    }
                };
                params::apply(scene, &param, &[*r, *r, *r])?;
            }
            let seen = pixels_where(scene, &view.camera, |m| meshes.contains(&m));
            let n = seen
                .iter()
                .zip(&view.mask)
                .filter(|(a, b)| **a && **b)
                .count();
            if n < MIN_REFERENCE_PIXELS {
                return Err(Error::input(
                    path,
                    format!("{at}.shape"),
                    format!("the card `{shape}` covers {n} pixels of the photo: at least {MIN_REFERENCE_PIXELS} are needed"),
                ));
            }
            let r = match reflectance {
                Some(r) => format!("reflectance {r}"),
                None => format!("the material `{material_name}`"),
            };
            Ok(Some(format!("the grey card `{shape}` ({r}, {n} pixels)")))
        }
        ScaleReference::Light { name } => {
            let meshes: Vec<usize> = meshes_named(name)
                .into_iter()
                .filter(|&m| scene.mesh_lights(m).is_some() || scene.meshes()[m].pls.is_some())
                .collect();
            if meshes.is_empty() {
                return Err(Error::input(
                    path,
                    format!("{at}.light"),
                    format!("no emitting shape or PLS light named `{name}`"),
                ));
            }
            if params.iter().any(|p| match p.owner {
                Owner::Shape(m) | Owner::Pls { mesh: m, .. } => meshes.contains(&m),
                _ => false,
            }) {
                return Err(Error::input(
                    path,
                    format!("{at}.light"),
                    format!(
                        "the light `{name}` is being fitted: a reference is measured, not fitted"
                    ),
                ));
            }
            let seen = pixels_where(scene, &view.camera, |m| meshes.contains(&m));
            let n = seen.iter().filter(|s| **s).count();
            if n < MIN_REFERENCE_PIXELS {
                return Err(Error::input(
                    path,
                    format!("{at}.light"),
                    format!("the light `{name}` covers {n} pixels of the photo: at least {MIN_REFERENCE_PIXELS} are needed"),
                ));
            }
            // A clipped light says nothing of its brightness (float photos
            // do not clip).
            let clipped = match photo.clip {
                None => 0,
                Some(top) => seen
                    .iter()
                    .zip(&photo.radiance)
                    .filter(|(s, p)| **s && p.cmpge(top * 0.999).any())
                    .count(),
            };
            if clipped * 4 > n {
                return Err(Error::input(
                    path,
                    format!("{at}.light"),
                    format!(
                        "the light `{name}` is clipped in the photo ({clipped} of its {n} pixels at \
                         the top code): its brightness cannot be read; use an HDR photo or a \
                         shorter exposure"
                    ),
                ));
            }
            for (m, s) in view.mask.iter_mut().zip(&seen) {
                *m |= *s;
            }
            Ok(Some(format!(
                "the light `{name}`'s measured brightness ({n} pixels)"
            )))
        }
    }
}

/// The windows fitted: each light's name and what its search found.
type Windows = Vec<(String, light::WindowFit)>;

/// Fits each window light in turn; returns what each search found and
/// the parameters to write. Adam's parameters of a fitted light start
/// from its fitted brightness and colour.
fn fit_windows(
    scene: &mut Scene,
    description: Option<&plsr::scene::SceneDescription>,
    views: &[View],
    window_lights: Vec<(String, usize, usize, usize)>,
    options: &FitOptions,
    rebuilds: bool,
    params: &mut [Parameter],
) -> Result<(Windows, Vec<Parameter>)> {
    let mut windows = Vec::new();
    let mut written = Vec::new();
    for (name, mesh, table, index) in window_lights {
        let found = light::fit_window(
            scene,
            description,
            views,
            mesh,
            &window_options(options, rebuilds),
        )?;
        let owner = Owner::Pls {
            mesh,
            table,
            light: index,
        };
        written.extend(window_parameters(
            scene, &name, mesh, &owner, &found, options, rebuilds,
        ));
        for p in params.iter_mut() {
            if p.owner == owner {
                if let Some(pls) = &scene.meshes()[mesh].pls {
                    p.value = match p.field {
                        "b" => vec![pls.light.b],
                        _ => pls.light.c.to_array().to_vec(),
                    };
                    p.initial = p.value.clone();
                }
            }
        }
        windows.push((name, found));
    }
    Ok((windows, written))
}

/// How a window light is searched, from the fit's options.
fn window_options(options: &FitOptions, rebuilds: bool) -> light::WindowFitOptions {
    light::WindowFitOptions {
        spp: 4 * options.spp,
        seed: options.base_seed() ^ 0x9e37,
        threads: options.threads,
        fit_direction: options.window_direction,
        fit_size: options.window_size,
        fit_shape: options.window_shape,
        fit_penumbra: !(options.window_size || options.window_shape),
        max_evaluations: options
            .window_evaluations
            .unwrap_or(if options.window_shape {
                400
            } else if rebuilds {
                160
            } else {
                80
            }),
    }
}

/// The parameters a window search found for light `name`, as written
/// into the fitted files.
fn window_parameters(
    scene: &Scene,
    name: &str,
    mesh: usize,
    owner: &Owner,
    found: &light::WindowFit,
    options: &FitOptions,
    rebuilds: bool,
) -> Vec<Parameter> {
    let mut fields = vec![
        ("a", vec![found.a_deg]),
        ("penumbra", vec![found.penumbra_deg]),
        ("b", vec![found.b]),
    ];
    if options.window_direction {
        fields.push(("n", found.n.to_array().to_vec()));
    }
    if rebuilds {
        fields.push(("e1", found.e[0].to_array().to_vec()));
        fields.push(("e2", found.e[1].to_array().to_vec()));
    }
    if options.window_shape {
        // The explicit outline (a circle light becomes one).
        let alpha = scene.meshes()[mesh]
            .pls
            .as_ref()
            .map_or([1.0 / 3.0, 2.0 / 3.0], |p| {
                [p.light.g.alpha1, p.light.g.alpha2]
            });
        fields.push(("alpha1", vec![alpha[0]]));
        fields.push(("alpha2", vec![alpha[1]]));
        fields.push(("d", found.d.to_vec()));
    } else if options.window_size {
        fields.push(("d", found.d.to_vec()));
        // A circle light's radius (its `d2 = d3 = 1.35·r`).
        fields.push((
            "circle.radius",
            vec![found.d[1] / plsr::light::pls::CIRCLE_FACTOR],
        ));
    }
    fields
        .into_iter()
        .map(|(field, v)| Parameter {
            name: format!("{name}.{field}"),
            owner: owner.clone(),
            field,
            initial: v.clone(),
            value: v,
            bounds: (f32::MIN, f32::MAX),
            slot: u32::MAX,
        })
        .collect()
}

/// Runs Adam's iterations (each shown to `progress`, which may cancel),
/// then averages; returns the fit, the losses (the last at the fitted
/// values) and the seconds the iterations took.
fn run_adam(
    scene: Scene,
    views: Vec<View>,
    params: Vec<Parameter>,
    options: &FitOptions,
    progress: &mut dyn FnMut(&Iteration, &[Parameter]) -> bool,
) -> Result<(Fit, Vec<f64>, f64)> {
    let mut fit = Fit::new(scene, views, params, options.clone())?;
    let mut losses = Vec::with_capacity(options.iterations as usize + 1);
    let mut seconds = 0.0;
    for i in 0..options.iterations {
        let it = fit.step(i)?;
        losses.push(it.loss);
        seconds += it.seconds;
        if !progress(&it, fit.parameters()) {
            return Err(Error::cancelled());
        }
    }
    fit.finish()?;
    losses.push(
        fit.loss(
            options
                .base_seed()
                .wrapping_add(2 * options.iterations as u64),
        )?,
    );
    Ok((fit, losses, seconds))
}

/// The exposure `k` of `photo ≈ k·render` at the starting values, by the
/// compositing's robust fit over the view's surface pixels.
fn auto_exposure(
    scene: &mut Scene,
    camera: &Camera,
    photo: &Photo,
    options: &FitOptions,
    label: &str,
) -> Result<f32> {
    if (photo.width, photo.height) != (camera.width(), camera.height()) {
        return Err(Error::invalid_argument(format!(
            "{label}: the photo is {}×{} pixels but its camera renders {}×{}",
            photo.width,
            photo.height,
            camera.width(),
            camera.height()
        )));
    }
    scene.set_camera(camera.clone());
    let mask = surface_mask(scene, camera);
    let job = RenderJob {
        spp: options.spp.max(16),
        sample_start: 0,
        max_depth: scene.default_job().max_depth,
        seed: options.base_seed() ^ 0x5eed,
        hide_virtual: true,
        ..Default::default()
    };
    let render_options = RenderOptions {
        threads: options.threads,
        ..RenderOptions::default()
    };
    let (sums, _) = render_sums(scene, &job, &render_options, &|_, _| true)?;
    let without = sums.means();
    let matte: Vec<f32> = mask.iter().map(|m| if *m { 0.0 } else { 1.0 }).collect();
    crate::composite::fit_exposure(&photo.radiance, &without, &matte)
        .map(|f| f.k)
        .ok_or_else(|| {
            Error::invalid_argument(format!(
                "{label}: the exposure cannot be fitted: the render is black where the photo \
                 sees the scene's surfaces"
            ))
        })
}

impl FitOutcome {
    /// Writes the fitted scene to `out` (and its fitted PLS files beside
    /// it), the loss curve as CSV to `loss_csv` and as a PNG plot to
    /// `loss_png`, all committed together; none may replace one of the
    /// scene's `inputs`.
    pub fn write(
        &self,
        out: &std::path::Path,
        loss_csv: &std::path::Path,
        loss_png: &std::path::Path,
        inputs: &[std::path::PathBuf],
    ) -> Result<()> {
        let mut targets: Vec<(&std::path::Path, &str)> = vec![(out, self.fitted.scene.as_str())];
        for (p, text) in &self.fitted.pls {
            targets.push((p, text));
        }
        for (target, _) in &targets {
            if let Some(input) = inputs
                .iter()
                .find(|i| plsr_base::atomic_write::same_file(i, target))
            {
                return Err(Error::output(
                    target.to_path_buf(),
                    format!("would replace the input {}", input.display()),
                ));
            }
        }
        for extra in [loss_csv, loss_png] {
            if inputs
                .iter()
                .any(|i| plsr_base::atomic_write::same_file(i, extra))
            {
                return Err(Error::output(
                    extra.to_path_buf(),
                    "would replace one of the scene's inputs",
                ));
            }
        }
        let mut outputs = plsr_base::atomic_write::OutputSet::new();
        for (target, text) in targets {
            outputs.stage_bytes(target, text.as_bytes())?;
        }
        plot::stage_loss_csv(&mut outputs, loss_csv, &self.losses)?;
        plot::stage_loss_plot(&mut outputs, loss_png, &self.losses)?;
        Ok(outputs.commit()?)
    }
}
