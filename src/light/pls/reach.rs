//! Where a parametric light source can send light.
//!
//! A PLS emits only inside its cone (window function `W`, paper eq. 12): a
//! shading point `p` receives light from the emitter only if some point `x` on
//! it sees `p` within angle `a` of the axis `n`, i.e. `(p − x)·n ≥ cos a·|p − x|`.
//! [`Reach::can_reach`] decides that exactly: a bounding-sphere test settles
//! most points at once; for the rest, the concave function
//! `g(x) = (p − x)·n − cos a·|p − x|` is maximised over the emitter in closed
//! form: its maximum over a region is on the region's boundary unless the
//! region contains the set `g ≥ 0` entirely, and that set always contains the
//! point where the ray from `p` along `−n` meets the emitter.

use super::Cone;
use glam::Vec3;

/// A planar rectangle as two triangles and its four edges.
type Rectangle = ([[Vec3; 3]; 2], [(Vec3, Vec3); 4]);

/// The emitter's triangles and cone, with a bounding sphere for quick answers.
#[derive(Debug, Clone, PartialEq)]
pub struct Reach {
    cone: Cone,
    sin_a: f32,
    centre: Vec3,
    radius: f32,
    triangles: Vec<[Vec3; 3]>,
    /// Edges used by exactly one triangle: the outline.
    boundary: Vec<(Vec3, Vec3)>,
    /// For a planar emitter, its bounding rectangle in its plane (two
    /// triangles and four edges): a cheap exact test of a superset, run
    /// before the test of the outline itself.
    rectangle: Option<Rectangle>,
    /// Distance from `centre` to the rectangle's farthest corner.
    rectangle_radius: f32,
    /// The bounding cones of [`Reach::bounding_cones`]: apexes and cosines.
    back: (Vec3, f32),
    front: (Vec3, f32),
}

impl Reach {
    /// The reach of an emitter made of `triangles` emitting into `cone`.
    pub fn new(cone: Cone, triangles: Vec<[Vec3; 3]>) -> Reach {
        let (lo, hi) = triangles.iter().flatten().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), v| (lo.min(*v), hi.max(*v)),
        );
        let centre = 0.5 * (lo + hi);
        let radius = triangles
            .iter()
            .flatten()
            .map(|v| (*v - centre).length())
            .fold(0.0f32, f32::max);
        // Boundary edges: those not shared with another triangle. Positions
        // are compared bit for bit: shared vertices of a tessellation are the
        // same floats.
        let key = |v: Vec3| v.to_array().map(f32::to_bits);
        let edge = |a: Vec3, b: Vec3| {
            let (a, b) = (key(a), key(b));
            if a < b {
                (a, b)
            } else {
                (b, a)
            }
        };
        let mut count = std::collections::HashMap::new();
        for t in &triangles {
            for k in 0..3 {
                *count.entry(edge(t[k], t[(k + 1) % 3])).or_insert(0u32) += 1;
            }
        }
        let boundary = triangles
            .iter()
            .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
            .filter(|&(a, b)| count[&edge(a, b)] == 1)
            .collect();
        let rectangle = bounding_rectangle(&triangles, cone.axis);
        let rectangle_radius = rectangle.as_ref().map_or(radius, |(_, edges)| {
            edges
                .iter()
                .map(|(a, _)| (*a - centre).length())
                .fold(radius, f32::max)
        });
        // The cones of all points within `radius` of the centre lie inside
        // the cone whose apex is moved back by r / sin a along the axis, and
        // all contain the one moved forward by as much (with a little slack
        // for rounding).
        let sin_a = (1.0 - cone.cos_a * cone.cos_a).max(0.0).sqrt();
        let shift = radius / sin_a.max(1e-6);
        let back = (centre - shift * cone.axis, (cone.cos_a - 1e-6).max(0.0));
        let front = (centre + shift * cone.axis, (cone.cos_a + 1e-6).max(0.0));
        Reach {
            back,
            front,
            rectangle_radius,
            sin_a,
            cone,
            centre,
            radius,
            triangles,
            boundary,
            rectangle,
        }
    }

    /// Whether the point `x` of the emitter sends light towards `p` (the
    /// brute-force reference of the tests).
    #[cfg(test)]
    fn sees(&self, x: Vec3, p: Vec3) -> bool {
        let d = p - x;
        d.dot(self.cone.axis) >= self.cone.cos_a * d.length()
    }

    /// Whether any point of the emitter sends light towards `p`.
    pub fn can_reach(&self, p: Vec3) -> bool {
        let (decided, reaches) = self.bounding_cones(p);
        if decided {
            return reaches;
        }
        self.reaches_exactly(p)
    }

    /// The quick answer of two cones around the emitter's axis, one that
    /// holds every point the emitter can reach and one that only holds such
    /// points: `(decided, reaches)`, where `reaches` is the answer when
    /// `decided`. Branch-free, for testing many points at once; where it
    /// does not decide, [`Reach::can_reach`] does.
    #[inline(always)]
    pub fn bounding_cones(&self, p: Vec3) -> (bool, bool) {
        let n = self.cone.axis;
        // d·n ≥ c·|d| without a square root (c = cos a ≥ 0 for a ≤ 90°).
        let inside = |(apex, c): (Vec3, f32)| {
            let d = p - apex;
            let dn = d.dot(n);
            (dn >= 0.0) & (dn * dn >= c * c * d.length_squared())
        };
        let (back, front) = (inside(self.back), inside(self.front));
        (!back | front, back & front)
    }

    /// [`Reach::can_reach`] for a point the bounding cones leave undecided.
    fn reaches_exactly(&self, p: Vec3) -> bool {
        if let Some((tris, edges)) = &self.rectangle {
            if !self.polygon_reaches(tris, edges, self.rectangle_radius, p) {
                return false;
            }
        }
        self.polygon_reaches(&self.triangles, &self.boundary, self.radius, p)
    }

    /// Exact test for a polygon given as triangles and its boundary edges,
    /// all within `radius` of `self.centre`.
    fn polygon_reaches(
        &self,
        triangles: &[[Vec3; 3]],
        boundary: &[(Vec3, Vec3)],
        radius: f32,
        p: Vec3,
    ) -> bool {
        // The set g ≥ 0 contains the point where the ray from p along −n
        // meets the emitter's plane; if that point is on the emitter, p is lit.
        // (Only if that ray passes within the bounding sphere at all.)
        let to_centre = self.centre - p;
        let along = to_centre.dot(-self.cone.axis);
        let miss2 = to_centre.length_squared() - along * along;
        if along >= -radius
            && miss2 <= radius * radius
            && triangles
                .iter()
                .any(|t| axis_pierces(p, -self.cone.axis, t))
        {
            return true;
        }
        // Otherwise the set, if it meets the emitter, crosses its outline:
        // first its corners, then the stationary points of its edges.
        if boundary.iter().any(|&(a, _)| self.g(a, p) >= 0.0) {
            return true;
        }
        boundary
            .iter()
            .any(|&(a, b)| self.edge_interior_max(a, b, p) >= 0.0)
    }

    /// `max g(x)` over the open segment `x = a + s·(b − a)`, `s ∈ (0, 1)`, in
    /// closed form. With `q = p − a`, `D = b − a`, `k = D·n`, `c = cos a`,
    /// `α = |D|²`, `β = q·D` and `h²` the squared distance from p to the
    /// line, the stationary point satisfies `f = β − s·α = k·h / √(c² − k²/α)`
    /// (no stationary point when `c² ≤ k²/α`: g is monotone). g is concave,
    /// so its maximum is at the clamped stationary point or an end.
    /// The edges' ends are tested separately (every boundary vertex starts
    /// one boundary edge), so this returns the value at the stationary point,
    /// or −∞ when there is none inside the edge.
    fn edge_interior_max(&self, a: Vec3, b: Vec3, p: Vec3) -> f32 {
        let n = self.cone.axis;
        let c = self.cone.cos_a;
        let mut best = f32::NEG_INFINITY;
        let d = b - a;
        let q = p - a;
        let alpha = d.length_squared();
        if alpha > 0.0 {
            let k = d.dot(n);
            let beta = q.dot(d);
            let h2 = (q.length_squared() - beta * beta / alpha).max(0.0);
            let denom = c * c - k * k / alpha;
            if denom > 0.0 {
                let f = k * h2.sqrt() / denom.sqrt();
                let s = (beta - f) / alpha;
                if s > 0.0 && s < 1.0 {
                    best = self.g(a + s * d, p);
                }
            }
        }
        best
    }

    /// `g(x) = (p − x)·n − cos a·|p − x|`: non-negative iff `x` sends light to `p`.
    #[inline]
    fn g(&self, x: Vec3, p: Vec3) -> f32 {
        let d = p - x;
        d.dot(self.cone.axis) - self.cone.cos_a * d.length()
    }

    /// The cone the emitter sends light into.
    pub fn cone(&self) -> &Cone {
        &self.cone
    }

    /// The sine of the cone's half-angle.
    pub fn sin_a(&self) -> f32 {
        self.sin_a
    }
}

/// The bounding rectangle of planar triangles in their common plane, or
/// `None` if they are not planar. Corners are counter-clockwise around the plane normal.
fn bounding_rectangle(triangles: &[[Vec3; 3]], axis: Vec3) -> Option<Rectangle> {
    let normal: Vec3 = triangles
        .iter()
        .map(|t| (t[1] - t[0]).cross(t[2] - t[0]))
        .sum();
    let m = normal.try_normalize()?;
    let m = if m.dot(axis) < 0.0 { -m } else { m };
    let frame = crate::warp::Frame::from_normal(m);
    let origin = triangles.first()?[0];
    let (mut lo, mut hi) = (
        glam::Vec2::splat(f32::INFINITY),
        glam::Vec2::splat(f32::NEG_INFINITY),
    );
    let mut extent = 0.0f32;
    let mut off_plane = 0.0f32;
    for v in triangles.iter().flatten() {
        let d = *v - origin;
        let q = glam::Vec2::new(d.dot(frame.s), d.dot(frame.t));
        lo = lo.min(q);
        hi = hi.max(q);
        extent = extent.max(d.length());
        off_plane = off_plane.max(d.dot(m).abs());
    }
    if off_plane > 1e-5 * extent.max(f32::MIN_POSITIVE) {
        return None;
    }
    // Grow by a hair so rounding never makes the superset smaller.
    let pad = 1e-5 * extent;
    let corner = |x: f32, y: f32| origin + frame.s * x + frame.t * y;
    let c = [
        corner(lo.x - pad, lo.y - pad),
        corner(hi.x + pad, lo.y - pad),
        corner(hi.x + pad, hi.y + pad),
        corner(lo.x - pad, hi.y + pad),
    ];
    Some((
        [[c[0], c[1], c[2]], [c[0], c[2], c[3]]],
        [(c[0], c[1]), (c[1], c[2]), (c[2], c[3]), (c[3], c[0])],
    ))
}

/// Whether the ray `o + s·d`, `s ≥ 0`, passes through the triangle.
fn axis_pierces(o: Vec3, d: Vec3, t: &[Vec3; 3]) -> bool {
    let e1 = t[1] - t[0];
    let e2 = t[2] - t[0];
    let h = d.cross(e2);
    let det = e1.dot(h);
    if det.abs() < 1e-20 {
        return false;
    }
    let s = o - t[0];
    let u = s.dot(h) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    let dist = e2.dot(q) / det;
    u >= 0.0 && v >= 0.0 && u + v <= 1.0 && dist >= 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit square at z = 0 emitting down (−z) into a 30° cone.
    fn square_down() -> Reach {
        let a = Vec3::new(-0.5, -0.5, 0.0);
        let b = Vec3::new(0.5, -0.5, 0.0);
        let c = Vec3::new(0.5, 0.5, 0.0);
        let d = Vec3::new(-0.5, 0.5, 0.0);
        Reach::new(Cone::new(-Vec3::Z, 30.0), vec![[a, c, b], [a, d, c]])
    }

    /// A disk-like PLS outline (the paper's circle) of radius 0.5 at z = 0,
    /// emitting down into a 30° cone: its bounding rectangle is a strict
    /// superset, so the rectangle pre-test and the outline test both matter.
    fn disk_down() -> (Reach, Vec<[Vec3; 3]>) {
        let l = crate::light::pls::Pls::circle(
            Vec3::ZERO,
            0.5,
            -Vec3::Z,
            Vec3::X,
            30.0,
            Vec3::ONE,
            1.0,
        )
        .unwrap();
        let m = l.tessellate(16);
        let tris: Vec<[Vec3; 3]> = m
            .triangles
            .iter()
            .map(|t| t.map(|i| m.positions[i as usize]))
            .collect();
        (Reach::new(Cone::new(-Vec3::Z, 30.0), tris.clone()), tris)
    }

    #[test]
    fn reach_of_a_disk_matches_brute_force() {
        let (r, tris) = disk_down();
        let mut rng = crate::rng::Rng::new(5, 6);
        let (mut wrong, mut reached) = (0, 0);
        for _ in 0..2000 {
            let p = Vec3::new(
                4.0 * rng.next_f32() - 2.0,
                4.0 * rng.next_f32() - 2.0,
                -3.0 * rng.next_f32(),
            );
            // Brute force: dense barycentric samples of every triangle.
            let brute = tris.iter().any(|t| {
                (0..=12).any(|i| {
                    (0..=12 - i).any(|j| {
                        let (u, v) = (i as f32 / 12.0, j as f32 / 12.0);
                        r.sees(t[0] + u * (t[1] - t[0]) + v * (t[2] - t[0]), p)
                    })
                })
            });
            let exact = r.can_reach(p);
            if brute && !exact {
                wrong += 1;
            }
            reached += exact as u32;
        }
        assert_eq!(
            wrong, 0,
            "a point some emitter point lights was declared unreachable"
        );
        assert!(reached > 200 && reached < 1800, "{reached}");
    }

    #[test]
    fn reach_matches_brute_force() {
        let r = square_down();
        let mut rng = crate::rng::Rng::new(3, 4);
        let mut disagreements = 0;
        let (mut reached, mut total) = (0, 0);
        for _ in 0..3000 {
            let p = Vec3::new(
                6.0 * rng.next_f32() - 3.0,
                6.0 * rng.next_f32() - 3.0,
                -4.0 * rng.next_f32() + 0.5,
            );
            // Brute force over a fine grid of emitter points.
            let mut brute = false;
            'grid: for i in 0..=60 {
                for j in 0..=60 {
                    let x = Vec3::new(i as f32 / 60.0 - 0.5, j as f32 / 60.0 - 0.5, 0.0);
                    if r.sees(x, p) {
                        brute = true;
                        break 'grid;
                    }
                }
            }
            let exact = r.can_reach(p);
            // The grid can miss a sliver the exact test finds, never the reverse.
            if brute && !exact {
                disagreements += 100;
            }
            if exact && !brute {
                disagreements += 1;
            }
            reached += exact as u32;
            total += 1;
        }
        assert!(
            reached > 300 && reached < total - 300,
            "{reached} of {total}"
        );
        assert!(disagreements < 30, "{disagreements}");
    }

    #[test]
    fn just_inside_and_just_outside_the_cone() {
        let r = square_down();
        // Directly below the edge x = 0.5 at depth h, the cone reaches out to
        // x = 0.5 + h·tan 30°.
        let h = 2.0;
        let edge = 0.5 + h * 30f32.to_radians().tan();
        assert!(r.can_reach(Vec3::new(edge - 1e-3, 0.0, -h)));
        assert!(!r.can_reach(Vec3::new(edge + 1e-3, 0.0, -h)));
        // Behind the emitter: never.
        assert!(!r.can_reach(Vec3::new(0.0, 0.0, 1.0)));
    }
}
