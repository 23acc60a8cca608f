//! An image a point light projects over its directions: Mitsuba's
//! `projector` emitter (a slide projector, the reciprocal of a perspective
//! camera) and the `texture` of its `spot` light.
//!
//! The light's frame is `x` (the image's left, as Mitsuba's `look_at`
//! builds it: `up × axis`), `y` (up) and `z` (the axis). A direction `d`
//! from the light, `(x, y, z)` in that frame, looks up the image at
//!
//! - a projector: `u = ½ − ½·cot(fov/2)·x/z`,
//!   `v = ½ + ½·a·cot(fov/2)·y/z` (plsr's `v` runs up; `fov` along the
//!   image's width, `a` its width over its height), where the intensity is
//!   the image times `π / cos³θ` (`cos θ = z`), so that the irradiance on a
//!   plane facing the projector at distance 1 is `π` times the image, the
//!   same everywhere (Mitsuba's `projector`); nothing outside the image;
//! - a spot light: `u = ½ + ½·x/(z·tan θc)`, `v = ½ − ½·y/(z·tan θc)`,
//!   where the intensity is the image times the spot's beam (Mitsuba's spot
//!   `texture`, mirrored as Mitsuba mirrors it).

use crate::texture::ImageTexture;
use glam::{Vec2, Vec3};
use std::sync::Arc;

/// How directions map onto the image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ProjectionKind {
    /// Mitsuba's `projector`: a perspective frustum.
    Projector {
        /// `cot(fov/2)`, the field of view along the image's width.
        cot_half_fov: f32,
        /// The image's width over its height.
        aspect: f32,
    },
    /// A spot light's image, spread over its cutoff cone.
    Spot {
        /// `tan` of the cutoff angle.
        tan_cutoff: f32,
    },
}

/// An image projected by a point light (see the module's text).
#[derive(Debug, Clone, PartialEq)]
pub struct Projection {
    /// The light's unit frame in world space: `[x, y, z]`, `z` the axis.
    pub frame: [Vec3; 3],
    /// The image (linear RGB), looked up as its map says.
    pub image: Arc<ImageTexture>,
    /// How directions map onto it.
    pub kind: ProjectionKind,
}

impl Projection {
    /// The factor the light's intensity is multiplied by along the unit
    /// direction `d` leaving the light (zero outside the image).
    #[inline]
    pub fn factor(&self, d: Vec3) -> Vec3 {
        let [fx, fy, fz] = self.frame;
        let (x, y, z) = (d.dot(fx), d.dot(fy), d.dot(fz));
        if z <= 0.0 {
            return Vec3::ZERO;
        }
        match self.kind {
            ProjectionKind::Projector {
                cot_half_fov,
                aspect,
            } => {
                let uv = Vec2::new(
                    0.5 - 0.5 * cot_half_fov * x / z,
                    0.5 + 0.5 * aspect * cot_half_fov * y / z,
                );
                if !(0.0..=1.0).contains(&uv.x) || !(0.0..=1.0).contains(&uv.y) {
                    return Vec3::ZERO;
                }
                self.image.eval(uv) * (std::f32::consts::PI / (z * z * z))
            }
            ProjectionKind::Spot { tan_cutoff } => {
                let s = 0.5 / (z * tan_cutoff);
                self.image.eval(Vec2::new(0.5 + s * x, 0.5 - s * y))
            }
        }
    }

    /// The mean of [`Projection::factor`] over the directions the image
    /// covers, for picking lights: the mean texel (times `π` for a
    /// projector, its value on the axis).
    pub fn mean_factor(&self) -> Vec3 {
        match self.kind {
            ProjectionKind::Projector { .. } => self.image.mean() * std::f32::consts::PI,
            ProjectionKind::Spot { .. } => self.image.mean(),
        }
    }

    /// For a projector, the solid-angle integral of the factor:
    /// `π · mean texel · (area of the image on the plane z = 1)`;
    /// `None` for a spot light.
    pub fn projector_integral(&self) -> Option<Vec3> {
        match self.kind {
            ProjectionKind::Projector {
                cot_half_fov,
                aspect,
            } => {
                let area = (2.0 / cot_half_fov) * (2.0 / (cot_half_fov * aspect));
                Some(self.image.mean() * (std::f32::consts::PI * area))
            }
            ProjectionKind::Spot { .. } => None,
        }
    }

    /// The half-angle of the cone around the axis that holds every
    /// direction the image covers (radians).
    pub fn half_angle(&self) -> f32 {
        match self.kind {
            ProjectionKind::Projector {
                cot_half_fov,
                aspect,
            } => {
                let (tx, ty) = (1.0 / cot_half_fov, 1.0 / (cot_half_fov * aspect));
                tx.hypot(ty).atan()
            }
            ProjectionKind::Spot { tan_cutoff } => tan_cutoff.atan(),
        }
    }

    /// The light's frame from its axis and up direction (`x = up × axis`,
    /// `y = axis × x`, Mitsuba's `look_at`), or `None` where they are
    /// parallel or zero.
    pub fn frame_from(axis: Vec3, up: Vec3) -> Option<[Vec3; 3]> {
        let z = axis.try_normalize()?;
        let x = up.cross(z).try_normalize()?;
        Some([x, z.cross(x), z])
    }
}
