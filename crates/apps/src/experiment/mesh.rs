//! A small triangle-mesh builder for the experiment's generated geometry
//! (room, furniture, light fixtures), written out as Wavefront OBJ.
//!
//! Faces wind counter-clockwise seen from the side their normal points to,
//! which is the side an emissive OBJ emits towards.

use glam::Vec3;
use std::fmt::Write as _;

/// Triangles in metres, built up from quads, boxes, disks and tubes.
#[derive(Debug, Clone, Default)]
pub struct MeshBuilder {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

impl MeshBuilder {
    /// An empty mesh.
    pub fn new() -> MeshBuilder {
        MeshBuilder::default()
    }

    /// Number of triangles so far.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    fn vertex(&mut self, p: Vec3) -> u32 {
        self.positions.push(p);
        (self.positions.len() - 1) as u32
    }

    /// The quad `a, b, c, d` (in order around it; its normal is
    /// `(b − a) × (c − a)`), as two triangles.
    pub fn quad(&mut self, a: Vec3, b: Vec3, c: Vec3, d: Vec3) {
        let [ia, ib, ic, id] = [a, b, c, d].map(|p| self.vertex(p));
        self.triangles.push([ia, ib, ic]);
        self.triangles.push([ia, ic, id]);
    }

    /// An axis-aligned box from `min` to `max`, its faces pointing outwards.
    pub fn cuboid(&mut self, min: Vec3, max: Vec3) {
        let p = |x: bool, y: bool, z: bool| {
            Vec3::new(
                if x { max.x } else { min.x },
                if y { max.y } else { min.y },
                if z { max.z } else { min.z },
            )
        };
        let (f, t) = (false, true);
        self.quad(p(f, f, f), p(f, t, f), p(t, t, f), p(t, f, f)); // −z
        self.quad(p(f, f, t), p(t, f, t), p(t, t, t), p(f, t, t)); // +z
        self.quad(p(f, f, f), p(t, f, f), p(t, f, t), p(f, f, t)); // −y
        self.quad(p(f, t, f), p(f, t, t), p(t, t, t), p(t, t, f)); // +y
        self.quad(p(f, f, f), p(f, f, t), p(f, t, t), p(f, t, f)); // −x
        self.quad(p(t, f, f), p(t, t, f), p(t, t, t), p(t, f, t)); // +x
    }

    /// A regular `segments`-gon of circumradius `radius` around `center`
    /// in the plane orthogonal to `normal`, facing `normal` (a triangle
    /// fan). `u` fixes where the first corner lies.
    pub fn disk(&mut self, center: Vec3, normal: Vec3, u: Vec3, radius: f32, segments: u32) {
        let (u, v) = frame(normal, u);
        let c = self.vertex(center);
        let ring: Vec<u32> = (0..segments)
            .map(|k| self.vertex(center + radius * ring_dir(u, v, k, segments)))
            .collect();
        for k in 0..segments as usize {
            let next = ring[(k + 1) % ring.len()];
            self.triangles.push([c, ring[k], next]);
        }
    }

    /// The side wall of a prism over the same `segments`-gon as
    /// [`MeshBuilder::disk`], from `base` to `base + length·axis`, open at
    /// both ends; faces point outwards (an absorbing tube looks the same
    /// from either side).
    pub fn tube(
        &mut self,
        base: Vec3,
        axis: Vec3,
        u: Vec3,
        radius: f32,
        length: f32,
        segments: u32,
    ) {
        let (u, v) = frame(axis, u);
        let top = base + length * axis.normalize();
        for k in 0..segments {
            let a = radius * ring_dir(u, v, k, segments);
            let b = radius * ring_dir(u, v, k + 1, segments);
            self.quad(base + a, base + b, top + b, top + a);
        }
    }

    /// The mesh as OBJ text, headed by `comment` lines.
    pub fn to_obj(&self, comment: &str) -> String {
        let mut s = String::new();
        for line in comment.lines() {
            let _ = writeln!(s, "# {line}");
        }
        for p in &self.positions {
            let _ = writeln!(s, "v {} {} {}", fmt(p.x), fmt(p.y), fmt(p.z));
        }
        for t in &self.triangles {
            let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
        }
        s
    }
}

/// An orthonormal frame `(u, v)` of the plane orthogonal to `n`, with `u`
/// the projection of `hint` and `(u, v, n)` right-handed.
fn frame(n: Vec3, hint: Vec3) -> (Vec3, Vec3) {
    let n = n.normalize();
    let u = (hint - n * hint.dot(n)).normalize();
    (u, n.cross(u))
}

fn ring_dir(u: Vec3, v: Vec3, k: u32, segments: u32) -> Vec3 {
    let phi = std::f32::consts::TAU * (k % segments) as f32 / segments as f32;
    u * phi.cos() + v * phi.sin()
}

/// Six decimals (micrometres), without a trailing `-0`.
fn fmt(x: f32) -> String {
    let s = format!("{x:.6}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        "0.000000".into()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sum of the triangles' vector areas: zero for a closed surface.
    fn vector_area(m: &MeshBuilder) -> Vec3 {
        m.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                0.5 * (b - a).cross(c - a)
            })
            .sum()
    }

    #[test]
    fn a_cuboid_is_closed_and_faces_outwards() {
        let mut m = MeshBuilder::new();
        m.cuboid(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0));
        assert!(vector_area(&m).length() < 1e-6);
        // The +z face (triangles 2 and 3) points up.
        let [a, b, c] = m.triangles[2].map(|i| m.positions[i as usize]);
        assert!((b - a).cross(c - a).z > 0.0);
    }

    #[test]
    fn a_disk_faces_its_normal_with_the_polygons_area() {
        let mut m = MeshBuilder::new();
        let n = Vec3::new(1.0, -2.0, 0.5).normalize();
        m.disk(Vec3::ONE, n, Vec3::Z, 0.5, 64);
        let area = vector_area(&m);
        let polygon = 0.5 * 64.0 * 0.25 * (std::f32::consts::TAU / 64.0).sin();
        assert!((area.dot(n) - polygon).abs() < 1e-5, "{area:?}");
        assert!(area.normalize().dot(n) > 0.99999);
    }

    #[test]
    fn a_tube_with_its_two_caps_is_closed() {
        let mut m = MeshBuilder::new();
        let axis = Vec3::new(0.3, 0.2, -1.0).normalize();
        m.tube(Vec3::ZERO, axis, Vec3::X, 0.1, 0.4, 32);
        m.disk(Vec3::ZERO, -axis, Vec3::X, 0.1, 32);
        m.disk(0.4 * axis, axis, Vec3::X, 0.1, 32);
        assert!(vector_area(&m).length() < 1e-5);
    }
}
