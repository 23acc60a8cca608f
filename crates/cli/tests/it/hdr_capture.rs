//! `plsr hdr capture` closes the HDR loop: a scene's panorama rendered at a
//! position, photographed as 8-bit brackets with EXIF through a simulated
//! camera, merged back by `plsr hdr merge`, agrees with the rendered truth.

use plsr::film::Film;
use std::path::Path;
use std::process::Command;

fn plsr(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(args)
        .output()
        .unwrap()
}

const SCENE: &str = r#"
[render]
spp = 16
max_depth = 4
seed = 3

[camera]
position = [0, -3, 1]
look_at = [0, 0, 0.5]
up = [0, 0, 1]
vfov = 40
resolution = [8, 8]

[environment]
radiance = [0.05, 0.06, 0.08]

[[materials]]
name = "grey"
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]

[[shapes]]
type = "rectangle"
material = "grey"
transform = { scale = 5 }

[[shapes]]
type = "sphere"
center = [0, 0, 0.5]
radius = 0.5
material = "grey"

# A small bright panel: a sun-like source three decades above the sky.
[[shapes]]
type = "rectangle"
emission = [80, 75, 70]
flip_normals = true
transform = { scale = 0.3, translate = [1, 1, 3] }
"#;

fn read_exr(p: &Path) -> Film {
    plsr::film::Film::read_exr(p).unwrap()
}

/// Captures SCENE at (0, −1.5, 1) with `extra` arguments and merges the
/// brackets back from their EXIF alone: the rendered truth, the merge, the
/// number of brackets and what the capture printed.
fn capture_and_merge(dir: &Path, extra: &[&str]) -> (Film, Film, usize, String) {
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let out = dir.join("capture");
    let mut args = vec![
        "hdr",
        "capture",
        scene.to_str().unwrap(),
        "--at",
        "0,-1.5,1",
        "-o",
        out.to_str().unwrap(),
        "--size",
        "128,64",
    ];
    args.extend(extra);
    let o = plsr(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let printed = String::from_utf8_lossy(&o.stdout).into_owned();
    let mut brackets: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "tif"))
        .map(|p| p.to_str().unwrap().to_string())
        .collect();
    brackets.sort();
    // Merge with exposure times from EXIF only.
    let pano = dir.join("pano.exr");
    let mut args = vec!["hdr", "merge", "--quiet", "-o", pano.to_str().unwrap()];
    args.extend(brackets.iter().map(String::as_str));
    let o = plsr(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (truth, merged) = (read_exr(&out.join("truth.exr")), read_exr(&pano));
    assert_eq!((truth.width, truth.height), (merged.width, merged.height));
    (truth, merged, brackets.len(), printed)
}

/// Log-space RMSE of `merged` against `truth` after the best global scale,
/// over the values of `truth` in `range`.
fn log_rmse(truth: &Film, merged: &Film, range: std::ops::Range<f64>) -> f64 {
    let logs: Vec<f64> = truth
        .color
        .iter()
        .zip(&merged.color)
        .flat_map(|(t, m)| (0..3).map(move |c| (t[c] as f64, m[c] as f64)))
        .filter(|&(t, _)| range.contains(&t))
        .map(|(t, m)| (m.max(1e-6) / t).ln())
        .collect();
    let mean = logs.iter().sum::<f64>() / logs.len() as f64;
    (logs.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / logs.len() as f64).sqrt()
}

/// The brightest value of the image over its sky (pixel (64, 2), red).
fn range_over_sky(f: &Film) -> f32 {
    let max = f.color.iter().fold(0.0f32, |a, c| a.max(c.max_element()));
    max / f.color[f.index(64, 2)].x
}

#[test]
fn captured_brackets_merge_back_to_the_rendered_panorama() {
    // Default exposures: chosen from the panorama's dynamic range, so the
    // panel (radiance 80, which the paper's shortest 1/30 s clips) is kept.
    let dir = tempfile::tempdir().unwrap();
    let (truth, merged, count, printed) = capture_and_merge(dir.path(), &[]);
    assert!(
        printed.contains("exposures from the panorama's dynamic range"),
        "{printed}"
    );
    assert!((3..=16).contains(&count), "{count} brackets");
    let rmse = log_rmse(&truth, &merged, 1e-3..f64::INFINITY);
    assert!(rmse < 0.15, "log-RMSE {rmse}");
    // The panel's radiance over the sky's, as rendered, within 10 %.
    let (t, m) = (range_over_sky(&truth), range_over_sky(&merged));
    assert!(t > 1000.0, "truth's range {t}");
    assert!((m / t - 1.0).abs() < 0.1, "merged range {m}, truth {t}");
    // The bright values alone are right too.
    let bright = log_rmse(&truth, &merged, 30.0..f64::INFINITY);
    assert!(bright < 0.1, "log-RMSE of the bright values {bright}");

    // The paper's ten exposures: the merge holds the sky but clips the
    // panel to about what 1/30 s records.
    let dir = tempfile::tempdir().unwrap();
    let (truth, merged, count, printed) = capture_and_merge(dir.path(), &["--exposures", "paper"]);
    assert_eq!(count, 10, "the paper's ten exposures");
    assert!(printed.contains("exposures: 1/30, 1/15,"), "{printed}");
    let rmse = log_rmse(&truth, &merged, 1e-3..30.0);
    assert!(rmse < 0.15, "log-RMSE {rmse} below the clip point");
    let (t, m) = (range_over_sky(&truth), range_over_sky(&merged));
    assert!(m > 100.0 && m < 0.7 * t, "merged range {m}, truth {t}");
}

#[test]
fn capture_refuses_bad_input_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let busy = dir.path().join("busy");
    std::fs::create_dir(&busy).unwrap();
    std::fs::write(busy.join("keep.txt"), "x").unwrap();
    for (args, fragment) in [
        (vec!["--at", "0,0", "-o", "out1"], "--at"),
        (
            vec!["--at", "0,0,1", "-o", "out2", "--size", "64"],
            "--size",
        ),
        (
            vec!["--at", "0,0,1", "-o", "out3", "--exposures", "1/30"],
            "two",
        ),
        (
            vec!["--at", "0,0,1", "-o", "out4", "--format", "bmp"],
            "format",
        ),
        (
            vec!["--at", "0,0,1", "-o", busy.to_str().unwrap()],
            "not empty",
        ),
    ] {
        let mut all = vec!["hdr", "capture", scene.to_str().unwrap()];
        let args: Vec<String> = args
            .iter()
            .map(|a| {
                if a.starts_with("out") {
                    dir.path().join(a).to_str().unwrap().to_string()
                } else {
                    a.to_string()
                }
            })
            .collect();
        all.extend(args.iter().map(String::as_str));
        let o = plsr(&all);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{all:?}: {err}");
        assert!(
            err.contains(fragment) && !err.contains("panicked"),
            "{all:?}: {err}"
        );
    }
    // Nothing but the scene and the untouched folder.
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["busy", "scene.toml"]);
    assert_eq!(std::fs::read_dir(&busy).unwrap().count(), 1);
}
