//! Signed-distance grids (Mitsuba 3's `sdfgrid`): the zero level set of a
//! grid of distances, interpolated trilinearly, turned into a triangle
//! mesh.
//!
//! The grid comes from a Mitsuba volume file (`.vol`: `VOL`, version 3,
//! float32, one channel) and spans the unit cube: grid point `(i, j, k)` of
//! an `nx × ny × nz` grid sits at `(i/(nx − 1), j/(ny − 1), k/(nz − 1))`,
//! and between grid points the distance is interpolated trilinearly
//! (Mitsuba's texture lookup, clamped at the border). Negative is inside.
//!
//! The surface is found by marching tetrahedra over the grid refined
//! `subdivisions` times per cell: each vertex lies on the level set where it
//! crosses an edge of the refined grid, and each triangle faces the
//! distance's gradient (outwards). Shading normals are Mitsuba's, computed
//! at each vertex: `analytic`, the gradient of the trilinear interpolant in
//! the cell holding the vertex; or `smooth` (Mitsuba's default), the
//! per-cell gradients of the eight cells round the vertex blended
//! trilinearly (Hansson-Söderlund, Evans and Akenine-Möller 2022).

use glam::{IVec3, Vec3};

/// The largest grid accepted (points per axis).
pub const MAX_GRID_SIDE: usize = 1024;
/// The most grid points accepted in all.
pub const MAX_GRID_POINTS: usize = 1 << 27;

/// A grid of signed distances over the unit cube.
#[derive(Debug, Clone)]
pub struct SdfGrid {
    /// Points along x, y and z (each at least 2).
    pub size: [usize; 3],
    /// Distances, x fastest, then y, then z.
    pub values: Vec<f32>,
}

/// How the shading normal is computed (Mitsuba's `normals`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SdfNormals {
    /// The gradient of the cell holding the point.
    Analytic,
    /// The gradients of the eight cells round the point, blended.
    Smooth,
}

/// Reads a Mitsuba `.vol` file's bytes as a grid, or a message naming the
/// fault. The header is checked before anything is allocated.
pub fn read_vol(bytes: &[u8]) -> Result<SdfGrid, String> {
    if bytes.len() < 48 || &bytes[..3] != b"VOL" {
        return Err("not a Mitsuba volume file (no `VOL` header)".into());
    }
    if bytes[3] != 3 {
        return Err(format!("volume file version {}, expected 3", bytes[3]));
    }
    let int = |at: usize| i32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
    if int(4) != 1 {
        return Err(format!("encoding {}, expected 1 (float32)", int(4)));
    }
    let mut size = [0usize; 3];
    for (axis, s) in size.iter_mut().enumerate() {
        let n = int(8 + 4 * axis);
        if !(2..=MAX_GRID_SIDE as i32).contains(&n) {
            return Err(format!(
                "grid size {n} along {}: must be 2 to {MAX_GRID_SIDE}",
                ["x", "y", "z"][axis]
            ));
        }
        *s = n as usize;
    }
    if int(20) != 1 {
        return Err(format!("{} channels, an SDF grid has 1", int(20)));
    }
    let count = size[0] * size[1] * size[2];
    if count > MAX_GRID_POINTS {
        return Err(format!("{count} grid points, more than {MAX_GRID_POINTS}"));
    }
    let data = &bytes[48..];
    if data.len() != 4 * count {
        return Err(format!(
            "{} bytes of data for a {}×{}×{} grid, expected {}",
            data.len(),
            size[0],
            size[1],
            size[2],
            4 * count
        ));
    }
    let values: Vec<f32> = data
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
        .collect();
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(format!("grid value {i} is not finite"));
    }
    Ok(SdfGrid { size, values })
}

impl SdfGrid {
    /// The value at grid point `(i, j, k)`, clamped to the grid.
    fn at(&self, p: IVec3) -> f32 {
        let [nx, ny, nz] = self.size;
        let i = p.x.clamp(0, nx as i32 - 1) as usize;
        let j = p.y.clamp(0, ny as i32 - 1) as usize;
        let k = p.z.clamp(0, nz as i32 - 1) as usize;
        self.values[(k * ny + j) * nx + i]
    }

    /// Cells along each axis.
    fn cells(&self) -> Vec3 {
        Vec3::new(
            (self.size[0] - 1) as f32,
            (self.size[1] - 1) as f32,
            (self.size[2] - 1) as f32,
        )
    }

    /// The trilinearly interpolated distance at `p` in the unit cube
    /// (clamped to it).
    pub fn eval(&self, p: Vec3) -> f32 {
        let g = (p.clamp(Vec3::ZERO, Vec3::ONE)) * self.cells();
        let base = g.floor().as_ivec3();
        let f = g - base.as_vec3();
        let v = |dx, dy, dz| self.at(base + IVec3::new(dx, dy, dz));
        let x00 = v(0, 0, 0) + (v(1, 0, 0) - v(0, 0, 0)) * f.x;
        let x10 = v(0, 1, 0) + (v(1, 1, 0) - v(0, 1, 0)) * f.x;
        let x01 = v(0, 0, 1) + (v(1, 0, 1) - v(0, 0, 1)) * f.x;
        let x11 = v(0, 1, 1) + (v(1, 1, 1) - v(0, 1, 1)) * f.x;
        let y0 = x00 + (x10 - x00) * f.y;
        let y1 = x01 + (x11 - x01) * f.y;
        y0 + (y1 - y0) * f.z
    }

    /// The gradient at `p` of the trilinear interpolant of cell `cell`
    /// (Mitsuba's `voxel_grad`: differences across the cell through `p`).
    fn cell_gradient(&self, p: Vec3, cell: IVec3) -> Vec3 {
        let size = Vec3::ONE / self.cells();
        let lo = cell.as_vec3() * size;
        let f = |q: Vec3| self.eval(q);
        Vec3::new(
            (f(Vec3::new(lo.x + size.x, p.y, p.z)) - f(Vec3::new(lo.x, p.y, p.z))) / size.x,
            (f(Vec3::new(p.x, lo.y + size.y, p.z)) - f(Vec3::new(p.x, lo.y, p.z))) / size.y,
            (f(Vec3::new(p.x, p.y, lo.z + size.z)) - f(Vec3::new(p.x, p.y, lo.z))) / size.z,
        )
    }

    /// The shading normal at `p` (object space, unit; Mitsuba's rules).
    pub fn normal(&self, p: Vec3, mode: SdfNormals) -> Vec3 {
        let scaled = p * self.cells();
        match mode {
            SdfNormals::Analytic => self
                .cell_gradient(p, scaled.floor().as_ivec3())
                .normalize_or(Vec3::Z),
            SdfNormals::Smooth => {
                let first = scaled.round().as_ivec3() - IVec3::ONE;
                let mut n = Vec3::ZERO;
                let mut inside = [[[false; 2]; 2]; 2];
                let mut normals = [[[Vec3::ZERO; 2]; 2]; 2];
                for (dz, plane) in normals.iter_mut().enumerate() {
                    for (dy, row) in plane.iter_mut().enumerate() {
                        for (dx, cell_n) in row.iter_mut().enumerate() {
                            let cell = first + IVec3::new(dx as i32, dy as i32, dz as i32);
                            if cell.min_element() >= 0 {
                                inside[dz][dy][dx] = true;
                                *cell_n = self.cell_gradient(p, cell).normalize_or_zero();
                            }
                        }
                    }
                }
                let mut w = scaled - (first + IVec3::ONE).as_vec3() + Vec3::splat(0.5);
                // Along an axis whose lower (upper) cells are all outside the
                // grid, only the other side counts.
                let side = |axis: usize, s: usize| {
                    (0..2).all(|a| {
                        (0..2).all(|b| {
                            let idx = match axis {
                                0 => [a, b, s],
                                1 => [a, s, b],
                                _ => [s, a, b],
                            };
                            !inside[idx[0]][idx[1]][idx[2]]
                        })
                    })
                };
                for axis in 0..3 {
                    if side(axis, 0) {
                        w[axis] = 1.0;
                    }
                    if side(axis, 1) {
                        w[axis] = 0.0;
                    }
                }
                for (dz, plane) in normals.iter().enumerate() {
                    for (dy, row) in plane.iter().enumerate() {
                        for (dx, cell_n) in row.iter().enumerate() {
                            let weight =
                                [1.0 - w.x, w.x][dx] * [1.0 - w.y, w.y][dy] * [1.0 - w.z, w.z][dz];
                            n += *cell_n * weight;
                        }
                    }
                }
                n.normalize_or(Vec3::Z)
            }
        }
    }

    /// The level set's triangles (object space) with their shading
    /// normals: marching tetrahedra over the grid refined `subdivisions`
    /// times per cell. Vertices are not shared between triangles.
    pub fn mesh(
        &self,
        subdivisions: u32,
        mode: SdfNormals,
    ) -> (Vec<Vec3>, Vec<[u32; 3]>, Vec<Vec3>) {
        let s = subdivisions.max(1) as usize;
        let n = [
            (self.size[0] - 1) * s + 1,
            (self.size[1] - 1) * s + 1,
            (self.size[2] - 1) * s + 1,
        ];
        let point = |i: usize, j: usize, k: usize| {
            Vec3::new(
                i as f32 / (n[0] - 1) as f32,
                j as f32 / (n[1] - 1) as f32,
                k as f32 / (n[2] - 1) as f32,
            )
        };
        // The refined grid's values, one z-plane pair at a time.
        let plane = |k: usize| -> Vec<f32> {
            let mut v = Vec::with_capacity(n[0] * n[1]);
            for j in 0..n[1] {
                for i in 0..n[0] {
                    v.push(self.eval(point(i, j, k)));
                }
            }
            v
        };
        // Six tetrahedra round the cube's diagonal 0–7 (corner bits: x, y, z).
        const TETS: [[usize; 4]; 6] = [
            [0, 1, 3, 7],
            [0, 3, 2, 7],
            [0, 2, 6, 7],
            [0, 6, 4, 7],
            [0, 4, 5, 7],
            [0, 5, 1, 7],
        ];
        let (mut positions, mut triangles, mut normals) = (Vec::new(), Vec::new(), Vec::new());
        let mut below = plane(0);
        for k in 0..n[2] - 1 {
            let above = plane(k + 1);
            for j in 0..n[1] - 1 {
                for i in 0..n[0] - 1 {
                    let mut corner = [(0usize, Vec3::ZERO, 0.0f32); 8];
                    let mut any_in = false;
                    let mut any_out = false;
                    for (c, slot) in corner.iter_mut().enumerate() {
                        let (di, dj, dk) = (c & 1, (c >> 1) & 1, (c >> 2) & 1);
                        let idx = (j + dj) * n[0] + i + di;
                        let v = if dk == 0 { below[idx] } else { above[idx] };
                        let id = ((k + dk) * n[1] + j + dj) * n[0] + i + di;
                        *slot = (id, point(i + di, j + dj, k + dk), v);
                        any_in |= v < 0.0;
                        any_out |= v >= 0.0;
                    }
                    if !(any_in && any_out) {
                        continue;
                    }
                    for tet in TETS {
                        let t = tet.map(|c| corner[c]);
                        let inside: Vec<usize> = (0..4).filter(|&a| t[a].2 < 0.0).collect();
                        let outside: Vec<usize> = (0..4).filter(|&a| t[a].2 >= 0.0).collect();
                        // The crossing on the edge between two corners, computed
                        // from the lower-numbered point so that neighbouring
                        // tetrahedra get the same bits.
                        let cross = |a: usize, b: usize| {
                            let (p, q) = if t[a].0 < t[b].0 {
                                (t[a], t[b])
                            } else {
                                (t[b], t[a])
                            };
                            let s = p.2 / (p.2 - q.2);
                            p.1 + (q.1 - p.1) * s
                        };
                        let polygon: Vec<Vec3> = match (inside.len(), outside.len()) {
                            (1, 3) => outside.iter().map(|&o| cross(inside[0], o)).collect(),
                            (3, 1) => inside.iter().map(|&i| cross(i, outside[0])).collect(),
                            (2, 2) => vec![
                                cross(inside[0], outside[0]),
                                cross(inside[0], outside[1]),
                                cross(inside[1], outside[1]),
                                cross(inside[1], outside[0]),
                            ],
                            _ => continue,
                        };
                        let fans: &[[usize; 3]] = if polygon.len() == 4 {
                            &[[0, 1, 2], [0, 2, 3]]
                        } else {
                            &[[0, 1, 2]]
                        };
                        for f in fans {
                            let [a, b, c] = f.map(|v| polygon[v]);
                            let face = (b - a).cross(c - a);
                            if face.length_squared() == 0.0 {
                                continue;
                            }
                            let centre = (a + b + c) / 3.0;
                            let grad = self
                                .cell_gradient(centre, (centre * self.cells()).floor().as_ivec3());
                            let (b, c) = if face.dot(grad) < 0.0 { (c, b) } else { (b, c) };
                            let first = positions.len() as u32;
                            for v in [a, b, c] {
                                positions.push(v);
                                normals.push(self.normal(v, mode));
                            }
                            triangles.push([first, first + 1, first + 2]);
                        }
                    }
                }
            }
            below = above;
        }
        (positions, triangles, normals)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere of radius 0.3 at the cube's centre, as a grid of `n³`.
    fn sphere(n: usize) -> SdfGrid {
        let mut values = Vec::new();
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let p = Vec3::new(i as f32, j as f32, k as f32) / (n - 1) as f32;
                    values.push((p - Vec3::splat(0.5)).length() - 0.3);
                }
            }
        }
        SdfGrid {
            size: [n; 3],
            values,
        }
    }

    fn vol(size: [i32; 3], values: &[f32]) -> Vec<u8> {
        let mut b = b"VOL\x03".to_vec();
        for v in [1, size[0], size[1], size[2], 1] {
            b.extend(v.to_le_bytes());
        }
        for v in [0.0f32, 0.0, 0.0, 1.0, 1.0, 1.0] {
            b.extend(v.to_le_bytes());
        }
        for v in values {
            b.extend(v.to_le_bytes());
        }
        b
    }

    #[test]
    fn a_sphere_grid_meshes_to_a_closed_sphere_facing_out() {
        let grid = sphere(12);
        for mode in [SdfNormals::Analytic, SdfNormals::Smooth] {
            let (p, t, n) = grid.mesh(2, mode);
            assert!(t.len() > 500);
            let centre = Vec3::splat(0.5);
            let mut volume = 0.0;
            for tri in &t {
                let [a, b, c] = tri.map(|i| p[i as usize] - centre);
                // Outward: the face normal points away from the centre.
                assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
                volume += a.dot(b.cross(c)) / 6.0;
            }
            for (q, m) in p.iter().zip(&n) {
                assert!(((*q - centre).length() - 0.3).abs() < 0.01, "{q}");
                assert!(m.dot((*q - centre).normalize()) > 0.95, "{mode:?} {q}: {m}");
            }
            // Closed: every edge (its end points' bits) is shared by two
            // triangles, once in each direction.
            let key = |v: Vec3| v.to_array().map(f32::to_bits);
            let mut edges = std::collections::HashMap::new();
            for tri in &t {
                for e in 0..3 {
                    let (a, b) = (p[tri[e] as usize], p[tri[(e + 1) % 3] as usize]);
                    *edges.entry((key(a), key(b))).or_insert(0) += 1;
                }
            }
            for ((a, b), count) in &edges {
                assert_eq!((count, edges.get(&(*b, *a))), (&1, Some(&1)));
            }
            // The trilinear sphere lies inside the true one (the distance is
            // convex, so interpolation overestimates it), by under 10 %.
            let exact = 4.0 / 3.0 * std::f32::consts::PI * 0.3f32.powi(3);
            assert!(volume < exact && volume > 0.9 * exact, "{volume} {exact}");
        }
    }

    #[test]
    fn volume_files_are_read_and_their_faults_named() {
        let values = sphere(3).values;
        let grid = read_vol(&vol([3, 3, 3], &values)).unwrap();
        assert_eq!((grid.size, grid.values.len()), ([3, 3, 3], 27));
        assert!((grid.eval(Vec3::splat(0.5)) + 0.3).abs() < 1e-6);
        assert!(read_vol(b"PLY").unwrap_err().contains("VOL"));
        let e = read_vol(&vol([3, 3, 3], &values[..20])).unwrap_err();
        assert!(e.contains("expected 108"), "{e}");
        let e = read_vol(&vol([1 << 20, 3, 3], &[])).unwrap_err();
        assert!(e.contains("grid size"), "{e}");
        let mut nan = values.clone();
        nan[5] = f32::NAN;
        assert!(read_vol(&vol([3, 3, 3], &nan))
            .unwrap_err()
            .contains("value 5"));
    }
}
