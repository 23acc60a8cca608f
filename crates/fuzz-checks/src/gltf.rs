//! glTF 2.0 scenes, as `plsr render scene.gltf` reads them: JSON (`.gltf`)
//! or binary (`.glb`, by its `glTF` magic). The input's bytes after its
//! first NUL byte (JSON) are written beside it as `buf.bin`, the buffer a
//! seed's `"uri"` names.

/// Checks one input.
pub fn check(data: &[u8]) {
    let (name, file, buffer): (&str, &[u8], &[u8]) = if data.starts_with(b"glTF") {
        ("scene.glb", data, &[])
    } else {
        let (json, buffer) = crate::common::split_two(data, 0);
        ("scene.gltf", json, buffer)
    };
    crate::common::input_file("buf.bin", buffer);
    let path = crate::common::input_file(name, file);
    match plsr::scene::gltf_scene::read_gltf(&path) {
        Ok(scene) => {
            for object in &scene.objects {
                let n = object.positions.len();
                assert!(object.triangles.iter().flatten().all(|&i| (i as usize) < n));
                assert!(object.normals.is_empty() || object.normals.len() == n);
                assert!(object.uvs.is_empty() || object.uvs.len() == n);
            }
        }
        Err(e) => assert!(!e.to_string().trim().is_empty()),
    }
    crate::common::check_scene_file(&path, name);
}
