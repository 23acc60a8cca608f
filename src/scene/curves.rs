//! Curves (Mitsuba 3's `bsplinecurve` and `linearcurve`): tubes of varying
//! radius swept along cubic B-splines or polylines, turned into triangle
//! meshes.
//!
//! A curve file holds one control point per line, `x y z radius`; an empty
//! line starts a new curve (Mitsuba's text format). A B-spline curve of
//! `n ≥ 4` points has `n − 3` cubic segments; a polyline of `n ≥ 2` points
//! has `n − 1` straight ones, joined and ended by spheres (Embree's round
//! curves). The tube is the envelope of the spheres of radius `r(t)` swept
//! along the centre line `c(t)`, as Embree's round curves are: the point
//! at angle `φ` of the ring at `t` is `c + r·(−(r′/|c′|)·T + √(1 − (r′/|c′|)²)·
//! (cos φ·U + sin φ·V))`, and its normal is that offset over `r`.
//!
//! Texture coordinates are Mitsuba's: `u = φ/2π`, measured in its frame
//! (`V` the world's `+z` made perpendicular to the tangent `T`, `U = V × T`;
//! `V = +y` where `T` is vertical), and `v = (segment + t)/segments` over
//! all the file's segments in order. The transform moves the control
//! points; the radii stay as written (Mitsuba's convention).
//!
//! Unlike Embree's analytic curves, the mesh is an approximation whose
//! error falls with `sides` and `steps`: with the defaults (32 sides, 16
//! steps per segment) a tube's silhouette is within 0.5 % of its radius.
//! The tubes are open-ended, as Mitsuba's; Mitsuba culls the inside of a
//! tube, plsr shades it (seen only through an open end).

use glam::{Mat4, Vec2, Vec3, Vec4};
use std::f32::consts::TAU;

/// The largest number of control points a curve file may hold (each makes
/// one ring or sphere of triangles).
pub const MAX_CONTROL_POINTS: usize = 1 << 20;

/// How the control points define a curve.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CurveBasis {
    /// Uniform cubic B-spline (`bsplinecurve`), at least four points.
    BSpline,
    /// Straight segments with round joints and ends (`linearcurve`), at
    /// least two points.
    Linear,
}

impl CurveBasis {
    /// The fewest control points one curve needs.
    pub fn min_points(self) -> usize {
        match self {
            CurveBasis::BSpline => 4,
            CurveBasis::Linear => 2,
        }
    }

    /// The number of segments of a curve of `n` control points.
    fn segments(self, n: usize) -> usize {
        n + 1 - self.min_points()
    }
}

/// Reads a curve file's text: the curves' control points `(x, y, z,
/// radius)`, or a message naming the line and the fault.
pub fn parse_curves(text: &str, basis: CurveBasis) -> Result<Vec<Vec<Vec4>>, String> {
    let mut curves: Vec<Vec<Vec4>> = Vec::new();
    let mut current: Vec<Vec4> = Vec::new();
    let mut count = 0usize;
    let mut finish = |current: &mut Vec<Vec4>, line: usize| -> Result<(), String> {
        if !current.is_empty() {
            if current.len() < basis.min_points() {
                return Err(format!(
                    "the curve ending before line {line} has {} control points; a {} curve needs at least {}",
                    current.len(),
                    match basis {
                        CurveBasis::BSpline => "B-spline",
                        CurveBasis::Linear => "linear",
                    },
                    basis.min_points()
                ));
            }
            curves.push(std::mem::take(current));
        }
        Ok(())
    };
    let mut last = 0;
    for (i, line) in text.lines().enumerate() {
        last = i + 1;
        let line = line.trim();
        if line.is_empty() {
            finish(&mut current, i + 1)?;
            continue;
        }
        let values: Vec<&str> = line.split_whitespace().collect();
        if values.len() != 4 {
            return Err(format!(
                "line {}: expected `x y z radius`, got {} numbers",
                i + 1,
                values.len()
            ));
        }
        let mut v = [0.0f32; 4];
        for (k, s) in values.iter().enumerate() {
            v[k] = s
                .parse::<f32>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("line {}: `{s}` is not a finite number", i + 1))?;
        }
        if v[3] < 0.0 {
            return Err(format!("line {}: radius {} is negative", i + 1, v[3]));
        }
        count += 1;
        if count > MAX_CONTROL_POINTS {
            return Err(format!(
                "more than {MAX_CONTROL_POINTS} control points (plsr meshes curves; \
                 hair-scale files are not supported yet)"
            ));
        }
        current.push(Vec4::from_array(v));
    }
    finish(&mut current, last + 1)?;
    if curves.is_empty() {
        return Err("no control points".into());
    }
    Ok(curves)
}

/// A triangle mesh with vertex normals and texture coordinates.
pub type CurveMesh = (Vec<Vec3>, Vec<[u32; 3]>, Vec<Vec3>, Vec<Vec2>);

/// Mitsuba's frame round the unit tangent `t`: `(V, U)` with `V` the
/// world's `+z` made perpendicular to `t` (`+y` where `t` is vertical) and
/// `U = V × t`; a ring's `u = φ/2π` is measured from `U` towards `V`.
fn ring_frame(t: Vec3) -> (Vec3, Vec3) {
    let guide = Vec3::Z;
    let v = if t.dot(guide).abs() >= 1.0 {
        Vec3::Y
    } else {
        (guide - t * t.dot(guide)).normalize()
    };
    (v, v.cross(t))
}

/// The centre, its derivative, the radius and its derivative of the
/// uniform cubic B-spline segment over `p` at `t` in `[0, 1]`.
fn bspline(p: &[Vec4], t: f32) -> (Vec3, Vec3, f32, f32) {
    let (t2, t3) = (t * t, t * t * t);
    let w = [
        (-t3 + 3.0 * t2 - 3.0 * t + 1.0) / 6.0,
        (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
        (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0,
        t3 / 6.0,
    ];
    let dw = [
        (-3.0 * t2 + 6.0 * t - 3.0) / 6.0,
        (9.0 * t2 - 12.0 * t) / 6.0,
        (-9.0 * t2 + 6.0 * t + 3.0) / 6.0,
        3.0 * t2 / 6.0,
    ];
    let mut c = Vec4::ZERO;
    let mut dc = Vec4::ZERO;
    for k in 0..4 {
        c += p[k] * w[k];
        dc += p[k] * dw[k];
    }
    (c.truncate(), dc.truncate(), c.w, dc.w)
}

/// Appends the ring of `sides + 1` vertices (the seam repeated at `u = 1`)
/// of the swept sphere at centre `c`, radius `r`, with derivatives `dc`,
/// `dr`, at texture coordinate `v`.
fn push_ring(mesh: &mut CurveMesh, sides: u32, (c, dc, r, dr): (Vec3, Vec3, f32, f32), v: f32) {
    let speed = dc.length().max(1e-20);
    let t = dc / speed;
    let (vv, uu) = ring_frame(t);
    // The envelope touches each sphere on a circle tilted back by r′/|c′|.
    let along = (-dr / speed).clamp(-1.0, 1.0);
    let across = (1.0 - along * along).max(0.0).sqrt();
    for i in 0..=sides {
        let turns = i as f32 / sides as f32;
        let (sin, cos) = if i == sides {
            (0.0, 1.0)
        } else {
            (TAU * turns).sin_cos()
        };
        let n = t * along + (uu * cos + vv * sin) * across;
        mesh.0.push(c + n * r);
        mesh.2.push(n);
        mesh.3.push(Vec2::new(turns, v));
    }
}

/// Joins ring `a` to ring `b` (each `sides + 1` vertices) by quads.
fn join_rings(mesh: &mut CurveMesh, sides: u32, a: u32, b: u32) {
    for i in 0..sides {
        mesh.1.push([a + i, a + i + 1, b + i + 1]);
        mesh.1.push([a + i, b + i + 1, b + i]);
    }
}

/// Appends a sphere of radius `r` at `c` (a polyline's joint or end), its
/// rings round the axis `t`, at texture coordinate `v`.
fn push_sphere(mesh: &mut CurveMesh, sides: u32, c: Vec3, r: f32, t: Vec3, v: f32) {
    let stacks = (sides / 2).max(2);
    let first = mesh.0.len() as u32;
    for k in 0..=stacks {
        // From −t to +t: a ring of the sphere is a swept sphere's ring
        // tilted all the way.
        let along = -(std::f32::consts::PI * k as f32 / stacks as f32).cos();
        let dr = -along;
        push_ring(mesh, sides, (c, t, r, dr), v);
    }
    for k in 0..stacks {
        let a = first + k * (sides + 1);
        join_rings(mesh, sides, a, a + sides + 1);
    }
}

/// The mesh of `curves` (control points in the curve file's space) moved by
/// `to_world` (the radii unchanged): `sides` vertices round each ring,
/// `steps` rings per B-spline segment. Triangles wind counter-clockwise
/// seen from outside.
pub fn curve_mesh(
    curves: &[Vec<Vec4>],
    basis: CurveBasis,
    to_world: &Mat4,
    sides: u32,
    steps: u32,
) -> CurveMesh {
    let world: Vec<Vec<Vec4>> = curves
        .iter()
        .map(|c| {
            c.iter()
                .map(|p| to_world.transform_point3(p.truncate()).extend(p.w))
                .collect()
        })
        .collect();
    let total: usize = world.iter().map(|c| basis.segments(c.len())).sum();
    let mut mesh: CurveMesh = Default::default();
    let mut segment = 0usize;
    for points in &world {
        match basis {
            CurveBasis::BSpline => {
                let mut previous: Option<u32> = None;
                for s in 0..basis.segments(points.len()) {
                    let p = &points[s..s + 4];
                    let first = if s == 0 { 0 } else { 1 };
                    for k in first..=steps {
                        let t = k as f32 / steps as f32;
                        let v = (segment as f32 + t) / total as f32;
                        let ring = mesh.0.len() as u32;
                        push_ring(&mut mesh, sides, bspline(p, t), v);
                        if let Some(a) = previous {
                            join_rings(&mut mesh, sides, a, ring);
                        }
                        previous = Some(ring);
                    }
                    segment += 1;
                }
            }
            CurveBasis::Linear => {
                for s in 0..basis.segments(points.len()) {
                    let (a, b) = (points[s], points[s + 1]);
                    let dc = (b - a).truncate();
                    let dr = b.w - a.w;
                    let v0 = segment as f32 / total as f32;
                    let v1 = (segment + 1) as f32 / total as f32;
                    let ring = mesh.0.len() as u32;
                    push_ring(&mut mesh, sides, (a.truncate(), dc, a.w, dr), v0);
                    push_ring(&mut mesh, sides, (b.truncate(), dc, b.w, dr), v1);
                    join_rings(&mut mesh, sides, ring, ring + sides + 1);
                    let t = dc.normalize_or(Vec3::Z);
                    if s == 0 {
                        push_sphere(&mut mesh, sides, a.truncate(), a.w, t, v0);
                    }
                    push_sphere(&mut mesh, sides, b.truncate(), b.w, t, v1);
                    segment += 1;
                }
            }
        }
    }
    // Wind every triangle to face its vertices' normals (outwards).
    let (p, n) = (&mesh.0, &mesh.2);
    for tri in &mut mesh.1 {
        let [a, b, c] = tri.map(|i| i as usize);
        let face = (p[b] - p[a]).cross(p[c] - p[a]);
        if face.dot(n[a] + n[b] + n[c]) < 0.0 {
            tri.swap(1, 2);
        }
    }
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_file_format_is_read_and_its_faults_named() {
        let text = "0 0 0 0.1\n1 0 0 0.1\n2 0 0 0.1\n3 0 0 0.1\n\n0 1 0 1\n1 1 0 2\n";
        let curves = parse_curves(text, CurveBasis::Linear).unwrap();
        assert_eq!((curves.len(), curves[0].len(), curves[1][1].w), (2, 4, 2.0));
        let e = parse_curves(text, CurveBasis::BSpline).unwrap_err();
        assert!(
            e.contains("2 control points") && e.contains("at least 4"),
            "{e}"
        );
        let e = parse_curves("0 0 0\n", CurveBasis::Linear).unwrap_err();
        assert!(e.contains("line 1"), "{e}");
        let e = parse_curves("0 0 0 nan\n1 1 1 1\n", CurveBasis::Linear).unwrap_err();
        assert!(e.contains("line 1") && e.contains("nan"), "{e}");
        assert!(parse_curves("\n\n", CurveBasis::Linear).is_err());
    }

    #[test]
    fn a_straight_tube_is_a_cylinder_of_its_radius() {
        let line: Vec<Vec4> = (0..6)
            .map(|i| Vec4::new(i as f32, 0.0, 0.0, 0.25))
            .collect();
        let (p, t, n, uv) = curve_mesh(&[line], CurveBasis::BSpline, &Mat4::IDENTITY, 16, 4);
        for (q, m) in p.iter().zip(&n) {
            assert!((Vec2::new(q.y, q.z).length() - 0.25).abs() < 1e-5, "{q}");
            assert!((*q - Vec3::new(q.x, 0.0, 0.0) - *m * 0.25).length() < 1e-5);
        }
        // A B-spline over evenly spaced points runs from the second to the
        // second-to-last; v covers [0, 1] over its three segments.
        let xs = p.iter().map(|q| q.x);
        let (lo, hi) = xs.fold((f32::MAX, f32::MIN), |(a, b), x| (a.min(x), b.max(x)));
        assert!(
            (lo - 1.0).abs() < 1e-5 && (hi - 4.0).abs() < 1e-5,
            "{lo} {hi}"
        );
        assert_eq!(uv.first().unwrap().y, 0.0);
        assert!((uv.last().unwrap().y - 1.0).abs() < 1e-6);
        // Outward winding everywhere.
        for tri in &t {
            let [a, b, c] = tri.map(|i| p[i as usize]);
            let centre = (a + b + c) / 3.0;
            let out = Vec3::new(0.0, centre.y, centre.z);
            assert!((b - a).cross(c - a).dot(out) > 0.0);
        }
        // u runs from Mitsuba's U (here +y for a tangent along +x, U = V × T
        // with V = +z) towards V (+z).
        assert!(
            (p[0] - Vec3::new(1.0, 0.25, 0.0)).length() < 1e-5,
            "{}",
            p[0]
        );
        assert!(
            (p[4] - Vec3::new(1.0, 0.0, 0.25)).length() < 1e-5,
            "{}",
            p[4]
        );
    }

    #[test]
    fn radii_stay_as_written_under_the_transform() {
        let line = vec![Vec4::new(0.0, 0.0, 0.0, 0.1), Vec4::new(1.0, 0.0, 0.0, 0.1)];
        let scale = Mat4::from_scale(Vec3::new(4.0, 3.0, 3.0));
        let (p, _, _, _) = curve_mesh(&[line], CurveBasis::Linear, &scale, 16, 1);
        let max_yz = p
            .iter()
            .map(|q| Vec2::new(q.y, q.z).length())
            .fold(0.0, f32::max);
        let max_x = p.iter().map(|q| q.x).fold(f32::MIN, f32::max);
        assert!((max_yz - 0.1).abs() < 1e-5 && (max_x - 4.1).abs() < 1e-5);
    }
}
