//! Malformed MTL libraries are clean errors that name the library and the
//! line, never a panic (tobj's reader unwraps on some of them), from the
//! command line and from the library alike.

use std::path::Path;
use std::process::Command;

const OBJ: &str = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";

const SCENE: &str = r#"
[camera]
position = [0, 0, 3]
look_at = [0, 0, 0]
up = [0, 1, 0]
vfov = 40
resolution = [8, 8]

[[shapes]]
type = "obj"
file = "t.obj"
"#;

/// A folder with the scene, `t.obj` and `m.mtl` holding `mtl`.
fn folder(mtl: &[u8]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.toml"), SCENE).unwrap();
    std::fs::write(dir.path().join("t.obj"), OBJ).unwrap();
    std::fs::write(dir.path().join("m.mtl"), mtl).unwrap();
    dir
}

/// The error of rendering with this MTL, after checking exit status 1, no
/// panic text and no output.
fn cli_error(mtl: &[u8]) -> String {
    let dir = folder(mtl);
    let output = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .current_dir(dir.path())
        .args(["render", "scene.toml", "-o", "out.exr", "--quiet"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(!dir.path().join("out.exr").exists());
    // The library says the same, as an error rather than a panic.
    let err = plsr::scene::Scene::load(&dir.path().join("scene.toml"))
        .err()
        .expect("an error")
        .to_string();
    assert!(err.contains("m.mtl"), "{err}");
    stderr
}

#[test]
fn a_colour_with_two_values_names_the_line() {
    let e = cli_error(b"newmtl a\nKd 0.5 0.5\n");
    assert!(
        e.contains("m.mtl") && e.contains("line 2") && e.contains("three numbers"),
        "{e}"
    );
}

#[test]
fn words_for_numbers_name_the_line() {
    let e = cli_error(b"newmtl a\nNs 10\nKd red green blue\n");
    assert!(e.contains("line 3") && e.contains("`Kd`"), "{e}");
    let e = cli_error(b"newmtl a\nd opaque\n");
    assert!(e.contains("line 2") && e.contains("a number"), "{e}");
}

#[test]
fn random_bytes_are_not_a_library() {
    // A fixed pseudo-random byte string (xorshift), with control bytes.
    let mut x = 0x2545_f491_4f6c_dd1du64;
    let bytes: Vec<u8> = (0..512)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x as u8
        })
        .collect();
    let e = cli_error(&bytes);
    assert!(e.contains("not a text MTL library"), "{e}");
}

#[test]
fn random_text_is_not_a_library() {
    // 8 KiB of printable words and numbers, control bytes excluded: once
    // this rendered with no word of it.
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    let text: Vec<u8> = (0..8192)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            b"abcdefghijklmnopqrstuvwxyz0123456789 .\n"[(x % 39) as usize]
        })
        .collect();
    let e = cli_error(&text);
    assert!(
        e.contains("m.mtl") && e.contains("line 1") && e.contains("before any `newmtl`"),
        "{e}"
    );
    // A library of comments alone (an exporter's, for no materials) loads.
    let dir = folder(b"# Blender MTL File: 'None'\n# Material Count: 0\n");
    assert!(plsr::scene::Scene::load(&dir.path().join("scene.toml")).is_ok());
}

#[test]
fn a_good_library_still_loads() {
    let dir = folder(b"# a comment\nnewmtl a\nKd 0.5 0.25 0.125\nNs 10\nd 1\n");
    let scene = plsr::scene::Scene::load(&dir.path().join("scene.toml")).unwrap();
    let m = &scene.materials()[scene.meshes()[0].material as usize];
    assert_eq!(m.bsdf.albedo(), glam::Vec3::new(0.5, 0.25, 0.125));
    assert!(Path::new(&dir.path().join("t.obj")).is_file());
}

#[test]
fn latin1_comments_and_names_load() {
    // Older exporters write ISO 8859-1: "é" is the single byte 0xe9.
    let dir = folder(b"# mat\xe9riau\nnewmtl a\nKd 0.5 0.25 0.125\n");
    std::fs::write(
        dir.path().join("t.obj"),
        b"# cr\xe9\xe9 par un vieux logiciel\nmtllib m.mtl\no caf\xe9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n",
    )
    .unwrap();
    let scene = plsr::scene::Scene::load(&dir.path().join("scene.toml")).unwrap();
    assert_eq!(scene.meshes().len(), 1);
    assert!(
        scene.meshes()[0].name.contains("café"),
        "{}",
        scene.meshes()[0].name
    );
    let m = &scene.materials()[scene.meshes()[0].material as usize];
    assert_eq!(m.bsdf.albedo(), glam::Vec3::new(0.5, 0.25, 0.125));
}

/// The error of rendering a scene whose OBJ path is `target`, after
/// checking exit status 1, no panic text and no output.
#[cfg(unix)]
fn mesh_path_error(target: &Path) -> String {
    let dir = folder(b"newmtl a\nKd 1 1 1\n");
    std::fs::remove_file(dir.path().join("t.obj")).unwrap();
    std::os::unix::fs::symlink(target, dir.path().join("t.obj")).unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .current_dir(dir.path())
        .args(["render", "scene.toml", "-o", "out.exr", "--quiet"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(!dir.path().join("out.exr").exists());
    stderr
}

#[test]
#[cfg(unix)]
fn a_fifo_or_a_device_is_not_a_mesh() {
    // A FIFO with no writer would block a reader forever.
    let fifos = tempfile::tempdir().unwrap();
    let fifo = fifos.path().join("pipe.obj");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    for target in [fifo.as_path(), Path::new("/dev/null")] {
        let e = mesh_path_error(target);
        assert!(
            e.contains("t.obj") && e.contains("not a regular file") && !e.contains("not found"),
            "{e}"
        );
    }
    let e = mesh_path_error(fifos.path());
    assert!(e.contains("is a folder"), "{e}");
}

#[test]
fn loose_obj_files_that_tobj_reads_still_load() {
    // Normal and texture indices without any `vn`/`vt`, a point and a line
    // among the faces, CRLF line ends, a weight, a positive index naming a
    // vertex defined later: all load.
    let dir = folder(b"newmtl a\nKd 0.5 0.25 0.125\n");
    std::fs::write(
        dir.path().join("t.obj"),
        "mtllib m.mtl\r\nusemtl a\r\nf 1//1 2//2 4//3\r\nv 0 0 0\r\nv 1 0 0 1\r\nv 0 1 0\r\n\
         v 0 1 1\r\nf 2/1 3/1 1/1\r\np 1\r\nl 1 2\r\nf 1 2\r\nvt 0 0 0\r\n",
    )
    .unwrap();
    let scene = plsr::scene::Scene::load(&dir.path().join("scene.toml")).unwrap();
    assert_eq!(scene.meshes()[0].triangles.len(), 2);
    // Vertex colours on some vertices only: tobj cannot; the line is named.
    std::fs::write(
        dir.path().join("t.obj"),
        "v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let e = plsr::scene::Scene::load(&dir.path().join("scene.toml"))
        .err()
        .expect("refused")
        .to_string();
    assert!(
        e.contains("t.obj: line 2: a vertex without a colour"),
        "{e}"
    );
}
