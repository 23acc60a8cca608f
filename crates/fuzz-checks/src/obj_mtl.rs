//! Wavefront OBJ meshes with their MTL library, as a scene file's `obj`
//! shape reads them. The input holds both files, the OBJ before the first
//! NUL byte and the MTL after it; the OBJ is given `mtllib m.mtl` first
//! when its own text does not name a library.

const SCENE: &str = "[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\n\
    vfov = 40\nresolution = [6, 6]\n\n[[shapes]]\ntype = \"obj\"\nfile = \"t.obj\"\n\
    emission = [0, 0, 0]\n\n[[shapes]]\ntype = \"sphere\"\nemission = [1, 1, 1]\n\
    center = [0, 0, -5]\n";

/// Checks one input.
pub fn check(data: &[u8]) {
    let (obj, mtl) = crate::common::split_two(data, 0);
    let mut obj = obj.to_vec();
    if !obj.windows(6).any(|w| w == b"mtllib") {
        obj.splice(0..0, b"mtllib m2.mtl\n".iter().copied());
    }
    crate::common::input_file("t.obj", &obj);
    crate::common::input_file("m2.mtl", mtl);
    let scene = crate::common::input_file("obj-scene.toml", SCENE.as_bytes());
    let desc = match plsr::scene::file::load_contents(&scene) {
        Ok(contents) => contents.description,
        Err(e) => {
            return crate::common::assert_clean_error(&e.to_string(), &["t.obj", ".mtl"]);
        }
    };
    match plsr::scene::Scene::build(desc) {
        Ok(scene) => crate::common::render_if_small(&scene, 64),
        Err(e) => assert!(!e.to_string().trim().is_empty()),
    }
}
