//! Mitsuba's `serialized` meshes (zlib-compressed shapes with a trailing
//! offset table): the first input byte picks the shape index, the rest is
//! the file.

/// Checks one input.
pub fn check(data: &[u8]) {
    let Some((&index, file)) = data.split_first() else {
        return;
    };
    match plsr::scene::serialized::parse_serialized(file, u32::from(index % 4)) {
        Err(e) => assert!(!e.to_string().trim().is_empty()),
        Ok(m) => {
            let n = m.positions.len();
            assert!(m.triangles.iter().flatten().all(|&i| (i as usize) < n));
            assert!(m.normals.is_empty() || m.normals.len() == n);
            assert!(m.uvs.is_empty() || m.uvs.len() == n);
        }
    }
}
