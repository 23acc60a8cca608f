//! Surface scattering models (BSDFs).
//!
//! # The BSDF interface
//!
//! All directions are unit vectors in the local shading frame (normal = +z),
//! both pointing *away* from the surface: `wo` towards the viewer, `wi` towards
//! the light. The integrator flips the frame so that `wo.z > 0` on two-sided
//! surfaces.
//!
//! - [`Bsdf::eval`] returns the BSDF value `f(wo, wi)` (1/sr), *without* the
//!   cosine factor.
//! - [`Bsdf::sample`] draws `wi` and returns the BSDF value and the density
//!   **separately** (a [`BsdfSample`]); the density is in solid angle measure.
//!   It also returns their ratio `weight = f·|cos θi| / pdf`, computed in
//!   closed form where the model allows (exactly the albedo for Lambert),
//!   which is what the path throughput is multiplied by.
//!   A sample that fails (absorbed, below the horizon) is `None`, never a zero pdf.
//! - [`Bsdf::pdf`] is the density `sample` would have produced for `wi`, used
//!   as the MIS counterpart when a light sample is weighted.
//!
//! Parameters are plain structs so that a later material-fitting stage can
//! read and write them by index.
//!
//! ```toml
//! [[materials]]
//! name = "white"
//! type = "diffuse"
//! reflectance = [0.73, 0.73, 0.73]   # linear RGB albedo in [0, 1]
//! ```

use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Parameters of the Lambertian BSDF.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiffuseParams {
    /// Linear RGB albedo, each channel in `[0, 1]`.
    pub reflectance: Vec3,
}

/// A BSDF; a closed set of models, dispatched by `match`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bsdf {
    /// Lambertian reflection: `f = ρ / π`, cosine-weighted sampling.
    Diffuse(DiffuseParams),
}

/// A direction drawn by [`Bsdf::sample`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BsdfSample {
    /// Sampled direction, local frame, unit length.
    pub wi: Vec3,
    /// BSDF value `f(wo, wi)` (1/sr), without the cosine.
    pub f: Vec3,
    /// Solid-angle density of `wi`.
    pub pdf: f32,
    /// `f · |cos θi| / pdf`, the factor the path throughput is multiplied by.
    pub weight: Vec3,
}

impl Bsdf {
    /// A Lambertian BSDF with albedo `reflectance`.
    pub fn diffuse(reflectance: Vec3) -> Bsdf {
        Bsdf::Diffuse(DiffuseParams { reflectance })
    }

    /// `f(wo, wi)` in 1/sr, without the cosine.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match self {
            Bsdf::Diffuse(p) => {
                if wo.z > 0.0 && wi.z > 0.0 {
                    p.reflectance * FRAC_1_PI
                } else {
                    Vec3::ZERO
                }
            }
        }
    }

    /// Draws `wi` for the outgoing direction `wo` from the uniform pair `u`.
    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        match self {
            Bsdf::Diffuse(p) => {
                if wo.z <= 0.0 {
                    return None;
                }
                let wi = square_to_cosine_hemisphere(u);
                let pdf = cosine_hemisphere_pdf(wi.z);
                // f·cos/pdf = (ρ/π)·cos / (cos/π) = ρ.
                (pdf > 0.0).then(|| BsdfSample {
                    wi,
                    f: p.reflectance * FRAC_1_PI,
                    pdf,
                    weight: p.reflectance,
                })
            }
        }
    }

    /// Solid-angle density with which [`Bsdf::sample`] picks `wi`.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Bsdf::Diffuse(_) => {
                if wo.z > 0.0 {
                    cosine_hemisphere_pdf(wi.z)
                } else {
                    0.0
                }
            }
        }
    }

    /// Directional albedo proxy for the albedo AOV (linear RGB).
    pub fn albedo(&self) -> Vec3 {
        match self {
            Bsdf::Diffuse(p) => p.reflectance,
        }
    }
}
