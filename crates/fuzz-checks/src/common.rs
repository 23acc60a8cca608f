//! What the checks share: a folder of fixture files that fuzzed inputs may
//! refer to, the file each input is written to, and the check that a
//! refusal is clean. Every target states the same property as the proptest
//! fuzzers (tests/it/fuzz_parsers.rs): a value that holds its invariants,
//! or an error that is not empty and names the file it is about. Under
//! libFuzzer, a panic, an abort, an allocation over `-malloc_limit_mb` or a
//! run over `-timeout` is a finding.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The folder the inputs are written to, made once per process, with the
/// fixtures generated inputs refer to: a PLS file (`lights.toml`), a
/// texture (`tex.png`), an environment (`sky.exr`), a mesh (`mesh.obj`
/// with `m.mtl`), a file of the wrong kind (`notamesh.obj`) and a folder
/// (`folder.obj`). It is `plsr-fuzz-PID` in the system's temporary folder;
/// the next process removes those whose process has ended.
pub fn workdir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        remove_ended_workdirs();
        let dir = std::env::temp_dir().join(format!("plsr-fuzz-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("the fuzz work folder can be made");
        make_fixtures(&dir);
        dir
    })
}

/// Removes the work folders of processes that are gone.
fn remove_ended_workdirs() {
    let Ok(entries) = std::fs::read_dir(std::env::temp_dir()) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name.to_str().and_then(|n| n.strip_prefix("plsr-fuzz-")) else {
            continue;
        };
        if pid.parse::<u32>().is_ok() && !Path::new("/proc").join(pid).exists() {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
}

fn make_fixtures(d: &Path) {
    std::fs::write(d.join("lights.toml"), PLS_FIXTURE).unwrap();
    let mut film = plsr::film::Film::new(4, 2);
    for (i, c) in film.color.iter_mut().enumerate() {
        *c = glam::Vec3::splat(i as f32 * 0.25);
    }
    film.write_exr(&d.join("sky.exr")).unwrap();
    film.write_png(&d.join("tex.png"), Default::default())
        .unwrap();
    std::fs::write(d.join("m.mtl"), "newmtl a\nKd 0.5 0.5 0.5\n").unwrap();
    std::fs::write(
        d.join("mesh.obj"),
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(d.join("notamesh.obj"), "[camera]\ntype = \"lens\"\n").unwrap();
    std::fs::create_dir_all(d.join("folder.obj")).unwrap();
}

/// A valid PLS file (the paper's lights), for scenes that name `lights.toml`.
const PLS_FIXTURE: &str = include_str!("../../../assets/lights/paper.toml");

/// Writes `bytes` to `name` in the work folder and returns its path.
pub fn input_file(name: &str, bytes: &[u8]) -> PathBuf {
    let path = workdir().join(name);
    std::fs::write(&path, bytes).expect("the fuzz input can be written");
    path
}

/// Panics (a finding) unless `message` is a clean refusal: not empty, and
/// naming one of `names` (the file it is about).
pub fn assert_clean_error(message: &str, names: &[&str]) {
    assert!(!message.trim().is_empty(), "an empty error message");
    assert!(
        names.iter().any(|n| message.contains(n)),
        "the error does not name the file ({names:?}): {message}"
    );
}

/// Splits `data` at the first `sep` byte: a fuzz input holding two files
/// (an OBJ and its MTL, a glTF and its buffer).
pub fn split_two(data: &[u8], sep: u8) -> (&[u8], &[u8]) {
    match data.iter().position(|&b| b == sep) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[]),
    }
}

/// Renders `scene` at 1 spp, depth 3, on one thread when its camera has at
/// most `max_pixels` pixels, and checks every pixel is finite. A render
/// that is refused must say why.
pub fn render_if_small(scene: &plsr::scene::Scene, max_pixels: u32) {
    use plsr::render::{render, RenderJob, RenderOptions};
    let cam = scene.camera();
    if cam.width() * cam.height() > max_pixels {
        return;
    }
    let job = RenderJob {
        spp: 1,
        max_depth: 3,
        ..scene.default_job()
    };
    let options = RenderOptions {
        threads: Some(1),
        ..Default::default()
    };
    match render(scene, &job, &options, &|_, _| true) {
        Ok((film, _)) => {
            let bad = film.color.iter().position(|c| !c.is_finite());
            assert!(bad.is_none(), "pixel {bad:?} is not finite");
        }
        Err(e) => assert!(!e.to_string().trim().is_empty(), "an empty render error"),
    }
}

/// Loads the scene file at `path`, builds it and renders it when small;
/// refusals must name `name` (or, for a failed build, say something).
pub fn check_scene_file(path: &Path, name: &str) {
    let desc = match plsr::scene::file::load_contents(path) {
        Ok(contents) => contents.description,
        Err(e) => return assert_clean_error(&e.to_string(), &[name]),
    };
    match plsr::scene::Scene::build(desc) {
        Ok(scene) => render_if_small(&scene, 64),
        Err(e) => assert!(!e.to_string().trim().is_empty(), "an empty build error"),
    }
}
