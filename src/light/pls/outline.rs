//! The outline of a parametric light (paper eq. 3–7, 9–11): its axis,
//! its Bézier anchors, the boundary curves and their tessellation into the
//! triangles Embree traces.

use super::Pls;
use glam::{Mat4, Vec3};

/// Cubic Bézier over four points at `t`.
#[inline]
fn bezier3(p: [Vec3; 4], t: f32) -> Vec3 {
    let s = 1.0 - t;
    p[0] * (s * s * s) + p[1] * (3.0 * s * s * t) + p[2] * (3.0 * s * t * t) + p[3] * (t * t * t)
}

/// Scalar cubic Bézier at `t`.
#[inline]
fn bezier3_scalar(p: [f32; 4], t: f32) -> f32 {
    let s = 1.0 - t;
    p[0] * (s * s * s) + p[1] * (3.0 * s * s * t) + p[2] * (3.0 * s * t * t) + p[3] * (t * t * t)
}

/// The tessellated emitter: positions and counter-clockwise triangles (seen
/// from the side `n` points to).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlsMesh {
    /// Vertex positions (metres).
    pub positions: Vec<Vec3>,
    /// Triangles; no zero-area ones.
    pub triangles: Vec<[u32; 3]>,
}

impl PlsMesh {
    /// The mesh with every vertex transformed by the affine `m` (what
    /// transforming a light through its vertices means).
    pub fn transformed(&self, m: &Mat4) -> PlsMesh {
        PlsMesh {
            positions: self
                .positions
                .iter()
                .map(|p| m.transform_point3(*p))
                .collect(),
            triangles: self.triangles.clone(),
        }
    }

    /// Total area (m²).
    pub fn area(&self) -> f32 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.positions[i as usize]);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }
}

impl Pls {
    /// Axis control points `(e1, a1, a2, e2)` (eq. 3–4).
    pub fn axis_points(&self) -> [Vec3; 4] {
        let v = self.g.e2 - self.g.e1;
        [
            self.g.e1,
            self.g.e1 + self.g.alpha1 * v,
            self.g.e1 + self.g.alpha2 * v,
            self.g.e2,
        ]
    }

    /// The eight Bézier anchors `c1..c8` (eq. 5–6, 9).
    pub fn anchors(&self) -> [Vec3; 8] {
        let a = self.axis_points();
        let p = self.p();
        let d = self.g.d;
        [
            a[0] + d[0] * p,
            a[1] + d[1] * p,
            a[2] + d[2] * p,
            a[3] + d[3] * p,
            a[0] - d[0] * p,
            a[1] - d[1] * p,
            a[2] - d[2] * p,
            a[3] - d[3] * p,
        ]
    }

    /// The two boundary curves at `t ∈ [0, 1]`: `(B1(t), B2(t))` (eq. 10–11).
    pub fn boundary(&self, t: f32) -> (Vec3, Vec3) {
        let axis = bezier3(self.axis_points(), t);
        let w = bezier3_scalar(self.g.d, t) * self.p();
        (axis + w, axis - w)
    }

    /// Tessellates the outline into `nf` quads between consecutive samples of
    /// `B1` and `B2` at `t = k/nf`, as triangles facing `n`. Where a width is
    /// zero (a pointed end) the quad degenerates to one triangle; zero-area
    /// triangles are never emitted. An outline pointed at both ends needs
    /// `nf ≥ 2` to have any area, so `nf` is raised to 2 there.
    pub fn tessellate(&self, nf: u32) -> PlsMesh {
        let pointed_both_ends = self.g.d[0] == 0.0 && self.g.d[3] == 0.0;
        let nf = if pointed_both_ends {
            nf.max(2)
        } else {
            nf.max(1)
        };
        let axis = self.axis_points();
        let p = self.p();
        let mut positions = Vec::with_capacity(2 * (nf as usize + 1));
        let mut widths = Vec::with_capacity(nf as usize + 1);
        for k in 0..=nf {
            let t = k as f32 / nf as f32;
            let a = bezier3(axis, t);
            let w = bezier3_scalar(self.g.d, t);
            positions.push(a + w * p); // 2k: on B1
            positions.push(a - w * p); // 2k + 1: on B2
            widths.push(w);
        }
        let mut triangles = Vec::with_capacity(2 * nf as usize);
        let n = self.normal();
        let mut push = |t: [u32; 3], positions: &[Vec3]| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            let cross = (b - a).cross(c - a);
            // Keep only triangles with real area that face n.
            if cross.dot(n) > 0.0 && cross.length_squared() > 0.0 {
                triangles.push(t);
            }
        };
        for k in 0..nf {
            let (b1k, b2k) = (2 * k, 2 * k + 1);
            let (b1n, b2n) = (2 * k + 2, 2 * k + 3);
            let (wk, wn) = (widths[k as usize], widths[k as usize + 1]);
            match (wk > 0.0, wn > 0.0) {
                (true, true) => {
                    push([b1k, b1n, b2n], &positions);
                    push([b1k, b2n, b2k], &positions);
                }
                // Pointed start: B1(t_k) = B2(t_k).
                (false, true) => push([b1k, b1n, b2n], &positions),
                // Pointed end: B1(t_k+1) = B2(t_k+1).
                (true, false) => push([b1k, b1n, b2k], &positions),
                (false, false) => {}
            }
        }
        // Drop vertices no triangle uses (the duplicated tips).
        let mut remap = vec![u32::MAX; positions.len()];
        let mut used = Vec::new();
        for t in &mut triangles {
            for i in t.iter_mut() {
                if remap[*i as usize] == u32::MAX {
                    remap[*i as usize] = used.len() as u32;
                    used.push(positions[*i as usize]);
                }
                *i = remap[*i as usize];
            }
        }
        PlsMesh {
            positions: used,
            triangles,
        }
    }

    /// Exact area of the Bézier outline (m²): `2·|v|·∫ w(t)·x'(t) dt`, with
    /// `x(t)` the axis parameter, by 3-point Gauss–Legendre quadrature (exact
    /// for the degree-5 integrand).
    pub fn outline_area(&self) -> f32 {
        let v_len = (self.g.e2 - self.g.e1).length() as f64;
        let (a1, a2) = (self.g.alpha1 as f64, self.g.alpha2 as f64);
        // x(t) = Bézier(0, α1, α2, 1); x'(t) = 3[(α1)(1−t)² + 2(α2−α1)(1−t)t + (1−α2)t²].
        let dx = |t: f64| {
            let s = 1.0 - t;
            3.0 * (a1 * s * s + 2.0 * (a2 - a1) * s * t + (1.0 - a2) * t * t)
        };
        let w = |t: f64| bezier3_scalar(self.g.d, t as f32) as f64;
        let r = (3.0f64 / 5.0).sqrt() / 2.0;
        let nodes = [
            (0.5 - r, 5.0 / 18.0),
            (0.5, 8.0 / 18.0),
            (0.5 + r, 5.0 / 18.0),
        ];
        let integral: f64 = nodes.iter().map(|&(t, wt)| wt * w(t) * dx(t)).sum();
        (2.0 * v_len * integral) as f32
    }
}
