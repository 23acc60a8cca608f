//! Derivatives of BSDF values with respect to their parameters, by hand,
//! for the differentiable path tracer (`crate::integrator::gradient`).
//!
//! [`Bsdf::eval_gradient`] returns `f(wo, wi)` and `∂f/∂θ` for the seven
//! fittable parameters of [`BsdfParam`]: the three colour channels
//! (Lambert's `reflectance` or the principled `base_color`), `roughness`,
//! `metallic`, `anisotropic` and `specular`. Every derivative is an RGB
//! vector (the principled specular tint couples the channels).
//!
//! Only the Lambert model and the principled model in Mitsuba's mode
//! (`energy_conserving = false`) have derivatives; [`Bsdf::gradient_support`]
//! says why another cannot be fitted. The sampling densities are not
//! differentiated: the integrator treats them as constants (detached
//! sampling), which keeps its estimator unbiased.
//!
//! The derivatives are checked against central finite differences of
//! [`Bsdf::eval`] in `crates/cli/tests/it/gradients.rs`.

use super::fresnel;
use super::microfacet::{Microfacet, MIN_ALPHA};
use super::models::PrincipledParams;
use super::Bsdf;
use crate::color::luminance;
use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

/// Number of fittable BSDF parameters (slots of [`BsdfGradient::d`]).
pub const BSDF_PARAMS: usize = 7;

/// Every parameter's bit, for [`Bsdf::eval_gradient_of`].
pub const ALL_PARAMS: u8 = (1 << BSDF_PARAMS) - 1;

/// A fittable BSDF parameter; its `as usize` is its slot in
/// [`BsdfGradient::d`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BsdfParam {
    /// Red channel of the colour (`reflectance` or `base_color`).
    Red = 0,
    /// Green channel of the colour.
    Green = 1,
    /// Blue channel of the colour.
    Blue = 2,
    /// Principled `roughness`.
    Roughness = 3,
    /// Principled `metallic`.
    Metallic = 4,
    /// Principled `anisotropic`.
    Anisotropic = 5,
    /// Principled `specular`.
    Specular = 6,
}

/// A BSDF value and its derivatives (the value as [`Bsdf::eval`] gives it,
/// up to rounding).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BsdfGradient {
    /// `f(wo, wi)` (1/sr), without the cosine.
    pub f: Vec3,
    /// `∂f/∂θ` for each [`BsdfParam`] slot (1/sr per unit of the parameter).
    pub d: [Vec3; BSDF_PARAMS],
}

impl BsdfGradient {
    const ZERO: BsdfGradient = BsdfGradient {
        f: Vec3::ZERO,
        d: [Vec3::ZERO; BSDF_PARAMS],
    };
}

impl Bsdf {
    /// Which parameters of this model have derivatives, or why none do.
    pub fn gradient_support(&self) -> Result<&'static [BsdfParam], &'static str> {
        use BsdfParam::*;
        match self {
            Bsdf::Diffuse(_) => Ok(&[Red, Green, Blue]),
            Bsdf::Principled(p) if p.energy_conserving => Err(
                "energy-conserving principled materials cannot be fitted (their diffuse lobe \
                 uses tabulated albedos); set energy_conserving = false to fit this material",
            ),
            Bsdf::Principled(_) => {
                Ok(&[Red, Green, Blue, Roughness, Metallic, Anisotropic, Specular])
            }
            Bsdf::BlinnPhong(_) => Err("blinn_phong materials cannot be fitted"),
            Bsdf::CookTorrance(_) => Err("cook_torrance materials cannot be fitted"),
            Bsdf::Dielectric(_) => Err("dielectric materials cannot be fitted"),
            Bsdf::Plastic(_) | Bsdf::RoughPlastic(_) => {
                Err("plastic and rough_plastic materials cannot be fitted")
            }
            Bsdf::ThinDielectric(_) => Err("thin_dielectric materials cannot be fitted"),
            Bsdf::PrincipledThin(_) => Err("principled_thin materials cannot be fitted"),
            Bsdf::PrincipledFull(_) => Err(
                "principled materials with sheen, clearcoat, spec_trans or flatness cannot be fitted",
            ),
        }
    }

    /// `f(wo, wi)` and its derivatives (local frame, as [`Bsdf::eval`]); all
    /// derivatives are zero for models without [`Bsdf::gradient_support`].
    #[inline]
    pub fn eval_gradient(&self, wo: Vec3, wi: Vec3) -> BsdfGradient {
        self.eval_gradient_of(wo, wi, ALL_PARAMS)
    }

    /// [`Bsdf::eval_gradient`] for the parameters whose bits (`1 << slot`)
    /// are set in `wanted`; the other derivatives are left at zero (and not
    /// computed). The value `f` equals [`Bsdf::eval`]'s bit for bit.
    #[inline]
    pub fn eval_gradient_of(&self, wo: Vec3, wi: Vec3, wanted: u8) -> BsdfGradient {
        match self {
            Bsdf::Diffuse(p) => {
                if !(wo.z > 0.0 && wi.z > 0.0) {
                    return BsdfGradient::ZERO;
                }
                let mut g = BsdfGradient::ZERO;
                g.f = p.eval(wo, wi);
                for c in 0..3 {
                    if wanted & (1 << c) != 0 {
                        g.d[c][c] = FRAC_1_PI;
                    }
                }
                g
            }
            Bsdf::Principled(p) if !p.energy_conserving => principled_gradient(p, wo, wi, wanted),
            _ => BsdfGradient {
                f: self.eval(wo, wi),
                d: [Vec3::ZERO; BSDF_PARAMS],
            },
        }
    }
}

/// The unit vector of channel `c`.
fn unit(c: usize) -> Vec3 {
    let mut v = Vec3::ZERO;
    v[c] = 1.0;
    v
}

/// `∂Fr/∂η` of the unpolarised dielectric Fresnel reflectance for
/// `cos_i > 0` and `η > 1` (no total internal reflection): with
/// `cos_t = √(1 − (1 − cos_i²)/η²)`, `r∥ = (η cos_i − cos_t)/(η cos_i + cos_t)`
/// and `r⊥ = (cos_i − η cos_t)/(cos_i + η cos_t)`,
/// `∂Fr/∂η = r∥ ∂r∥/∂η + r⊥ ∂r⊥/∂η`.
fn dielectric_d_eta(cos_i: f32, eta: f32) -> f32 {
    let c = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - c * c) / (eta * eta);
    if sin2_t >= 1.0 {
        return 0.0;
    }
    let ct = (1.0 - sin2_t).max(1e-12).sqrt();
    let dct = (1.0 - c * c) / (eta * eta * eta * ct);
    let (n1, m1) = (eta * c - ct, eta * c + ct);
    let r_par = n1 / m1;
    let dr_par = ((c - dct) * m1 - n1 * (c + dct)) / (m1 * m1);
    let u = eta * ct;
    let du = ct + eta * dct;
    let (n2, m2) = (c - u, c + u);
    let r_perp = n2 / m2;
    let dr_perp = -2.0 * c * du / (m2 * m2);
    r_par * dr_par + r_perp * dr_perp
}

/// GGX `D(h)` and its derivatives with respect to `αx` and `αy`.
fn ggx_d_gradient(m: &Microfacet, h: Vec3) -> (f32, f32, f32) {
    if h.z <= 0.0 {
        return (0.0, 0.0, 0.0);
    }
    let (ax, ay) = (m.alpha_x, m.alpha_y);
    // As `Microfacet::d`, operation for operation.
    let (x2, y2) = ((h.x / ax) * (h.x / ax), (h.y / ay) * (h.y / ay));
    let s = x2 + y2 + h.z * h.z;
    let d = 1.0 / (PI * ax * ay * s * s);
    // ∂s/∂αx = −2 hx²/αx³, so ∂D/∂αx = −D/αx − (2D/s)·∂s/∂αx.
    let dax = -d / ax + 4.0 * d * x2 / (s * ax);
    let day = -d / ay + 4.0 * d * y2 / (s * ay);
    (d, dax, day)
}

/// Smith's GGX `G1(w, h)` and its derivatives with respect to `αx`, `αy`:
/// `G1 = 1/(1 + Λ)`, `Λ = (√(1 + A) − 1)/2`, `A = (αx² wx² + αy² wy²)/wz²`.
fn ggx_g1_gradient(m: &Microfacet, w: Vec3, h: Vec3) -> (f32, f32, f32) {
    if w.dot(h) * w.z <= 0.0 || w.z == 0.0 {
        return (0.0, 0.0, 0.0);
    }
    let g1 = m.g1(w, h);
    let cos2 = w.z * w.z;
    let a = ((m.alpha_x * w.x).powi(2) + (m.alpha_y * w.y).powi(2)) / cos2;
    let k = 0.25 / (1.0 + a).sqrt();
    let dl_dax = k * 2.0 * m.alpha_x * w.x * w.x / cos2;
    let dl_day = k * 2.0 * m.alpha_y * w.y * w.y / cos2;
    (g1, -g1 * g1 * dl_dax, -g1 * g1 * dl_day)
}

/// The principled BSDF (Mitsuba's mode) and its derivatives; the formulas
/// are those of `PrincipledParams::eval`, differentiated term by term.
fn principled_gradient(p: &PrincipledParams, wo: Vec3, wi: Vec3, wanted: u8) -> BsdfGradient {
    let want = |k: BsdfParam| wanted & (1 << k as u8) != 0;
    if !(wo.z > 0.0 && wi.z > 0.0) {
        return BsdfGradient::ZERO;
    }
    let mut g = BsdfGradient::ZERO;
    let h = (wo + wi).normalize();
    let m = p.microfacet();
    let cos_d = wi.dot(h);
    let eta = p.eta();
    let (metal, tint_w) = (p.metallic, p.spec_tint);

    // The microfacet factor K = D·G1(wo)·G1(wi)/(4 cos θo cos θi) and its
    // derivatives through αx and αy.
    // The shape's derivatives only when roughness or anisotropy is wanted.
    let shape = want(BsdfParam::Roughness) || want(BsdfParam::Anisotropic);
    let (d, d_ax, d_ay) = if shape {
        ggx_d_gradient(&m, h)
    } else {
        (m.d(h), 0.0, 0.0)
    };
    let (go, go_ax, go_ay) = if shape {
        ggx_g1_gradient(&m, wo, h)
    } else {
        (m.g1(wo, h), 0.0, 0.0)
    };
    let (gi, gi_ax, gi_ay) = if shape {
        ggx_g1_gradient(&m, wi, h)
    } else {
        (m.g1(wi, h), 0.0, 0.0)
    };
    let denom = 4.0 * wo.z * wi.z;
    // As `PrincipledParams::eval`: D·(G1·G1)/(4 cos θo cos θi).
    let k = d * (go * gi) / denom;
    let k_ax = (d_ax * go * gi + d * go_ax * gi + d * go * gi_ax) / denom;
    let k_ay = (d_ay * go * gi + d * go_ay * gi + d * go * gi_ay) / denom;

    // αx = r²/aspect, αy = r²·aspect, aspect = √(1 − 0.9·anisotropic);
    // an alpha held at MIN_ALPHA does not move.
    let r = p.roughness;
    let aspect = (1.0 - 0.9 * p.anisotropic).sqrt();
    let (raw_ax, raw_ay) = (r * r / aspect, r * r * aspect);
    let live = |raw: f32| if raw > MIN_ALPHA { 1.0 } else { 0.0 };
    let (lx, ly) = (live(raw_ax), live(raw_ay));
    let dax_dr = lx * 2.0 * r / aspect;
    let day_dr = ly * 2.0 * r * aspect;
    let daspect = -0.45 / aspect;
    let dax_da = lx * (-r * r / (aspect * aspect)) * daspect;
    let day_da = ly * r * r * daspect;
    let k_r = k_ax * dax_dr + k_ay * day_dr;
    let k_a = k_ax * dax_da + k_ay * day_da;

    // The Fresnel blend F and its derivatives.
    let w = fresnel::schlick_weight(cos_d);
    let fd = if want(BsdfParam::Metallic) || want(BsdfParam::Specular) {
        fresnel::dielectric(cos_d, eta)
    } else {
        0.0
    };
    let f0 = fresnel::dielectric_f0(eta);
    let lum = luminance(p.base_color);
    let tint = if lum > 0.0 {
        p.base_color / lum
    } else {
        Vec3::ONE
    };
    let schlick_base = fresnel::schlick(p.base_color, cos_d);
    let schlick_tint = fresnel::schlick(tint * f0, cos_d);
    let fresnel = p.fresnel(cos_d, eta);

    // Burley's diffuse lobe: base·(1 − metallic)/π·B.
    let (fo, fi) = (fresnel::schlick_weight(wo.z), fresnel::schlick_weight(wi.z));
    let rr = 2.0 * r * cos_d * cos_d;
    let retro = rr * (fo + fi + fo * fi * (rr - 1.0));
    let b = (1.0 - 0.5 * fo) * (1.0 - 0.5 * fi) + retro;
    let diffuse_weight = FRAC_1_PI * (1.0 - metal);

    // The value, from the same pieces.
    g.f = p.base_color * (diffuse_weight * b) + fresnel * k;

    // Colour channels.
    for c in 0..3 {
        if wanted & (1 << c) == 0 {
            continue;
        }
        let e = unit(c);
        let mut df = e * metal * (1.0 - w);
        if tint_w > 0.0 && lum > 0.0 {
            let lc = luminance(e);
            let dtint = e / lum - p.base_color * (lc / (lum * lum));
            df += dtint * (f0 * (1.0 - w) * (1.0 - metal) * tint_w);
        }
        g.d[c] = e * (diffuse_weight * b) + df * k;
    }
    // Roughness: the retro-reflection term and the lobe's shape.
    if want(BsdfParam::Roughness) {
        let dretro_dr = 2.0 * cos_d * cos_d * (fo + fi + fo * fi * (2.0 * rr - 1.0));
        g.d[BsdfParam::Roughness as usize] =
            p.base_color * (diffuse_weight * dretro_dr) + fresnel * k_r;
    }
    // Metallic: the diffuse weight and the Fresnel blend.
    if want(BsdfParam::Metallic) {
        let df_dm = Vec3::splat(-fd * (1.0 - tint_w)) + schlick_base - schlick_tint * tint_w;
        g.d[BsdfParam::Metallic as usize] = -p.base_color * (FRAC_1_PI * b) + df_dm * k;
    }
    // Anisotropic: the lobe's shape only.
    if want(BsdfParam::Anisotropic) {
        g.d[BsdfParam::Anisotropic as usize] = fresnel * k_a;
    }
    // Specular, through η = 2/(1 − √(0.08 s)) − 1.
    let q = (0.08 * p.specular).sqrt();
    if q > 0.0 && want(BsdfParam::Specular) {
        let deta = 2.0 / ((1.0 - q) * (1.0 - q)) * (0.04 / q);
        let df0 = 4.0 * (eta - 1.0) / (eta + 1.0).powi(3);
        let df_deta = Vec3::splat((1.0 - metal) * (1.0 - tint_w) * dielectric_d_eta(cos_d, eta))
            + tint * ((1.0 - metal) * tint_w * (1.0 - w) * df0);
        g.d[BsdfParam::Specular as usize] = df_deta * (deta * k);
    }
    g
}
