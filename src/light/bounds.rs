//! Where a group of lights is and which way it faces, for picking lights by
//! their likely contribution at a shading point rather than by power alone.
//!
//! A group (a point light, the triangles of one emissive mesh or of one
//! parametric light) is bounded by a sphere around its points and a cone
//! around its emitting sides' normals, as pbrt-v4's `LightBounds` bound its
//! light BVH's nodes. [`LightBounds::importance`] is an upper bound, up to the
//! group's power, on the irradiance the group can send to a point: its power
//! over the squared distance, times the cosine of the smallest angle the
//! bounds allow between an emitting side's normal and the direction to the
//! point. It is zero only where no light of the group can arrive (behind
//! every one-sided emitter of the group), so picking by it is unbiased.

use glam::Vec3;

/// A bounding sphere and normal cone of a group of lights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightBounds {
    /// Centre of the bounding sphere (scene units).
    center: Vec3,
    /// Radius of the bounding sphere (scene units; 0 for a point light).
    radius: f32,
    /// Unit axis of the cone around the emitting sides' normals.
    axis: Vec3,
    /// Cosine of the cone's half-angle; −1 for light leaving in every
    /// direction (a point light, or normals that no cone narrower than the
    /// sphere bounds).
    cos_spread: f32,
    /// Whether light leaves on both sides of the triangles (then the cone
    /// bounds the normals up to their sign).
    two_sided: bool,
}

impl LightBounds {
    /// The bounds of an isotropic point light at `position`.
    pub fn point(position: Vec3) -> LightBounds {
        LightBounds {
            center: position,
            radius: 0.0,
            axis: Vec3::Z,
            cos_spread: -1.0,
            two_sided: true,
        }
    }

    /// The bounds of triangles `(vertices, unit normal, area)` that emit on
    /// the side of their normal (`two_sided`: on both sides) into the
    /// hemisphere; `None` for no triangles.
    pub fn triangles(
        triangles: impl Iterator<Item = ([Vec3; 3], Vec3, f32)> + Clone,
        two_sided: bool,
    ) -> Option<LightBounds> {
        let (lo, hi) = triangles.clone().flat_map(|(p, _, _)| p).fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(p), hi.max(p)),
        );
        if triangles.clone().next().is_none() || lo.x > hi.x {
            return None;
        }
        let center = 0.5 * (lo + hi);
        let radius = triangles
            .clone()
            .flat_map(|(p, _, _)| p)
            .map(|p| p.distance(center))
            .fold(0.0f32, f32::max);
        // The cone's axis: the area-weighted mean normal (for two-sided
        // triangles, each normal flipped into the first one's hemisphere).
        let first = triangles.clone().next().map_or(Vec3::Z, |t| t.1);
        let orient = |n: Vec3| {
            if two_sided && n.dot(first) < 0.0 {
                -n
            } else {
                n
            }
        };
        let sum: Vec3 = triangles.clone().map(|(_, n, a)| orient(n) * a).sum();
        let axis = sum.normalize_or_zero();
        let cos_spread = if axis == Vec3::ZERO {
            -1.0
        } else {
            triangles
                .map(|(_, n, _)| orient(n).dot(axis))
                .fold(1.0f32, f32::min)
        };
        // A little wider than the normals measured, against rounding.
        let cos_spread = if cos_spread > -1.0 {
            (cos_spread - 1e-4).max(-1.0)
        } else {
            -1.0
        };
        Some(LightBounds {
            center,
            radius,
            axis,
            cos_spread,
            two_sided,
        })
    }

    /// An upper bound on the irradiance (relative to power 1) the group can
    /// send to the point `p`: `cos θ′ / d²`, with `d` the distance from the
    /// sphere's centre (at least its radius) and `θ′` the smallest angle
    /// between an emitting normal and the direction to `p` that the cone and
    /// the sphere allow (pbrt-v4's `LightBounds::Importance` without the
    /// receiver's normal). 0 where every emitter faces away from `p`.
    #[inline]
    pub fn importance(&self, p: Vec3) -> f32 {
        let to_p = p - self.center;
        let dist2 = to_p.length_squared();
        let d2 = dist2.max(self.radius * self.radius).max(1e-12);
        if self.cos_spread <= -1.0 {
            return 1.0 / d2;
        }
        // Inside the sphere every direction is possible.
        if dist2 <= self.radius * self.radius {
            return 1.0 / d2;
        }
        let dist = dist2.sqrt();
        let cos_w = self.axis.dot(to_p) / dist;
        let cos_w = if self.two_sided { cos_w.abs() } else { cos_w };
        let sin_w = (1.0 - cos_w * cos_w).max(0.0).sqrt();
        // θx = max(0, θw − θo).
        let cos_o = self.cos_spread;
        let sin_o = (1.0 - cos_o * cos_o).max(0.0).sqrt();
        let (cos_x, sin_x) = if cos_w >= cos_o {
            (1.0, 0.0)
        } else {
            (
                cos_w * cos_o + sin_w * sin_o,
                (sin_w * cos_o - cos_w * sin_o).max(0.0),
            )
        };
        // θ′ = max(0, θx − θb), θb the half-angle the sphere subtends.
        let sin_b = self.radius / dist;
        let cos_b = (1.0 - sin_b * sin_b).max(0.0).sqrt();
        let cos_p = if cos_x >= cos_b {
            1.0
        } else {
            cos_x * cos_b + sin_x * sin_b
        };
        // Emission into the hemisphere: nothing beyond 90°.
        if cos_p <= 0.0 {
            return 0.0;
        }
        cos_p / d2
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(z: f32, up: bool) -> Vec<([Vec3; 3], Vec3, f32)> {
        let n = if up { Vec3::Z } else { -Vec3::Z };
        let (a, b, c, d) = (
            Vec3::new(-0.5, -0.5, z),
            Vec3::new(0.5, -0.5, z),
            Vec3::new(0.5, 0.5, z),
            Vec3::new(-0.5, 0.5, z),
        );
        vec![([a, b, c], n, 0.5), ([a, c, d], n, 0.5)]
    }

    #[test]
    fn a_point_light_falls_off_with_the_square_of_distance() {
        let b = LightBounds::point(Vec3::new(1.0, 2.0, 3.0));
        let near = b.importance(Vec3::new(1.0, 2.0, 4.0));
        let far = b.importance(Vec3::new(1.0, 2.0, 6.0));
        assert!((near - 1.0).abs() < 1e-6, "{near}");
        assert!((near / far - 9.0).abs() < 1e-4, "{near} / {far}");
    }

    #[test]
    fn a_one_sided_panel_has_no_importance_behind_it_and_full_in_front() {
        let tris = square(0.0, false); // facing down
        let b = LightBounds::triangles(tris.iter().copied(), false).unwrap();
        // Straight below at distance 2: cos 1, d² = 4.
        let below = b.importance(Vec3::new(0.0, 0.0, -2.0));
        assert!((below - 0.25).abs() < 1e-5, "{below}");
        assert_eq!(b.importance(Vec3::new(0.0, 0.0, 2.0)), 0.0);
        // Just beside the panel's plane, a point some of its area faces.
        assert!(b.importance(Vec3::new(3.0, 0.0, -0.01)) > 0.0);
        // Two-sided: lit from both sides alike.
        let b2 = LightBounds::triangles(tris.iter().copied(), true).unwrap();
        let (up, down) = (
            b2.importance(Vec3::new(0.0, 0.0, 2.0)),
            b2.importance(Vec3::new(0.0, 0.0, -2.0)),
        );
        assert!(up > 0.0 && (up - down).abs() < 1e-6, "{up} {down}");
    }

    #[test]
    fn the_cosine_bound_holds_for_every_emitter() {
        // For points all around a bent pair of triangles, the bound's cosine
        // (the bound times the squared distance it divides by) is at least
        // the cosine between each triangle's normal and the direction from
        // each of its vertices to the point.
        let tris = vec![
            ([Vec3::ZERO, Vec3::X, Vec3::Y], Vec3::Z, 0.5),
            (
                [Vec3::X, Vec3::new(1.0, 1.0, 0.5), Vec3::Y],
                Vec3::new(-0.5, -0.5, 1.0).normalize(),
                0.6,
            ),
        ];
        let b = LightBounds::triangles(tris.iter().copied(), false).unwrap();
        let mut rng = crate::rng::Rng::new(7, 1);
        for _ in 0..2000 {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 8.0 - 4.0;
            let bound = b.importance(p);
            for (v, n, _) in &tris {
                for x in v {
                    let w = (p - *x).normalize();
                    let cos = n.dot(w);
                    if cos > 1e-3 {
                        let d2 = (p - b.center).length_squared().max(b.radius * b.radius);
                        assert!(
                            bound * d2 >= cos - 1e-4,
                            "p {p}: bound {bound} below cos {cos} at {x}"
                        );
                    }
                }
            }
        }
    }
}
