//! What the plastic tests share: both models behind one type, and
//! integration over the hemisphere.

#![allow(dead_code)]

use glam::{Vec2, Vec3};
use plsr::bsdf::fresnel;
use plsr::bsdf::{BsdfSample, PlasticParams, RoughPlasticParams};

/// Either model, as `Bsdf` would hold it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Model {
    Plastic(PlasticParams),
    Rough(RoughPlasticParams),
}

impl Model {
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match self {
            Model::Plastic(p) => p.eval(wo, wi),
            Model::Rough(p) => p.eval(wo, wi),
        }
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Model::Plastic(p) => p.pdf(wo, wi),
            Model::Rough(p) => p.pdf(wo, wi),
        }
    }

    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        match self {
            Model::Plastic(p) => p.eval_pdf(wo, wi),
            Model::Rough(p) => p.eval_pdf(wo, wi),
        }
    }

    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        match self {
            Model::Plastic(p) => p.sample(wo, uc, u),
            Model::Rough(p) => p.sample(wo, uc, u),
        }
    }

    /// The probability that `sample` takes the specular lobe from `wo`.
    pub fn specular_probability(&self, wo: Vec3) -> f32 {
        match self {
            Model::Plastic(p) => p.specular_probability(wo),
            Model::Rough(p) => p.specular_probability(p.table().transmittance(wo.z)),
        }
    }

    /// The albedo of the delta lobe towards `wo`: `F(cos θo)·ks` for the
    /// smooth plastic, nothing for the rough one.
    pub fn delta_albedo(&self, wo: Vec3) -> Vec3 {
        match self {
            Model::Plastic(p) => p.specular_reflectance * fresnel::dielectric(wo.z, p.eta()),
            Model::Rough(_) => Vec3::ZERO,
        }
    }

    pub fn is_rough(&self) -> bool {
        matches!(self, Model::Rough(_))
    }
}

/// `∫ g(w) dω` over the upper hemisphere by the midpoint rule in `(s, φ)`
/// on an `ns × np` grid, with `θ = (π/4)(1 − cos πs)`, `s ∈ [0, 1]`, which
/// crowds the nodes towards the pole and the horizon.
pub fn integrate_hemisphere<const N: usize>(
    g: &dyn Fn(Vec3) -> [f64; N],
    ns: usize,
    np: usize,
) -> [f64; N] {
    use std::f64::consts::PI;
    let mut sum = [0.0; N];
    for i in 0..ns {
        let s = (i as f64 + 0.5) / ns as f64;
        let theta = 0.25 * PI * (1.0 - (PI * s).cos());
        let dtheta = 0.25 * PI * PI * (PI * s).sin() / ns as f64;
        let (st, ct) = theta.sin_cos();
        let mut row = [0.0; N];
        for j in 0..np {
            let phi = 2.0 * PI * (j as f64 + 0.5) / np as f64;
            let v = g(Vec3::new(
                (st * phi.cos()) as f32,
                (st * phi.sin()) as f32,
                ct as f32,
            ));
            for (r, v) in row.iter_mut().zip(v) {
                *r += v;
            }
        }
        for (s, r) in sum.iter_mut().zip(row) {
            *s += r * st * dtheta * 2.0 * PI / np as f64;
        }
    }
    sum
}

/// The directional albedo `∫ f(wo, wi) cos θi dωi` of the model's non-delta
/// part by [`integrate_hemisphere`], on a grid fine enough for its
/// sharpest lobe (α = 0.05 at grazing incidence needs about 6000 × 1200).
pub fn integrated_albedo(model: &Model, wo: Vec3) -> [f64; 3] {
    let (ns, np) = match model {
        Model::Rough(p) if p.alpha < 0.1 => (8000, 1600),
        Model::Rough(_) => (4000, 800),
        Model::Plastic(_) => (1000, 200),
    };
    integrate_hemisphere(
        &|wi| {
            let f = model.eval(wo, wi) * wi.z;
            [f.x as f64, f.y as f64, f.z as f64]
        },
        ns,
        np,
    )
}

/// Monte-Carlo directional albedo with the model's own sampling (its delta
/// lobe included): per channel, the mean weight and its standard error.
pub fn sampled_albedo(model: &Model, wo: Vec3, n: usize, seed: u64) -> [(f64, f64); 3] {
    let mut rng = plsr::rng::Rng::new(seed, 3);
    let (mut s1, mut s2) = ([0.0f64; 3], [0.0f64; 3]);
    for _ in 0..n {
        let (uc, u) = (rng.next_f32(), rng.next_2d());
        if let Some(s) = model.sample(wo, uc, u) {
            for c in 0..3 {
                let w = s.weight[c] as f64;
                s1[c] += w;
                s2[c] += w * w;
            }
        }
    }
    std::array::from_fn(|c| {
        let mean = s1[c] / n as f64;
        let var = (s2[c] / n as f64 - mean * mean).max(0.0);
        (mean, (var / n as f64).sqrt())
    })
}
