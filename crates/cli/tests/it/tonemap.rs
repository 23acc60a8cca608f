//! `plsr tonemap`, `--exposure auto` and `plsr info`: automatic exposure
//! makes neither a dim nor a bright image black or blown out, and `info`
//! lists what an EXR holds.

use plsr_testkit as common;

use common::scenes::cornell_64;
use glam::Vec3;
use plsr::film::{auto_exposure_stops, Film};
use std::path::Path;

use crate::plsr;

/// A 64×32 image: a horizontal gradient over two decades of radiance,
/// times `scale`, with a small light 1000× brighter in one corner.
fn gradient(path: &Path, scale: f32) {
    let mut film = Film::new(64, 32);
    for y in 0..32 {
        for x in 0..64 {
            let v = scale * 10f32.powf(x as f32 / 32.0 - 1.0);
            let i = film.index(x, y);
            film.color[i] = if x < 3 && y < 3 {
                Vec3::splat(1000.0 * scale)
            } else {
                Vec3::new(v, 0.8 * v, 0.6 * v)
            };
        }
    }
    film.write_exr(path).unwrap();
}

/// (mean of the 8-bit values, fraction of pixels with a channel at 255).
fn png_stats(path: &Path) -> (f64, f64) {
    let img = image::open(path).unwrap().to_rgb8();
    let n = (img.width() * img.height()) as f64;
    let mean = img
        .pixels()
        .flat_map(|p| p.0)
        .map(|v| v as f64)
        .sum::<f64>()
        / (3.0 * n);
    let clipped = img.pixels().filter(|p| p.0.contains(&255)).count() as f64 / n;
    (mean, clipped)
}

#[test]
fn auto_exposure_neither_blacks_out_nor_blows_out() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (name, scale) in [("dim", 1e-4f32), ("mid", 0.2), ("bright", 5e4)] {
        let exr = d.join(format!("{name}.exr"));
        let png = d.join(format!("{name}.png"));
        gradient(&exr, scale);
        let (ok, _, err) = plsr(&[
            "tonemap",
            exr.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
        ]);
        assert!(ok, "{err}");
        let (mean, clipped) = png_stats(&png);
        assert!((60.0..200.0).contains(&mean), "{name}: mean {mean}");
        assert!(clipped <= 0.03, "{name}: {clipped} clipped");
    }
    // Without auto, the bright one is white and the dim one black: the
    // test images need the exposure chosen.
    let png = d.join("fixed.png");
    for (name, black) in [("bright", false), ("dim", true)] {
        let exr = d.join(format!("{name}.exr"));
        assert!(
            plsr(&[
                "tonemap",
                exr.to_str().unwrap(),
                "-o",
                png.to_str().unwrap(),
                "--exposure",
                "0"
            ])
            .0
        );
        let (mean, _) = png_stats(&png);
        assert!(
            if black { mean < 5.0 } else { mean > 250.0 },
            "{name}: {mean}"
        );
    }
    // The same exposure from render --png and merge --png.
    let exr = d.join("mid.exr");
    let (ok, _, err) = plsr(&[
        "tonemap",
        exr.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--exposure",
        "bright",
    ]);
    assert!(
        !ok && err.contains("expected `auto` or a number of stops"),
        "{err}"
    );
    let (ok, _, err) = plsr(&[
        "tonemap",
        d.join("none.exr").to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
    ]);
    assert!(!ok && err.contains("none.exr"), "{err}");
}

#[test]
fn auto_exposure_maps_the_key_to_middle_grey_and_limits_clipping() {
    // A uniform image: its key is its value.
    for v in [1e-3f32, 0.5, 40.0] {
        let stops = auto_exposure_stops(&vec![Vec3::splat(v); 100]);
        assert!((stops - (0.18 / v).log2()).abs() < 1e-4, "{v}: {stops}");
    }
    // 10 % of pixels 100× brighter: lowered until at most 2 % clip, but by
    // at most 2 stops.
    let mut img = vec![Vec3::splat(0.1); 900];
    img.extend(vec![Vec3::splat(10.0); 100]);
    let log_mean = 0.9 * 0.1f64.ln() + 0.1 * 10f64.ln();
    let key = (0.18f64.ln() - log_mean) / std::f64::consts::LN_2;
    let stops = auto_exposure_stops(&img) as f64;
    assert!((stops - (key - 2.0)).abs() < 1e-4, "{stops} vs key {key}");
    // Black or empty: no change.
    assert_eq!(auto_exposure_stops(&[Vec3::ZERO; 10]), 0.0);
    assert_eq!(auto_exposure_stops(&[]), 0.0);
}

#[test]
fn render_takes_auto_exposure_and_info_lists_an_exr() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let part = d.join("part.exr");
    let png = d.join("part.png");
    let (ok, _, err) = plsr(&[
        "render",
        "tests/data/cornell-64.toml",
        "-o",
        part.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
        "--samples",
        "0..2",
        "--exposure",
        "auto",
    ]);
    assert!(ok, "{err}");
    let (mean, _) = png_stats(&png);
    assert!((40.0..200.0).contains(&mean), "{mean}");
    let (ok, out, err) = plsr(&["info", part.to_str().unwrap()]);
    assert!(ok, "{err}");
    for want in [
        "64×64 pixels",
        "and 39 channels part.* of the render's exact sums",
        "resumable (plsr render --resume): samples 0..2 of the whole 64×64 image",
        "R (float)",
        "plsrPartSamples = \"0 2\"",
        "plsrSpp = 2",
    ] {
        assert!(out.contains(want), "{want} not in:\n{out}");
    }
    // A PNG is described too (size, channels, pixel type); a file that is
    // no image is an error naming it.
    let (ok, out, err) = plsr(&["info", png.to_str().unwrap()]);
    assert!(
        ok && out.contains("64×64 pixels, 3 channel(s)"),
        "{out}{err}"
    );
    let text = png.with_extension("txt");
    std::fs::write(&text, "not an image").unwrap();
    let (ok, _, err) = plsr(&["info", text.to_str().unwrap()]);
    assert!(
        !ok && err.contains("part.txt") && err.contains("cannot read as OpenEXR"),
        "{err}"
    );
}

/// The stops `render`/`merge` report for each PNG they write.
fn reported_stops(stderr: &str) -> Vec<f32> {
    stderr
        .lines()
        .filter_map(|l| {
            let (_, rest) = l.rsplit_once(".png (")?;
            rest.strip_suffix(" stops)")?.parse().ok()
        })
        .collect()
}

#[test]
fn default_png_exposure_is_the_scenes_or_auto() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let render = |scene: &Path, name: &str, exposure: Option<&str>| {
        let exr = d.join(format!("{name}.exr"));
        let png = d.join(format!("{name}.png"));
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "-o",
            exr.to_str().unwrap(),
            "--png",
            png.to_str().unwrap(),
            "--spp",
            "4",
        ];
        if let Some(e) = exposure {
            args.extend(["--exposure", e]);
        }
        let (ok, _, err) = plsr(&args);
        assert!(ok, "{err}");
        let stops = reported_stops(&err);
        assert_eq!(stops.len(), 1, "{err}");
        (std::fs::read(&png).unwrap(), exr, stops[0])
    };
    // No exposure stated: the default is auto, not 0 stops.
    let plain = cornell_64(d, "plain.toml", None, "");
    let (default_png, exr, stops) = render(&plain, "default", None);
    let (auto_png, _, _) = render(&plain, "auto", Some("auto"));
    let (zero_png, _, _) = render(&plain, "zero", Some("0"));
    assert_eq!(default_png, auto_png);
    assert_ne!(default_png, zero_png);
    let film = Film::read_exr(&exr).unwrap();
    assert!(
        (stops - auto_exposure_stops(&film.color)).abs() < 0.006,
        "{stops}"
    );
    let (mean, clipped) = png_stats(&d.join("default.png"));
    assert!((40.0..200.0).contains(&mean), "{mean}");
    assert!(clipped <= 0.03, "{clipped}");
    // A scene that states its exposure gets it, as it asked: here 9 stops
    // up, white, unless --exposure says otherwise.
    let bright = cornell_64(d, "bright.toml", None, "\n[film]\nexposure_ev = 9\n");
    let (stated_png, _, stops) = render(&bright, "stated", None);
    let (stated_zero, _, _) = render(&bright, "stated-zero", Some("0"));
    assert_eq!(stops, 0.0);
    assert_eq!(stated_png, stated_zero);
    assert!(png_stats(&d.join("stated.png")).0 > 200.0);
    let (_, _, stops) = render(&bright, "stated-auto", Some("auto"));
    assert!(stops < -7.0, "{stops}");
    // So does a camera's shutter, ISO and f-number.
    let camera = cornell_64(
        d,
        "camera.toml",
        None,
        "\n[film]\nshutter = 0.01\niso = 100\nf_number = 2\n",
    );
    assert_eq!(render(&camera, "camera", None).2, 0.0);

    // merge --png: the same default, from the parts' film settings.
    let part = d.join("part.exr");
    let (ok, _, err) = plsr(&[
        "render",
        plain.to_str().unwrap(),
        "-o",
        part.to_str().unwrap(),
        "--samples",
        "0..4",
    ]);
    assert!(ok, "{err}");
    let merged_png = d.join("merged.png");
    let (ok, _, err) = plsr(&[
        "merge",
        part.to_str().unwrap(),
        "-o",
        d.join("merged.exr").to_str().unwrap(),
        "--png",
        merged_png.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    assert_eq!(std::fs::read(&merged_png).unwrap(), default_png);
}

#[test]
fn a_sequence_keeps_the_first_frames_exposure() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The camera moves from the box's opening to a close view of a wall.
    let path_camera = "[camera]\nup = [0, 1, 0]\nvfov = 37\nresolution = [64, 64]\n\
        [[camera.path]]\nframe = 0\nposition = [278, 273, -800]\nlook_at = [278, 273, 0]\n\
        [[camera.path]]\nframe = 3\nposition = [450, 150, 100]\nlook_at = [0, 100, 300]";
    let scene = cornell_64(d, "anim.toml", Some(path_camera), "");
    let exr = d.join("f-{frame}.exr");
    let png = d.join("f-{frame}.png");
    let (ok, _, err) = plsr(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
        "--frames",
        "0..=3",
        "--spp",
        "2",
    ]);
    assert!(ok, "{err}");
    let stops = reported_stops(&err);
    assert_eq!(stops.len(), 4, "{err}");
    assert!(stops.iter().all(|&s| s == stops[0]), "{stops:?}");
    // Each frame's own auto exposure differs: without keeping the first
    // frame's, the sequence would flicker.
    let own: Vec<f32> = (0..=3)
        .map(|f| {
            let film = Film::read_exr(&d.join(format!("f-{f:04}.exr"))).unwrap();
            auto_exposure_stops(&film.color)
        })
        .collect();
    assert!((own[0] - stops[0]).abs() < 0.006, "{own:?} {stops:?}");
    assert!((own[3] - own[0]).abs() > 0.1, "{own:?}");
}

#[test]
fn an_exr_whose_data_window_is_inverted_is_refused_not_read_as_another_size() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("inverted.exr");
    gradient(&exr, 1.0);
    // dataWindow (box2i): min x, min y, max x, max y. Swap the corners.
    let mut bytes = std::fs::read(&exr).unwrap();
    let key = b"dataWindow\0box2i\0";
    let at = bytes
        .windows(key.len())
        .position(|w| w == key)
        .expect("a data window")
        + key.len()
        + 4;
    let (min, max) = (bytes[at..at + 8].to_vec(), bytes[at + 8..at + 16].to_vec());
    bytes[at..at + 8].copy_from_slice(&max);
    bytes[at + 8..at + 16].copy_from_slice(&min);
    std::fs::write(&exr, &bytes).unwrap();
    let png = dir.path().join("out.png");
    for args in [
        vec![
            "tonemap",
            exr.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
        ],
        vec!["info", exr.to_str().unwrap()],
    ] {
        let (ok, _, err) = plsr(&args);
        assert!(
            !ok && err.contains("inverted.exr") && err.contains("dataWindow"),
            "{args:?}: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
    assert!(!png.exists());
}

/// A crop's PNG takes the exposure of the whole frame (from a preview of
/// it), not its own: crops of one image match. Here a crop of the dark
/// floor corner would otherwise be exposed about a stop brighter.
#[test]
fn a_crop_s_png_takes_the_whole_frame_s_exposure() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = cornell_64(d, "c.toml", None, "");
    let stops_of = |extra: &[&str], name: &str| -> (f32, String) {
        let exr = d.join(format!("{name}.exr"));
        let png = d.join(format!("{name}.png"));
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "-o",
            exr.to_str().unwrap(),
            "--png",
            png.to_str().unwrap(),
            "--spp",
            "64",
        ];
        args.extend(extra);
        let (ok, _, err) = plsr(&args);
        assert!(ok, "{err}");
        let (_, rest) = err.rsplit_once(".png (").unwrap_or_else(|| panic!("{err}"));
        let stops: f32 = rest
            .split(" stops")
            .next()
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("{err}"));
        (stops, err)
    };
    let (whole, _) = stops_of(&[], "whole");
    let (crop, err) = stops_of(&["--crop", "0,40,24,64"], "crop");
    assert!(err.contains("stops, the whole frame's)"), "{err}");
    eprintln!("whole frame {whole:+.3} stops, crop {crop:+.3} stops");
    assert!((crop - whole).abs() < 0.15, "{crop} vs {whole}");
    // The crop's own auto exposure differs: the test is not vacuous.
    let film = Film::read_exr(&d.join("whole.exr")).unwrap();
    let w = film.width as usize;
    let window: Vec<Vec3> = (40..64)
        .flat_map(|y| (0..24).map(move |x| (x, y)))
        .map(|(x, y)| film.color[y * w + x])
        .collect();
    let own = auto_exposure_stops(&window);
    assert!((own - whole).abs() > 0.3, "own {own} vs whole {whole}");
}
