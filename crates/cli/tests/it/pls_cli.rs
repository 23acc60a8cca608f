//! `plsr pls check | mesh | transform` end to end.

use std::path::Path;

use crate::plsr;

#[test]
fn check_prints_a_table_of_the_lights() {
    let (ok, out, err) = plsr(&["pls", "check", "assets/lights/paper.toml"]);
    assert!(ok, "{err}");
    assert!(
        out.contains("2 light(s)") && out.contains("intensity"),
        "{out}"
    );
    assert!(
        out.contains("| 0 | flashlight |") && out.contains("| 1 | lamp |"),
        "{out}"
    );
}

#[test]
fn check_rejects_a_bad_file_naming_light_and_parameter() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    let text = std::fs::read_to_string("assets/lights/paper.toml")
        .unwrap()
        .replace("a = 85.227", "a = 95");
    std::fs::write(&bad, text).unwrap();
    let (ok, _, err) = plsr(&["pls", "check", bad.to_str().unwrap()]);
    assert!(!ok);
    assert!(err.contains("bad.toml: lights[1] (lamp).a:"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn mesh_writes_an_obj_that_loads_back() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("lights.obj");
    let (ok, _, err) = plsr(&[
        "pls",
        "mesh",
        "assets/lights/paper.toml",
        "-o",
        obj.to_str().unwrap(),
        "--nf",
        "8",
    ]);
    assert!(ok, "{err}");
    let f = plsr::scene::shapes::load_obj(&obj, Path::new("test"), "obj").unwrap();
    assert_eq!(f.objects.len(), 2);
    assert_eq!(f.objects[0].name, "flashlight");
    // Flashlight: pointed ends, 8 quads → 14 triangles; lamp: 16.
    assert_eq!(f.objects[0].triangles.len(), 14);
    assert_eq!(f.objects[1].triangles.len(), 16);
}

#[test]
fn transform_moves_every_light_through_its_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("moved.toml");
    let (ok, _, err) = plsr(&[
        "pls",
        "transform",
        "assets/lights/paper.toml",
        "-o",
        out.to_str().unwrap(),
        "--translate",
        "1,0,-0.5",
    ]);
    assert!(ok, "{err}");
    let a = plsr::light::pls::file::load(Path::new("assets/lights/paper.toml")).unwrap();
    let b = plsr::light::pls::file::load(&out).unwrap();
    for (x, y) in a.lights.iter().zip(&b.lights) {
        assert!((y.g.e1 - x.g.e1 - glam::Vec3::new(1.0, 0.0, -0.5)).length() < 1e-6);
        assert_eq!((x.a_deg, x.c, x.b, x.g.d), (y.a_deg, y.c, y.b, y.g.d));
    }
    // A matrix and the flags agree.
    let out2 = dir.path().join("moved.json");
    let (ok, _, err) = plsr(&[
        "pls",
        "transform",
        "assets/lights/paper.toml",
        "-o",
        out2.to_str().unwrap(),
        "--matrix",
        "1 0 0 1  0 1 0 0  0 0 1 -0.5  0 0 0 1",
    ]);
    assert!(ok, "{err}");
    assert_eq!(plsr::light::pls::file::load(&out2).unwrap(), b);
    // A projective last row is refused and nothing is written.
    let out3 = dir.path().join("bad.toml");
    let (ok, _, err) = plsr(&[
        "pls",
        "transform",
        "assets/lights/paper.toml",
        "-o",
        out3.to_str().unwrap(),
        "--matrix",
        "1 0 0 0  0 1 0 0  0 0 1 0  0 0 1 1",
    ]);
    assert!(!ok && err.contains("last row"), "{err}");
    assert!(!out3.exists());
}
