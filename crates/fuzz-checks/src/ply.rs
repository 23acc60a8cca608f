//! PLY meshes (ASCII and binary): a mesh whose indices, normals and
//! texture coordinates fit its vertices, or an error.

/// Checks one input.
pub fn check(data: &[u8]) {
    match plsr::scene::ply::parse_ply(data) {
        Err(e) => assert!(!e.to_string().trim().is_empty()),
        Ok(m) => {
            let n = m.positions.len();
            assert!(m.triangles.iter().flatten().all(|&i| (i as usize) < n));
            assert!(m.normals.is_empty() || m.normals.len() == n);
            assert!(m.uvs.is_empty() || m.uvs.len() == n);
            assert!(m.positions.iter().all(|p| p.is_finite()));
        }
    }
}
