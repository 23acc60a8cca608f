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

impl SoftEdge {
    /// The window on the edge, `(a + w/2 − θ) / w` clamped to `[0, 1]`, for
    /// `d = cos θ` (eq. 12′). Branch-free (with its own `acos`), so that the
    /// vectorised kernel computes it per lane exactly as [`Cone::window`]
    /// does.
    #[inline(always)]
    pub fn ramp(&self, d: f32) -> f32 {
        ((self.outer - acos(d.clamp(-1.0, 1.0))) / self.width).clamp(0.0, 1.0)
    }
}

/// `acos x` for `x ∈ [−1, 1]` in radians, within 3·10⁻⁷ of the exact value,
/// without branches: the classic reduction to `asin` (`acos x = π/2 − asin x`
/// for `|x| ≤ ½`, `2·asin √((1 − |x|)/2)` beyond, mirrored for `x < 0`) with
/// a degree-11 odd polynomial for `asin` on `[0, ½]` (the minimax fit of
/// Cephes' `asinf`). The standard library's `acos` calls the C library, which
/// a vectorised loop cannot.
#[inline(always)]
pub fn acos(x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, PI};
    let a = x.abs();
    let big = a > 0.5;
    let z = if big { 0.5 * (1.0 - a) } else { a * a };
    let s = if big { z.sqrt() } else { a };
    let poly = (((4.216_32e-2 * z + 2.418_131e-2) * z + 4.547_002_6e-2) * z + 7.495_300_3e-2) * z
        + 1.666_675_2e-1;
    // asin(s) for s ∈ [0, ½].
    let asin_s = s + s * z * poly;
    let small = FRAC_PI_2 - if x < 0.0 { -asin_s } else { asin_s };
    let large = if x < 0.0 {
        PI - 2.0 * asin_s
    } else {
        2.0 * asin_s
    };
    if big {
        large
    } else {
        small
    }
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
            Some(s) => s.ramp(d),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn branch_free_acos_is_within_its_bound_everywhere() {
        // Every 2⁻²² over [−1, 1], the ends and the switch at ±½ included.
        let steps = 1 << 23;
        let mut worst = (0.0f64, 0.0f32);
        for i in 0..=steps {
            let x = (i as f64 / steps as f64 * 2.0 - 1.0) as f32;
            let err = (acos(x) as f64 - (x as f64).acos()).abs();
            if err > worst.0 {
                worst = (err, x);
            }
        }
        assert!(worst.0 < 3e-7, "acos({}) is off by {:e}", worst.1, worst.0);
        assert_eq!(acos(1.0), 0.0);
        assert_eq!(acos(0.0), std::f32::consts::FRAC_PI_2);
    }

    #[test]
    fn the_soft_edge_ramps_from_one_to_zero_across_its_width() {
        let c = Cone::with_penumbra(Vec3::Z, 20.0, 10.0);
        let at = |deg: f32| {
            let t = deg.to_radians();
            c.window(Vec3::new(t.sin(), 0.0, t.cos()))
        };
        assert_eq!(at(14.0), 1.0);
        assert!((at(20.0) - 0.5).abs() < 1e-5, "{}", at(20.0));
        assert!((at(17.5) - 0.75).abs() < 1e-5, "{}", at(17.5));
        assert_eq!(at(26.0), 0.0);
    }
}
