//! Bad input: each case is a clear error naming the file and the field, exits
//! with status 1 (not a panic), and writes no output file.

use std::path::Path;
use std::process::Command;

const CAMERA: &str = r#"
[camera]
position = [0, -3, 1]
look_at = [0, 0, 0]
up = [0, 0, 1]
vfov = 40
resolution = [8, 8]
"#;

/// Runs `plsr render` on `scene_text` in a fresh folder; returns stderr after
/// checking the common expectations.
fn expect_error(scene_text: &str, extra_args: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, scene_text).unwrap();
    let out = dir.path().join("out.exr");
    let png = dir.path().join("out.png");
    let output = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .arg("--png")
        .arg(&png)
        .arg("--quiet")
        .args(extra_args)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(1), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        stderr.contains("scene.toml"),
        "the error names the file: {stderr}"
    );
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(
        left,
        vec![std::ffi::OsString::from("scene.toml")],
        "no output written"
    );
    stderr
}

#[test]
fn missing_obj() {
    let e = expect_error(
        &format!("{CAMERA}\n[[shapes]]\ntype = \"obj\"\nfile = \"meshes/missing.obj\"\n"),
        &[],
    );
    assert!(e.contains("shapes[0].file"), "{e}");
    assert!(e.contains("missing.obj") && e.contains("not found"), "{e}");
}

#[test]
fn malformed_toml() {
    let e = expect_error(&format!("{CAMERA}\n[[shapes]\ntype = \"sphere\"\n"), &[]);
    assert!(e.contains("line 9"), "the error gives the line: {e}");
}

#[test]
fn nan_in_a_transform() {
    let e = expect_error(
        &format!(
            "{CAMERA}\n[[shapes]]\ntype = \"sphere\"\ntransform = {{ translate = [0, nan, 0] }}\n"
        ),
        &[],
    );
    assert!(e.contains("shapes[0].transform.translate[1]"), "{e}");
    assert!(e.contains("finite"), "{e}");
}

#[test]
fn nan_in_a_matrix() {
    let e = expect_error(
        &format!(
            "{CAMERA}\n[[shapes]]\ntype = \"rectangle\"\ntransform = {{ matrix = [[1,0,0,0],[0,1,0,0],[0,0,1,inf],[0,0,0,1]] }}\n"
        ),
        &[],
    );
    assert!(e.contains("shapes[0].transform.matrix[2][3]"), "{e}");
}

#[test]
fn negative_spp() {
    let e = expect_error(&format!("[render]\nspp = -4\n{CAMERA}"), &[]);
    assert!(e.contains("render.spp") && e.contains("-4"), "{e}");
}

#[test]
fn roulette_depth_out_of_range() {
    let e = expect_error(&format!("[render]\nrr_depth = 2000\n{CAMERA}"), &[]);
    assert!(e.contains("render.rr_depth"), "{e}");
    assert!(e.contains("2000"), "{e}");
}

#[test]
fn unknown_key() {
    let e = expect_error(&format!("[render]\nsamples = 4\n{CAMERA}"), &[]);
    assert!(e.contains("unknown field `samples`"), "{e}");
    assert!(
        e.contains("render.samples"),
        "the error names the field: {e}"
    );
    assert!(e.contains("line 2"), "{e}");
}

#[test]
fn wrong_type() {
    let e = expect_error(&format!("{CAMERA}\n[[shapes]]\ntype = \"sphere\"\n\n[[shapes]]\ntype = \"sphere\"\nradius = \"big\"\n"), &[]);
    assert!(e.contains("shapes[1].radius"), "{e}");
}

#[test]
fn missing_mtl_library() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("box.obj"),
        "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let scene = format!(
        "{CAMERA}\n[[shapes]]\ntype = \"obj\"\nfile = \"{}\"\n",
        dir.path().join("box.obj").display()
    );
    let e = expect_error(&scene, &[]);
    assert!(
        e.contains("shapes[0].file") && e.contains("gone.mtl"),
        "{e}"
    );
}

#[test]
fn missing_pls_file() {
    let e = expect_error(
        &format!("{CAMERA}\n[[pls]]\nfile = \"lights/none.toml\"\n"),
        &[],
    );
    assert!(e.contains("pls[0].file") && e.contains("none.toml"), "{e}");
}

#[test]
fn invalid_light_in_a_pls_file() {
    let dir = tempfile::tempdir().unwrap();
    let lights = dir.path().join("lights.toml");
    let text = std::fs::read_to_string("assets/lights/paper.toml")
        .unwrap()
        .replace("b = 7.011", "b = -7.011");
    std::fs::write(&lights, text).unwrap();
    let e = expect_error(
        &format!("{CAMERA}\n[[pls]]\nfile = \"{}\"\n", lights.display()),
        &[],
    );
    assert!(e.contains("lights.toml: lights[0] (flashlight).b"), "{e}");
}

#[test]
fn unknown_material_reference() {
    let e = expect_error(
        &format!("{CAMERA}\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"gold\"\n"),
        &[],
    );
    assert!(
        e.contains("shapes[0].material") && e.contains("gold"),
        "{e}"
    );
}

#[test]
fn reflectance_above_one() {
    let e = expect_error(
        &format!("{CAMERA}\n[[materials]]\nname = \"m\"\ntype = \"diffuse\"\nreflectance = [1.5, 0, 0]\n"),
        &[],
    );
    assert!(e.contains("materials[0].reflectance"), "{e}");
}

#[test]
fn camera_without_field_of_view() {
    let e = expect_error(
        "[camera]\nposition = [0, -3, 1]\nlook_at = [0, 0, 0]\nup = [0, 0, 1]\nresolution = [8, 8]\n",
        &[],
    );
    assert!(e.contains("camera.vfov"), "{e}");
}

#[test]
fn a_good_scene_renders_and_writes_both_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(
        &scene,
        format!("{CAMERA}\n[[shapes]]\ntype = \"sphere\"\nemission = [1, 1, 1]\n"),
    )
    .unwrap();
    let out = dir.path().join("out.exr");
    let png = dir.path().join("out.png");
    let status = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(["render", "--quiet", "--spp", "2"])
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .arg("--png")
        .arg(&png)
        .status()
        .unwrap();
    assert!(status.success());
    let film = plsr::film::Film::read_exr(&out).unwrap();
    assert_eq!((film.width, film.height, film.spp), (8, 8, 2));
    assert!(Path::new(&png).is_file());
    // The sphere emits 1 towards the camera: the centre pixel is 1.
    assert!((film.color[film.index(4, 4)].x - 1.0).abs() < 1e-6);
}

#[test]
fn a_light_too_small_to_render_is_refused_when_checked() {
    let dir = tempfile::tempdir().unwrap();
    let lights = dir.path().join("tiny.toml");
    let text = std::fs::read_to_string("assets/lights/paper.toml").unwrap();
    let d = text
        .lines()
        .find(|l| l.trim_start().starts_with("d ="))
        .expect("a d line");
    std::fs::write(&lights, text.replacen(d, "d = [0, 1e-30, 1e-30, 0]", 1)).unwrap();
    // `plsr pls check` and the renderer say the same.
    let output = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(["pls", "check"])
        .arg(&lights)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("tiny.toml") && stderr.contains(".d") && stderr.contains("area"),
        "{stderr}"
    );
    let e = expect_error(
        &format!("{CAMERA}\n[[pls]]\nfile = \"{}\"\n", lights.display()),
        &[],
    );
    assert!(e.contains("tiny.toml") && e.contains("area"), "{e}");
}

#[test]
fn a_zero_environment_up_is_blamed_on_up() {
    let dir = tempfile::tempdir().unwrap();
    let sky = dir.path().join("sky.exr");
    plsr::film::Film::new(4, 2).write_exr(&sky).unwrap();
    let e = expect_error(
        &format!(
            "{CAMERA}\n[environment]\nfile = \"{}\"\nup = [0, 0, 0]\nforward = [0, 1, 0]\n",
            sky.display()
        ),
        &[],
    );
    assert!(e.contains("environment.up") && e.contains("zero"), "{e}");
    let e = expect_error(
        &format!(
            "{CAMERA}\n[environment]\nfile = \"{}\"\nup = [0, 0, 1]\nforward = [0, 0, 2]\n",
            sky.display()
        ),
        &[],
    );
    assert!(
        e.contains("environment.forward") && e.contains("parallel"),
        "{e}"
    );
}

#[test]
fn an_image_larger_than_memory_is_refused_before_allocating() {
    // 2^32 pixels: about 1.3 TiB of film, more than any test machine has.
    let e = expect_error(
        &format!(
            "{}\n[[shapes]]\ntype = \"sphere\"\n",
            CAMERA.replace("[8, 8]", "[65536, 65536]")
        ),
        &[],
    );
    assert!(
        e.contains("camera.resolution") && e.contains("iB of memory") && e.contains("available"),
        "{e}"
    );
}

/// A file that is not a plsr scene — another program's scene, a mesh, a
/// binary file, XML that is not a Mitsuba scene — is "unsupported scene format", not a TOML syntax error.
#[test]
fn other_formats_are_unsupported_not_toml_errors() {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes, says) in [
        (
            "drawing.xml",
            b"<svg width=\"10\">\n</svg>\n".to_vec(),
            "XML whose root element is <svg>",
        ),
        (
            "drawing.toml",
            b"\n  <?xml version=\"1.0\"?>\n<svg/>".to_vec(),
            "not a Mitsuba 3 <scene>",
        ),
        ("bunny.obj", b"v 0 0 0\n".to_vec(), "a mesh"),
        (
            "scene.yaml",
            b"camera:\n  vfov: 40\n".to_vec(),
            "not a plsr scene file",
        ),
        (
            "noise.toml",
            vec![0xff, 0xfe, 0x00, 0x41],
            "not a text file",
        ),
    ] {
        let scene = dir.path().join(name);
        std::fs::write(&scene, &bytes).unwrap();
        let out = dir.path().join("out.exr");
        let output = Command::new(env!("CARGO_BIN_EXE_plsr"))
            .arg("render")
            .arg(&scene)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{name}: {stderr}");
        assert!(
            stderr.contains(name)
                && stderr.contains("unsupported scene format")
                && stderr.contains(says),
            "{name}: {stderr}"
        );
        assert!(!out.exists());
    }
}

#[test]
fn disk_segments_are_checked_and_cubes_take_none() {
    let e = expect_error(
        &format!("{CAMERA}\n[[shapes]]\ntype = \"disk\"\nsegments = 2\n"),
        &[],
    );
    assert!(
        e.contains("shapes[0].segments") && e.contains("between 3 and"),
        "{e}"
    );
    let e = expect_error(
        &format!("{CAMERA}\n[[shapes]]\ntype = \"cube\"\nsegments = 8\n"),
        &[],
    );
    assert!(
        e.contains("shapes[0]") && e.contains("not used by shapes of type `cube`"),
        "{e}"
    );
}
