//! Image metrics against their reference implementations: the scores of
//! `tests/fixtures/metrics/reference.json` were computed once by
//! `scripts/metrics_reference.py` (pyiqa's CW-SSIM, SSIM and PSNR, the
//! `lpips` package's LPIPS, `flip-evaluator`'s LDR- and HDR-FLIP); plsr's
//! agree within 1e-3 (CW-SSIM, SSIM, LPIPS), 1e-4 dB (PSNR) and 1e-4 (mean
//! FLIP, on PNG pairs and on half-float EXR pairs). And `plsr compare`
//! on bad input: clear errors, exit status 1.

use plsr_metrics::{compare_files, CompareOptions, Crop, CropSpec, Metric};
use std::path::{Path, PathBuf};
use std::process::Command;

fn fixtures() -> PathBuf {
    Path::new(plsr_testkit::REPO_ROOT).join("tests/fixtures/metrics")
}

fn reference() -> serde_json::Value {
    let text = std::fs::read_to_string(fixtures().join("reference.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn scores_agree_with_the_reference_implementations() {
    let doc = reference();
    let options = CompareOptions {
        metrics: Metric::ALL.to_vec(),
        ..CompareOptions::default()
    };
    let mut worst = [0.0f64; 5];
    let mut hdr_pairs = 0;
    for pair in doc["pairs"].as_array().unwrap() {
        let r = fixtures().join(pair["reference"].as_str().unwrap());
        let t = fixtures().join(pair["test"].as_str().unwrap());
        let report = compare_files(&r, &t, None, CropSpec::Whole, &options).unwrap();
        let hdr = pair["hdr"].as_bool().unwrap_or(false);
        assert_eq!(
            report.reference.hdr && report.test.hdr,
            hdr,
            "{}",
            t.display()
        );
        if hdr {
            // HDR-FLIP chose the reference's exposures.
            hdr_pairs += 1;
            let map = plsr_metrics::flip::hdr_flip(
                &report.reference,
                &report.test,
                &plsr_metrics::flip::FlipOptions::default(),
            )
            .unwrap();
            let e = map.exposures.unwrap();
            let want = pair["flip_exposures"].as_array().unwrap();
            assert!((e.start - want[0].as_f64().unwrap()).abs() < 1e-5, "{e:?}");
            assert!((e.stop - want[1].as_f64().unwrap()).abs() < 1e-5, "{e:?}");
            assert_eq!(e.count as u64, want[2].as_u64().unwrap());
        }
        for (k, (name, tolerance)) in [
            ("cwssim", 1e-3),
            ("ssim", 1e-3),
            ("psnr", 1e-4),
            ("lpips", 1e-3),
            ("flip", 1e-4),
        ]
        .into_iter()
        .enumerate()
        {
            let Some(mut want) = pair[name].as_f64() else {
                continue;
            };
            if name == "psnr" {
                // pyiqa adds 1e-8 to the mean squared error; plsr does not.
                want = -10.0 * (10f64.powf(-want / 10.0) - 1e-8).log10();
            }
            let got = report
                .scores
                .iter()
                .find(|s| s.metric.name() == name)
                .unwrap()
                .value;
            let error = (got - want).abs();
            worst[k] = worst[k].max(error);
            assert!(
                error <= tolerance,
                "{name} of {} against {}: plsr {got}, reference {want}",
                t.display(),
                r.display()
            );
        }
    }
    assert!(hdr_pairs >= 2, "the fixtures hold HDR pairs");
    eprintln!(
        "largest differences: CW-SSIM {:.2e}, SSIM {:.2e}, PSNR {:.2e} dB, LPIPS {:.2e}, FLIP {:.2e}",
        worst[0], worst[1], worst[2], worst[3], worst[4]
    );
}

#[test]
fn an_hdr_file_is_scored_through_the_fixed_display_operator() {
    // The photo as linear radiance in an EXR: srgb(clamp(x)) gives back the
    // PNG's values, so the scores match the PNG's.
    let dir = tempfile::tempdir().unwrap();
    let img = image::open(fixtures().join("photo.png")).unwrap().to_rgb8();
    let (w, h) = img.dimensions();
    let linear: Vec<f32> = img
        .as_raw()
        .iter()
        .map(|&v| plsr::texture::srgb_to_linear(v as f32 / 255.0))
        .collect();
    let exr = dir.path().join("photo.exr");
    plsr_hdr::oiio::write_image(
        &exr,
        w as usize,
        h as usize,
        3,
        plsr_hdr::oiio::PixelType::F32,
        &[],
        &linear,
    )
    .unwrap();
    let options = CompareOptions {
        metrics: vec![Metric::CwSsim, Metric::Ssim],
        ..CompareOptions::default()
    };
    let test = fixtures().join("noise.png");
    let from_png = compare_files(
        &fixtures().join("photo.png"),
        &test,
        None,
        CropSpec::Whole,
        &options,
    )
    .unwrap();
    let from_exr = compare_files(&exr, &test, None, CropSpec::Whole, &options).unwrap();
    assert!(from_exr.reference.hdr);
    for (a, b) in from_png.scores.iter().zip(&from_exr.scores) {
        assert!((a.value - b.value).abs() < 1e-4, "{a:?} vs {b:?}");
    }
}

#[test]
fn auto_crop_is_the_masks_box_with_a_margin_and_the_mask_restricts_pixel_metrics() {
    let options = CompareOptions {
        metrics: vec![Metric::Rmse],
        ..CompareOptions::default()
    };
    let f = fixtures();
    let report = compare_files(
        &f.join("photo.png"),
        &f.join("composite.png"),
        Some(&plsr_metrics::MaskSource {
            path: f.join("mask.png"),
            channel: None,
        }),
        CropSpec::Auto,
        &options,
    )
    .unwrap();
    let mask = image::open(f.join("mask.png")).unwrap().to_luma8();
    let (mut x0, mut y0, mut x1, mut y1) = (u32::MAX, u32::MAX, 0, 0);
    for (x, y, p) in mask.enumerate_pixels() {
        if p[0] > 127 {
            x0 = x0.min(x);
            y0 = y0.min(y);
            x1 = x1.max(x + 1);
            y1 = y1.max(y + 1);
        }
    }
    let m = plsr_metrics::AUTO_MARGIN as u32;
    let want = Crop {
        x: x0.saturating_sub(m) as usize,
        y: y0.saturating_sub(m) as usize,
        w: ((x1 + m).min(mask.width()) - x0.saturating_sub(m)) as usize,
        h: ((y1 + m).min(mask.height()) - y0.saturating_sub(m)) as usize,
    };
    assert!(
        want.w >= 64 && want.h >= 64,
        "the fixture's box is big enough: {want:?}"
    );
    assert_eq!(report.crop, want);
    // RMSE over the mask only: computed here from the PNGs.
    let a = image::open(f.join("photo.png")).unwrap().to_rgb8();
    let b = image::open(f.join("composite.png")).unwrap().to_rgb8();
    let (mut sum, mut n) = (0.0f64, 0);
    for (x, y, p) in mask.enumerate_pixels() {
        if p[0] > 127 {
            for c in 0..3 {
                let d = (a.get_pixel(x, y)[c] as f64 - b.get_pixel(x, y)[c] as f64) / 255.0;
                sum += d * d;
                n += 1;
            }
        }
    }
    assert_eq!(report.pixels * 3, n);
    assert!((report.scores[0].value - (sum / n as f64).sqrt()).abs() < 1e-6);
}

fn plsr() -> Command {
    Command::new(env!("CARGO_BIN_EXE_plsr"))
}

#[test]
fn plsr_compare_prints_scores_as_text_and_json_and_writes_a_map() {
    let dir = tempfile::tempdir().unwrap();
    let f = fixtures();
    let map = dir.path().join("map.png");
    let out = plsr()
        .args(["compare"])
        .arg(f.join("photo.png"))
        .arg(f.join("composite.png"))
        .args(["--mask"])
        .arg(f.join("mask.png"))
        .args(["--crop", "auto", "--json", "--map"])
        .arg(&map)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for m in ["cwssim", "lpips", "ssim", "psnr", "rmse", "flip"] {
        assert!(doc["scores"][m].is_number(), "{doc}");
    }
    let img = image::open(&map).unwrap();
    assert_eq!(
        [img.width() as u64, img.height() as u64],
        [
            doc["crop"][2].as_u64().unwrap() - doc["crop"][0].as_u64().unwrap(),
            doc["crop"][3].as_u64().unwrap() - doc["crop"][1].as_u64().unwrap()
        ]
    );
    let text = plsr()
        .args(["compare", "--metric", "ssim,psnr"])
        .arg(f.join("photo.png"))
        .arg(f.join("blur.png"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&text.stdout);
    assert!(
        stdout.contains("ssim") && stdout.contains("psnr") && !stdout.contains("cwssim"),
        "{stdout}"
    );
}

#[test]
fn bad_compare_input_is_a_clear_error_with_status_1_and_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let f = fixtures();
    // A 100×50 image and a 100×50 mask.
    let small = dir.path().join("small.png");
    image::RgbImage::from_pixel(100, 50, image::Rgb([255, 255, 255]))
        .save(&small)
        .unwrap();
    let empty = dir.path().join("empty.png");
    image::GrayImage::new(160, 120).save(&empty).unwrap();
    let map = dir.path().join("map.png");
    let cases: Vec<(Vec<std::ffi::OsString>, &str)> = vec![
        (
            vec![f.join("photo.png").into(), small.clone().into()],
            "must have the same size",
        ),
        (
            vec![
                f.join("photo.png").into(),
                f.join("blur.png").into(),
                "--mask".into(),
                empty.clone().into(),
            ],
            "the mask is empty",
        ),
        (
            vec![
                f.join("photo.png").into(),
                f.join("blur.png").into(),
                "--mask".into(),
                small.clone().into(),
            ],
            "the mask is 100×50 but the images are 160×120",
        ),
        (
            vec![
                f.join("photo.png").into(),
                f.join("blur.png").into(),
                "--crop".into(),
                "100,100,200,200".into(),
            ],
            "is not inside the 160×120 image",
        ),
        (
            vec![
                f.join("photo.png").into(),
                f.join("blur.png").into(),
                "--crop".into(),
                "auto".into(),
            ],
            "--crop auto needs --mask",
        ),
        (
            vec![
                f.join("photo.png").into(),
                f.join("blur.png").into(),
                "--metric".into(),
                "vif".into(),
            ],
            "unknown metric",
        ),
        (
            vec![
                f.join("photo.png").into(),
                f.join("blur.png").into(),
                "--crop".into(),
                "0,0,40,40".into(),
                "--map".into(),
                map.clone().into(),
            ],
            "at most 3 pyramid levels",
        ),
        (
            vec![
                f.join("photo.png").into(),
                dir.path().join("missing.png").into(),
            ],
            "missing.png",
        ),
        (
            vec![
                small.clone().into(),
                small.clone().into(),
                "--map".into(),
                small.clone().into(),
            ],
            "it would be overwritten",
        ),
    ];
    for (args, want) in cases {
        let out = plsr().arg("compare").args(&args).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains(want), "{args:?}: {stderr}");
    }
    assert!(!map.exists(), "no map is written when the comparison fails");
}

/// `--mask FILE:CHANNEL`: a matte in one channel of an EXR (as a
/// composite's `A`) masks as the same matte in a grey PNG does; without a
/// channel, an image whose channels differ is refused with the spelling
/// that names one, and an unknown channel lists those the file has.
#[test]
fn a_mask_is_read_from_the_channel_named() {
    let f = fixtures();
    let dir = tempfile::tempdir().unwrap();
    let mask = image::open(f.join("mask.png")).unwrap().to_luma8();
    let (w, h) = mask.dimensions();
    // R, G, B: a gradient; A: the mask.
    let mut film = plsr::film::Film::new(w, h);
    for (i, p) in mask.pixels().enumerate() {
        film.color[i] = glam::Vec3::new(i as f32 / (w * h) as f32, 0.3, 0.9);
        film.alpha[i] = p[0] as f32 / 255.0;
    }
    let exr = dir.path().join("matte.exr");
    film.write_exr(&exr).unwrap();
    let run = |mask: &str| {
        let o = plsr()
            .args([
                "compare", "--metric", "rmse", "--crop", "auto", "--json", "--mask", mask,
            ])
            .arg(f.join("photo.png"))
            .arg(f.join("composite.png"))
            .output()
            .unwrap();
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stdout).into_owned(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let (ok, from_png, err) = run(f.join("mask.png").to_str().unwrap());
    assert!(ok, "{err}");
    let (ok, from_exr, err) = run(&format!("{}:A", exr.display()));
    assert!(ok, "{err}");
    assert_eq!(from_png, from_exr);
    let (ok, _, err) = run(exr.to_str().unwrap());
    assert!(!ok && err.contains("matte.exr:A"), "{err}");
    let (ok, _, err) = run(&format!("{}:Q", exr.display()));
    assert!(
        !ok && err.contains("no such channel") && err.contains("Q"),
        "{err}"
    );
}
