//! Scene files in JSON (the TOML format's other syntax): loaded, built
//! and, when their camera is small, rendered at 1 spp.

/// Checks one input.
pub fn check(data: &[u8]) {
    let path = crate::common::input_file("scene.json", data);
    crate::common::check_scene_file(&path, "scene.json");
}
