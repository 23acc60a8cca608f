//! Point lights: isotropic, or a spot light limited to a cone.
//!
//! ```toml
//! [[lights]]
//! type = "point"
//! position = [213, 300, 227]
//! intensity = [100000, 100000, 100000]   # radiant intensity, W/sr per RGB channel
//!
//! [[lights]]
//! type = "spot"              # Mitsuba's `spot`
//! position = [0, 0, 5]
//! direction = [0, 0, -1]     # the beam's axis
//! intensity = [50, 50, 50]   # W/sr on the axis
//! cutoff_angle = 20          # degrees: nothing beyond
//! beam_width = 15            # degrees: full intensity within (default ¾ cutoff)
//! ```
//!
//! A spot light's intensity falls linearly in angle from the beam width to
//! the cutoff, `(θc − θ)/(θc − θb)`, as Mitsuba's `spot` does. A spot light
//! may project an image over its beam, and a projector is a point light
//! whose intensity is an image ([`Projection`]).

use super::pls::{Cone, SoftEdge};
use super::projection::Projection;
use super::{luminance, LightSample};
use glam::Vec3;
use std::sync::Arc;

/// A point light of radiant intensity `intensity`, in every direction or,
/// for a spot light, times the window of its `cone`.
#[derive(Debug, Clone, PartialEq)]
pub struct PointLight {
    /// Position (scene units).
    pub position: Vec3,
    /// Radiant intensity, W/sr per linear RGB channel (on the axis of a
    /// spot light).
    pub intensity: Vec3,
    /// A spot light's beam: its axis and how its intensity falls off with
    /// the angle from it; `None` for an isotropic light.
    pub cone: Option<Cone>,
    /// An image the light projects, which multiplies its intensity by
    /// direction (a spot light's texture, or a projector's slide).
    pub projection: Option<Arc<Projection>>,
}

impl PointLight {
    /// An isotropic point light.
    pub fn isotropic(position: Vec3, intensity: Vec3) -> PointLight {
        PointLight {
            position,
            intensity,
            cone: None,
            projection: None,
        }
    }

    /// Irradiance-producing sample: `I / r²` along the direction to the
    /// light, times a spot light's window in the direction it leaves.
    #[inline]
    pub fn sample_li(&self, p: Vec3) -> Option<LightSample> {
        let (valid, mut sample) = point_light_sample(self.position, self.intensity, p);
        if let Some(cone) = &self.cone {
            sample.radiance *= cone.window(-sample.wi);
        }
        if let Some(projection) = &self.projection {
            sample.radiance *= projection.factor(-sample.wi);
        }
        (valid && sample.radiance != Vec3::ZERO).then_some(sample)
    }

    /// The weight lights are picked by (luminance): `4π·I`, for a spot
    /// light too. Wherever a spot's beam reaches, a point receives its full
    /// intensity, so a narrow beam must not be picked less often than a wide
    /// one (as a parametric light is weighed without its window): picked by
    /// its emitted power, a spot next to an environment was sampled a tenth
    /// as often as Mitsuba samples it, and its pool of light was noise.
    /// With a projected image, the intensity is weighed by the image's
    /// mean ([`Projection::mean_factor`]).
    pub fn power(&self) -> f32 {
        let intensity = match &self.projection {
            Some(p) => self.intensity * p.mean_factor(),
            None => self.intensity,
        };
        4.0 * std::f32::consts::PI * luminance(intensity)
    }

    /// The power the light emits (luminance): `4π·I`, or for a spot light
    /// `I·∫ window dω` (times the mean texel of a projected image, an
    /// approximation), for a projector `I·∫ factor dω`.
    pub fn emitted_power(&self) -> f32 {
        if let Some(p) = &self.projection {
            if let Some(integral) = p.projector_integral() {
                return luminance(self.intensity * integral);
            }
        }
        let image = self
            .projection
            .as_ref()
            .map_or(1.0, |p| luminance(p.mean_factor()));
        let solid_angle = match &self.cone {
            None => 4.0 * std::f32::consts::PI,
            Some(cone) => spot_solid_angle(cone),
        };
        solid_angle * luminance(self.intensity) * image
    }
}

/// The beam of a spot light around unit `axis`: full intensity within
/// `beam_width` of it, nothing beyond `cutoff`, linear in angle between
/// (radians, `0 ≤ beam_width ≤ cutoff ≤ π`).
pub fn spot_cone(axis: Vec3, cutoff: f32, beam_width: f32) -> Cone {
    let soft = (cutoff > beam_width).then(|| SoftEdge {
        cos_inner: beam_width.cos(),
        outer: cutoff,
        width: cutoff - beam_width,
    });
    Cone {
        axis,
        cos_a: cutoff.cos(),
        soft,
    }
}

/// `∫ window dω` of a spot light's cone:
/// `2π·(1 − (sin θc − sin θb)/(θc − θb))` with the linear fall-off, and
/// `2π·(1 − cos θc)` for a hard edge.
fn spot_solid_angle(cone: &Cone) -> f32 {
    let tau = std::f32::consts::TAU;
    match &cone.soft {
        None => tau * (1.0 - cone.cos_a),
        Some(s) => {
            let (outer, inner) = (s.outer as f64, (s.outer - s.width) as f64);
            let integral = 1.0 - (outer.sin() - inner.sin()) / (outer - inner);
            tau * integral as f32
        }
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
