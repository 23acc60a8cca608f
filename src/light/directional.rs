//! A directional light: parallel light from one direction, as from a very
//! distant sun (Mitsuba's `directional`).
//!
//! ```toml
//! [[lights]]
//! type = "directional"
//! direction = [0, -1, -1]     # the way the light travels
//! irradiance = [3, 3, 3]      # W/m² on a surface facing it, per RGB channel
//! ```

use super::{luminance, LightSample};
use glam::Vec3;

/// Light arriving along one direction everywhere, with irradiance
/// `irradiance` on a surface facing it: a delta distribution in direction.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionalLight {
    /// Unit direction the light travels in (from the light into the scene).
    pub direction: Vec3,
    /// Irradiance on a surface facing the light, W/m² per linear RGB channel.
    pub irradiance: Vec3,
}

impl DirectionalLight {
    /// The light as seen from any point: `wi = −direction`, the irradiance
    /// as the delta sample's value, at infinite distance.
    #[inline]
    pub fn sample_li(&self) -> Option<LightSample> {
        (self.irradiance != Vec3::ZERO).then_some(LightSample {
            radiance: self.irradiance,
            wi: -self.direction,
            dist: f32::INFINITY,
            pdf: 1.0,
            delta: true,
        })
    }

    /// The power falling on the scene's bounding disk of radius
    /// `scene_radius` (luminance): `π·r²·E`.
    pub fn power(&self, scene_radius: f32) -> f32 {
        std::f32::consts::PI * scene_radius * scene_radius * luminance(self.irradiance)
    }
}
