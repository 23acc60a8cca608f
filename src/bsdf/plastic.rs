//! Mitsuba 3's `plastic` and `roughplastic` BSDFs: a diffuse substrate
//! under a dielectric coating, smooth ([`PlasticParams`]) or rough
//! ([`RoughPlasticParams`]), with Mitsuba's parameters, defaults and values
//! (`eval` agrees with Mitsuba 3.9's to f32 rounding; tested against values
//! Mitsuba computed, `mitsuba_reference.py`).
//!
//! # The model (both BSDFs)
//!
//! Light from `wo` is reflected by the coating's outer interface (a mirror
//! for `plastic`, a microfacet lobe for `roughplastic`) or refracted into
//! the layer, where it meets a Lambertian substrate of albedo `ρ`
//! (`diffuse_reflectance`). What the substrate reflects is partly
//! refracted out and partly reflected back down by the interface's inner
//! side, where it scatters again, and so on: the series
//! `ρ + ρ·Fᵢ·ρ + … = ρ / (1 − ρ·Fᵢ)`, with `Fᵢ` the interface's internal
//! reflectance averaged over a diffuse (cosine-weighted) hemisphere. With
//! `nonlinear = false`, Mitsuba's default, the denominator is `1 − Fᵢ`
//! instead: the substrate's colour is then scaled, not shifted towards
//! darker and more saturated hues, so that a texture keeps its colours.
//! The light that leaves is refracted out through the interface (its
//! radiance scaled by `1/η²`, η = `int_ior / ext_ior`) and distributed as
//! Lambert's `cos/π`. So the substrate's contribution to `f(wo, wi)` is
//!
//! ```text
//! f_diffuse = ρ / (1 − [ρ]·Fᵢ) · T(wo) · T(wi) / (π η²)
//! ```
//!
//! with `T(w)` the fraction of the light from `w` the interface transmits:
//! - `plastic`: `T = 1 − F(cos θ)`, the exact dielectric Fresnel term, and
//!   `Fᵢ` Mitsuba's `fresnel_diffuse_reflectance(1/η)`, a polynomial fit
//!   (Egan and Hilgeman 1973 for `1/η < 1`, d'Eon and Irving 2011 above;
//!   [`fresnel_diffuse_reflectance`]). The specular lobe is a delta mirror
//!   of weight `F(cos θo)·specular_reflectance`: `eval` does not include
//!   it, `sample` draws it.
//! - `roughplastic`: `T(μ)` is the rough interface's *transmittance*
//!   `∫ (1 − F(wo·h))·G1(wt)·VNDF(h) dh` (the visible microfacets, what
//!   each lets through by Fresnel and the refracted direction's masking),
//!   and `Fᵢ = 2∫ R(μ) μ dμ` the hemispherical average of the interface's
//!   *reflectance* from inside (relative index `1/η`), both tabulated per
//!   `(distribution, α, η)` as Mitsuba does at load ([`RoughPlasticTable`]).
//!   The specular lobe is Cook–Torrance
//!   `F(wo·h)·D(h)·G1(wo)·G1(wi) / (4 cos θo cos θi)` times
//!   `specular_reflectance`.
//!
//! Mitsuba's masking term for Beckmann is Walter et al.'s rational
//! approximation (≤ 0.35 % from Smith's exact `G1`), not plsr's
//! [`Microfacet::g1`]; the specular lobe's value and the tables use it
//! ([`mitsuba_smith_g1`]), so that `eval` is Mitsuba's to rounding. The
//! *densities* use the exact `G1`, the normalisation of the visible normals
//! that `sample` draws, so that `pdf` is the density `sample` draws from
//! (Mitsuba's `pdf` uses the rational `G1` there too and so differs from
//! its own sampling density by up to 0.35 % for directions of grazing
//! `wo`; plsr's chi-square tests ask for the exact density).
//!
//! # Energy
//!
//! With a white substrate the smooth plastic reflects `F + (1 − F)·k`, with
//! `k = (1 − F̄ₑ)/(η²(1 − Fᵢ))` (`F̄ₑ` the exact diffuse reflectance from
//! outside): exactly 1 if `Fᵢ` were exact, and `1.0011` at η = 1.49,
//! `0.9995` at η = 1.9 with Mitsuba's fit, as Mitsuba (tested). The rough
//! plastic loses what its single-scattering interface masks, on the way in,
//! out and inside: a white one reflects 0.97 at α = 0.1 (Beckmann) but 0.69
//! at α = 0.3 (GGX), 0.34 at α = 1, at normal incidence, as Mitsuba's.
//!
//! # Sampling (Mitsuba's strategy)
//!
//! A lobe is picked with probability proportional to
//! `(1 − T(wo))·w` (specular) and `T(wo)·(1 − w)` (diffuse), where
//! `w = s/(d + s)` with `d`, `s` the means of `diffuse_reflectance` and
//! `specular_reflectance` over RGB (`plastic`: `1 − T = F`). The diffuse
//! lobe is sampled by the cosine, the rough specular lobe by visible
//! normals (`sample_visible`, the default; Heitz 2018 for GGX, Jakob 2014's
//! numerically inverted routine for Beckmann) or by `D(h) cos θh`.

use super::fresnel::{self, reflect};
use super::microfacet::{
    beckmann_slope_normal, beckmann_visible_slope, sample_visible_beckmann, stretched,
    Distribution, Microfacet,
};
use super::models::{both_above, finish_sample};
use super::{BsdfSample, ParamError};
use crate::elementary;
use crate::elementary::erfinv;
use crate::warp::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use glam::{Vec2, Vec3};
use std::cell::RefCell;
use std::f32::consts::FRAC_1_PI;
use std::sync::Mutex;

/// Mitsuba's index of refraction of air, `ext_ior`'s default.
pub const AIR_IOR: f32 = 1.000277;
/// Mitsuba's index of refraction of polypropylene, `int_ior`'s default.
pub const POLYPROPYLENE_IOR: f32 = 1.49;
/// Smallest roughness: Mitsuba clamps `alpha` to it.
pub const MIN_ALPHA: f32 = 1e-4;

/// Mitsuba's `fresnel_diffuse_reflectance(eta)`: the Fresnel reflectance
/// of an interface of relative index `eta` averaged over a cosine-weighted
/// hemisphere of incident directions, by a polynomial fit (Egan and
/// Hilgeman 1973 for `eta < 1`, within 0.1 % up to `1/eta = 1.5`; d'Eon and
/// Irving 2011 for `eta ≥ 1`, within 0.2 % up to 10).
#[inline(always)]
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    let inv_eta = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv_eta + (eta * (eta * -1.4399 + 0.7099) + 0.6681)
    } else {
        let x = inv_eta;
        0.919317 + x * (-3.4793 + x * (6.75335 + x * (-7.80989 + x * (4.98554 + x * -1.36881))))
    }
}

/// Mean of an RGB colour, as Mitsuba's `Texture::mean` of a colour.
#[inline(always)]
fn mean(c: Vec3) -> f32 {
    (c.x + c.y + c.z) / 3.0
}

/// Mitsuba's `specular_sampling_weight` `s/(d + s)` from the mean
/// diffuse and specular reflectances (½ for a black material, which never
/// scatters anyway).
#[inline(always)]
fn specular_sampling_weight(diffuse: Vec3, specular: Vec3) -> f32 {
    let (d, s) = (mean(diffuse), mean(specular));
    if d + s > 0.0 {
        s / (d + s)
    } else {
        0.5
    }
}

/// The probability of the specular lobe, `(1 − T)·w` against `T·(1 − w)`
/// normalised, from the transmittance `t` towards `wo` and the sampling
/// weight `w`.
#[inline(always)]
fn lobe_probability(t: f32, w: f32) -> f32 {
    let (spec, diff) = ((1.0 - t) * w, t * (1.0 - w));
    if spec + diff > 0.0 {
        spec / (spec + diff)
    } else {
        0.0
    }
}

/// The substrate's albedo after internal scattering, `ρ/(1 − ρ·Fᵢ)`, or
/// `ρ/(1 − Fᵢ)` unless `nonlinear`.
#[inline(always)]
fn substrate(rho: Vec3, internal_reflectance: f32, nonlinear: bool) -> Vec3 {
    let denominator = if nonlinear {
        Vec3::ONE - rho * internal_reflectance
    } else {
        Vec3::splat(1.0 - internal_reflectance)
    };
    rho / denominator
}

/// Checks an index of refraction is positive and finite.
fn ior(parameter: &'static str, value: f32) -> Result<(), ParamError> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(ParamError {
            parameter,
            value,
            range: "(0, ∞)",
        })
    }
}

/// Mitsuba 3's `plastic`: a diffuse substrate under a smooth dielectric
/// coating (see the [module](self) for the model). `eval` and `pdf` are
/// the substrate's alone (the coating's mirror reflection is a delta lobe);
/// `sample` draws the mirror direction with probability
/// [`PlasticParams::specular_probability`] and returns it as a delta
/// sample (`delta = true`, `pdf` the lobe's probability, `weight`
/// `F·specular_reflectance/pdf`).
///
/// ```text
/// f(wo, wi) = ρ / (1 − [ρ]·Fdr(1/η)) · (1 − F(cos θo)) (1 − F(cos θi)) / (π η²)
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlasticParams {
    /// The substrate's albedo `ρ` (linear RGB, `[0, 1]`); Mitsuba's
    /// default 0.5.
    pub diffuse_reflectance: Vec3,
    /// Factor on the coating's reflection (linear RGB, `[0, 1]`); 1 for a
    /// physical coating, Mitsuba's default.
    pub specular_reflectance: Vec3,
    /// Index of refraction of the coating (Mitsuba's default 1.49,
    /// polypropylene).
    pub int_ior: f32,
    /// Index of refraction of the outside (Mitsuba's default 1.000277, air).
    pub ext_ior: f32,
    /// Whether internal scattering shifts the substrate's colour
    /// (`ρ/(1 − ρ·Fᵢ)`) rather than scaling it (`ρ/(1 − Fᵢ)`, Mitsuba's
    /// default `false`).
    pub nonlinear: bool,
}

impl Default for PlasticParams {
    /// Mitsuba's defaults: white polypropylene (`ρ = 0.5`) in air.
    fn default() -> PlasticParams {
        PlasticParams {
            diffuse_reflectance: Vec3::splat(0.5),
            specular_reflectance: Vec3::ONE,
            int_ior: POLYPROPYLENE_IOR,
            ext_ior: AIR_IOR,
            nonlinear: false,
        }
    }
}

impl PlasticParams {
    /// Checks every parameter's range: both reflectances' channels in
    /// `[0, 1]`, both indices positive and finite (NaN fails). Returns the
    /// parameters.
    pub fn validate(self) -> Result<PlasticParams, ParamError> {
        ParamError::check_colour("diffuse_reflectance", self.diffuse_reflectance)?;
        ParamError::check_colour("specular_reflectance", self.specular_reflectance)?;
        ior("int_ior", self.int_ior)?;
        ior("ext_ior", self.ext_ior)?;
        Ok(self)
    }

    /// The relative index of refraction `η = int_ior / ext_ior`.
    #[inline(always)]
    pub fn eta(&self) -> f32 {
        self.int_ior / self.ext_ior
    }

    /// Directional albedo proxy for the albedo AOV: the substrate's
    /// `diffuse_reflectance` (what Mitsuba's `eval_diffuse_reflectance`
    /// reports).
    pub fn albedo(&self) -> Vec3 {
        self.diffuse_reflectance
    }

    /// The probability with which [`PlasticParams::sample`] takes the
    /// mirror lobe for `wo` (above the surface): Mitsuba's
    /// `F(cos θo)·w / (F·w + (1 − F)(1 − w))`, `w` the specular sampling
    /// weight.
    #[inline(always)]
    pub fn specular_probability(&self, wo: Vec3) -> f32 {
        let f = fresnel::dielectric(wo.z, self.eta());
        lobe_probability(
            1.0 - f,
            specular_sampling_weight(self.diffuse_reflectance, self.specular_reflectance),
        )
    }

    /// `f(wo, wi)`: the substrate's term (zero unless both directions are
    /// above the surface; the mirror lobe is a delta).
    #[inline(always)]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.eval_pdf(wo, wi).0
    }

    /// The density of [`PlasticParams::sample`]'s diffuse lobe,
    /// `(1 − P_specular)·cos θi/π` (the mirror lobe is a delta).
    #[inline(always)]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval_pdf(wo, wi).1
    }

    /// `(f(wo, wi), pdf)` with the Fresnel term of `wo` computed once.
    #[inline(always)]
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        if !both_above(wo, wi) {
            return (Vec3::ZERO, 0.0);
        }
        let eta = self.eta();
        let (fo, fi) = (
            fresnel::dielectric(wo.z, eta),
            fresnel::dielectric(wi.z, eta),
        );
        let f = self.substrate() * (FRAC_1_PI * (1.0 / (eta * eta)) * (1.0 - fo) * (1.0 - fi));
        let w = specular_sampling_weight(self.diffuse_reflectance, self.specular_reflectance);
        let pd = 1.0 - lobe_probability(1.0 - fo, w);
        (f, pd * cosine_hemisphere_pdf(wi.z))
    }

    /// The substrate's albedo after internal scattering (Mitsuba's
    /// `fdr_int`, the diffuse reflectance of the coating from inside).
    #[inline(always)]
    fn substrate(&self) -> Vec3 {
        let internal = fresnel_diffuse_reflectance(1.0 / self.eta());
        substrate(self.diffuse_reflectance, internal, self.nonlinear)
    }

    /// Draws `wi` for `wo`: the mirror direction if `uc` falls below
    /// [`PlasticParams::specular_probability`] (a delta sample: `pdf` the
    /// lobe's probability, `f` the reflectance over the cosine, as plsr's
    /// smooth dielectric stores it), else a cosine-weighted direction from
    /// `u`.
    ///
    /// Both candidates are computed and one kept, and the tests are flags
    /// checked at the end rather than early returns (as
    /// `DielectricParams::sample`), so that a vectorised loop calling it
    /// stays vector code; the values are the same.
    #[inline(always)]
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        let fo = fresnel::dielectric(wo.z, self.eta());
        let w = specular_sampling_weight(self.diffuse_reflectance, self.specular_reflectance);
        let ps = lobe_probability(1.0 - fo, w);
        let specular = self.specular_reflectance * fo;
        let mirror = BsdfSample {
            wi: Vec3::new(-wo.x, -wo.y, wo.z),
            f: specular / wo.z,
            pdf: ps,
            weight: specular / ps,
            delta: true,
        };
        let wi = square_to_cosine_hemisphere(u);
        let (f, pdf) = self.eval_pdf(wo, wi);
        if wo.z <= 0.0 {
            None
        } else if uc < ps {
            Some(mirror)
        } else {
            finish_sample(wi, f, pdf)
        }
    }
}

/// Mitsuba 3's `roughplastic`: a diffuse substrate under a rough dielectric
/// coating (see the [module](self) for the model), isotropic GGX or
/// Beckmann:
///
/// ```text
/// f(wo, wi) = s·F(wo·h)·D(h)·G1(wo)·G1(wi) / (4 cos θo cos θi)
///           + ρ / (1 − [ρ]·Fᵢ) · T(cos θo)·T(cos θi) / (π η²)
/// ```
///
/// `T` and `Fᵢ` come from the [`RoughPlasticTable`] of
/// `(distribution, alpha, η)`, computed at first use (about 0.1 s) and kept
/// for the life of the process: `alpha` is a material constant (Mitsuba has
/// no roughness texture for it either; a roughness map must not change it,
/// or every distinct value would compute and keep a table), and
/// [`RoughPlasticParams::prepare`] computes it in advance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoughPlasticParams {
    /// The substrate's albedo `ρ` (linear RGB, `[0, 1]`); Mitsuba's
    /// default 0.5.
    pub diffuse_reflectance: Vec3,
    /// Factor `s` on the specular lobe (linear RGB, `[0, 1]`); 1, Mitsuba's
    /// default, for a physical coating.
    pub specular_reflectance: Vec3,
    /// Index of refraction of the coating (Mitsuba's default 1.49).
    pub int_ior: f32,
    /// Index of refraction of the outside (Mitsuba's default 1.000277).
    pub ext_ior: f32,
    /// Whether internal scattering shifts the substrate's colour (see
    /// [`PlasticParams::nonlinear`]; Mitsuba's default `false`).
    pub nonlinear: bool,
    /// The microfacet distribution (Mitsuba's default Beckmann).
    pub distribution: Distribution,
    /// Roughness α (Mitsuba's default 0.1); values below [`MIN_ALPHA`] are
    /// taken as it, as Mitsuba does.
    pub alpha: f32,
    /// Whether the specular lobe is sampled by visible normals (Mitsuba's
    /// default `true`) or by `D(h) cos θh`; only the noise differs.
    pub sample_visible: bool,
}

impl Default for RoughPlasticParams {
    /// Mitsuba's defaults: white polypropylene (`ρ = 0.5`) in air, Beckmann
    /// with α = 0.1, visible-normal sampling.
    fn default() -> RoughPlasticParams {
        RoughPlasticParams {
            diffuse_reflectance: Vec3::splat(0.5),
            specular_reflectance: Vec3::ONE,
            int_ior: POLYPROPYLENE_IOR,
            ext_ior: AIR_IOR,
            nonlinear: false,
            distribution: Distribution::Beckmann,
            alpha: 0.1,
            sample_visible: true,
        }
    }
}

/// What the substrate term of a [`RoughPlasticParams`] reads from its
/// [`RoughPlasticTable`] for one pair of directions: the transmittances
/// towards `wo` and `wi` and the internal reflectance. Looked up by
/// [`RoughPlasticTable::terms`], or by a caller in advance (so that a
/// vectorised loop evaluating the BSDF reads no table).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SubstrateTerms {
    /// `T(cos θo)`.
    pub t_o: f32,
    /// `T(cos θi)`.
    pub t_i: f32,
    /// `Fᵢ`, the interface's hemispherical reflectance from inside.
    pub internal_reflectance: f32,
}

impl RoughPlasticParams {
    /// Checks every parameter's range: both reflectances' channels in
    /// `[0, 1]`, both indices positive, finite and different (Mitsuba's
    /// condition), `alpha` finite and ≥ 0 (NaN fails). Returns the
    /// parameters.
    pub fn validate(self) -> Result<RoughPlasticParams, ParamError> {
        ParamError::check_colour("diffuse_reflectance", self.diffuse_reflectance)?;
        ParamError::check_colour("specular_reflectance", self.specular_reflectance)?;
        ior("int_ior", self.int_ior)?;
        ior("ext_ior", self.ext_ior)?;
        if self.int_ior == self.ext_ior {
            return Err(ParamError {
                parameter: "int_ior",
                value: self.int_ior,
                range: "(0, ∞) other than ext_ior",
            });
        }
        if !(self.alpha >= 0.0 && self.alpha.is_finite()) {
            return Err(ParamError {
                parameter: "alpha",
                value: self.alpha,
                range: "[0, ∞)",
            });
        }
        Ok(self)
    }

    /// The relative index of refraction `η = int_ior / ext_ior`.
    #[inline(always)]
    pub fn eta(&self) -> f32 {
        self.int_ior / self.ext_ior
    }

    /// The specular lobe's distribution (α clamped to [`MIN_ALPHA`]).
    #[inline(always)]
    pub fn microfacet(&self) -> Microfacet {
        let alpha = self.alpha.max(MIN_ALPHA);
        Microfacet {
            kind: self.distribution,
            alpha_x: alpha,
            alpha_y: alpha,
        }
    }

    /// Directional albedo proxy for the albedo AOV: the substrate's
    /// `diffuse_reflectance` (what Mitsuba's `eval_diffuse_reflectance`
    /// reports).
    pub fn albedo(&self) -> Vec3 {
        self.diffuse_reflectance
    }

    /// This material's table (computed at first use).
    pub fn table(&self) -> &'static RoughPlasticTable {
        RoughPlasticTable::of(self.distribution, self.alpha, self.eta())
    }

    /// Computes the table now (otherwise computed at first use).
    pub fn prepare(&self) {
        self.table();
    }

    /// The probability with which [`RoughPlasticParams::sample`] takes the
    /// specular lobe for `wo`, whose transmittance is `t_o`:
    /// `(1 − T)·w / ((1 − T)·w + T·(1 − w))`, `w` the specular sampling
    /// weight.
    #[inline(always)]
    pub fn specular_probability(&self, t_o: f32) -> f32 {
        lobe_probability(
            t_o,
            specular_sampling_weight(self.diffuse_reflectance, self.specular_reflectance),
        )
    }

    /// `f(wo, wi)`: the first half of [`RoughPlasticParams::eval_pdf`].
    #[inline(always)]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.eval_pdf(wo, wi).0
    }

    /// The density of [`RoughPlasticParams::sample`]: the second half of
    /// [`RoughPlasticParams::eval_pdf`].
    #[inline(always)]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval_pdf(wo, wi).1
    }

    /// `(f(wo, wi), pdf)`, the terms looked up in this material's table.
    #[inline(always)]
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        self.eval_pdf_with(self.table().terms(wo, wi), wo, wi)
    }

    /// `(f(wo, wi), pdf)` with the table's terms for this pair of
    /// directions given (pure arithmetic: what a vectorised loop calls).
    /// The half vector, `D(h)` and the masking of `wo` are computed once.
    #[inline(always)]
    pub fn eval_pdf_with(&self, terms: SubstrateTerms, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        if !both_above(wo, wi) {
            return (Vec3::ZERO, 0.0);
        }
        let m = self.microfacet();
        let eta = self.eta();
        let h = (wo + wi).normalize();
        let d = m.d(h);
        let g = mitsuba_smith_g1(&m, wo, h) * mitsuba_smith_g1(&m, wi, h);
        let specular = self.specular_reflectance
            * (fresnel::dielectric(wo.dot(h), eta) * d * g / (4.0 * wo.z * wi.z));
        let diffuse = substrate(
            self.diffuse_reflectance,
            terms.internal_reflectance,
            self.nonlinear,
        ) * (FRAC_1_PI * (1.0 / (eta * eta)) * terms.t_o * terms.t_i);
        let spec_pdf = if self.sample_visible {
            // Visible normals: G1(wo)·(wo·h)·D/cos θo over h, times the
            // Jacobian 1/(4 wo·h) of the reflection.
            d * m.g1(wo, h) / (4.0 * wo.z)
        } else {
            // D(h) cos θh over h; Mitsuba's Jacobian 1/(4 wi·h) (the same
            // as 1/(4 wo·h) but for rounding, which matters where wo and wi
            // nearly oppose).
            d * h.z / (4.0 * wi.dot(h))
        };
        let ps = self.specular_probability(terms.t_o);
        (
            specular + diffuse,
            ps * spec_pdf + (1.0 - ps) * cosine_hemisphere_pdf(wi.z),
        )
    }

    /// Draws `wi` for `wo`: `uc` picks the lobe
    /// ([`RoughPlasticParams::specular_probability`]), `u` the direction
    /// (the terms looked up in this material's table).
    #[inline(always)]
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        let table = self.table();
        let wi = self.sample_direction(table.transmittance(wo.z), wo, uc, u);
        self.finish(table.terms(wo, wi), wo, wi)
    }

    /// [`RoughPlasticParams::sample`] with the table's terms of `wo` and of
    /// the direction [`RoughPlasticParams::sample_direction`] draws given
    /// (what a vectorised loop calls, with terms looked up in advance).
    #[inline(always)]
    pub fn sample_with(
        &self,
        terms: SubstrateTerms,
        wo: Vec3,
        uc: f32,
        u: Vec2,
    ) -> Option<BsdfSample> {
        let wi = self.sample_direction(terms.t_o, wo, uc, u);
        self.finish(terms, wo, wi)
    }

    /// The sample of the direction `wi` drawn for `wo`: `None` unless both
    /// lie above the surface (tested after the arithmetic, as flags, so
    /// that a vectorised loop stays vector code).
    #[inline(always)]
    fn finish(&self, terms: SubstrateTerms, wo: Vec3, wi: Vec3) -> Option<BsdfSample> {
        let (f, pdf) = self.eval_pdf_with(terms, wo, wi);
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return None;
        }
        finish_sample(wi, f, pdf)
    }

    /// The direction [`RoughPlasticParams::sample`] draws for `wo` (whose
    /// transmittance is `t_o`), before any check of it: the reflection of
    /// `wo` about a sampled microfacet normal, or a cosine-weighted
    /// direction.
    #[inline(always)]
    pub fn sample_direction(&self, t_o: f32, wo: Vec3, uc: f32, u: Vec2) -> Vec3 {
        if uc < self.specular_probability(t_o) {
            reflect(wo, self.sample_h(wo, u))
        } else {
            square_to_cosine_hemisphere(u)
        }
    }

    /// A microfacet normal for `wo` (above the surface): visible normals
    /// (plsr's samplers, [`Microfacet::sample_h`]) or `D(h) cos θh`
    /// ([`sample_beckmann_distribution`], [`sample_ggx_distribution`]).
    #[inline(always)]
    fn sample_h(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let m = self.microfacet();
        match (self.distribution, self.sample_visible) {
            (Distribution::Ggx, true) => m.sample_h(wo, u),
            (Distribution::Beckmann, true) => sample_visible_beckmann(m.alpha_x, m.alpha_x, wo, u),
            (Distribution::Beckmann, false) => sample_beckmann_distribution(m.alpha_x, u),
            (Distribution::Ggx, false) => sample_ggx_distribution(m.alpha_x, u),
        }
    }
}

/// Mitsuba's Smith masking `G1(w, h)` of an isotropic distribution: for
/// GGX the exact `2/(1 + √(1 + α² tan² θ))`; for Beckmann Walter et al.'s
/// rational approximation in `a = 1/(α tan θ)`,
/// `(3.535a + 2.181a²)/(1 + 2.276a + 2.577a²)` below `a = 1.6` and 1 above
/// (within 0.35 % of the exact [`Microfacet::g1`]). 0 where `w` sees the
/// back of `h`.
#[inline(always)]
pub fn mitsuba_smith_g1(m: &Microfacet, w: Vec3, h: Vec3) -> f32 {
    let xy = (m.alpha_x * w.x) * (m.alpha_x * w.x) + (m.alpha_y * w.y) * (m.alpha_y * w.y);
    let tan2 = xy / (w.z * w.z);
    let g = match m.kind {
        Distribution::Ggx => 2.0 / (1.0 + (1.0 + tan2).sqrt()),
        Distribution::Beckmann => {
            let a = 1.0 / tan2.sqrt();
            if a >= 1.6 {
                1.0
            } else {
                (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
            }
        }
    };
    let g = if xy == 0.0 { 1.0 } else { g };
    if w.dot(h) * w.z <= 0.0 {
        0.0
    } else {
        g
    }
}

/// A microfacet normal drawn from `D(h) cos θh` of the isotropic Beckmann
/// distribution of roughness `alpha` (Walter et al. 2007):
/// `tan² θ = −α² ln(1 − u)`.
#[inline(always)]
pub fn sample_beckmann_distribution(alpha: f32, u: Vec2) -> Vec3 {
    let (s, c) = elementary::sin_cos_turns(u.y);
    let tan2 = -alpha * alpha * elementary::ln(1.0 - u.x);
    let cos = 1.0 / (1.0 + tan2).sqrt();
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    Vec3::new(sin * c, sin * s, cos)
}

/// A microfacet normal drawn from `D(h) cos θh` of the isotropic GGX
/// distribution of roughness `alpha`: `tan² θ = α² u/(1 − u)`.
#[inline(always)]
pub fn sample_ggx_distribution(alpha: f32, u: Vec2) -> Vec3 {
    let tan2 = alpha * alpha * u.x / (1.0 - u.x);
    let cos = 1.0 / (1.0 + tan2).sqrt();
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let (s, c) = elementary::sin_cos_turns(u.y);
    Vec3::new(sin * c, sin * s, cos)
}

/// Points of the transmittance table over `μ = cos θ ∈ [0, 1]` (Mitsuba's
/// `MI_ROUGH_TRANSMITTANCE_RES`).
pub const TRANSMITTANCE_POINTS: usize = 64;

/// The tables of a rough plastic's substrate term, for one
/// `(distribution, α, η)`, computed as Mitsuba's `roughplastic` computes
/// them when it loads (`RoughPlastic::parameters_changed`; not a data file):
///
/// - the external transmittance `T(μ)` of the rough interface at
///   `μ = k/63` (`k = 0..64`, `μ = 0` taken as `10⁻⁶`): Mitsuba's
///   `eval_transmittance`, the integral over the unit square of the
///   visible-normal sampler of `(1 − F(wo·h))·G1(wt, h)` (`wt` the
///   refracted direction, kept where it leaves on the other side), by a
///   32 × 32 Gauss–Legendre rule (128 × 128 where `η < 1`), always
///   with visible-normal sampling and Mitsuba's `G1`;
/// - the internal reflectance `Fᵢ = 2·mean_k(R(μ_k)·μ_k)`, `R` the
///   interface's reflectance `F(wo·h)·G1(wr, h)` integrated in the same way
///   with the relative index `1/η` (light meeting the coating from inside;
///   a 128 × 128 rule where `1/η < 1`, since total internal reflection
///   makes the integrand jump): Mitsuba's `eval_reflectance`. The mean over
///   the 64 points is Mitsuba's (a Riemann sum of `2∫R μ dμ`, not an exact
///   integral), kept so that the values match.
///
/// The arithmetic is Mitsuba's in f32 (nodes computed in f64 and rounded,
/// sums in f32 in Mitsuba's order), with plsr's elementary functions and
/// Fresnel term, so the entries agree with Mitsuba's to f32 rounding.
/// `T(μ)` is looked up as Mitsuba's `lerp_gather` does (linear between the
/// points).
#[derive(Clone, PartialEq)]
pub struct RoughPlasticTable {
    kind: Distribution,
    alpha: f32,
    eta: f32,
    /// `T(μ)` at `μ = k/63`.
    pub transmittance: [f32; TRANSMITTANCE_POINTS],
    /// `Fᵢ`.
    pub internal_reflectance: f32,
}

impl std::fmt::Debug for RoughPlasticTable {
    /// The table's parameters and internal reflectance (not its entries).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RoughPlasticTable")
            .field("kind", &self.kind)
            .field("alpha", &self.alpha)
            .field("eta", &self.eta)
            .field("internal_reflectance", &self.internal_reflectance)
            .finish_non_exhaustive()
    }
}

impl RoughPlasticTable {
    /// The table of `(kind, alpha, eta)` (α clamped to [`MIN_ALPHA`]),
    /// computed on first use for each distinct triple (about 0.1 s: 1.1
    /// million evaluations of the interface) and kept for the life of the
    /// process; later calls are
    /// a lookup in a per-thread list.
    pub fn of(kind: Distribution, alpha: f32, eta: f32) -> &'static RoughPlasticTable {
        /// Tables computed so far, shared by all threads.
        static ALL: Mutex<Vec<&'static RoughPlasticTable>> = Mutex::new(Vec::new());
        thread_local! {
            /// The last few tables this thread used.
            static RECENT: RefCell<Vec<&'static RoughPlasticTable>> =
                const { RefCell::new(Vec::new()) };
        }
        let alpha = alpha.max(MIN_ALPHA);
        super::table_cache::interned(
            &ALL,
            &RECENT,
            |t| {
                t.kind == kind
                    && t.alpha.to_bits() == alpha.to_bits()
                    && t.eta.to_bits() == eta.to_bits()
            },
            || RoughPlasticTable::compute(kind, alpha, eta),
        )
    }

    /// Computes the table of `(kind, alpha, eta)` (`alpha` ≥ [`MIN_ALPHA`])
    /// as Mitsuba does (serially: it may first be needed inside a render's
    /// worker).
    pub fn compute(kind: Distribution, alpha: f32, eta: f32) -> RoughPlasticTable {
        let m = Microfacet {
            kind,
            alpha_x: alpha,
            alpha_y: alpha,
        };
        let step = 1.0 / (TRANSMITTANCE_POINTS - 1) as f32;
        let mut transmittance = [0.0; TRANSMITTANCE_POINTS];
        let mut reflectance_sum = 0.0f32;
        for (k, t) in transmittance.iter_mut().enumerate() {
            let mu = (k as f32 * step).max(1e-6);
            let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            *t = interface_integral(&m, wi, eta, Scattering::Transmission);
            reflectance_sum += interface_integral(&m, wi, 1.0 / eta, Scattering::Reflection) * mu;
        }
        RoughPlasticTable {
            kind,
            alpha,
            eta,
            transmittance,
            internal_reflectance: reflectance_sum / TRANSMITTANCE_POINTS as f32 * 2.0,
        }
    }

    /// `T(μ)`, linear between the table's points (Mitsuba's `lerp_gather`;
    /// `μ` clamped to `[0, 1]`). The index goes through `i32` (AVX2
    /// converts packed `f32` to 32-bit integers only) and is clamped, so
    /// that every read is provably in bounds.
    #[inline(always)]
    pub fn transmittance(&self, mu: f32) -> f32 {
        let x = mu.clamp(0.0, 1.0) * (TRANSMITTANCE_POINTS - 1) as f32;
        let i = (x as i32).clamp(0, TRANSMITTANCE_POINTS as i32 - 2) as usize;
        let (v0, v1) = (self.transmittance[i], self.transmittance[i + 1]);
        let t = x - i as f32;
        v0 + (v1 - v0) * t
    }

    /// The terms the substrate reads for the pair `(wo, wi)`.
    #[inline(always)]
    pub fn terms(&self, wo: Vec3, wi: Vec3) -> SubstrateTerms {
        SubstrateTerms {
            t_o: self.transmittance(wo.z),
            t_i: self.transmittance(wi.z),
            internal_reflectance: self.internal_reflectance,
        }
    }
}

/// Which part of the light meeting the interface [`interface_integral`]
/// counts.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Scattering {
    Reflection,
    Transmission,
}

/// Mitsuba's `eval_reflectance` / `eval_transmittance` for one direction
/// `wi` (above the surface) and relative index `eta`: the fraction of the
/// light from `wi` the rough interface `m` reflects (`F·G1` of the
/// reflected direction) or transmits (`(1 − F)·G1` of the refracted one),
/// integrated over the visible-normal sampler's unit square by a
/// Gauss–Legendre rule of 32² nodes (128² where `eta ≤ 1`), summed in f32
/// in Mitsuba's order.
fn interface_integral(m: &Microfacet, wi: Vec3, eta: f32, part: Scattering) -> f32 {
    let (nodes, weights) = gauss_legendre(if eta > 1.0 { 32 } else { 128 });
    let n = nodes.len();
    let us: Vec<f32> = nodes.iter().map(|x| x * 0.5 + 0.5).collect();
    // Beckmann's sampler in its parts: the slope along the azimuth depends
    // on u.x alone, the one across on u.y alone (the same values as
    // `sample_visible_beckmann` of each node, computed n times, not n²).
    let (cos, cos_phi, sin_phi) = stretched(m.alpha_x, m.alpha_x, wi);
    let clamped = |u: f32| u.clamp(1e-6, 1.0 - 1e-6);
    let (along, across): (Vec<f32>, Vec<f32>) = if m.kind == Distribution::Beckmann {
        (
            us.iter()
                .map(|&u| beckmann_visible_slope(cos, clamped(u)))
                .collect(),
            us.iter().map(|&u| erfinv(2.0 * clamped(u) - 1.0)).collect(),
        )
    } else {
        (Vec::new(), Vec::new())
    };
    let mut sum = 0.0f32;
    for j in 0..n * n {
        // Dr.Jit's meshgrid: x varies fastest.
        let (ix, iy) = (j % n, j / n);
        let h = match m.kind {
            Distribution::Ggx => m.sample_h(wi, Vec2::new(us[ix], us[iy])),
            Distribution::Beckmann => beckmann_slope_normal(
                m.alpha_x,
                m.alpha_x,
                cos_phi,
                sin_phi,
                Vec2::new(along[ix], across[iy]),
            ),
        };
        let cos_i = wi.dot(h);
        let f = fresnel::dielectric(cos_i, eta);
        let value = match part {
            Scattering::Reflection => {
                let wo = reflect(wi, h);
                if wo.z <= 0.0 || wi.z <= 0.0 {
                    0.0
                } else {
                    mitsuba_smith_g1(m, wo, h) * f
                }
            }
            Scattering::Transmission => {
                // Mitsuba's `fresnel` and `refract`: cos θt signed opposite
                // to cos θi, the direction scaled by η_ti = 1/η (or η from
                // inside).
                let eta_ti = if cos_i >= 0.0 { 1.0 / eta } else { eta };
                let cos_t2 = 1.0 - (1.0 - cos_i * cos_i) * (eta_ti * eta_ti);
                let cos_t = -cos_t2.max(0.0).sqrt().copysign(cos_i);
                let wt = h * (cos_i * eta_ti + cos_t) - wi * eta_ti;
                if wt.z * wi.z >= 0.0 {
                    0.0
                } else {
                    mitsuba_smith_g1(m, wt, h) * (1.0 - f)
                }
            }
        };
        sum += value * (weights[ix] * weights[iy]) * 0.25;
    }
    sum
}

/// Nodes and weights of the `n`-point Gauss–Legendre rule on `[−1, 1]`,
/// computed in f64 by Newton's method on the Legendre polynomial and
/// rounded to f32 (as Mitsuba's `quad::gauss_legendre`), nodes ascending.
fn gauss_legendre(n: usize) -> (Vec<f32>, Vec<f32>) {
    /// `(P_n(x), P_n'(x))` by the three-term recurrence.
    fn legendre(n: usize, x: f64) -> (f64, f64) {
        let (mut p0, mut p1) = (1.0, x);
        for k in 2..=n {
            let k = k as f64;
            let p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
            p0 = p1;
            p1 = p2;
        }
        (p1, n as f64 * (x * p1 - p0) / (x * x - 1.0))
    }
    let (mut nodes, mut weights) = (vec![0.0f32; n], vec![0.0f32; n]);
    for i in 0..n.div_ceil(2) {
        let mut x = -((2 * i + 1) as f64 / (2 * n) as f64 * std::f64::consts::PI).cos();
        for _ in 0..100 {
            let (p, dp) = legendre(n, x);
            let step = p / dp;
            x -= step;
            if step.abs() <= 4.0 * x.abs() * f64::EPSILON {
                break;
            }
        }
        let (_, dp) = legendre(n, x);
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        (nodes[i], nodes[n - 1 - i]) = (x as f32, -x as f32);
        (weights[i], weights[n - 1 - i]) = (w as f32, w as f32);
    }
    (nodes, weights)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for n in [32, 128] {
            let (x, w) = gauss_legendre(n);
            let sum: f64 = w.iter().map(|&w| w as f64).sum();
            assert!((sum - 2.0).abs() < 1e-5, "{n}: Σw = {sum}");
            // ∫ x⁴ over [−1, 1] = 2/5.
            let m4: f64 = x
                .iter()
                .zip(&w)
                .map(|(&x, &w)| (x as f64).powi(4) * w as f64)
                .sum();
            assert!((m4 - 0.4).abs() < 1e-5, "{n}: {m4}");
            assert!(x.windows(2).all(|p| p[0] < p[1]));
        }
    }

    #[test]
    fn mitsuba_g1_is_close_to_smiths() {
        for kind in [Distribution::Ggx, Distribution::Beckmann] {
            let m = Microfacet::isotropic(kind, 0.3);
            for i in 1..100 {
                let cos = i as f32 / 100.0;
                let w = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
                let (a, b) = (mitsuba_smith_g1(&m, w, Vec3::Z), m.g1(w, Vec3::Z));
                let tol = if kind == Distribution::Ggx {
                    1e-6
                } else {
                    4e-3
                };
                assert!((a - b).abs() <= tol * b, "{kind:?} cos {cos}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn transmittance_lookup_is_linear_between_points() {
        let t = RoughPlasticTable::of(Distribution::Ggx, 0.3, 1.5);
        assert_eq!(t.transmittance(0.0), t.transmittance[0]);
        assert_eq!(t.transmittance(1.0), t.transmittance[63]);
        let mid = t.transmittance(10.5 / 63.0);
        let want = 0.5 * (t.transmittance[10] + t.transmittance[11]);
        assert!((mid - want).abs() < 1e-6);
        // The same table comes back (computed once).
        assert!(std::ptr::eq(
            t,
            RoughPlasticTable::of(Distribution::Ggx, 0.3, 1.5)
        ));
    }
}
