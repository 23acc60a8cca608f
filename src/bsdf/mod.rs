//! Surface scattering models (BSDFs).
//!
//! # The BSDF interface
//!
//! All directions are unit vectors in the local shading frame (normal = +z,
//! first tangent = +x, the direction anisotropic roughness refers to), both
//! pointing *away* from the surface: `wo` towards the viewer, `wi` towards the
//! light. For opaque models the integrator flips the frame so that
//! `wo.z > 0` (surfaces are two-sided); for transmissive models
//! ([`Bsdf::transmits`]) it keeps the geometric normal's side as the
//! *outside*, and `wo.z < 0` means the path is inside.
//!
//! - [`Bsdf::eval`] returns the BSDF value `f(wo, wi)` (1/sr), *without* the
//!   cosine factor; 0 for delta lobes.
//! - [`Bsdf::sample`] draws `wi` from a uniform number `uc` (which picks a
//!   lobe) and a uniform pair `u`, and returns the BSDF value and the density
//!   **separately** (a [`BsdfSample`]); the density is in solid angle measure.
//!   It also returns their ratio `weight = f·|cos θi| / pdf`, which is what
//!   the path throughput is multiplied by. A sample from a delta lobe (a
//!   smooth mirror or refraction) has `delta = true`; its `pdf` is then the
//!   discrete probability of the lobe and only `weight` is meaningful.
//!   A sample that fails (absorbed, below the horizon) is `None`, never a
//!   zero pdf.
//! - [`Bsdf::pdf`] is the density `sample` would have produced for `wi`, used
//!   as the MIS counterpart when a light sample is weighted (0 for delta
//!   lobes).
//!
//! Parameters are plain structs (in [`models`]) so that a later
//! material-fitting stage can read and write them.
//!
//! The models (each documented in [`models`], scene-file keys in
//! `docs/scene-format.md`):
//!
//! | type | model |
//! | --- | --- |
//! | `diffuse` | Lambert |
//! | `blinn_phong` | normalised Blinn–Phong |
//! | `cook_torrance` | microfacet reflection, GGX or Beckmann, Smith G, Schlick / dielectric / conductor Fresnel |
//! | `dielectric` | smooth or rough (Walter et al. 2007) glass-like interface |
//! | `principled` | Burley's principled BSDF with Mitsuba 3's parameters; optionally energy-conserving; with sheen, clearcoat, specular transmission or flatness, every lobe of Mitsuba's ([`principled_full`]) |
//! | `principled_thin` | Burley's thin sheet with Mitsuba 3's `principledthin` parameters ([`principled_thin`]) |
//! | `plastic`, `rough_plastic` | Mitsuba 3's `plastic` and `roughplastic`: a diffuse substrate under a smooth or rough dielectric coating ([`plastic`]) |
//!
//! ```toml
//! [[materials]]
//! name = "white"
//! type = "diffuse"
//! reflectance = [0.73, 0.73, 0.73]   # linear RGB albedo in [0, 1]
//! ```

pub mod albedo;
mod albedo_specular;
pub mod fresnel;
pub mod gradient;
pub mod microfacet;
pub mod mixture;
pub mod models;
pub mod plastic;
pub mod principled_full;
pub mod principled_thin;
mod table_cache;
pub mod thin_dielectric;

pub use fresnel::METALS;
pub use gradient::{BsdfGradient, BsdfParam, ALL_PARAMS, BSDF_PARAMS};
pub use microfacet::{Distribution, Microfacet};
pub use mixture::{Mixture, Scatter};
pub use models::{
    lambert_eval, lambert_pdf, lambert_sample, BlinnPhongParams, CookTorranceParams,
    DielectricParams, DiffuseParams, Fresnel, ParamError, PrincipledParams,
};
pub use plastic::{PlasticParams, RoughPlasticParams};
pub use principled_full::PrincipledFullParams;
pub use principled_thin::PrincipledThinParams;
pub use thin_dielectric::ThinDielectricParams;

use glam::{Vec2, Vec3};

/// A BSDF; a closed set of models, dispatched by `match`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bsdf {
    /// Lambertian reflection.
    Diffuse(DiffuseParams),
    /// Normalised Blinn–Phong.
    BlinnPhong(BlinnPhongParams),
    /// Cook–Torrance microfacet reflection.
    CookTorrance(CookTorranceParams),
    /// Smooth or rough dielectric interface (reflection and transmission).
    Dielectric(DielectricParams),
    /// Burley's principled BSDF (Mitsuba 3's parameters).
    Principled(PrincipledParams),
    /// A diffuse substrate under a smooth dielectric coating (Mitsuba's
    /// `plastic`).
    Plastic(PlasticParams),
    /// A diffuse substrate under a rough dielectric coating (Mitsuba's
    /// `roughplastic`).
    RoughPlastic(RoughPlasticParams),
    /// A thin dielectric sheet: mirror and straight-through transmission
    /// (Mitsuba's `thindielectric`).
    ThinDielectric(ThinDielectricParams),
    /// Burley's thin principled sheet: glossy and diffuse reflection and
    /// transmission (Mitsuba's `principledthin`).
    PrincipledThin(PrincipledThinParams),
    /// Burley's principled BSDF with every lobe of Mitsuba's `principled`
    /// (sheen, clearcoat, specular transmission, flatness).
    PrincipledFull(PrincipledFullParams),
}

/// A direction drawn by [`Bsdf::sample`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BsdfSample {
    /// Sampled direction, local frame, unit length.
    pub wi: Vec3,
    /// BSDF value `f(wo, wi)` (1/sr), without the cosine.
    pub f: Vec3,
    /// Solid-angle density of `wi` (for a delta lobe: its probability).
    pub pdf: f32,
    /// `f · |cos θi| / pdf`, the factor the path throughput is multiplied by.
    pub weight: Vec3,
    /// Whether `wi` came from a delta lobe (mirror or smooth refraction).
    pub delta: bool,
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
            Bsdf::Diffuse(p) => p.eval(wo, wi),
            Bsdf::BlinnPhong(p) => p.eval(wo, wi),
            Bsdf::CookTorrance(p) => p.eval(wo, wi),
            Bsdf::Dielectric(p) => p.eval(wo, wi),
            Bsdf::Principled(p) => p.eval(wo, wi),
            Bsdf::Plastic(p) => p.eval(wo, wi),
            Bsdf::RoughPlastic(p) => p.eval(wo, wi),
            Bsdf::ThinDielectric(p) => p.eval(wo, wi),
            Bsdf::PrincipledThin(p) => p.eval(wo, wi),
            Bsdf::PrincipledFull(p) => p.eval(wo, wi),
        }
    }

    /// Draws `wi` for the outgoing direction `wo`: `uc` picks a lobe, `u`
    /// the direction within it (all uniform in `[0, 1)`).
    #[inline]
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        match self {
            Bsdf::Diffuse(p) => p.sample(wo, u),
            Bsdf::BlinnPhong(p) => p.sample(wo, uc, u),
            Bsdf::CookTorrance(p) => p.sample(wo, u),
            Bsdf::Dielectric(p) => p.sample(wo, uc, u),
            Bsdf::Principled(p) => p.sample(wo, uc, u),
            Bsdf::Plastic(p) => p.sample(wo, uc, u),
            Bsdf::RoughPlastic(p) => p.sample(wo, uc, u),
            Bsdf::ThinDielectric(p) => p.sample(wo, uc),
            Bsdf::PrincipledThin(p) => p.sample(wo, uc, u),
            Bsdf::PrincipledFull(p) => p.sample(wo, uc, u),
        }
    }

    /// Solid-angle density with which [`Bsdf::sample`] picks `wi`.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Bsdf::Diffuse(p) => p.pdf(wo, wi),
            Bsdf::BlinnPhong(p) => p.pdf(wo, wi),
            Bsdf::CookTorrance(p) => p.pdf(wo, wi),
            Bsdf::Dielectric(p) => p.pdf(wo, wi),
            Bsdf::Principled(p) => p.pdf(wo, wi),
            Bsdf::Plastic(p) => p.pdf(wo, wi),
            Bsdf::RoughPlastic(p) => p.pdf(wo, wi),
            Bsdf::ThinDielectric(p) => p.pdf(wo, wi),
            Bsdf::PrincipledThin(p) => p.pdf(wo, wi),
            Bsdf::PrincipledFull(p) => p.pdf(wo, wi),
        }
    }

    /// `(eval, pdf)` for the same pair of directions, computed together
    /// where the model shares work between them.
    #[inline]
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        match self {
            Bsdf::Principled(p) => p.eval_pdf(wo, wi),
            Bsdf::CookTorrance(p) => p.eval_pdf(wo, wi),
            Bsdf::Dielectric(p) => p.eval_pdf(wo, wi),
            Bsdf::Plastic(p) => p.eval_pdf(wo, wi),
            Bsdf::RoughPlastic(p) => p.eval_pdf(wo, wi),
            _ => (self.eval(wo, wi), self.pdf(wo, wi)),
        }
    }

    /// Whether light passes through the surface: the integrator then keeps
    /// the geometric normal as the outside instead of facing it to the viewer.
    /// A thin principled sheet counts as transmissive even with its
    /// transmission at 0: it has two sides as Mitsuba's has; so does a
    /// principled material with a transmission lobe, wherever its map
    /// takes it to 0.
    #[inline]
    pub fn transmits(&self) -> bool {
        match self {
            Bsdf::Dielectric(_) | Bsdf::ThinDielectric(_) | Bsdf::PrincipledThin(_) => true,
            Bsdf::PrincipledFull(p) => p.has_transmission,
            _ => false,
        }
    }

    /// `η²` of a scattering from `wo` to `wi` (local frame): the square of
    /// the relative index across the interface for a refraction (`η` going
    /// in, `1/η` coming out), 1 for a reflection or a BSDF that does not
    /// transmit. A refraction scales radiance by `1/η²`; the path tracer's
    /// Russian roulette multiplies it back (see `integrator`).
    #[inline(always)]
    pub fn eta_scale(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Bsdf::Dielectric(p) if wo.z * wi.z < 0.0 => {
                let eta = if wo.z > 0.0 { p.eta } else { 1.0 / p.eta };
                eta * eta
            }
            Bsdf::PrincipledFull(p) => p.eta_scale(wo, wi),
            _ => 1.0,
        }
    }

    /// Whether every lobe is a delta distribution, so that light sampling
    /// cannot contribute and is skipped.
    #[inline]
    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Bsdf::Dielectric(DielectricParams {
                microfacet: None,
                ..
            }) | Bsdf::ThinDielectric(_)
        )
    }

    /// Whether the model depends on the tangent direction (anisotropic
    /// roughness), so that the integrator must build a tangent frame.
    #[inline]
    pub fn is_anisotropic(&self) -> bool {
        let aniso = |m: &Microfacet| m.alpha_x != m.alpha_y;
        match self {
            Bsdf::CookTorrance(p) => aniso(&p.microfacet),
            Bsdf::Dielectric(p) => p.microfacet.as_ref().is_some_and(aniso),
            Bsdf::Principled(p) => p.anisotropic > 0.0,
            Bsdf::PrincipledThin(p) => p.anisotropic > 0.0,
            Bsdf::PrincipledFull(p) => p.anisotropic > 0.0,
            Bsdf::Diffuse(_)
            | Bsdf::BlinnPhong(_)
            | Bsdf::Plastic(_)
            | Bsdf::RoughPlastic(_)
            | Bsdf::ThinDielectric(_) => false,
        }
    }

    /// The base colour a colour map or the mesh's colours replace or
    /// scale (Lambert's reflectance, Blinn–Phong's diffuse colour, the
    /// principled base colour, a plastic's diffuse reflectance), if the
    /// model has one.
    pub fn base_color(&self) -> Option<Vec3> {
        match self {
            Bsdf::Diffuse(p) => Some(p.reflectance),
            Bsdf::BlinnPhong(p) => Some(p.diffuse),
            Bsdf::Principled(p) => Some(p.base_color),
            Bsdf::PrincipledThin(p) => Some(p.base_color),
            Bsdf::PrincipledFull(p) => Some(p.base_color),
            Bsdf::Plastic(p) => Some(p.diffuse_reflectance),
            Bsdf::RoughPlastic(p) => Some(p.diffuse_reflectance),
            Bsdf::CookTorrance(_) | Bsdf::Dielectric(_) | Bsdf::ThinDielectric(_) => None,
        }
    }

    /// The BSDF with base colour `c` in `[0, 1]` (see [`Bsdf::base_color`];
    /// Blinn–Phong's is lowered to leave room for its specular colour);
    /// unchanged for a model without one.
    pub fn with_base_color(mut self, c: Vec3) -> Bsdf {
        match &mut self {
            Bsdf::Diffuse(p) => p.reflectance = c,
            Bsdf::BlinnPhong(p) => p.diffuse = c.min(Vec3::ONE - p.specular),
            Bsdf::Principled(p) => p.base_color = c,
            Bsdf::PrincipledThin(p) => p.base_color = c,
            Bsdf::PrincipledFull(p) => p.base_color = c,
            Bsdf::Plastic(p) => p.diffuse_reflectance = c,
            Bsdf::RoughPlastic(p) => p.diffuse_reflectance = c,
            Bsdf::CookTorrance(_) | Bsdf::Dielectric(_) | Bsdf::ThinDielectric(_) => {}
        }
        self
    }

    /// Directional albedo proxy for the albedo AOV (linear RGB).
    pub fn albedo(&self) -> Vec3 {
        match self {
            Bsdf::Diffuse(p) => p.reflectance,
            Bsdf::BlinnPhong(p) => p.diffuse + p.specular,
            Bsdf::CookTorrance(p) => p.fresnel.eval(1.0),
            Bsdf::Dielectric(_) => Vec3::ONE,
            Bsdf::Principled(p) => p.base_color,
            Bsdf::PrincipledThin(p) => p.base_color,
            Bsdf::PrincipledFull(p) => p.base_color,
            Bsdf::Plastic(p) => p.albedo(),
            Bsdf::RoughPlastic(p) => p.albedo(),
            Bsdf::ThinDielectric(_) => Vec3::ONE,
        }
    }
}
