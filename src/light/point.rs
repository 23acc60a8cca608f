//! Isotropic point light.
//!
//! ```toml
//! [[lights]]
//! type = "point"
//! position = [213, 300, 227]
//! intensity = [100000, 100000, 100000]   # radiant intensity, W/sr per RGB channel
//! ```

use super::{luminance, LightSample};
use glam::Vec3;

/// A point light of constant radiant intensity in every direction.
#[derive(Debug, Clone, PartialEq)]
pub struct PointLight {
    /// Position (scene units).
    pub position: Vec3,
    /// Radiant intensity, W/sr per linear RGB channel.
    pub intensity: Vec3,
}

impl PointLight {
    /// Irradiance-producing sample: `I / r²` along the direction to the light.
    #[inline]
    pub fn sample_li(&self, p: Vec3) -> Option<LightSample> {
        let (valid, sample) = point_light_sample(self.position, self.intensity, p);
        valid.then_some(sample)
    }

    /// Emitted power `4π·I` (luminance).
    pub fn power(&self) -> f32 {
        4.0 * std::f32::consts::PI * luminance(self.intensity)
    }
}

/// The light sample of a point light at `position` of intensity
/// `intensity` (W/sr) seen from `p`, and whether it is valid (`p` is not
/// the light's position). Branch-free: the vectorised kernel calls it per
/// lane, [`PointLight::sample_li`] per shading point.
#[inline(always)]
pub fn point_light_sample(position: Vec3, intensity: Vec3, p: Vec3) -> (bool, LightSample) {
    let d = position - p;
    let dist2 = d.length_squared();
    let inv_dist = dist2.sqrt().recip();
    let sample = LightSample {
        radiance: intensity * (inv_dist * inv_dist),
        wi: d * inv_dist,
        dist: dist2 * inv_dist,
        pdf: 1.0,
        delta: true,
    };
    (dist2 != 0.0, sample)
}
