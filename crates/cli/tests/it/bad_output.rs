//! Outputs never destroy a user's file: `plsr render` refuses an output
//! that is the scene file, a folder, another output or of the wrong
//! format before rendering, and commits its EXR and PNG together or not at
//! all. Every case exits with 1, names the file, writes nothing, and leaves
//! every file that was there byte for byte.

use plsr_testkit as common;

use common::SMALL_SCENE;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Every file under `dir` (recursively) with its bytes.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let bytes = std::fs::read(&p).unwrap();
                out.push((p, bytes));
            }
        }
    }
    out.sort();
    out
}

/// Asserts that `dir` holds exactly the files of `before`, byte for byte;
/// the message names the files that changed, appeared or vanished.
fn assert_unchanged(dir: &Path, before: &[(PathBuf, Vec<u8>)], what: &str) {
    let after = snapshot(dir);
    if after != before {
        let names = |s: &[(PathBuf, Vec<u8>)]| -> Vec<String> {
            s.iter()
                .map(|(p, b)| format!("{} ({} bytes)", p.display(), b.len()))
                .collect()
        };
        panic!(
            "{what}: files changed\nbefore: {:?}\nafter: {:?}",
            names(before),
            names(&after)
        );
    }
}

/// Runs `plsr render scene.toml ARGS` in a folder holding the scene, an
/// old `old.exr` and a folder `d.png`; checks that it fails with status 1,
/// that the message names `names` and says `fault`, and that no file
/// changed, appeared or vanished.
fn refused(args: &[&str], names: &str, fault: &str) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.toml"), SMALL_SCENE).unwrap();
    std::fs::write(dir.path().join("old.exr"), b"an old image").unwrap();
    std::fs::create_dir(dir.path().join("d.png")).unwrap();
    let before = snapshot(dir.path());
    let output = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .current_dir(dir.path())
        .args(["render", "scene.toml", "--quiet"])
        .args(args)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(stderr.contains(names), "{args:?}: names {names}: {stderr}");
    assert!(stderr.contains(fault), "{args:?}: says {fault}: {stderr}");
    assert_unchanged(dir.path(), &before, &format!("{args:?}: files changed"));
}

#[test]
fn the_scene_file_is_never_an_output() {
    refused(&["-o", "scene.toml"], "scene.toml", "OpenEXR");
    // Named as an EXR through a link, it is still the scene.
    #[cfg(unix)]
    {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("scene.toml");
        std::fs::write(&scene, SMALL_SCENE).unwrap();
        std::os::unix::fs::symlink(&scene, dir.path().join("link.exr")).unwrap();
        let before = snapshot(dir.path());
        let output = Command::new(env!("CARGO_BIN_EXE_plsr"))
            .current_dir(dir.path())
            .args(["render", "scene.toml", "--quiet", "-o", "link.exr"])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains("scene file"), "{stderr}");
        assert_unchanged(dir.path(), &before, "");
    }
}

#[test]
fn outputs_of_the_wrong_format_are_refused() {
    refused(&["-o", "out.png"], "out.png", "name the file `.exr`");
    refused(
        &["-o", "t.exr", "--png", "t.exr"],
        "t.exr",
        "name the file `.png`",
    );
    refused(&["-o", "old.exr", "--png", "x.jpg"], "x.jpg", "`.png`");
}

#[test]
fn a_folder_is_not_an_output_and_nothing_is_replaced() {
    // The PNG is a folder: old.exr must not be replaced.
    refused(&["-o", "old.exr", "--png", "d.png"], "d.png", "folder");
    refused(&["-o", "missing/out.exr"], "missing", "does not exist");
}

#[test]
fn both_outputs_are_written_together() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.toml"), SMALL_SCENE).unwrap();
    let status = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .current_dir(dir.path())
        .args([
            "render",
            "scene.toml",
            "--quiet",
            "-o",
            "a.exr",
            "--png",
            "a.png",
        ])
        .status()
        .unwrap();
    assert!(status.success());
    assert!(plsr::film::Film::read_exr(&dir.path().join("a.exr")).is_ok());
    let png = std::fs::read(dir.path().join("a.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG", "a PNG named .png");
    // No temporary file is left next to them.
    let mut names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["a.exr", "a.png", "scene.toml"]);
}

/// A folder with two small float brackets (1/8 s and 2 s) of a synthetic
/// scene, and their paths.
fn two_brackets() -> (tempfile::TempDir, Vec<PathBuf>) {
    use plsr_hdr::synth::{write_brackets, BracketOptions, CameraModel, SyntheticScene};
    let dir = tempfile::tempdir().unwrap();
    let brackets = write_brackets(
        &SyntheticScene::new(32, 16),
        &CameraModel::linear(),
        &[1.0 / 8.0, 2.0],
        dir.path(),
        &BracketOptions {
            extension: "exr".into(),
            ..Default::default()
        },
    )
    .unwrap();
    (dir, brackets)
}

#[test]
fn hdr_merge_never_writes_over_a_bracket() {
    let (dir, brackets) = two_brackets();
    let before = snapshot(dir.path());
    let first = brackets[0].to_str().unwrap();
    for extra in [
        vec!["-o", first],
        vec!["-o", "pano.exr", "--curve", first],
        vec!["-o", "pano.exr", "--curve", "pano.exr"],
    ] {
        let output = Command::new(env!("CARGO_BIN_EXE_plsr"))
            .current_dir(dir.path())
            .args(["hdr", "merge", "--quiet", "--exposures", "0.125,2"])
            .args(&brackets)
            .args(&extra)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{extra:?}: {stderr}");
        assert!(
            stderr.contains("overwritten") || stderr.contains("same file"),
            "{extra:?}: {stderr}"
        );
        assert_unchanged(dir.path(), &before, &format!("{extra:?}: files changed"));
    }
}

#[test]
fn hdr_merge_refuses_unknown_compressions() {
    let (dir, brackets) = two_brackets();
    let before = snapshot(dir.path());
    for (out, compression, fault) in [
        ("pano.exr", "bogus", "not an OpenEXR compression"),
        ("pano.exr", "zip:x", "level"),
        ("pano.hdr", "zip", "only OpenEXR"),
    ] {
        let output = Command::new(env!("CARGO_BIN_EXE_plsr"))
            .current_dir(dir.path())
            .args(["hdr", "merge", "--quiet", "--exposures", "0.125,2"])
            .args(&brackets)
            .args(["-o", out, "--compression", compression])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{compression}: {stderr}");
        assert!(
            stderr.contains(compression) && stderr.contains(fault),
            "{compression}: {stderr}"
        );
        assert_unchanged(
            dir.path(),
            &before,
            &format!("{compression}: files changed"),
        );
    }
    // A known one with a level still merges.
    let status = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .current_dir(dir.path())
        .args(["hdr", "merge", "--quiet", "--exposures", "0.125,2"])
        .args(&brackets)
        .args(["-o", "pano.exr", "--compression", "zip:4"])
        .status()
        .unwrap();
    assert!(status.success());
}

/// A scene reading an OBJ with an MTL library, a PNG texture and an EXR
/// environment, written next to it in `dir`.
fn scene_with_inputs(dir: &Path) {
    // An EXR and a PNG to read, made by rendering the small scene.
    std::fs::write(dir.join("small.toml"), SMALL_SCENE).unwrap();
    let status = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .current_dir(dir)
        .args(["render", "small.toml", "--quiet", "-o", "sky.exr"])
        .args(["--png", "tex.png"])
        .status()
        .unwrap();
    assert!(status.success());
    std::fs::write(dir.join("m.mtl"), "newmtl red\nKd 0.8 0.1 0.1\n").unwrap();
    std::fs::write(
        dir.join("m.obj"),
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n",
    )
    .unwrap();
    let scene = SMALL_SCENE.replace(
        "[[shapes]]",
        r#"[environment]
file = "sky.exr"
up = [0, 0, 1]
forward = [0, 1, 0]

[[materials]]
name = "textured"
type = "diffuse"
base_color_map = "tex.png"

[[shapes]]
type = "obj"
file = "m.obj"

[[shapes]]
type = "rectangle"
material = "textured"

[[shapes]]"#,
    );
    std::fs::write(dir.join("scene.toml"), scene).unwrap();
}

#[test]
fn no_output_replaces_a_file_the_scene_reads() {
    let dir = tempfile::tempdir().unwrap();
    scene_with_inputs(dir.path());
    let (_, inputs) = plsr::scene::file::load_with_inputs(&dir.path().join("scene.toml")).unwrap();
    let names: Vec<_> = inputs
        .iter()
        .map(|p| p.file_name().unwrap().to_str().unwrap())
        .collect();
    assert_eq!(
        names,
        ["tex.png", "m.obj", "m.mtl", "sky.exr"],
        "{inputs:?}"
    );
    let before = snapshot(dir.path());
    for args in [
        vec!["-o", "sky.exr"],
        vec!["-o", "new.exr", "--png", "tex.png"],
        vec!["-o", "./sky.exr"],
    ] {
        let output = Command::new(env!("CARGO_BIN_EXE_plsr"))
            .current_dir(dir.path())
            .args(["render", "scene.toml", "--quiet"])
            .args(&args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(
            stderr.contains("which the scene reads"),
            "{args:?}: {stderr}"
        );
        assert_unchanged(dir.path(), &before, &format!("{args:?}: files changed"));
    }
}

/// Whether `dir` holds a temporary output (`.NAME….partial…`).
fn has_partial(dir: &Path) -> bool {
    std::fs::read_dir(dir).unwrap().any(|e| {
        e.unwrap()
            .file_name()
            .to_string_lossy()
            .contains(".partial")
    })
}

#[test]
#[cfg(unix)]
fn an_interrupted_merge_leaves_no_partial_file() {
    use plsr_hdr::synth::{write_brackets, BracketOptions, CameraModel, SyntheticScene};
    use std::time::{Duration, Instant};
    let dir = tempfile::tempdir().unwrap();
    // Large enough that the merge pass, which streams rows into the
    // temporary output, lasts long enough to be interrupted.
    let brackets = write_brackets(
        &SyntheticScene::new(3072, 1536),
        &CameraModel::linear(),
        &[1.0 / 8.0, 1.0 / 2.0, 2.0],
        dir.path(),
        &BracketOptions {
            extension: "tif".into(),
            ..Default::default()
        },
    )
    .unwrap();
    std::fs::write(dir.path().join("pano.exr"), b"yesterday's panorama").unwrap();
    let before = snapshot(dir.path());
    for (signal, name) in [(2, "INT"), (15, "TERM")] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_plsr"))
            .current_dir(dir.path())
            .args(["hdr", "merge", "--quiet", "--exposures", "0.125,0.5,2"])
            .args(&brackets)
            .args(["-o", "pano.exr", "--threads", "1"])
            .spawn()
            .unwrap();
        // Signal as soon as the temporary output exists.
        let start = Instant::now();
        while !has_partial(dir.path()) {
            assert!(
                child.try_wait().unwrap().is_none(),
                "the merge ended before it could be interrupted"
            );
            assert!(
                start.elapsed() < Duration::from_secs(120),
                "no partial file"
            );
            std::thread::sleep(Duration::from_millis(1));
        }
        let killed = Command::new("kill")
            .args([format!("-{name}"), child.id().to_string()])
            .status()
            .unwrap();
        assert!(killed.success());
        let status = child.wait().unwrap();
        use std::os::unix::process::ExitStatusExt;
        assert_eq!(status.signal(), Some(signal), "{status:?}");
        assert!(!has_partial(dir.path()), "SIG{name} left a partial file");
        assert_unchanged(dir.path(), &before, &format!("SIG{name}: files changed"));
    }
}

#[test]
fn partials_of_killed_runs_are_swept_by_the_next() {
    let (dir, brackets) = two_brackets();
    // What `kill -9` during a merge leaves: a temporary of a process that
    // no longer runs (Linux pids stay below 2^22), next to the output.
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname").unwrap_or_default();
    let host: String = host
        .trim()
        .chars()
        .filter(|c| c.is_ascii_alphanumeric() || *c == '-')
        .take(32)
        .collect();
    let host = if host.is_empty() { "host".into() } else { host };
    let stale = dir
        .path()
        .join(format!(".pano.{host}.99999999.0.partial.exr"));
    std::fs::write(&stale, vec![0u8; 4096]).unwrap();
    let status = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .current_dir(dir.path())
        .args(["hdr", "merge", "--quiet", "--exposures", "0.125,2"])
        .args(&brackets)
        .args(["-o", "pano.exr"])
        .status()
        .unwrap();
    assert!(status.success());
    assert!(dir.path().join("pano.exr").is_file());
    assert!(!stale.exists(), "the stale partial was not swept");
    assert!(!has_partial(dir.path()));
}

/// Runs `sh -c script` in a private mount namespace (as root, or as a user
/// through a user namespace) with a 64 KiB tmpfs mounted on `full`; `None`
/// where this system allows neither.
#[cfg(target_os = "linux")]
fn on_a_tiny_disk(full: &Path, script: &str) -> Option<std::process::Output> {
    let mount = format!(
        "mount -t tmpfs -o size=64k tmpfs '{}' && {script}",
        full.display()
    );
    for unshare in [&["-m"][..], &["-r", "-m"][..]] {
        let output = Command::new("unshare")
            .args(unshare)
            .args(["sh", "-c", &mount])
            .output()
            .ok()?;
        let stderr = String::from_utf8_lossy(&output.stderr);
        if !(stderr.contains("unshare failed") || stderr.contains("mount:")) {
            return Some(output);
        }
    }
    None
}

#[test]
#[cfg(target_os = "linux")]
fn a_full_disk_says_so() {
    let (dir, brackets) = two_brackets();
    let full = dir.path().join("full");
    std::fs::create_dir(&full).unwrap();
    let plsr = env!("CARGO_BIN_EXE_plsr");
    let inputs: Vec<String> = brackets
        .iter()
        .map(|b| format!("'{}'", b.display()))
        .collect();
    // Fill the disk, then merge and render onto it.
    std::fs::write(dir.path().join("scene.toml"), SMALL_SCENE).unwrap();
    let script = format!(
        "head -c 100000 /dev/zero > full/filler 2>/dev/null; \
         '{plsr}' hdr merge --quiet --exposures 0.125,2 {} -o full/pano.exr; echo \"merge exit $?\" >&2; \
         '{plsr}' render --quiet scene.toml -o full/image.exr; echo \"render exit $?\" >&2; \
         ls -a full >&2",
        inputs.join(" ")
    );
    let Some(output) = on_a_tiny_disk(&full, &format!("cd '{}' && {script}", dir.path().display()))
    else {
        eprintln!("skipped: no mount namespace on this system");
        return;
    };
    let stderr = String::from_utf8_lossy(&output.stderr).to_lowercase();
    assert!(stderr.contains("merge exit 1"), "{stderr}");
    assert!(stderr.contains("render exit 1"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    for name in ["pano.exr", "image.exr"] {
        let line = stderr
            .lines()
            .find(|l| l.contains("error") && l.contains(name))
            .unwrap_or_else(|| panic!("no error names {name}: {stderr}"));
        assert!(line.contains("no space left on device"), "{stderr}");
    }
    // Only the filler is on the disk: no partial file left, none named.
    assert!(!stderr.contains(".partial"), "{stderr}");
    assert!(stderr.ends_with(".\n..\nfiller\n"), "{stderr}");
}

#[test]
fn a_curve_that_cannot_be_written_keeps_the_old_panorama() {
    let (dir, brackets) = two_brackets();
    std::fs::write(dir.path().join("pano.exr"), b"yesterday's panorama").unwrap();
    // The curve's plot would be curve.png, which is a folder.
    std::fs::create_dir(dir.path().join("curve.png")).unwrap();
    let before = snapshot(dir.path());
    let output = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .current_dir(dir.path())
        .args(["hdr", "merge", "--quiet", "--exposures", "0.125,2"])
        .args(&brackets)
        .args(["-o", "pano.exr", "--curve", "curve.csv"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("curve.png"), "{stderr}");
    assert_unchanged(dir.path(), &before, "files changed");
    assert!(!has_partial(dir.path()));
}

#[test]
fn equal_exposures_are_a_warning_and_all_equal_an_error() {
    let (dir, brackets) = two_brackets();
    let run = |files: &[&PathBuf], exposures: &str| {
        Command::new(env!("CARGO_BIN_EXE_plsr"))
            .current_dir(dir.path())
            .args(["hdr", "merge", "--quiet", "--exposures", exposures])
            .args(files)
            .args(["-o", "pano.exr"])
            .output()
            .unwrap()
    };
    let output = run(&[&brackets[0], &brackets[1]], "1/60,0.016666667");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("same exposure (1/60 s") && stderr.contains("at least two different"),
        "{stderr}"
    );
    assert!(!dir.path().join("pano.exr").exists());
    let output = run(&[&brackets[0], &brackets[0], &brackets[1]], "0.125,0.125,2");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    let name = brackets[0].file_name().unwrap().to_str().unwrap();
    assert!(
        stderr.contains("warning") && stderr.contains(name) && stderr.contains("1/8 s"),
        "{stderr}"
    );
}

/// A room small enough for a 64 KiB disk: a floor, a point light and a
/// virtual sphere; `PHOTO` is replaced by a `[photo]` table or nothing.
const TINY_ROOM: &str = r#"
[render]
spp = 4
max_depth = 2

[camera]
position = [0, -4, 3]
look_at = [0, 0, 0.3]
up = [0, 0, 1]
vfov = 40
resolution = [12, 8]

PHOTO

[[materials]]
name = "floor"
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]

[[shapes]]
type = "rectangle"
material = "floor"
transform = { scale = 3 }

[[lights]]
type = "point"
position = [1.5, -1, 3]
intensity = [6, 6, 6]

[[shapes]]
type = "sphere"
center = [0, 0, 0.5]
radius = 0.5
virtual = true
"#;

#[test]
#[cfg(target_os = "linux")]
fn merge_fit_and_composite_on_a_full_disk_keep_the_old_files_and_succeed_next_time() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let plsr = env!("CARGO_BIN_EXE_plsr");
    let run = |args: &[&str]| {
        let o = Command::new(plsr)
            .current_dir(d)
            .args(args)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    // The inputs, on the ordinary disk: a photo and two parts.
    std::fs::write(d.join("room.toml"), TINY_ROOM.replace("PHOTO", "")).unwrap();
    run(&["render", "room.toml", "-o", "photo.exr", "--quiet"]);
    run(&[
        "render",
        "room.toml",
        "--samples",
        "0..2",
        "-o",
        "a.exr",
        "--quiet",
    ]);
    run(&[
        "render",
        "room.toml",
        "--samples",
        "2..4",
        "-o",
        "b.exr",
        "--quiet",
    ]);
    let photo = "[photo]\nfile = \"photo.exr\"\nresponse = \"linear\"\nexposure = 1";
    std::fs::write(d.join("ar.toml"), TINY_ROOM.replace("PHOTO", photo)).unwrap();
    std::fs::create_dir(d.join("full")).unwrap();
    let commands = [
        ("merge", format!("'{plsr}' merge a.exr b.exr -o full/m.exr")),
        (
            "fit",
            format!(
                "'{plsr}' fit ar.toml -o full/fitted.toml --iterations 1 --param 'floor.*' --quiet"
            ),
        ),
        (
            "composite",
            format!("'{plsr}' composite ar.toml -o full/c.exr --quiet"),
        ),
    ];
    // Yesterday's outputs, then a filler to the brim; each command fails.
    // The filler goes, and each succeeds.
    let mut script = String::from(
        "echo old > full/m.exr; echo old > full/fitted.toml; echo old > full/c.exr; \
         head -c 100000 /dev/zero > full/filler 2>/dev/null; ",
    );
    for (name, command) in &commands {
        script += &format!("{command}; echo \"{name} on a full disk: $?\" >&2; ");
    }
    script += "cat full/m.exr full/fitted.toml full/c.exr >&2; ls -a full >&2; rm full/filler; ";
    for (name, command) in &commands {
        script += &format!("{command}; echo \"{name} next time: $?\" >&2; ");
    }
    script += "ls full >&2";
    let Some(output) = on_a_tiny_disk(
        &d.join("full"),
        &format!("cd '{}' && {script}", d.display()),
    ) else {
        eprintln!("skipped: no mount namespace on this system");
        return;
    };
    let stderr = String::from_utf8_lossy(&output.stderr).to_lowercase();
    assert!(!stderr.contains("panicked"), "{stderr}");
    for (name, _) in &commands {
        assert!(
            stderr.contains(&format!("{name} on a full disk: 1")),
            "{stderr}"
        );
        assert!(stderr.contains(&format!("{name} next time: 0")), "{stderr}");
    }
    assert!(stderr.contains("no space left on device"), "{stderr}");
    // The old files were whole after the failures, and nothing else was
    // left on the disk but the filler.
    assert!(
        stderr.contains("old\nold\nold\n.\n..\nc.exr\nfiller\nfitted.toml\nm.exr\n"),
        "{stderr}"
    );
    // Next time: the new outputs (fit's loss curve beside its scene).
    let listing = stderr.rsplit("next time: 0\n").next().unwrap();
    for name in ["c.exr", "fitted.toml", "fitted.loss.csv", "m.exr"] {
        assert!(listing.contains(name), "{name} missing: {stderr}");
    }
}
