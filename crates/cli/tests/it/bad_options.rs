//! Command-line options are checked as strictly as scene files: a bad
//! value exits with 1 before any work, names the option and the fault, and
//! writes nothing.

use plsr_testkit as common;

use common::SMALL_SCENE;
use std::process::Command;

/// Runs `plsr render scene.toml -o out.exr --png out.png ARGS`; checks exit
/// status 1, the option and fault in the message, and no output.
fn refused(args: &[&str], option: &str, fault: &str) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.toml"), SMALL_SCENE).unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .current_dir(dir.path())
        .args([
            "render",
            "scene.toml",
            "-o",
            "out.exr",
            "--png",
            "out.png",
            "--quiet",
        ])
        .args(args)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        stderr.contains(option) && stderr.contains(fault),
        "{args:?}: {stderr}"
    );
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(left.len(), 1, "{args:?}: only the scene remains");
}

#[test]
fn exposure_must_be_finite_and_in_range() {
    refused(&["--exposure", "NaN"], "--exposure", "between -64 and 64");
    refused(&["--exposure", "inf"], "--exposure", "between -64 and 64");
    refused(&["--exposure", "-65"], "--exposure", "got -65");
}

#[test]
fn tile_size_must_be_positive_and_bounded() {
    refused(&["--tile-size", "0"], "--tile-size 0", "between 1 and 4096");
    refused(
        &["--tile-size", "5000"],
        "--tile-size 5000",
        "between 1 and 4096",
    );
}

#[test]
fn roulette_depth_is_bounded() {
    refused(&["--rr-depth", "5000"], "--rr-depth 5000", "at most 1024");
}

#[test]
fn thread_counts_are_capped() {
    refused(&["--threads", "100000"], "thread count 100000", "per core");
    refused(&["--threads", "0"], "thread count", "at least 1");
    // Checked before the memory estimate, which grows with the threads.
    refused(
        &["--threads", "100000", "--resolution", "32,24"],
        "thread count 100000",
        "per core",
    );
}

#[test]
fn the_c_abi_refuses_the_same_exposures() {
    assert!(plsr::film::check_exposure_stops(64.0).is_ok());
    assert!(plsr::film::check_exposure_stops(-64.0).is_ok());
    assert!(plsr::film::check_exposure_stops(f32::NAN).is_err());
    assert!(plsr::film::check_exposure_stops(f32::INFINITY).is_err());
    assert!(plsr::threads::thread_pool(Some(plsr::threads::max_threads() + 1)).is_err());
}

#[test]
fn nf_has_one_range_everywhere() {
    // The command line: `plsr pls check --nf`.
    for nf in ["0", "100000000", "4294967295"] {
        let output = Command::new(env!("CARGO_BIN_EXE_plsr"))
            .args(["pls", "check", "assets/lights/paper.toml", "--nf", nf])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "--nf {nf}: {stderr}");
        assert!(
            stderr.contains("--nf") && stderr.contains("between 1 and 4096"),
            "{stderr}"
        );
    }
    // The library's one check.
    assert_eq!(plsr::light::pls::check_nf(32), Ok(32));
    assert!(plsr::light::pls::check_nf(0).is_err());
    assert!(plsr::light::pls::check_nf(4097).is_err());
}

#[test]
fn resolution_overrides_the_scene_and_is_checked() {
    refused(&["--resolution", "0,8"], "--resolution 0,8", "not a size");
    refused(&["--resolution", "8"], "--resolution 8", "expected W,H");
    // One spelling of sizes: W,H, and the other is refused with it.
    refused(
        &["--resolution", "640x480"],
        "--resolution 640x480",
        "sizes are written W,H in plsr: --resolution 640,480",
    );
    refused(
        &["--resolution", "70000,8"],
        "--resolution",
        "from 1 to 65536",
    );
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.toml"), SMALL_SCENE).unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .current_dir(dir.path())
        .args([
            "render",
            "scene.toml",
            "-o",
            "out.exr",
            "-q",
            "--resolution",
            "12,5",
        ])
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let film = plsr::film::Film::read_exr(&dir.path().join("out.exr")).unwrap();
    assert_eq!((film.width, film.height), (12, 5));
}

#[test]
fn an_animation_time_is_for_gltf_files_only() {
    // A plsr scene's `gltf` shape takes `time`; --anim-time is for a glTF
    // file given as the scene.
    refused(&["--anim-time", "1.5"], "--anim-time 1.5", "time = 1.5");
}
