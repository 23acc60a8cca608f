//! The window function of a parametric light (paper eq. 12): the hard-edged
//! cone of directions it emits into.

use glam::Vec3;

/// A hard-edged cone of emission: light leaves only along directions `u`
/// with `acos(u·axis) ≤ a` (the PLS window function `W(u)`, eq. 12).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cone {
    /// Unit axis (the PLS normal `n`).
    pub axis: Vec3,
    /// `cos a`, with `a` the divergence half-angle.
    pub cos_a: f32,
}

impl Cone {
    /// A cone around `axis` (normalised here) of half-angle `a_deg` degrees.
    pub fn new(axis: Vec3, a_deg: f32) -> Cone {
        Cone {
            axis: axis.normalize(),
            cos_a: a_deg.to_radians().cos(),
        }
    }

    /// `W(u)`: whether the unit direction `u` (leaving the light) is inside.
    #[inline]
    pub fn contains(&self, u: Vec3) -> bool {
        u.dot(self.axis) >= self.cos_a
    }
}
