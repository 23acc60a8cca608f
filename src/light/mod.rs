//! Light sources and how the integrator samples them.
//!
//! # The light interface
//!
//! - [`Light::sample_li`] picks a point on the light as seen from a shading
//!   point `p` and returns a [`LightSample`]: the incident radiance `radiance`
//!   arriving at `p` along `wi` (for a delta light, the irradiance-producing
//!   quantity `I / r²`), the unit direction `wi` *from `p` towards the light*,
//!   the distance to the sampled point, and the density `pdf` **separately**,
//!   in solid angle measure at `p` (for a delta light, `pdf = 1` and
//!   `delta = true`). A sample that cannot contribute (back side of a one-sided
//!   emitter, zero area) is `None`, never a zero pdf.
//! - [`Light::pdf_li`] is the solid-angle density `sample_li` would have had
//!   for a direction that a BSDF sample found, the MIS counterpart.
//! - Emitters are one-sided by default: a triangle emits towards the side of
//!   its geometric normal `(p1 − p0) × (p2 − p0)` (counter-clockwise winding
//!   seen from the lit side); `two_sided = true` makes it emit on both.
//!
//! [`LightSet`] picks one light per shading point with probability
//! proportional to its power; the integrator multiplies by that probability.

mod point;
mod triangle;

pub use point::PointLight;
pub use triangle::TriangleLight;

use crate::sampling::Distribution1D;
use glam::{Vec2, Vec3};

/// One light source; a closed set of kinds, dispatched by `match`.
#[derive(Debug, Clone, PartialEq)]
pub enum Light {
    /// An isotropic point light.
    Point(PointLight),
    /// One triangle of an emissive mesh (an area light).
    Triangle(TriangleLight),
}

/// A point on a light sampled from a shading point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightSample {
    /// Radiance arriving along `wi` (W/(m²·sr) per RGB channel); for a delta
    /// light, `I / r²`.
    pub radiance: Vec3,
    /// Unit direction from the shading point towards the light point.
    pub wi: Vec3,
    /// Distance from the shading point to the light point.
    pub dist: f32,
    /// Solid-angle density of `wi` (1 for delta lights).
    pub pdf: f32,
    /// Whether the light is a delta distribution (cannot be hit by BSDF rays).
    pub delta: bool,
}

/// Luminance of a linear Rec.709 RGB colour.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

impl Light {
    /// Samples the light from shading point `p` with the uniform pair `u`.
    #[inline]
    pub fn sample_li(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        match self {
            Light::Point(l) => l.sample_li(p),
            Light::Triangle(l) => l.sample_li(p, u),
        }
    }

    /// Solid-angle density of `sample_li` at `p` for the point `x` on the
    /// light, reached along the unit direction `wi` (0 for delta lights).
    #[inline]
    pub fn pdf_li(&self, p: Vec3, x: Vec3, wi: Vec3) -> f32 {
        match self {
            Light::Point(_) => 0.0,
            Light::Triangle(l) => l.pdf_li(p, x, wi),
        }
    }

    /// Total emitted power (W, luminance-weighted), used to pick lights.
    pub fn power(&self) -> f32 {
        match self {
            Light::Point(l) => l.power(),
            Light::Triangle(l) => l.power(),
        }
    }
}

/// All lights of a scene and the distribution used to pick one.
#[derive(Debug, Clone, Default)]
pub struct LightSet {
    /// The lights; triangle lights of one mesh are contiguous.
    pub lights: Vec<Light>,
    select: Distribution1D,
}

impl LightSet {
    /// A light set picking lights in proportion to their power.
    pub fn new(lights: Vec<Light>) -> LightSet {
        let weights: Vec<f32> = lights.iter().map(Light::power).collect();
        LightSet {
            select: Distribution1D::new(&weights),
            lights,
        }
    }

    /// Whether the scene has no light that can be sampled.
    pub fn is_empty(&self) -> bool {
        self.select.is_empty()
    }

    /// Picks a light for `u ∈ [0, 1)`: `(light, probability)`.
    #[inline]
    pub fn pick(&self, u: f32) -> Option<(&Light, f32)> {
        self.select.sample(u).map(|(i, p)| (&self.lights[i], p))
    }

    /// Probability that [`LightSet::pick`] returns light `index`.
    #[inline]
    pub fn pick_pmf(&self, index: usize) -> f32 {
        self.select.pmf(index)
    }
}
