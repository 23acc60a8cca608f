//! The window function of a parametric light (paper eq. 12): the cone of
//! directions it emits into, hard-edged as in the paper or, as plsr's
//! extension, with a soft edge.
//!
//! With the angle `θ = acos(u·n)` between a direction `u` leaving the light
//! and its normal `n`, the divergence half-angle `a` and the width `w` of
//! the soft edge (the penumbra):
//!
//! ```text
//! W(u) = 1                          θ ≤ a − w/2
//!        (a + w/2 − θ) / w          a − w/2 < θ < a + w/2     (eq. 12′)
//!        0                          θ ≥ a + w/2
//! ```
//!
//! `w = 0` is the paper's hard window (eq. 12): `W = 1` inside `a`, 0
//! outside. The soft edge is centred on `a`, so the beam's half-power
//! angle stays `a` for a narrow edge; real flashlights and lamps have such
//! edges (their reflector and lens blur the beam's rim).

use glam::Vec3;

/// The soft edge of a [`Cone`]: where its window ramps from 1 to 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SoftEdge {
    /// `cos(a − w/2)`: inside it the window is 1.
    pub cos_inner: f32,
    /// `a + w/2`, radians: the window is 0 beyond it.
    pub outer: f32,
    /// `w`, radians (> 0).
    pub width: f32,
}

/// A cone of emission around `axis`: light leaves only along directions
/// `u` with `u·axis ≥ cos_a`, weighted by the window `W(u)` (eq. 12, or
/// eq. 12′ with a soft edge).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cone {
    /// Unit axis (the PLS normal `n`).
    pub axis: Vec3,
    /// The cosine of the cone's outer half-angle: `a` for a hard edge,
    /// `a + w/2` for a soft one (beyond it nothing is emitted).
    pub cos_a: f32,
    /// The soft edge, if any.
    pub soft: Option<SoftEdge>,
}

impl Cone {
    /// A hard-edged cone around `axis` (normalised here) of half-angle
    /// `a_deg` degrees.
    pub fn new(axis: Vec3, a_deg: f32) -> Cone {
        Cone {
            axis: axis.normalize(),
            cos_a: a_deg.to_radians().cos(),
            soft: None,
        }
    }

    /// A cone of half-angle `a_deg` whose window falls from 1 to 0 over
    /// `penumbra_deg` degrees centred on `a_deg` (eq. 12′); a hard cone when
    /// `penumbra_deg` is 0.
    pub fn with_penumbra(axis: Vec3, a_deg: f32, penumbra_deg: f32) -> Cone {
        if penumbra_deg <= 0.0 {
            return Cone::new(axis, a_deg);
        }
        let (a, w) = (a_deg.to_radians(), penumbra_deg.to_radians());
        let outer = (a + 0.5 * w).min(std::f32::consts::FRAC_PI_2);
        Cone {
            axis: axis.normalize(),
            cos_a: outer.cos(),
            soft: Some(SoftEdge {
                cos_inner: (a - 0.5 * w).max(0.0).cos(),
                outer,
                width: w,
            }),
        }
    }

    /// Whether the unit direction `u` (leaving the light) is inside the
    /// outer cone, where the window is not zero (up to the edge itself).
    #[inline]
    pub fn contains(&self, u: Vec3) -> bool {
        u.dot(self.axis) >= self.cos_a
    }

    /// The window `W(u)` for the unit direction `u` leaving the light
    /// (eq. 12 or 12′), in `[0, 1]`.
    #[inline]
    pub fn window(&self, u: Vec3) -> f32 {
        let d = u.dot(self.axis);
        if d < self.cos_a {
            return 0.0;
        }
        match &self.soft {
            None => 1.0,
            Some(s) if d >= s.cos_inner => 1.0,
            Some(s) => ((s.outer - d.clamp(-1.0, 1.0).acos()) / s.width).clamp(0.0, 1.0),
        }
    }

    /// `∫ W(u) cos θ dω / π` over the hemisphere: the share of a Lambertian
    /// emitter's power the window lets through (`sin² a` for a hard cone).
    pub fn power_fraction(&self) -> f32 {
        match &self.soft {
            None => (1.0 - self.cos_a * self.cos_a).max(0.0),
            Some(s) => {
                // 2∫ W(θ) cos θ sin θ dθ by the midpoint rule over the edge.
                let inner = s.cos_inner.clamp(-1.0, 1.0).acos();
                let mut sum = (1.0 - s.cos_inner * s.cos_inner).max(0.0);
                const N: usize = 64;
                let h = (s.outer - inner) / N as f32;
                for k in 0..N {
                    let t = inner + (k as f32 + 0.5) * h;
                    let w = ((s.outer - t) / s.width).clamp(0.0, 1.0);
                    sum += 2.0 * w * t.cos() * t.sin() * h;
                }
                sum
            }
        }
    }
}
