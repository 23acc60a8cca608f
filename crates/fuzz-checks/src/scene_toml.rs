//! Scene files in TOML (docs/scene-format.md): loaded, built and, when
//! their camera is small, rendered at 1 spp.

/// Checks one input.
pub fn check(data: &[u8]) {
    let path = crate::common::input_file("scene.toml", data);
    crate::common::check_scene_file(&path, "scene.toml");
}
