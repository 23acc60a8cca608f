//! The equirectangular (latitude–longitude) convention, written down once.
//!
//! The 360° camera ([`crate::camera::EquirectCamera`]) and the environment
//! emitter (HDR panorama lighting) both map between image coordinates and
//! directions with this pair of functions, so a panorama rendered by the
//! camera lights a scene exactly as it was captured.
//!
//! Image coordinates `uv ∈ [0, 1]²`: `u = x / width` to the right,
//! `v = y / height` downwards (a pixel `(x, y)` covers
//! `[x, x+1) × [y, y+1)`, so its centre has `uv = ((x + ½)/width, (y + ½)/height)`).
//! Directions are given in a [`SphereFrame`] `(forward, right, up)`:
//!
//! - **columns are azimuth**: `φ = 2π·(u − ½)`, measured from `forward`
//!   towards `right`. The image centre column `u = ½` looks along `forward`;
//!   `u = ¾` looks along `right`, `u = ¼` along `−right` (left), and both
//!   edges `u = 0` and `u = 1` look backwards (`−forward`): the seam is
//!   behind. This is the view from inside the sphere: what is to your right
//!   is to the right in the image, as in photographs taken by 360° cameras;
//! - **rows are elevation**: `θ = π·(½ − v)` above the horizon. The top row
//!   `v = 0` looks straight up (`up`), the middle row `v = ½` is the
//!   horizon, the bottom row `v = 1` looks straight down.
//!
//! ```text
//! direction(u, v) = cos θ·(cos φ·forward + sin φ·right) + sin θ·up
//! ```
//!
//! The map is one-to-one except at the poles (`v = 0`, `v = 1`, every `u`)
//! and on the seam (`u = 0` and `u = 1` are the same direction);
//! [`equirect_uv`] returns `u ∈ [0, 1)`.

use crate::elementary;
use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// An orthonormal, right-handed frame that orients a panorama: `forward` is
/// the centre of the image, `up` its top (the zenith), `right = forward × up`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereFrame {
    /// Unit direction at the image centre (`uv = (½, ½)`).
    pub forward: Vec3,
    /// Unit direction at `uv = (¾, ½)`.
    pub right: Vec3,
    /// Unit direction of the top row (the zenith).
    pub up: Vec3,
}

impl SphereFrame {
    /// A frame with zenith `up` (kept exactly, after normalising) and
    /// `forward` projected onto the horizon plane. `None` when either is zero
    /// or they are parallel.
    pub fn new(up: Vec3, forward: Vec3) -> Option<SphereFrame> {
        let up = up.try_normalize()?;
        let right = forward.cross(up).try_normalize()?;
        Some(SphereFrame {
            forward: up.cross(right),
            right,
            up,
        })
    }

    /// World-space +y up, looking along −z (right is +x): the common
    /// convention of y-up scenes.
    pub const Y_UP: SphereFrame = SphereFrame {
        forward: Vec3::NEG_Z,
        right: Vec3::X,
        up: Vec3::Y,
    };

    /// World-space +z up, looking along +y (right is +x): the paper's Z-up data.
    pub const Z_UP: SphereFrame = SphereFrame {
        forward: Vec3::Y,
        right: Vec3::X,
        up: Vec3::Z,
    };
}

/// The unit direction of image coordinates `uv` (see the module docs).
#[inline]
pub fn equirect_direction(uv: Vec2, frame: &SphereFrame) -> Vec3 {
    // φ = 2π(u − ½) and θ = π(½ − v), as fractions of a turn (exact
    // reductions, and no call into the C library: the vectorised kernel's
    // environment stages stay vector code).
    let (sin_phi, cos_phi) = elementary::sin_cos_turns(uv.x - 0.5);
    let (sin_theta, cos_theta) = elementary::sin_cos_turns(0.5 * (0.5 - uv.y));
    cos_theta * (cos_phi * frame.forward + sin_phi * frame.right) + sin_theta * frame.up
}

/// The image coordinates `uv ∈ [0, 1) × [0, 1]` of direction `dir` (any
/// length from 1e-18 to 1e18; not normalised, since both angles are ratios
/// of its components); the inverse of [`equirect_direction`].
#[inline]
pub fn equirect_uv(dir: Vec3, frame: &SphereFrame) -> Vec2 {
    let x = dir.dot(frame.forward);
    let y = dir.dot(frame.right);
    let z = dir.dot(frame.up);
    let u = elementary::atan2(y, x) * (1.0 / TAU) + 0.5;
    let u = if u >= 1.0 { u - 1.0 } else { u };
    // acos loses precision near the poles; atan2 of the horizontal length
    // does not.
    let v = elementary::atan2((x * x + y * y).sqrt(), z) * (1.0 / PI);
    Vec2::new(u.max(0.0), v.min(1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn landmarks_are_where_documented() {
        let f = SphereFrame::Z_UP;
        let at = |u, v| equirect_direction(Vec2::new(u, v), &f);
        assert!((at(0.5, 0.5) - f.forward).length() < 1e-6);
        assert!((at(0.75, 0.5) - f.right).length() < 1e-6);
        assert!((at(0.25, 0.5) + f.right).length() < 1e-6);
        assert!((at(0.0, 0.5) + f.forward).length() < 1e-6);
        assert!((at(0.3, 0.0) - f.up).length() < 1e-6);
        assert!((at(0.3, 1.0) + f.up).length() < 1e-6);
    }

    #[test]
    fn round_trip_over_the_sphere() {
        let f = SphereFrame::new(Vec3::new(0.1, 0.2, 1.0), Vec3::new(1.0, 0.3, 0.0)).unwrap();
        for i in 0..64 {
            for j in 1..32 {
                let uv = Vec2::new((i as f32 + 0.5) / 64.0, j as f32 / 32.0);
                let back = equirect_uv(equirect_direction(uv, &f), &f);
                assert!((back - uv).length() < 1e-5, "{uv} -> {back}");
            }
        }
    }

    #[test]
    fn frame_keeps_up_exactly() {
        let f = SphereFrame::new(Vec3::Z * 2.0, Vec3::new(1.0, 0.0, 0.5)).unwrap();
        assert_eq!(f.up, Vec3::Z);
        assert!((f.forward - Vec3::X).length() < 1e-6);
        assert!((f.right - Vec3::new(0.0, -1.0, 0.0)).length() < 1e-6);
        assert!(SphereFrame::new(Vec3::Z, Vec3::Z).is_none());
    }
}
