//! MikkTSpace tangents for normal-mapped glTF primitives that have none.
//!
//! glTF 2.0 (§3.7.2.1): "When tangents are not specified, client
//! implementations SHOULD calculate tangents using default MikkTSpace
//! algorithms with the specified vertex positions, normals, and texture
//! coordinates associated with the normal texture." MikkTSpace gives a
//! tangent per triangle corner; a vertex whose corners disagree (a UV seam,
//! a mirrored island) is split into one vertex per distinct tangent, so
//! that every vertex keeps one tangent as plsr's meshes store them.

use glam::{Vec2, Vec3, Vec4};
use std::collections::HashMap;

/// A primitive's vertices and triangles, as MikkTSpace reads them, with the
/// tangent it writes for each corner.
struct Corners<'a> {
    positions: &'a [Vec3],
    normals: &'a [Vec3],
    uvs: &'a [Vec2],
    triangles: &'a [[u32; 3]],
    tangents: Vec<Vec4>,
}

impl bevy_mikktspace::Geometry for Corners<'_> {
    fn num_faces(&self) -> usize {
        self.triangles.len()
    }
    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }
    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.positions[self.triangles[face][vert] as usize].to_array()
    }
    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        self.normals[self.triangles[face][vert] as usize].to_array()
    }
    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.uvs[self.triangles[face][vert] as usize].to_array()
    }
    fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
        self.tangents[3 * face + vert] = Vec4::from_array(tangent);
    }
}

/// A mesh rebuilt with tangents: for each new vertex the original vertex
/// it copies and its tangent, and the triangles over the new vertices.
pub type WithTangents = (Vec<u32>, Vec<Vec4>, Vec<[u32; 3]>);

/// MikkTSpace tangents (`w` the bitangent's sign, glTF's `TANGENT`) for
/// the mesh, from its positions, unit normals and texture coordinates
/// (plsr's, `v` up, as the normal map's green channel points); `None` where
/// MikkTSpace fails. Returns, for each new vertex, the original vertex it
/// copies, its tangent, and the triangles over the new vertices.
pub fn mikktspace(
    positions: &[Vec3],
    normals: &[Vec3],
    uvs: &[Vec2],
    triangles: &[[u32; 3]],
) -> Option<WithTangents> {
    let mut corners = Corners {
        positions,
        normals,
        uvs,
        triangles,
        tangents: vec![Vec4::ZERO; 3 * triangles.len()],
    };
    if !bevy_mikktspace::generate_tangents(&mut corners) {
        return None;
    }
    // One vertex per (original vertex, tangent) pair.
    let mut index: HashMap<(u32, [u32; 4]), u32> = HashMap::new();
    let (mut source, mut tangents) = (Vec::new(), Vec::new());
    let mut out = Vec::with_capacity(triangles.len());
    for (f, t) in triangles.iter().enumerate() {
        let mut new = [0u32; 3];
        for (v, &i) in t.iter().enumerate() {
            let tangent = corners.tangents[3 * f + v];
            let tangent = if tangent.is_finite() {
                tangent
            } else {
                Vec4::ZERO
            };
            let key = (i, tangent.to_array().map(f32::to_bits));
            new[v] = *index.entry(key).or_insert_with(|| {
                source.push(i);
                tangents.push(tangent);
                (source.len() - 1) as u32
            });
        }
        out.push(new);
    }
    Some((source, tangents, out))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square in z = 0 facing +z of two triangles, texture coordinates
    /// `(u, v) = (s·x, y)`.
    fn square(s: f32) -> (Vec<Vec3>, Vec<Vec3>, Vec<Vec2>, Vec<[u32; 3]>) {
        let p = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let uv = p.iter().map(|p| Vec2::new(s * p.x, p.y)).collect();
        (p, vec![Vec3::Z; 4], uv, vec![[0, 1, 2], [0, 2, 3]])
    }

    #[test]
    fn tangents_follow_u_and_the_sign_follows_v() {
        // u along +x, v along +y: tangent +x, bitangent +y = +1·(n × t).
        let (p, n, uv, t) = square(1.0);
        let (source, tangents, tris) = mikktspace(&p, &n, &uv, &t).unwrap();
        assert_eq!(source, vec![0, 1, 2, 3]);
        assert_eq!(tris, t);
        for tangent in &tangents {
            assert!((tangent.truncate() - Vec3::X).length() < 1e-5, "{tangent}");
            assert_eq!(tangent.w, 1.0);
        }
        // Mirrored in u: tangent −x, and the bitangent still +y, so the
        // sign turns round.
        let (p, n, uv, t) = square(-1.0);
        let (_, tangents, _) = mikktspace(&p, &n, &uv, &t).unwrap();
        for tangent in &tangents {
            assert!((tangent.truncate() + Vec3::X).length() < 1e-5, "{tangent}");
            assert_eq!(tangent.w, -1.0);
        }
    }

    #[test]
    fn a_mirrored_seam_splits_its_vertices() {
        // Two squares side by side sharing the edge x = 1, the second's
        // texture mirrored: the shared vertices get two tangents each.
        let p: Vec<Vec3> = [0.0, 1.0, 2.0]
            .iter()
            .flat_map(|&x| [Vec3::new(x, 0.0, 0.0), Vec3::new(x, 1.0, 0.0)])
            .collect();
        let uv: Vec<Vec2> = p
            .iter()
            .map(|p| Vec2::new(1.0 - (p.x - 1.0).abs(), p.y))
            .collect();
        let t = vec![[0, 2, 3], [0, 3, 1], [2, 4, 5], [2, 5, 3]];
        let (source, tangents, tris) = mikktspace(&p, &[Vec3::Z; 6], &uv, &t).unwrap();
        assert_eq!(source.len(), 8, "{source:?}");
        assert_eq!(source.iter().filter(|&&i| i == 2 || i == 3).count(), 4);
        for (f, tri) in tris.iter().enumerate() {
            let expected = if f < 2 { Vec3::X } else { -Vec3::X };
            for &v in tri {
                assert_eq!(
                    p[source[v as usize] as usize],
                    p[t[f][tri.iter().position(|&w| w == v).unwrap()] as usize]
                );
                assert!((tangents[v as usize].truncate() - expected).length() < 1e-5);
            }
        }
    }
}
