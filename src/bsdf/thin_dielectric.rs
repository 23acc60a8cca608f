//! A thin dielectric sheet (Mitsuba's `thindielectric`): a pane of glass
//! whose two parallel faces are so close that light leaves where it
//! entered, straight through or mirrored.
//!
//! Inside the sheet light bounces between the faces; summing the series,
//! the sheet reflects `R′ = 2R/(1 + R)` and transmits `1 − R′`, with `R`
//! the Fresnel reflectance of one face at the angle of incidence. Both
//! lobes are deltas: the mirror direction and `wi = −wo` (no refraction:
//! the two faces' bends cancel). [`ThinDielectricParams::sample`] takes the
//! mirror with probability `R′`, so each sample weighs the lobe's tint
//! (`specular_reflectance` or `specular_transmittance`) alone.
//!
//! ```toml
//! [[materials]]
//! name = "window"
//! type = "thin_dielectric"
//! ior = 1.5046                       # inside / outside
//! specular_reflectance = [1, 1, 1]
//! specular_transmittance = [1, 1, 1]
//! ```

use super::fresnel;
use super::BsdfSample;
use glam::Vec3;

/// A thin dielectric sheet.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThinDielectricParams {
    /// Relative index of refraction of the sheet's material, inside /
    /// outside (> 0).
    pub eta: f32,
    /// Tint of the reflected light (Mitsuba's `specular_reflectance`).
    pub reflectance: Vec3,
    /// Tint of the transmitted light (Mitsuba's `specular_transmittance`).
    pub transmittance: Vec3,
}

impl ThinDielectricParams {
    /// The sheet's reflectance `R′ = 2R/(1 + R)` for a direction whose
    /// cosine with the normal is `cos_theta` (either side).
    #[inline]
    pub fn reflectance_at(&self, cos_theta: f32) -> f32 {
        let r = fresnel::dielectric(cos_theta.abs(), self.eta);
        2.0 * r / (1.0 + r)
    }

    /// Both lobes are deltas: no value for any pair of directions.
    #[inline]
    pub(crate) fn eval(&self, _wo: Vec3, _wi: Vec3) -> Vec3 {
        Vec3::ZERO
    }

    /// Both lobes are deltas: no density for any direction.
    #[inline]
    pub(crate) fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }

    /// The mirror direction with probability `R′`, else straight through;
    /// the weight is the lobe's tint.
    #[inline]
    pub(crate) fn sample(&self, wo: Vec3, uc: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let r = self.reflectance_at(wo.z);
        let (wi, pdf, tint) = if uc < r {
            (Vec3::new(-wo.x, -wo.y, wo.z), r, self.reflectance)
        } else {
            (-wo, 1.0 - r, self.transmittance)
        };
        if pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            f: tint * (pdf / wi.z.abs()),
            pdf,
            weight: tint,
            delta: true,
        })
    }

    /// Checks the parameters: a positive, finite `eta` and tints in
    /// `[0, 1]`.
    pub fn validate(self) -> Result<ThinDielectricParams, String> {
        if !(self.eta > 0.0 && self.eta.is_finite()) {
            return Err(format!("ior must be a positive number, got {}", self.eta));
        }
        for (name, v) in [
            ("specular_reflectance", self.reflectance),
            ("specular_transmittance", self.transmittance),
        ] {
            if !(v.is_finite() && v.min_element() >= 0.0 && v.max_element() <= 1.0) {
                return Err(format!("{name} must be in [0, 1], got {v}"));
            }
        }
        Ok(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mitsuba 3.9.1's `thindielectric` (bk7 in air, `scalar_rgb`):
    /// reflectance R′ and the two lobes' directions and weights.
    #[test]
    fn sheet_reflects_two_r_over_one_plus_r() {
        let p = ThinDielectricParams {
            eta: 1.5046 / 1.000277,
            reflectance: Vec3::ONE,
            transmittance: Vec3::new(0.9, 0.8, 0.7),
        };
        // At normal incidence R = ((η − 1)/(η + 1))², R′ = 2R/(1 + R).
        let r = ((p.eta - 1.0) / (p.eta + 1.0)).powi(2);
        assert!((p.reflectance_at(1.0) - 2.0 * r / (1.0 + r)).abs() < 1e-6);
        assert!((p.reflectance_at(-1.0) - p.reflectance_at(1.0)).abs() < 1e-7);
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let m = p.sample(wo, 0.0).unwrap();
        assert_eq!(m.wi, Vec3::new(-0.6, 0.0, 0.8));
        assert_eq!(m.weight, Vec3::ONE);
        let t = p.sample(wo, 0.999).unwrap();
        assert_eq!(t.wi, -wo);
        assert_eq!(t.weight, p.transmittance);
        assert!((t.pdf + m.pdf - 1.0).abs() < 1e-6);
        // f·|cos|/pdf is the weight.
        assert!((t.f * t.wi.z.abs() / t.pdf - t.weight).abs().max_element() < 1e-6);
        assert!(p.validate().is_ok());
        assert!(ThinDielectricParams { eta: 0.0, ..p }.validate().is_err());
    }
}
