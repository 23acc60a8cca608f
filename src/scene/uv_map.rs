//! How a mesh's texture coordinates are found at a hit.
//!
//! Most meshes carry texture coordinates per vertex and a hit interpolates
//! them. The built-in `sphere` and `disk` are tessellations of round shapes
//! whose parameterisation (Mitsuba's) is not linear over a triangle: the
//! azimuth `atan2(y, x)` wraps round at a seam and turns fastest near the
//! poles and the centre. Their meshes carry per-vertex coordinates (for
//! tangent frames) and a [`UvMap`] that computes the exact coordinates from
//! the hit point in the shape's own frame, as Mitsuba's analytic shapes do:
//!
//! - sphere: `u = φ/2π` (the azimuth `atan2(y, x)` in `[0, 2π)`, from `+x`
//!   towards `+y`), `v = θ/π` (the polar angle from `+z`);
//! - disk: `u = r` (the distance from the centre, 1 on the rim),
//!   `v = φ/2π` (the azimuth in `[0, 2π)`);
//! - cylinder: `u = φ/2π` (the azimuth about the axis), `v = z` (0 at the
//!   first end, 1 at the second).
//!
//! `flip_v` (the scene file's key, set for shapes imported from Mitsuba)
//! gives `(u, 1 − v)`, as it does to per-vertex coordinates.

use glam::{Affine3A, Vec2, Vec3};

/// How texture coordinates are found at a hit on a mesh.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum UvMap {
    /// Interpolated from the mesh's per-vertex coordinates.
    #[default]
    Vertices,
    /// Spherical coordinates of the point in the unit sphere's frame:
    /// `to_local` maps world space to it (the centre to the origin, the
    /// radius to 1).
    Sphere {
        /// World space to the unit sphere's frame.
        to_local: Affine3A,
        /// `v` is `1 − θ/π`.
        flip_v: bool,
    },
    /// Polar coordinates of the point in the unit disk's frame (the disk at
    /// `z = 0`, radius 1).
    Disk {
        /// World space to the unit disk's frame.
        to_local: Affine3A,
        /// `v` is `1 − φ/2π`.
        flip_v: bool,
    },
    /// Cylindrical coordinates of the point in the unit cylinder's frame
    /// (`x² + y² = 1`, `0 ≤ z ≤ 1`).
    Cylinder {
        /// World space to the unit cylinder's frame.
        to_local: Affine3A,
        /// `v` is `1 − z`.
        flip_v: bool,
    },
}

impl UvMap {
    /// The same map with `v` flipped (`(u, 1 − v)`), as the `flip_v` key
    /// does to per-vertex coordinates.
    pub fn flipped_v(self) -> UvMap {
        match self {
            UvMap::Vertices => UvMap::Vertices,
            UvMap::Sphere { to_local, flip_v } => UvMap::Sphere {
                to_local,
                flip_v: !flip_v,
            },
            UvMap::Disk { to_local, flip_v } => UvMap::Disk {
                to_local,
                flip_v: !flip_v,
            },
            UvMap::Cylinder { to_local, flip_v } => UvMap::Cylinder {
                to_local,
                flip_v: !flip_v,
            },
        }
    }

    /// The texture coordinates at world point `p`, or `None` for
    /// [`UvMap::Vertices`] (interpolate the vertices' instead).
    #[inline]
    pub fn at(&self, p: Vec3) -> Option<Vec2> {
        let (uv, flip_v) = match *self {
            UvMap::Vertices => return None,
            UvMap::Sphere { to_local, flip_v } => {
                let q = to_local.transform_point3(p);
                let len = q.length();
                let theta = if len > 0.0 {
                    (q.z / len).clamp(-1.0, 1.0).acos()
                } else {
                    0.0
                };
                (
                    Vec2::new(azimuth_turns(q), theta * std::f32::consts::FRAC_1_PI),
                    flip_v,
                )
            }
            UvMap::Disk { to_local, flip_v } => {
                let q = to_local.transform_point3(p);
                (Vec2::new(q.x.hypot(q.y), azimuth_turns(q)), flip_v)
            }
            UvMap::Cylinder { to_local, flip_v } => {
                let q = to_local.transform_point3(p);
                (Vec2::new(azimuth_turns(q), q.z.clamp(0.0, 1.0)), flip_v)
            }
        };
        Some(if flip_v {
            Vec2::new(uv.x, 1.0 - uv.y)
        } else {
            uv
        })
    }
}

/// The azimuth of `q` about `+z`, from `+x` towards `+y`, as a fraction of
/// a turn in `[0, 1)` (0 on the axis).
#[inline]
pub fn azimuth_turns(q: Vec3) -> f32 {
    let phi = q.y.atan2(q.x) * (0.5 * std::f32::consts::FRAC_1_PI);
    if phi < 0.0 {
        // `phi + 1` rounds to 1 for the tiniest negative angles.
        (phi + 1.0).min(1.0 - f32::EPSILON / 2.0)
    } else {
        phi
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_and_disk_coordinates_are_mitsubas() {
        let unit = UvMap::Sphere {
            to_local: Affine3A::IDENTITY,
            flip_v: false,
        };
        let at = |m: &UvMap, p: Vec3| m.at(p).unwrap();
        // +x at the equator: u 0, v ½; +y: u ¼; −y: u ¾; the poles v 0, 1.
        assert!((at(&unit, Vec3::X) - Vec2::new(0.0, 0.5)).length() < 1e-6);
        assert!((at(&unit, Vec3::Y) - Vec2::new(0.25, 0.5)).length() < 1e-6);
        assert!((at(&unit, -Vec3::Y) - Vec2::new(0.75, 0.5)).length() < 1e-6);
        assert!(at(&unit, Vec3::Z).y.abs() < 1e-6);
        assert!((at(&unit, -Vec3::Z).y - 1.0).abs() < 1e-6);
        // A sphere of radius 2 at (1, 0, 0): the point (1, 0, 2) is its pole.
        let moved = UvMap::Sphere {
            to_local: Affine3A::from_scale_rotation_translation(
                Vec3::splat(2.0),
                glam::Quat::IDENTITY,
                Vec3::X,
            )
            .inverse(),
            flip_v: true,
        };
        assert!((at(&moved, Vec3::new(1.0, 0.0, 2.0)).y - 1.0).abs() < 1e-6);
        let disk = UvMap::Disk {
            to_local: Affine3A::IDENTITY,
            flip_v: false,
        };
        assert!((at(&disk, Vec3::new(0.0, 0.5, 0.0)) - Vec2::new(0.5, 0.25)).length() < 1e-6);
        assert!(
            (at(&disk.flipped_v(), Vec3::new(0.0, -1.0, 0.0)) - Vec2::new(1.0, 0.25)).length()
                < 1e-6
        );
        assert_eq!(UvMap::Vertices.at(Vec3::ONE), None);
        // The azimuth stays below one turn just below +x.
        assert!(azimuth_turns(Vec3::new(1.0, -1e-30, 0.0)) < 1.0);
    }
}
