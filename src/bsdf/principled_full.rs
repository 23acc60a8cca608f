//! Burley's principled BSDF with every lobe of Mitsuba 3's `principled`:
//! sheen, clearcoat, specular transmission and flatness on top of the
//! diffuse and specular lobes of [`PrincipledParams`](super::PrincipledParams).
//!
//! Following *Physically Based Shading at Disney* (Burley 2012) and its
//! extension to a BSDF (Burley 2015) as Mitsuba 3.9 implements them, with
//! Mitsuba's parameter names, ranges and quirks, so that a Mitsuba scene
//! renders the same image. With `m` = `metallic` and `s` = `spec_trans`:
//!
//! | lobe | weight | model |
//! | --- | --- | --- |
//! | specular reflection | 1 | anisotropic GGX; Fresnel `(1 − m)(1 − t)·F(η) + m·Schlick(base) + (1 − m)·t·Schlick(tint·f₀(η))`, `t` = `spec_tint` |
//! | specular transmission | `(1 − m)·s` | the rough dielectric's refraction (Walter et al. 2007) through the same microfacets, tinted by `√base_color` |
//! | diffuse | `(1 − m)(1 − s)` | Burley's diffuse and retro-reflection, blended by `flatness` towards the fake subsurface lobe |
//! | sheen | `(1 − m)·sheen` | `(1 − cos θd)⁵`, tinted by `sheen_tint`, only where the diffuse lobe is on |
//! | clearcoat | `clearcoat / 4` | GTR1 with `α` from 0.1 (`clearcoat_gloss` 0) to 0.001 (1), Schlick with `f₀ = 0.04`, Smith GGX masking with `α = 0.25` |
//!
//! Seen from inside (only with a transmission lobe), the surface is a
//! rough dielectric whose reflection is weighted by `(1 − m)·s`; without
//! one it is black from behind, as every opaque Mitsuba BSDF.
//!
//! Mitsuba's quirks, kept: the sheen lobe has no `1/π`; the clearcoat lobe
//! lacks a microfacet lobe's `1/(4 cos θo cos θi)`; the specular
//! reflection keeps its full dielectric Fresnel term whatever `s` is.
//! Lobes are drawn as Mitsuba draws them (its sampling rates at their
//! default, 1): from outside, the diffuse lobe with weight `(1 − m)(1 − s)`,
//! clearcoat `clearcoat/4`, the specular lobes 1 (split by the sampled
//! microfacet's Fresnel term `F` into reflection `1 − (1 − m)·s·(1 − F)`
//! and transmission); from inside, reflection `F` and transmission `1 − F`.

use super::fresnel::{self, reflect, refract_or_total, schlick_weight};
use super::microfacet::{Distribution, Microfacet};
use super::models::{finish_sample, hue};
use super::principled_thin::{alphas, burley_diffuse, schlick_towards};
use super::{BsdfSample, ParamError};
use crate::warp::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// The parameters of a principled BSDF with all its lobes (Mitsuba's
/// `principled` names and defaults, see [`PrincipledFullParams::default`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrincipledFullParams {
    /// Base colour (linear RGB, `[0, 1]`): the diffuse albedo, the metal's
    /// tint, and (its square root) the transmission's.
    pub base_color: Vec3,
    /// Roughness in `[0, 1]` of the specular lobes (`α = roughness²`).
    pub roughness: f32,
    /// Metallic in `[0, 1]`: 0 dielectric, 1 conductor.
    pub metallic: f32,
    /// Anisotropy in `[0, 1]`, stretching the specular lobes along the
    /// first tangent.
    pub anisotropic: f32,
    /// Relative index of refraction (inside over outside, `(0, 10]`), given
    /// as Mitsuba's `eta` or from `specular`
    /// ([`eta_from_specular`](super::albedo::eta_from_specular)).
    pub eta: f32,
    /// How far `[0, 1]` the dielectric specular takes the base colour's hue.
    pub spec_tint: f32,
    /// Weight in `[0, 1]` of the sheen at grazing angles.
    pub sheen: f32,
    /// How far `[0, 1]` the sheen takes the base colour's hue.
    pub sheen_tint: f32,
    /// Weight in `[0, 1]` of the clearcoat lobe.
    pub clearcoat: f32,
    /// Gloss in `[0, 1]` of the clearcoat lobe (0: `α = 0.1`, 1: `α = 0.001`).
    pub clearcoat_gloss: f32,
    /// Weight in `[0, 1]` of the specular transmission against the diffuse
    /// lobe (of the non-metallic part).
    pub spec_trans: f32,
    /// Blend `[0, 1]` from Burley's diffuse towards the fake subsurface
    /// lobe.
    pub flatness: f32,
    /// Whether the material has a transmission lobe at all (`spec_trans`
    /// non-zero or mapped): it then has an inside, seen from behind, as
    /// Mitsuba's has.
    pub has_transmission: bool,
}

impl Default for PrincipledFullParams {
    /// Mitsuba's defaults: base colour 0.5, roughness 0.5, `specular` 0.5
    /// (`η ≈ 1.4899`), the rest 0.
    fn default() -> Self {
        PrincipledFullParams {
            base_color: Vec3::splat(0.5),
            roughness: 0.5,
            metallic: 0.0,
            anisotropic: 0.0,
            eta: super::albedo::eta_from_specular(0.5),
            spec_tint: 0.0,
            sheen: 0.0,
            sheen_tint: 0.0,
            clearcoat: 0.0,
            clearcoat_gloss: 0.0,
            spec_trans: 0.0,
            flatness: 0.0,
            has_transmission: false,
        }
    }
}

/// Burley's GTR1 distribution (generalised Trowbridge–Reitz with `γ = 1`)
/// of the clearcoat lobe: isotropic, roughness `alpha` in `(0, 1)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gtr1 {
    /// Roughness in `(0, 1)`.
    pub alpha: f32,
}

impl Gtr1 {
    /// The clearcoat's distribution for `clearcoat_gloss` `g`:
    /// `α = 0.1·(1 − g) + 0.001·g`.
    #[inline(always)]
    pub fn of_gloss(g: f32) -> Gtr1 {
        Gtr1 {
            alpha: 0.1 * (1.0 - g) + 0.001 * g,
        }
    }

    /// `D(h) = (α² − 1) / (π ln α² (1 + (α² − 1) cos²θh))` (1/sr), 0 below
    /// the horizon.
    #[inline(always)]
    pub fn d(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        (a2 - 1.0) / (PI * a2.ln() * (1.0 + (a2 - 1.0) * h.z * h.z))
    }

    /// Density (solid angle, over `h`) of [`Gtr1::sample`]: `D(h) cos θh`.
    #[inline(always)]
    pub fn pdf(&self, h: Vec3) -> f32 {
        h.z.max(0.0) * self.d(h)
    }

    /// Draws a microfacet normal from `u` with density [`Gtr1::pdf`]:
    /// `cos²θ = (1 − α²^(1 − u.y)) / (1 − α²)`, `φ = 2π u.x`.
    #[inline(always)]
    pub fn sample(&self, u: Vec2) -> Vec3 {
        let a2 = self.alpha * self.alpha;
        let cos2 = ((1.0 - a2.powf(1.0 - u.y)) / (1.0 - a2)).clamp(0.0, 1.0);
        let (sin_phi, cos_phi) = (2.0 * PI * u.x).sin_cos();
        let sin_theta = (1.0 - cos2).sqrt();
        Vec3::new(cos_phi * sin_theta, sin_phi * sin_theta, cos2.sqrt())
    }
}

/// Whether microfacet `h` (upper hemisphere) faces `wo` on `wo`'s side and
/// `wi` on the same side (`reflection`) or the other (Mitsuba's
/// `mac_mic_compatibility`).
#[inline(always)]
fn compatible(h: Vec3, wo: Vec3, wi: Vec3, reflection: bool) -> bool {
    let facing = if wo.z < 0.0 { -h } else { h };
    let towards = if reflection { facing } else { -facing };
    wo.dot(facing) > 0.0 && wi.dot(towards) > 0.0
}

/// The lobes' probabilities `[diffuse, clearcoat, transmission,
/// reflection]` (summing to 1) for `wo` outside (`front`) or inside, with
/// `fresnel` the specular microfacet's dielectric Fresnel term.
#[inline(always)]
fn lobe_probabilities(p: &PrincipledFullParams, front: bool, fresnel: f32) -> [f32; 4] {
    let (diffuse, transmits) = p.weights();
    let [d, c, t, r] = if front {
        [
            diffuse,
            0.25 * p.clearcoat,
            transmits * (1.0 - fresnel),
            1.0 - transmits * (1.0 - fresnel),
        ]
    } else {
        [0.0, 0.0, 1.0 - fresnel, fresnel]
    };
    let total = d + c + t + r;
    [d / total, c / total, t / total, r / total]
}

impl PrincipledFullParams {
    /// Checks every parameter's range (NaN fails): `base_color` and the
    /// weights in `[0, 1]`, `eta` in `(0, 10]`.
    pub fn validate(self) -> Result<PrincipledFullParams, ParamError> {
        ParamError::check_colour("base_color", self.base_color)?;
        for (name, v) in [
            ("roughness", self.roughness),
            ("metallic", self.metallic),
            ("anisotropic", self.anisotropic),
            ("spec_tint", self.spec_tint),
            ("sheen", self.sheen),
            ("sheen_tint", self.sheen_tint),
            ("clearcoat", self.clearcoat),
            ("clearcoat_gloss", self.clearcoat_gloss),
            ("spec_trans", self.spec_trans),
            ("flatness", self.flatness),
        ] {
            ParamError::check_unit(name, v)?;
        }
        ParamError::check_eta(self.eta)?;
        Ok(self)
    }

    /// The weights `(1 − m)(1 − s)` of the diffuse lobe and `(1 − m)·s` of
    /// the transmission lobe.
    #[inline(always)]
    fn weights(&self) -> (f32, f32) {
        let dielectric = 1.0 - self.metallic;
        let transmits = if self.has_transmission {
            dielectric * self.spec_trans
        } else {
            0.0
        };
        (dielectric * (1.0 - self.spec_trans), transmits)
    }

    /// The specular lobes' GGX distribution (Mitsuba's anisotropy mapping
    /// and floor of `α = 0.001`).
    #[inline(always)]
    fn specular_lobe(&self) -> Microfacet {
        alphas(self.roughness, self.anisotropic)
    }

    /// The specular reflection's Fresnel term at `cos = wo·h` (Mitsuba's
    /// `principled_fresnel`): from inside, the dielectric's weighted by the
    /// transmission lobe's weight.
    #[inline(always)]
    fn fresnel(&self, dielectric: f32, cos: f32, front: bool) -> Vec3 {
        let (m, t) = (self.metallic, self.spec_tint);
        if !front {
            return Vec3::splat(self.weights().1 * dielectric);
        }
        let mut f = Vec3::splat((1.0 - m) * (1.0 - t) * dielectric);
        if m > 0.0 {
            f += schlick_towards(self.base_color, cos, self.eta) * m;
        }
        if t > 0.0 {
            let f0 = hue(self.base_color) * fresnel::dielectric_f0(self.eta);
            f += schlick_towards(f0, cos, self.eta) * ((1.0 - m) * t);
        }
        f
    }

    /// The half vector of a pair of directions (facing `+z`) and the
    /// relative index `η'` along the path (`η` entering, `1/η` leaving; 1
    /// for a reflection).
    #[inline(always)]
    fn half_vector(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        let reflect = wo.z * wi.z > 0.0;
        let eta_path = if reflect {
            1.0
        } else if wo.z > 0.0 {
            self.eta
        } else {
            1.0 / self.eta
        };
        let h = (wo + wi * eta_path).normalize();
        (if h.z < 0.0 { -h } else { h }, eta_path)
    }

    /// `f(wo, wi)` (1/sr, without the cosine).
    pub(crate) fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let (cos_o, cos_i) = (wo.z, wi.z);
        if cos_o == 0.0 || cos_i == 0.0 {
            return Vec3::ZERO;
        }
        let front = cos_o > 0.0;
        let (diffuse_weight, transmits) = self.weights();
        if !front && transmits <= 0.0 {
            return Vec3::ZERO;
        }
        let reflect = cos_o * cos_i > 0.0;
        let (h, eta_path) = self.half_vector(wo, wi);
        if !h.is_finite() {
            return Vec3::ZERO;
        }
        let f_dielectric = fresnel::dielectric(wo.dot(h), self.eta);
        let m = self.specular_lobe();
        // Mitsuba's BSDF value includes |cos θi|; divided out at the end.
        let mut value = Vec3::ZERO;
        if reflect && compatible(h, wo, wi, true) {
            if f_dielectric > 0.0 {
                let dg = m.d(h) * m.g(wo, wi, h);
                value += self.fresnel(f_dielectric, wo.dot(h), front) * (dg / (4.0 * cos_o.abs()));
            }
            if front && self.clearcoat > 0.0 {
                let f = schlick_towards(Vec3::splat(0.04), wo.dot(h), self.eta).x;
                let masking = Microfacet::isotropic(Distribution::Ggx, 0.25);
                let d = Gtr1::of_gloss(self.clearcoat_gloss).d(h);
                value += Vec3::splat(0.25 * self.clearcoat * f * d * masking.g(wo, wi, h) * cos_i);
            }
        }
        if !reflect && transmits > 0.0 && f_dielectric < 1.0 && compatible(h, wo, wi, false) {
            // Walter et al. 2007's refraction; the 1/η'² of radiance
            // crossing the interface cancels the η'² of the Jacobian.
            let (oh, ih) = (wo.dot(h), wi.dot(h));
            let denom = oh + eta_path * ih;
            let t = (1.0 - f_dielectric) * m.d(h) * m.g(wo, wi, h) * (oh * ih).abs()
                / (cos_o.abs() * denom * denom);
            value += self.base_color.map(f32::sqrt) * (transmits * t);
        }
        if reflect && front && diffuse_weight > 0.0 {
            let cos_d = h.dot(wi);
            let lobe = burley_diffuse(cos_o, cos_i, cos_d, self.roughness, self.flatness);
            value += self.base_color * (diffuse_weight * cos_i * FRAC_1_PI * lobe);
            let dielectric = 1.0 - self.metallic;
            if self.sheen > 0.0 && dielectric > 0.0 {
                let tint = Vec3::ONE.lerp(hue(self.base_color), self.sheen_tint);
                value += tint * (self.sheen * dielectric * schlick_weight(cos_d.abs()) * cos_i);
            }
        }
        value / cos_i.abs()
    }

    /// The solid-angle density [`PrincipledFullParams::sample`] draws `wi`
    /// with.
    pub(crate) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z == 0.0 || wi.z == 0.0 {
            return 0.0;
        }
        let front = wo.z > 0.0;
        if !front && self.weights().1 <= 0.0 {
            return 0.0;
        }
        let reflect = wo.z * wi.z > 0.0;
        let (h, eta_path) = self.half_vector(wo, wi);
        if !h.is_finite() {
            return 0.0;
        }
        let f_dielectric = fresnel::dielectric(wo.dot(h), self.eta);
        let [p_d, p_c, p_t, p_r] = lobe_probabilities(self, front, f_dielectric);
        let (oh, ih) = (wo.dot(h), wi.dot(h));
        let mut pdf = 0.0;
        if reflect {
            let dh_dwi = (1.0 / (4.0 * ih)).abs();
            if compatible(h, wo, wi, true) {
                pdf += p_r * self.specular_lobe().pdf_h(wo, h) * dh_dwi;
                if p_c > 0.0 {
                    pdf += p_c * Gtr1::of_gloss(self.clearcoat_gloss).pdf(h) * dh_dwi;
                }
            }
            if front {
                pdf += p_d * cosine_hemisphere_pdf(wi.z);
            }
        } else if p_t > 0.0 && compatible(h, wo, wi, false) {
            let denom = oh + eta_path * ih;
            let dh_dwi = (eta_path * eta_path * ih / (denom * denom)).abs();
            pdf += p_t * self.specular_lobe().pdf_h(wo, h) * dh_dwi;
        }
        pdf
    }

    /// `f` and the density together.
    pub(crate) fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        (self.eval(wo, wi), self.pdf(wo, wi))
    }

    /// Draws `wi`: `uc` picks a lobe, `u` its direction.
    pub(crate) fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let front = wo.z > 0.0;
        if !front && self.weights().1 <= 0.0 {
            return None;
        }
        let h = self.specular_lobe().sample_h(wo, u);
        let f_dielectric = fresnel::dielectric(wo.dot(h), self.eta);
        let [p_d, p_c, p_t, _] = lobe_probabilities(self, front, f_dielectric);
        let wi = if uc < p_d {
            square_to_cosine_hemisphere(u)
        } else if uc < p_d + p_c {
            let h = Gtr1::of_gloss(self.clearcoat_gloss).sample(u);
            let wi = reflect(wo, h);
            if wi.z <= 0.0 || !compatible(h, wo, wi, true) {
                return None;
            }
            wi
        } else if uc < p_d + p_c + p_t {
            let (wi, _, total) = refract_or_total(wo, h, self.eta);
            if total || wi.z * wo.z >= 0.0 || !compatible(h, wo, wi, false) {
                return None;
            }
            wi
        } else {
            let wi = reflect(wo, h);
            if wi.z * wo.z <= 0.0 || !compatible(h, wo, wi, true) {
                return None;
            }
            wi
        };
        let (f, pdf) = self.eval_pdf(wo, wi);
        finish_sample(wi, f, pdf)
    }

    /// `η²` of a scattering from `wo` to `wi`: the square of the relative
    /// index across the interface for a refraction, else 1 (see
    /// [`Bsdf::eta_scale`](super::Bsdf::eta_scale)).
    #[inline(always)]
    pub(crate) fn eta_scale(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z * wi.z < 0.0 {
            let eta = if wo.z > 0.0 { self.eta } else { 1.0 / self.eta };
            eta * eta
        } else {
            1.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::PrincipledParams;

    fn dir(x: f32, y: f32, z: f32) -> Vec3 {
        Vec3::new(x, y, z).normalize()
    }

    #[test]
    fn without_the_new_lobes_it_is_the_two_lobe_model() {
        let base = PrincipledParams {
            base_color: Vec3::new(0.8, 0.4, 0.2),
            roughness: 0.4,
            metallic: 0.3,
            anisotropic: 0.5,
            specular: 0.6,
            spec_tint: 0.4,
            energy_conserving: false,
        };
        let full = PrincipledFullParams {
            base_color: base.base_color,
            roughness: base.roughness,
            metallic: base.metallic,
            anisotropic: base.anisotropic,
            eta: base.eta(),
            spec_tint: base.spec_tint,
            ..Default::default()
        };
        let wo = dir(0.3, -0.2, 0.9);
        for wi in [
            dir(-0.4, 0.1, 0.7),
            dir(0.5, 0.5, 0.3),
            dir(-0.1, 0.0, 0.99),
        ] {
            let (a, b) = (base.eval(wo, wi), full.eval(wo, wi));
            assert!(((a - b) / a).abs().max_element() < 1e-4, "{wi}: {a} {b}");
        }
        assert_eq!(full.eval(-wo, dir(0.1, 0.2, -0.9)), Vec3::ZERO);
        assert!(full.sample(-wo, 0.5, Vec2::new(0.3, 0.6)).is_none());
    }

    #[test]
    fn gtr1_is_normalised_over_projected_area() {
        for g in [0.0, 0.5, 1.0] {
            let d = Gtr1::of_gloss(g);
            // ∫ D(h) cos θh dω = 1, over cos θ by the midpoint rule with the
            // peak resolved (substitution cos θ = 1 − t²).
            let n = 200_000;
            let mut sum = 0.0f64;
            for k in 0..n {
                let t = (k as f64 + 0.5) / n as f64;
                let c = 1.0 - t * t;
                let h = Vec3::new((1.0 - c * c).max(0.0).sqrt() as f32, 0.0, c as f32);
                sum += d.d(h) as f64 * c * 2.0 * std::f64::consts::PI * 2.0 * t / n as f64;
            }
            assert!((sum - 1.0).abs() < 2e-3, "gloss {g}: {sum}");
        }
    }

    #[test]
    fn inside_a_transmissive_surface_reflection_and_refraction_share_the_lobe() {
        let p = PrincipledFullParams {
            spec_trans: 0.7,
            has_transmission: true,
            roughness: 0.3,
            ..Default::default()
        };
        let wo = dir(0.2, 0.1, -0.9);
        let reflected = p.eval(wo, dir(-0.3, 0.0, -0.8));
        let refracted = p.eval(wo, dir(-0.2, -0.1, 0.9));
        assert!(reflected.x > 0.0 && refracted.x > 0.0);
        assert!(p.pdf(wo, dir(-0.3, 0.0, -0.8)) > 0.0);
        let scale = p.eta_scale(wo, dir(-0.2, -0.1, 0.9));
        assert!((scale - 1.0 / (p.eta * p.eta)).abs() < 1e-6, "{scale}");
    }

    #[test]
    fn parameters_out_of_range_are_refused_by_name() {
        let bad = PrincipledFullParams {
            clearcoat: 1.5,
            ..Default::default()
        };
        assert_eq!(bad.validate().unwrap_err().parameter, "clearcoat");
        let bad = PrincipledFullParams {
            eta: 0.0,
            ..Default::default()
        };
        assert_eq!(bad.validate().unwrap_err().parameter, "eta");
    }
}
