//! Mitsuba 3 XML scenes: translated, built and, when their film is small,
//! rendered at 1 spp.

/// Checks one input.
pub fn check(data: &[u8]) {
    let path = crate::common::input_file("scene.xml", data);
    crate::common::check_scene_file(&path, "scene.xml");
}
