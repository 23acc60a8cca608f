//! Burley's thin principled BSDF (Mitsuba 3's `principledthin`): a thin
//! translucent sheet, such as paper, leaves or fabric, with no inside.
//!
//! Following *Extending the Disney BRDF to a BSDF with Integrated
//! Subsurface Scattering* (Burley 2015) as Mitsuba 3 implements it, with
//! its parameter names and ranges. The sheet is symmetric: seen from
//! behind, both directions are mirrored to the front first. Four lobes,
//! weighted by `spec_trans` (`s`) and `diff_trans / 2` (`d`):
//!
//! | lobe | weight | model |
//! | --- | --- | --- |
//! | glossy reflection | `s` | GGX, `α` from `roughness` and `anisotropic`, the dielectric Fresnel `F(η)` blended towards a tinted Schlick term by `spec_tint` |
//! | glossy transmission | `s` | the reflection lobe mirrored through the sheet (no bending), roughness scaled by `0.65η − 0.35` (Burley 2015, fig. 15), times `base_color·(1 − F)` |
//! | diffuse reflection | `(1 − s)(1 − d)` | Burley's diffuse and retro-reflection, blended by `flatness` towards Hanrahan–Krueger's fake subsurface; plus `sheen` |
//! | diffuse transmission | `(1 − s)·d` | Lambert's, `base_color/π` |
//!
//! As in Mitsuba, a sheet without `spec_trans` has no glossy reflection at
//! all, and the sheen lobe has no `1/π`. Lobes are picked in proportion to
//! their weights (Mitsuba's sampling rates at their default, 1); the glossy
//! ones by visible normals, the diffuse ones by the cosine.

use super::fresnel::{self, reflect, schlick_weight};
use super::microfacet::{Distribution, Microfacet};
use super::models::{finish_sample, hue};
use super::{BsdfSample, ParamError};
use crate::warp::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// The parameters of a thin principled sheet (Mitsuba's `principledthin`
/// names and defaults, see [`PrincipledThinParams::default`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrincipledThinParams {
    /// Base colour (linear RGB, `[0, 1]`): the diffuse albedo and the tint
    /// of everything transmitted.
    pub base_color: Vec3,
    /// Roughness in `[0, 1]` of the glossy lobes (`α = roughness²`).
    pub roughness: f32,
    /// Anisotropy in `[0, 1]`, stretching the glossy lobes along the first
    /// tangent.
    pub anisotropic: f32,
    /// Weight in `[0, 1]` of the glossy lobes (reflection and transmission)
    /// against the diffuse ones.
    pub spec_trans: f32,
    /// The sheet's relative index of refraction (`> 0`), for its Fresnel
    /// term and the transmission's roughness.
    pub eta: f32,
    /// How far `[0, 1]` the glossy reflection's Fresnel term is tinted by
    /// the base colour's hue.
    pub spec_tint: f32,
    /// Weight in `[0, 1]` of the sheen at grazing angles.
    pub sheen: f32,
    /// How far `[0, 1]` the sheen is tinted by the base colour's hue.
    pub sheen_tint: f32,
    /// Blend `[0, 1]` from Burley's diffuse towards the fake subsurface
    /// lobe.
    pub flatness: f32,
    /// The diffuse energy sent through the sheet, `[0, 2]`: 0 only diffuse
    /// reflection, 1 half of each, 2 only diffuse transmission.
    pub diff_trans: f32,
}

impl Default for PrincipledThinParams {
    /// Mitsuba's defaults: base colour 0.5, roughness 0.5, η 1.5, the rest 0.
    fn default() -> Self {
        PrincipledThinParams {
            base_color: Vec3::splat(0.5),
            roughness: 0.5,
            anisotropic: 0.0,
            spec_trans: 0.0,
            eta: 1.5,
            spec_tint: 0.0,
            sheen: 0.0,
            sheen_tint: 0.0,
            flatness: 0.0,
            diff_trans: 0.0,
        }
    }
}

/// Schlick's approximation with normal-incidence reflectance `f0` for an
/// interface of relative index `eta`, at the angle of the denser side (the
/// transmitted angle when `eta < 1`), as Mitsuba's principled helpers.
#[inline(always)]
pub(super) fn schlick_towards(f0: Vec3, cos: f32, eta: f32) -> Vec3 {
    let (eta_it, eta_ti) = if cos >= 0.0 {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    let cos_t = (1.0 - (1.0 - cos * cos) * eta_ti * eta_ti).max(0.0).sqrt();
    let w = if eta_it > 1.0 {
        schlick_weight(cos.abs())
    } else {
        schlick_weight(cos_t)
    };
    f0 + (Vec3::ONE - f0) * w
}

/// `(α_x, α_y)` of a roughness and an anisotropy (Burley's mapping, with
/// Mitsuba's floor of 0.001).
#[inline(always)]
pub(super) fn alphas(roughness: f32, anisotropic: f32) -> Microfacet {
    let r2 = roughness * roughness;
    let aspect = (1.0 - 0.9 * anisotropic).sqrt();
    Microfacet::new(
        Distribution::Ggx,
        (r2 / aspect).max(0.001),
        (r2 * aspect).max(0.001),
    )
}

/// Burley's diffuse lobe with retro-reflection, blended by `flatness`
/// towards Hanrahan–Krueger's fake subsurface lobe (its `Fss90` flattening
/// the retro-reflection by roughness), without `base_color/π`: for the
/// cosines of both directions (above the surface) and of the angle between
/// `wi` and the half vector.
#[inline(always)]
pub(super) fn burley_diffuse(
    cos_o: f32,
    cos_i: f32,
    cos_d: f32,
    roughness: f32,
    flatness: f32,
) -> f32 {
    let (fo, fi) = (schlick_weight(cos_i), schlick_weight(cos_o));
    let diffuse = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
    let rr = 2.0 * roughness * cos_d * cos_d;
    let retro = rr * (fo + fi + fo * fi * (rr - 1.0));
    let fss90 = 0.5 * rr;
    let fss = (1.0 + (fss90 - 1.0) * fo) * (1.0 + (fss90 - 1.0) * fi);
    let subsurface = 1.25 * (fss * (1.0 / (cos_i + cos_o) - 0.5) + 0.5);
    diffuse + retro + (subsurface - diffuse - retro) * flatness
}

/// Whether microfacet `h` is seen from the front by `wo` and from its
/// front (reflection) or back (transmission) by `wi` (`wo` above).
#[inline(always)]
fn sides_agree(h: Vec3, wo: Vec3, wi: Vec3, reflection: bool) -> bool {
    let toward = if reflection { h } else { -h };
    wo.dot(h) > 0.0 && wi.dot(toward) > 0.0
}

/// The four lobes' probabilities: glossy reflection and transmission,
/// diffuse reflection and transmission (they sum to 1).
#[inline(always)]
fn lobe_probabilities(s: f32, d: f32) -> [f32; 4] {
    [0.5 * s, 0.5 * s, (1.0 - s) * (1.0 - d), (1.0 - s) * d]
}

impl PrincipledThinParams {
    /// Checks every parameter's range (NaN fails): `base_color` and the
    /// weights in `[0, 1]`, `diff_trans` in `[0, 2]`, `eta` in `(0, 10]`.
    pub fn validate(self) -> Result<PrincipledThinParams, ParamError> {
        ParamError::check_colour("base_color", self.base_color)?;
        for (name, v) in [
            ("roughness", self.roughness),
            ("anisotropic", self.anisotropic),
            ("spec_trans", self.spec_trans),
            ("spec_tint", self.spec_tint),
            ("sheen", self.sheen),
            ("sheen_tint", self.sheen_tint),
            ("flatness", self.flatness),
        ] {
            ParamError::check_unit(name, v)?;
        }
        ParamError::check_range("diff_trans", self.diff_trans, 0.0, 2.0, "[0, 2]")?;
        ParamError::check_eta(self.eta)?;
        Ok(self)
    }

    /// The glossy reflection lobe's distribution.
    #[inline(always)]
    fn reflection_lobe(&self) -> Microfacet {
        alphas(self.roughness, self.anisotropic)
    }

    /// The glossy transmission lobe's distribution (roughness scaled by
    /// `0.65η − 0.35`, Burley 2015 fig. 15).
    #[inline(always)]
    fn transmission_lobe(&self) -> Microfacet {
        alphas((0.65 * self.eta - 0.35) * self.roughness, self.anisotropic)
    }

    /// The base colour's hue at unit luminance (1 for black).
    #[inline(always)]
    fn tint(&self) -> Vec3 {
        hue(self.base_color)
    }

    /// Both directions mirrored to the front when `wo` is behind the sheet
    /// (it has no inside); `None` at grazing `wo`.
    #[inline(always)]
    fn to_front(wo: Vec3, wi: Vec3) -> Option<(Vec3, Vec3)> {
        if wo.z == 0.0 {
            return None;
        }
        let s = wo.z.signum();
        Some((wo * s, wi * s))
    }

    /// The half vector of `wo` (front) and `wi` mirrored above the sheet.
    #[inline(always)]
    fn half_vector(wo: Vec3, wi: Vec3) -> Vec3 {
        (wo + Vec3::new(wi.x, wi.y, wi.z.abs())).normalize()
    }

    /// `f(wo, wi)` (1/sr, without the cosine).
    pub(crate) fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let Some((wo, wi)) = Self::to_front(wo, wi) else {
            return Vec3::ZERO;
        };
        let (cos_o, cos_i) = (wo.z, wi.z);
        if cos_i == 0.0 {
            return Vec3::ZERO;
        }
        let (s, d) = (self.spec_trans, 0.5 * self.diff_trans);
        let h = Self::half_vector(wo, wi);
        let base = self.base_color;
        let mut value = Vec3::ZERO;
        if s > 0.0 {
            let f_dielectric = fresnel::dielectric(wo.dot(h), self.eta);
            if cos_i > 0.0 && sides_agree(h, wo, wi, true) {
                let m = self.reflection_lobe();
                let tinted = schlick_towards(
                    self.tint() * fresnel::dielectric_f0(self.eta),
                    wo.dot(h),
                    self.eta,
                );
                let f = Vec3::splat(f_dielectric).lerp(tinted, self.spec_tint);
                value += f * (s * m.d(h) * m.g(wo, wi, h) / (4.0 * cos_o));
            }
            if cos_i < 0.0 && sides_agree(h, wo, wi, false) {
                let m = self.transmission_lobe();
                value +=
                    base * (s * (1.0 - f_dielectric) * m.d(h) * m.g(wo, wi, h) / (4.0 * cos_o));
            }
        }
        if cos_i > 0.0 && s < 1.0 && d < 1.0 {
            let cos_d = h.dot(wi);
            let lobe = burley_diffuse(cos_o, cos_i, cos_d, self.roughness, self.flatness);
            let weight = (1.0 - s) * (1.0 - d);
            value += base * (weight * cos_i * FRAC_1_PI * lobe);
            if self.sheen > 0.0 {
                let sheen = Vec3::ONE.lerp(self.tint(), self.sheen_tint);
                value += sheen * (self.sheen * weight * schlick_weight(cos_d.abs()) * cos_i);
            }
        }
        if cos_i < 0.0 && s < 1.0 && d > 0.0 {
            value += base * ((1.0 - s) * d * FRAC_1_PI * -cos_i);
        }
        value / cos_i.abs()
    }

    /// The solid-angle density [`PrincipledThinParams::sample`] draws `wi`
    /// with.
    pub(crate) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some((wo, wi)) = Self::to_front(wo, wi) else {
            return 0.0;
        };
        let [p_sr, p_st, p_dr, p_dt] = lobe_probabilities(self.spec_trans, 0.5 * self.diff_trans);
        let mut pdf = 0.0;
        if self.spec_trans > 0.0 {
            let h = Self::half_vector(wo, wi);
            let wi_above = Vec3::new(wi.x, wi.y, wi.z.abs());
            let dh_dwi = (1.0 / (4.0 * wi_above.dot(h))).abs();
            if wi.z > 0.0 && sides_agree(h, wo, wi, true) {
                pdf += p_sr * self.reflection_lobe().pdf_h(wo, h) * dh_dwi;
            }
            if wi.z < 0.0 && sides_agree(h, wo, wi, false) {
                pdf += p_st * self.transmission_lobe().pdf_h(wo, h) * dh_dwi;
            }
        }
        if wi.z > 0.0 {
            pdf += p_dr * cosine_hemisphere_pdf(wi.z);
        } else if wi.z < 0.0 {
            pdf += p_dt * cosine_hemisphere_pdf(-wi.z);
        }
        pdf
    }

    /// `f` and the density together.
    pub(crate) fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        (self.eval(wo, wi), self.pdf(wo, wi))
    }

    /// Draws `wi`: `uc` picks a lobe, `u` its direction.
    pub(crate) fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        let sign = if wo.z == 0.0 {
            return None;
        } else {
            wo.z.signum()
        };
        let front = wo * sign;
        let [p_sr, p_st, p_dr, _] = lobe_probabilities(self.spec_trans, 0.5 * self.diff_trans);
        let wi = if uc < p_sr {
            let h = self.reflection_lobe().sample_h(front, u);
            let wi = reflect(front, h);
            if wi.z <= 0.0 || !sides_agree(h, front, wi, true) {
                return None;
            }
            wi
        } else if uc < p_sr + p_st {
            // Reflected on a microfacet, then mirrored through the sheet.
            let h = self.transmission_lobe().sample_h(front, u);
            let r = reflect(front, h);
            let wi = Vec3::new(r.x, r.y, -r.z);
            if wi.z >= 0.0 || !sides_agree(h, front, wi, false) {
                return None;
            }
            wi
        } else if uc < p_sr + p_st + p_dr {
            square_to_cosine_hemisphere(u)
        } else {
            -square_to_cosine_hemisphere(u)
        };
        let wi = wi * sign;
        let (f, pdf) = self.eval_pdf(wo, wi);
        finish_sample(wi, f, pdf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sheet_is_symmetric() {
        let p = PrincipledThinParams {
            base_color: Vec3::new(0.7, 0.4, 0.2),
            roughness: 0.4,
            spec_trans: 0.6,
            diff_trans: 0.8,
            sheen: 0.5,
            sheen_tint: 0.3,
            spec_tint: 0.2,
            ..Default::default()
        };
        let wo = Vec3::new(0.3, -0.2, 0.9).normalize();
        for wi in [
            Vec3::new(-0.4, 0.1, 0.7),
            Vec3::new(0.2, 0.5, -0.6),
            Vec3::new(-0.1, 0.0, -0.9),
        ] {
            let wi = wi.normalize();
            let (f, pdf) = p.eval_pdf(wo, wi);
            let (g, q) = p.eval_pdf(-wo, -wi);
            assert!((f - g).abs().max_element() < 1e-6 && (pdf - q).abs() < 1e-6);
            assert!(f.min_element() > 0.0 && pdf > 0.0, "{wi}: {f} {pdf}");
        }
    }

    #[test]
    fn only_diffuse_transmission_is_lambert_through_the_sheet() {
        let p = PrincipledThinParams {
            base_color: Vec3::new(0.6, 0.5, 0.4),
            diff_trans: 2.0,
            ..Default::default()
        };
        let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
        let wi = Vec3::new(-0.2, 0.3, -0.8).normalize();
        let f = p.eval(wo, wi);
        assert!(
            (f - p.base_color * FRAC_1_PI).abs().max_element() < 1e-6,
            "{f}"
        );
        assert_eq!(p.eval(wo, Vec3::new(0.0, 0.6, 0.8)), Vec3::ZERO);
        assert!((p.pdf(wo, wi) - cosine_hemisphere_pdf(-wi.z)).abs() < 1e-6);
    }

    #[test]
    fn parameters_out_of_range_are_refused_by_name() {
        let bad = PrincipledThinParams {
            diff_trans: 2.5,
            ..Default::default()
        };
        assert_eq!(bad.validate().unwrap_err().parameter, "diff_trans");
        let bad = PrincipledThinParams {
            eta: f32::NAN,
            ..Default::default()
        };
        assert_eq!(bad.validate().unwrap_err().parameter, "eta");
        assert!(PrincipledThinParams::default().validate().is_ok());
    }
}
