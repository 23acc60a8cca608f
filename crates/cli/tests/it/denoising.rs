//! `plsr denoise` and the `--denoise` flags as a user runs them: the EXR
//! keeps the noisy colour beside the denoised one, the command and the
//! flag give the same image, parts are denoised only once merged, and bad
//! input (no guide layers, NaN pixels) gets a note or a clear refusal.

use plsr::atomic_write::OutputSet;
use plsr::film::Film;
use std::path::Path;
use std::process::Command;

const SCENE: &str = "tests/data/cornell-64.toml";

/// Runs `plsr ARGS`: (success, stderr).
fn plsr(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn render_denoise_keeps_the_noisy_colour_and_equals_plsr_denoise() {
    let dir = tempfile::tempdir().unwrap();
    let (plain, flagged, command) = (
        dir.path().join("plain.exr"),
        dir.path().join("flagged.exr"),
        dir.path().join("command.exr"),
    );
    let base = ["render", SCENE, "--spp", "8"];
    let (ok, err) = plsr(&[&base[..], &["-o", s(&plain)]].concat());
    assert!(ok, "{err}");
    let (ok, err) = plsr(&[&base[..], &["-o", s(&flagged), "--denoise"]].concat());
    assert!(ok, "{err}");
    assert!(err.contains("denoised (colour + albedo + normal)"), "{err}");
    let (ok, err) = plsr(&["denoise", s(&plain), "-o", s(&command)]);
    assert!(ok, "{err}");
    let (plain, flagged, command) = (
        Film::read_exr(&plain).unwrap(),
        Film::read_exr(&flagged).unwrap(),
        Film::read_exr(&command).unwrap(),
    );
    assert!(plain.noisy.is_none());
    assert_eq!(flagged.noisy.as_ref(), Some(&plain.color));
    assert_ne!(flagged.color, plain.color);
    assert_eq!(command.color, flagged.color);
    assert_eq!(command.noisy, flagged.noisy);
    assert_eq!(command.albedo, plain.albedo);
    // Denoising an output again starts from its noisy layer.
    let again = tempfile::tempdir().unwrap().keep().join("again.exr");
    let (ok, err) = plsr(&[
        "denoise",
        s(&dir.path().join("command.exr")),
        "-o",
        s(&again),
    ]);
    assert!(ok, "{err}");
    assert_eq!(Film::read_exr(&again).unwrap().color, flagged.color);
    let _ = std::fs::remove_dir_all(again.parent().unwrap());
}

/// Writes an EXR of only `R G B` layers.
fn write_rgb(path: &Path, w: u32, h: u32, color: impl Fn(usize) -> f32) {
    let n = (w * h) as usize;
    let layers: Vec<(String, Vec<f32>)> = ["R", "G", "B"]
        .iter()
        .map(|c| (c.to_string(), (0..n).map(&color).collect()))
        .collect();
    let mut outputs = OutputSet::new();
    plsr::film::stage_exr_layers(&mut outputs, path, w, h, &layers, &[]).unwrap();
    outputs.commit().unwrap();
}

#[test]
fn an_exr_without_guide_layers_is_denoised_from_its_colour_with_a_note() {
    let dir = tempfile::tempdir().unwrap();
    let (input, output) = (dir.path().join("rgb.exr"), dir.path().join("out.exr"));
    write_rgb(&input, 37, 29, |i| {
        0.5 + 0.4 * ((i * 7919 % 101) as f32 / 101.0 - 0.5)
    });
    let (ok, err) = plsr(&["denoise", s(&input), "-o", s(&output)]);
    assert!(ok, "{err}");
    assert!(
        err.contains("has no albedo.R/G/B layer: denoising the colour alone"),
        "{err}"
    );
    assert!(err.contains("denoised (colour)"), "{err}");
    let film = Film::read_exr(&output).unwrap();
    assert!(film.noisy.is_some());
    assert!(film.color.iter().all(|c| c.is_finite()));
}

#[test]
fn nan_pixels_are_refused_naming_the_file_and_their_count() {
    let dir = tempfile::tempdir().unwrap();
    let (input, output) = (dir.path().join("nan.exr"), dir.path().join("out.exr"));
    write_rgb(&input, 16, 16, |i| {
        if i == 3 || i == 200 {
            f32::NAN
        } else {
            0.5
        }
    });
    let (ok, err) = plsr(&["denoise", s(&input), "-o", s(&output)]);
    assert!(!ok);
    assert!(err.contains("nan.exr"), "{err}");
    assert!(err.contains("2 pixels are NaN or infinite"), "{err}");
    assert!(!output.exists());
    // Nor is the input replaced by the output.
    let (ok, err) = plsr(&["denoise", s(&input), "-o", s(&input)]);
    assert!(!ok && err.contains("is the input"), "{err}");
}

#[test]
fn parts_are_denoised_only_once_merged() {
    let dir = tempfile::tempdir().unwrap();
    let part = |name: &str| dir.path().join(name);
    let (ok, err) = plsr(&[
        "render",
        SCENE,
        "--samples",
        "0..4",
        "-o",
        s(&part("a.exr")),
        "--denoise",
    ]);
    assert!(
        !ok && err.contains("plsr merge PARTS… -o OUT.exr --denoise"),
        "{err}"
    );
    assert!(!part("a.exr").exists());
    for (name, range) in [("a.exr", "0..4"), ("b.exr", "4..8")] {
        let (ok, err) = plsr(&["render", SCENE, "--samples", range, "-o", s(&part(name))]);
        assert!(ok, "{err}");
    }
    let (a, b) = (part("a.exr"), part("b.exr"));
    let (ok, err) = plsr(&["merge", s(&a), s(&b), "-o", s(&part("plain.exr"))]);
    assert!(ok, "{err}");
    let (ok, err) = plsr(&[
        "merge",
        s(&a),
        s(&b),
        "-o",
        s(&part("denoised.exr")),
        "--denoise",
    ]);
    assert!(ok, "{err}");
    assert!(err.contains("at 8 spp, denoised"), "{err}");
    let plain = Film::read_exr(&part("plain.exr")).unwrap();
    let denoised = Film::read_exr(&part("denoised.exr")).unwrap();
    assert_eq!(denoised.noisy.as_ref(), Some(&plain.color));
    assert_ne!(denoised.color, plain.color);
}
