//! HDR merge (issue 5, items 1–4): round trips through simulated brackets,
//! response recovery, EXIF, clipped pixels, bad input through the CLI, and
//! OpenImageIO errors.

use plsr_hdr::align;
use plsr_hdr::merge::{
    self as merge_mod, merge, Calibration, CropMode, MergeOptions, MergeSummary,
};
use plsr_hdr::oiio::{self, AttrValue, ImageReader, PixelType};
use plsr_hdr::response::ResponseMethod;
use plsr_hdr::synth::{
    self, BracketOptions, CameraModel, DarkRoom, PixelKind, RadianceImage, SyntheticScene,
    PAPER_EXPOSURES,
};
use std::path::{Path, PathBuf};
use std::process::Command;

const W: usize = 64;
const H: usize = 32;

fn scene() -> SyntheticScene {
    SyntheticScene::new(W, H)
}

fn brackets(dir: &Path, camera: &CameraModel, options: &BracketOptions) -> Vec<PathBuf> {
    synth::write_brackets(&scene(), camera, &PAPER_EXPOSURES, dir, options).unwrap()
}

fn run_merge(files: &[PathBuf], out: &Path, options: &MergeOptions) -> MergeSummary {
    merge(files, out, options, &|_, _, _| {}).unwrap()
}

fn with(method: ResponseMethod) -> MergeOptions {
    MergeOptions {
        response: method,
        ..Default::default()
    }
}

/// Log-space RMSE bounds after the best global scale, over the pixels some
/// bracket exposes well (8-bit brackets with noise, 10 exposures 1/30–15 s).
const BOUND_DEBEVEC: f64 = 0.05;
const BOUND_ROBERTSON: f64 = 0.05;
const BOUND_LINEAR: f64 = 0.05;

#[test]
fn round_trip_debevec() {
    let dir = tempfile::tempdir().unwrap();
    let camera = CameraModel::default();
    let files = brackets(dir.path(), &camera, &BracketOptions::default());
    let out = dir.path().join("pano.exr");
    run_merge(&files, &out, &with(ResponseMethod::Debevec));
    let a = synth::accuracy(&out, &scene(), &camera, &PAPER_EXPOSURES).unwrap();
    eprintln!("debevec: {a:?}");
    assert_eq!(a.bad_values, 0);
    assert!(a.log_rmse < BOUND_DEBEVEC, "{a:?}");
}

#[test]
fn round_trip_robertson() {
    let dir = tempfile::tempdir().unwrap();
    let camera = CameraModel::default();
    let files = brackets(dir.path(), &camera, &BracketOptions::default());
    let out = dir.path().join("pano.exr");
    run_merge(&files, &out, &with(ResponseMethod::Robertson));
    let a = synth::accuracy(&out, &scene(), &camera, &PAPER_EXPOSURES).unwrap();
    eprintln!("robertson: {a:?}");
    assert_eq!(a.bad_values, 0);
    assert!(a.log_rmse < BOUND_ROBERTSON, "{a:?}");
}

#[test]
fn round_trip_linear_camera() {
    let dir = tempfile::tempdir().unwrap();
    let camera = CameraModel::linear();
    let files = brackets(dir.path(), &camera, &BracketOptions::default());
    let out = dir.path().join("pano.exr");
    run_merge(&files, &out, &with(ResponseMethod::Linear));
    let a = synth::accuracy(&out, &scene(), &camera, &PAPER_EXPOSURES).unwrap();
    eprintln!("linear: {a:?}");
    assert_eq!(a.bad_values, 0);
    assert!(a.log_rmse < BOUND_LINEAR, "{a:?}");
    // The linear preset on a linear camera also gets the absolute scale.
    assert!((a.scale - 1.0).abs() < 0.05, "{a:?}");
}

#[test]
fn round_trip_16_bit() {
    let dir = tempfile::tempdir().unwrap();
    let camera = CameraModel {
        bits: 16,
        ..CameraModel::default()
    };
    let files = brackets(dir.path(), &camera, &BracketOptions::default());
    assert_eq!(
        ImageReader::open(&files[0]).unwrap().info().format,
        PixelType::U16
    );
    let out = dir.path().join("pano.exr");
    let s = run_merge(&files, &out, &with(ResponseMethod::Debevec));
    assert_eq!(s.curve.levels(), plsr_hdr::response::BINNED_LEVELS);
    let a = synth::accuracy(&out, &scene(), &camera, &PAPER_EXPOSURES).unwrap();
    eprintln!("16-bit debevec: {a:?}");
    assert!(a.log_rmse < BOUND_DEBEVEC, "{a:?}");
}

#[test]
fn float_brackets_merge_with_the_linear_preset() {
    // Float (EXR) brackets of a linear camera, normalised so 1.0 clips.
    let dir = tempfile::tempdir().unwrap();
    let camera = CameraModel {
        bits: 16,
        ..CameraModel::linear()
    };
    let files16 = brackets(dir.path(), &camera, &BracketOptions::default());
    let mut files = Vec::new();
    for (i, f) in files16.iter().enumerate() {
        let (info, data) = oiio::read_image_f32(f).unwrap();
        let p = dir.path().join(format!("float_{i}.exr"));
        let attrs = vec![(
            "ExposureTime".to_string(),
            AttrValue::Float(PAPER_EXPOSURES[i] as f32),
        )];
        oiio::write_image(
            &p,
            info.width,
            info.height,
            3,
            PixelType::Half,
            &attrs,
            &data,
        )
        .unwrap();
        files.push(p);
    }
    let out = dir.path().join("pano.exr");
    run_merge(&files, &out, &with(ResponseMethod::Linear));
    let a = synth::accuracy(&out, &scene(), &camera, &PAPER_EXPOSURES).unwrap();
    eprintln!("float linear: {a:?}");
    assert_eq!(a.bad_values, 0);
    assert!(a.log_rmse < BOUND_LINEAR, "{a:?}");
}

#[test]
fn recovered_debevec_curve_matches_the_true_curve() {
    let dir = tempfile::tempdir().unwrap();
    let camera = CameraModel::default();
    let files = brackets(dir.path(), &camera, &BracketOptions::default());
    let out = dir.path().join("pano.exr");
    let s = run_merge(&files, &out, &with(ResponseMethod::Debevec));
    // ln I(z) − ln f⁻¹(z) should be constant over the well-exposed range.
    let tolerance = 0.05;
    for c in 0..3 {
        let d: Vec<f64> = (13..=242)
            .map(|z| {
                let v = z as f32 / 255.0;
                (s.curve.inverse[c][z] as f64).ln() - (camera.inverse_response(v) as f64).ln()
            })
            .collect();
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        let rms = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / d.len() as f64).sqrt();
        let max = d.iter().map(|x| (x - mean).abs()).fold(0.0, f64::max);
        eprintln!("channel {c}: log RMS {rms:.4}, max {max:.4}");
        assert!(rms < tolerance, "channel {c}: log-RMS {rms}");
    }
}

#[test]
fn exif_exposures_give_the_same_result_as_explicit_ones() {
    let dir = tempfile::tempdir().unwrap();
    let camera = CameraModel::default();
    let mut files = brackets(dir.path(), &camera, &BracketOptions::default());
    let a = dir.path().join("exif.exr");
    let b = dir.path().join("explicit.exr");
    run_merge(&files, &a, &with(ResponseMethod::Debevec));
    // Explicit times, and the brackets in another order.
    files.reverse();
    let mut times = PAPER_EXPOSURES.to_vec();
    times.reverse();
    run_merge(
        &files,
        &b,
        &MergeOptions {
            exposures: Some(times),
            ..with(ResponseMethod::Debevec)
        },
    );
    let (_, da) = oiio::read_image_f32(&a).unwrap();
    let (_, db) = oiio::read_image_f32(&b).unwrap();
    let worst = da
        .iter()
        .zip(&db)
        .map(|(x, y)| ((x - y) / x.abs().max(1e-12)).abs())
        .fold(0f32, f32::max);
    assert!(worst < 1e-5, "relative difference {worst}");
    // The header records the exposure times and the curve.
    let r = ImageReader::open(&a).unwrap();
    let times = r.string_attribute("plsr:exposure_times").unwrap();
    assert_eq!(times.split(' ').count(), 10);
    assert!(times.starts_with("0.0333"), "{times}");
    assert_eq!(
        r.string_attribute("plsr:response").as_deref(),
        Some("debevec")
    );
    let curve = r.string_attribute("plsr:response_curve").unwrap();
    assert_eq!(curve.lines().count(), 3);
    assert_eq!(curve.lines().next().unwrap().split(' ').count(), 256);
}

#[test]
fn f_number_and_iso_enter_the_relative_exposure() {
    // Same exposure time everywhere; brightness varies by aperture and ISO.
    // JPEG, because OpenImageIO 2.4 writes no ISO into TIFF's EXIF (and
    // 0.3 s, because it writes 0.25 s into JPEG's EXIF as infinity).
    let dir = tempfile::tempdir().unwrap();
    let camera = CameraModel::default();
    let times = [0.3; 5];
    let f_numbers = vec![8.0, 4.0, 4.0, 2.0, 2.0];
    let isos = vec![100.0, 100.0, 400.0, 400.0, 1600.0];
    let files = synth::write_brackets(
        &scene(),
        &camera,
        &times,
        dir.path(),
        &BracketOptions {
            extension: "jpg".into(),
            f_numbers,
            isos,
            attributes: vec![("CompressionQuality".into(), AttrValue::Int(100))],
            ..Default::default()
        },
    )
    .unwrap();
    let r = ImageReader::open(&files[2]).unwrap();
    assert_eq!(r.exif().iso, Some(400.0), "{:?}", r.exif());
    assert_eq!(r.exif().f_number, Some(4.0), "{:?}", r.exif());
    let out = dir.path().join("pano.exr");
    // Any order.
    let shuffled = vec![
        files[3].clone(),
        files[0].clone(),
        files[4].clone(),
        files[2].clone(),
        files[1].clone(),
    ];
    let s = run_merge(&shuffled, &out, &with(ResponseMethod::Debevec));
    // Relative to the bracket of least exposure (f/8, ISO 100, given
    // second): 0.3 s × (8/N)² × ISO/100.
    let k: Vec<f64> = s.brackets.iter().map(|b| b.relative_exposure).collect();
    let want = [0.3, 1.2, 4.8, 19.2, 76.8];
    for (a, b) in k.iter().zip(want) {
        assert!((a / b - 1.0).abs() < 1e-3, "{k:?}");
    }
    let a = synth::accuracy(&out, &scene(), &camera, &want).unwrap();
    eprintln!("f-number/ISO (JPEG): {a:?}");
    assert!(a.log_rmse < 2.0 * BOUND_DEBEVEC, "{a:?}");
}

/// A value clipped in a short exposure but dark in a longer one is not a
/// sun (a scan's coloured border, a ghost): it takes the dark estimate,
/// while a value clipped in every bracket stays the brightest.
#[test]
fn clipped_then_dark_is_a_marker_not_a_sun() {
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    // Pixels: a sun, a marker, mid-grey, a shadow.
    for (name, row) in [
        ("short.png", [255u8, 255, 20, 2]),
        ("long.png", [255, 3, 200, 60]),
    ] {
        let path = dir.path().join(name);
        let grey: Vec<u8> = row.iter().flat_map(|&v| [v, v, v]).collect();
        image::save_buffer(&path, &grey, 4, 1, image::ExtendedColorType::Rgb8).unwrap();
        files.push(path);
    }
    let out = dir.path().join("merged.exr");
    run_merge(
        &files,
        &out,
        &MergeOptions {
            exposures: Some(vec![0.01, 1.0]),
            ..with(ResponseMethod::Srgb)
        },
    );
    let v = oiio::read_image_f32(&out).unwrap().1;
    let (sun, marker, grey, shadow) = (v[0], v[3], v[6], v[9]);
    assert!(
        sun >= 99.0,
        "the sun takes the short exposure's clip: {v:?}"
    );
    assert!(
        marker < shadow && marker < grey,
        "the marker is dark: {v:?}"
    );
    assert!(marker < 0.01, "{v:?}");
}

#[test]
fn saturated_and_dark_pixels_are_finite_and_ordered() {
    let dir = tempfile::tempdir().unwrap();
    for (method, camera) in [
        (ResponseMethod::Debevec, CameraModel::default()),
        (ResponseMethod::Robertson, CameraModel::default()),
        (ResponseMethod::Srgb, CameraModel::default()),
        (ResponseMethod::Linear, CameraModel::linear()),
    ] {
        let sub = dir.path().join(method.to_string());
        std::fs::create_dir_all(&sub).unwrap();
        let files = brackets(&sub, &camera, &BracketOptions::default());
        let out = sub.join("pano.exr");
        let s = run_merge(&files, &out, &with(method));
        assert!(s.saturated_values > 0 && s.dark_values > 0, "{method}");
        let (_, data) = oiio::read_image_f32(&out).unwrap();
        assert!(data.iter().all(|v| v.is_finite() && *v > 0.0), "{method}");
        let sc = scene();
        // Per channel: suns are at least as bright as anything else (pixels
        // of the gradient clipped everywhere share their value), dark spots
        // at most as bright as anything else.
        for c in 0..3 {
            let (mut sun_min, mut dark_max) = (f32::INFINITY, 0f32);
            let (mut grad_min, mut grad_max) = (f32::INFINITY, 0f32);
            for y in 0..H {
                for x in 0..W {
                    let v = data[(y * W + x) * 3 + c];
                    match sc.kind(x, y) {
                        PixelKind::Sun => sun_min = sun_min.min(v),
                        PixelKind::Dark => dark_max = dark_max.max(v),
                        PixelKind::Gradient => {
                            grad_min = grad_min.min(v);
                            grad_max = grad_max.max(v);
                        }
                    }
                }
            }
            eprintln!(
                "{method} channel {c}: dark ≤ {dark_max}, gradient {grad_min}…{grad_max}, sun ≥ {sun_min}"
            );
            assert!(sun_min.is_finite(), "{method}: no sun pixels?");
            assert!(
                sun_min >= grad_max,
                "{method}: dark sun: {sun_min} < {grad_max}"
            );
            assert!(
                dark_max <= grad_min,
                "{method}: bright hole: {dark_max} > {grad_min}"
            );
            assert!(dark_max > 0.0);
        }
    }
}

#[test]
fn alignment_recovers_camera_shake() {
    let dir = tempfile::tempdir().unwrap();
    let camera = CameraModel::default();
    let sc = SyntheticScene::textured(256, 128);
    let shake = vec![
        (2, -1),
        (0, 0),
        (1, 1),
        (-2, 0),
        (0, 2),
        (0, 0),
        (3, -2),
        (-1, -1),
        (0, 1),
        (2, 2),
    ];
    let files = synth::write_brackets(
        &sc,
        &camera,
        &PAPER_EXPOSURES,
        dir.path(),
        &BracketOptions {
            shifts: shake.clone(),
            ..Default::default()
        },
    )
    .unwrap();
    let aligned = dir.path().join("aligned.exr");
    let s = run_merge(
        &files,
        &aligned,
        &MergeOptions {
            align: true,
            ..with(ResponseMethod::Debevec)
        },
    );
    let found: Vec<(i32, i32)> = s.brackets.iter().map(|b| b.shift).collect();
    eprintln!("shake {shake:?}\nfound {found:?}");
    // The reference is the middle bracket (no shake); the others are undone.
    for (i, (f, t)) in found.iter().zip(&shake).enumerate() {
        assert_eq!(*f, (-t.0, -t.1), "bracket {i}: {found:?}");
    }
    // Alignment moved brackets, so the output is cropped to the area all
    // of them cover: 2 + 3 columns and 2 + 2 rows fewer, said in the header.
    let window = merge_mod::common_window(&found, 256, 128);
    assert_eq!(window, [2, 2, 253, 126]);
    assert_eq!(s.crop, Some(window));
    assert_eq!((s.width, s.height), (251, 124));
    let r = ImageReader::open(&aligned).unwrap();
    assert_eq!((r.info().width, r.info().height), (251, 124));
    assert_eq!(
        r.string_attribute("plsr:crop").as_deref(),
        Some("2 2 253 126 of 256x128")
    );
    // Kept whole, the border repeats the shifted brackets' edge pixels.
    let whole = dir.path().join("whole.exr");
    let sw = run_merge(
        &files,
        &whole,
        &MergeOptions {
            align: true,
            crop: CropMode::Never,
            ..with(ResponseMethod::Debevec)
        },
    );
    assert_eq!((sw.width, sw.height, sw.crop), (256, 128, None));
    let plain = dir.path().join("plain.exr");
    run_merge(&files, &plain, &with(ResponseMethod::Debevec));
    let a = synth::accuracy(&aligned, &sc, &camera, &PAPER_EXPOSURES).unwrap();
    let k = synth::accuracy(&whole, &sc, &camera, &PAPER_EXPOSURES).unwrap();
    let b = synth::accuracy(&plain, &sc, &camera, &PAPER_EXPOSURES).unwrap();
    eprintln!("aligned {a:?}\nwhole frame {k:?}\nunaligned {b:?}");
    assert!(
        a.log_rmse < 0.5 * b.log_rmse,
        "aligned {a:?}, unaligned {b:?}"
    );
    assert!(a.log_rmse < k.log_rmse, "cropped {a:?}, whole frame {k:?}");
}

#[test]
fn a_calibration_window_is_in_the_cropped_outputs_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let camera = CameraModel::default();
    let sc = SyntheticScene::textured(128, 64);
    let mut shake = vec![(0, 0); 10];
    shake[7] = (4, 3);
    let files = synth::write_brackets(
        &sc,
        &camera,
        &PAPER_EXPOSURES,
        dir.path(),
        &BracketOptions {
            shifts: shake,
            ..Default::default()
        },
    )
    .unwrap();
    // The window 10,10–30,20 of the output: its mean luminance is the value
    // given, whether the output is cropped or not.
    for crop in [CropMode::Auto, CropMode::Never] {
        let out = dir.path().join(format!("{crop:?}.exr"));
        let s = run_merge(
            &files,
            &out,
            &MergeOptions {
                align: true,
                crop,
                calibration: Calibration::Region {
                    window: [10, 10, 30, 20],
                    luminance: 2.0,
                    source: "test".into(),
                },
                ..with(ResponseMethod::Debevec)
            },
        );
        let (info, px) = plsr_hdr::oiio::read_image_f32(&out).unwrap();
        assert_eq!(s.crop.is_some(), crop == CropMode::Auto);
        let mut sum = 0f64;
        for y in 10..20 {
            for x in 10..30 {
                let p = &px[(y * info.width + x) * 3..][..3];
                sum += 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
            }
        }
        let mean = sum / 200.0;
        assert!((mean / 2.0 - 1.0).abs() < 1e-3, "{crop:?}: mean {mean}");
    }
    // A window beyond the cropped output is refused, naming the reason.
    let err = merge(
        &files,
        &dir.path().join("x.exr"),
        &MergeOptions {
            align: true,
            calibration: Calibration::Region {
                window: [100, 10, 128, 20],
                luminance: 2.0,
                source: "test".into(),
            },
            ..with(ResponseMethod::Debevec)
        },
        &|_, _, _| {},
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("cropped"), "{err}");
    assert!(!dir.path().join("x.exr").exists());
}

/// Writes the paper's ten brackets of `scene` (8-bit, default camera) with
/// the given camera shake into `dir`, and merges them with and without
/// `--align`: the shifts found and the accuracy of both merges.
fn aligned_and_plain<S: RadianceImage + ?Sized>(
    scene: &S,
    shifts: &[(i32, i32)],
    dir: &Path,
) -> (Vec<(i32, i32)>, synth::Accuracy, synth::Accuracy) {
    let camera = CameraModel::default();
    let files = synth::write_brackets(
        scene,
        &camera,
        &PAPER_EXPOSURES,
        dir,
        &BracketOptions {
            shifts: shifts.to_vec(),
            ..Default::default()
        },
    )
    .unwrap();
    let aligned = dir.join("aligned.exr");
    let s = run_merge(
        &files,
        &aligned,
        &MergeOptions {
            align: true,
            ..with(ResponseMethod::Debevec)
        },
    );
    let plain = dir.join("plain.exr");
    run_merge(&files, &plain, &with(ResponseMethod::Debevec));
    let a = synth::accuracy(&aligned, scene, &camera, &PAPER_EXPOSURES).unwrap();
    let b = synth::accuracy(&plain, scene, &camera, &PAPER_EXPOSURES).unwrap();
    (s.brackets.iter().map(|b| b.shift).collect(), a, b)
}

/// Fraction of the pixels of each bracket that are black (grey ≤ 4).
fn black_fractions(dir: &Path) -> Vec<f64> {
    (0..PAPER_EXPOSURES.len())
        .map(|i| {
            let path = dir.join(format!("bracket_{i:02}.tif"));
            let g = align::read_grey(&mut ImageReader::open(&path).unwrap()).unwrap();
            g.data.iter().filter(|&&v| v <= 4).count() as f64 / g.data.len() as f64
        })
        .collect()
}

/// Camera shake at every exposure, the middle one included; neighbours
/// differ by up to 6 pixels.
const SHAKE: [(i32, i32); 10] = [
    (3, -2),
    (-2, 3),
    (1, 1),
    (-3, -1),
    (2, 2),
    (-1, 2),
    (-3, -3),
    (3, 1),
    (-2, -2),
    (2, -3),
];

/// What alignment to the middle bracket must find for [`SHAKE`]: each
/// bracket's shake undone, relative to the middle one's.
fn undo(shake: &[(i32, i32)]) -> Vec<(i32, i32)> {
    let mid = shake[shake.len() / 2];
    shake.iter().map(|s| (mid.0 - s.0, mid.1 - s.1)).collect()
}

#[test]
fn alignment_keeps_a_tripod_stack_still() {
    // A dark room: without its window, the four shortest exposures are
    // black and noise (and the longest clipped near the glow); with it,
    // only the window shows in the shortest ones. Nothing moved, so every
    // shift is (0, 0) and the aligned merge is the plain one.
    for (name, room) in [
        ("windowless", DarkRoom::windowless(256, 128)),
        ("window", DarkRoom::new(256, 128)),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let (found, a, b) = aligned_and_plain(&room, &[], dir.path());
        let black = black_fractions(dir.path());
        eprintln!("{name}: found {found:?}\nblack {black:?}\naligned {a:?}\nunaligned {b:?}");
        if name == "windowless" {
            assert!(black[..4].iter().all(|&f| f > 0.9), "{black:?}");
        } else {
            assert!(black[0] > 0.6, "{black:?}");
        }
        assert!(found.iter().all(|&s| s == (0, 0)), "{name}: {found:?}");
        assert_eq!(a, b, "{name}");
    }
}

#[test]
fn alignment_recovers_shifts_at_every_exposure() {
    // Known shake of every bracket, the darkest, the brightest and the
    // middle one included: found exactly, relative to the middle one, in a
    // textured scene and in the dark room with a window (the shortest
    // exposures show only the window, the longest clip around it).
    let textured = SyntheticScene::textured(256, 128);
    let room = DarkRoom::new(256, 128);
    let scenes: [(&str, &dyn RadianceImage); 2] = [("textured", &textured), ("room", &room)];
    for (name, scene) in scenes {
        let dir = tempfile::tempdir().unwrap();
        let (found, _, _) = aligned_and_plain(scene, &SHAKE, dir.path());
        eprintln!("{name}: shake {SHAKE:?}\nfound {found:?}");
        assert_eq!(found, undo(&SHAKE), "{name}");
    }
    // With the middle bracket still (the merge is then in the truth's
    // frame), alignment brings the room's merge back to a tripod's accuracy.
    let mut shake = SHAKE;
    shake[5] = (0, 0);
    let dir = tempfile::tempdir().unwrap();
    let (found, a, b) = aligned_and_plain(&room, &shake, dir.path());
    let tripod = tempfile::tempdir().unwrap();
    let (_, t, _) = aligned_and_plain(&room, &[], tripod.path());
    eprintln!("room: found {found:?}\naligned {a:?}\nunaligned {b:?}\ntripod {t:?}");
    assert_eq!(found, undo(&shake));
    assert!(a.log_rmse < 1.2 * t.log_rmse, "aligned {a:?}, tripod {t:?}");
    assert!(
        b.log_rmse > 5.0 * a.log_rmse,
        "aligned {a:?}, unaligned {b:?}"
    );
}

#[test]
fn alignment_leaves_black_brackets_where_their_neighbour_is() {
    // The windowless room shaken: the brackets with detail are aligned
    // exactly; the nearly black ones cannot be, and each keeps its brighter
    // neighbour's shift rather than a guess.
    let dir = tempfile::tempdir().unwrap();
    let room = DarkRoom::windowless(256, 128);
    let (found, _, _) = aligned_and_plain(&room, &SHAKE, dir.path());
    let black = black_fractions(dir.path());
    eprintln!("found {found:?}\nblack {black:?}");
    assert!(black[..3].iter().all(|&f| f > 0.98), "{black:?}");
    assert!(black[4..].iter().all(|&f| f < 0.7), "{black:?}");
    assert_eq!(found[4..], undo(&SHAKE)[4..]);
    assert!(found[..3].iter().all(|&s| s == found[3]), "{found:?}");
}

// ---- The command-line program -------------------------------------------

fn plsr(args: &[&std::ffi::OsStr]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(args)
        .output()
        .unwrap()
}

/// Runs `plsr hdr merge ARGS -o dir/out.exr` and checks: exit status 1, no
/// panic, no output or partial file left; returns stderr.
fn expect_merge_error(dir: &Path, files: &[PathBuf], extra: &[&str]) -> String {
    let out = dir.join("out.exr");
    let mut args: Vec<&std::ffi::OsStr> = vec!["hdr".as_ref(), "merge".as_ref()];
    args.extend(files.iter().map(|f| f.as_os_str()));
    args.extend(["-o".as_ref(), out.as_os_str(), "--quiet".as_ref()]);
    args.extend(extra.iter().map(std::ffi::OsStr::new));
    let output = plsr(&args);
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(1), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(!out.exists(), "an output was written");
    let leftovers: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("partial") || n.starts_with("out"))
        .collect();
    assert!(leftovers.is_empty(), "left behind: {leftovers:?}");
    stderr
}

fn small_brackets(dir: &Path, n: usize, exif: bool) -> Vec<PathBuf> {
    synth::write_brackets(
        &SyntheticScene::new(16, 8),
        &CameraModel::default(),
        &PAPER_EXPOSURES[..n],
        dir,
        &BracketOptions {
            exif,
            ..Default::default()
        },
    )
    .unwrap()
}

#[test]
fn cli_merges_and_writes_the_curve() {
    let dir = tempfile::tempdir().unwrap();
    let files = small_brackets(dir.path(), 4, true);
    let out = dir.path().join("pano.exr");
    let curve = dir.path().join("curve.csv");
    let mut args: Vec<&std::ffi::OsStr> = vec!["hdr".as_ref(), "merge".as_ref()];
    args.extend(files.iter().map(|f| f.as_os_str()));
    args.extend([
        "-o".as_ref(),
        out.as_os_str(),
        "--curve".as_ref(),
        curve.as_os_str(),
        "--half".as_ref(),
    ]);
    let output = plsr(&args);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("merged 4 brackets"), "{stderr}");
    let r = ImageReader::open(&out).unwrap();
    assert_eq!(r.info().format, PixelType::Half);
    assert!(curve.exists() && dir.path().join("curve.png").exists());
    // `plsr info` summarises the curve the header keeps, and no line runs on.
    let info = plsr(&["info".as_ref(), out.as_os_str()]);
    let stdout = String::from_utf8_lossy(&info.stdout);
    assert!(info.status.success(), "{stdout}");
    let line = stdout
        .lines()
        .find(|l| l.contains("plsr:response_curve"))
        .unwrap_or_else(|| panic!("{stdout}"));
    assert!(
        line.contains("= 3 channels × 256 levels, values 0."),
        "{line}"
    );
    assert!(stdout.lines().all(|l| l.chars().count() < 250), "{stdout}");
}

/// A folder stands for the images in it, in name order: the merge is the
/// one of the files given one by one, byte for byte. Other files in the
/// folder are left out; a folder without images is refused.
#[test]
fn cli_merges_every_image_of_a_folder() {
    let dir = tempfile::tempdir().unwrap();
    let brackets = dir.path().join("brackets");
    std::fs::create_dir(&brackets).unwrap();
    let files = small_brackets(&brackets, 4, true);
    std::fs::write(brackets.join("notes.txt"), "shot on a tripod").unwrap();
    let merge_to = |inputs: &[&std::ffi::OsStr], out: &Path| {
        let mut args: Vec<&std::ffi::OsStr> = vec!["hdr".as_ref(), "merge".as_ref()];
        args.extend(inputs);
        args.extend(["-o".as_ref(), out.as_os_str()]);
        let output = plsr(&args);
        let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
        assert!(output.status.success(), "{stderr}");
        assert!(stderr.contains("merged 4 brackets"), "{stderr}");
        std::fs::read(out).unwrap()
    };
    let one_by_one: Vec<&std::ffi::OsStr> = files.iter().map(|f| f.as_os_str()).collect();
    let a = merge_to(&one_by_one, &dir.path().join("a.exr"));
    let b = merge_to(&[brackets.as_os_str()], &dir.path().join("b.exr"));
    assert!(a == b, "the folder's merge differs");
    // Written into the folder and merged again: the earlier output is not
    // taken for a bracket.
    let inside = brackets.join("pano.exr");
    assert!(merge_to(&[brackets.as_os_str()], &inside) == a);
    assert!(merge_to(&[brackets.as_os_str()], &inside) == a);
    // A high-dynamic-range file among the brackets (a reference, an
    // earlier merge under another name) is left out, and said.
    std::fs::copy(&inside, brackets.join("reference.exr")).unwrap();
    let out = dir.path().join("c.exr");
    let output = plsr(&[
        "hdr".as_ref(),
        "merge".as_ref(),
        brackets.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success() && stderr.contains("left out") && stderr.contains("reference.exr"),
        "{stderr}"
    );
    assert!(std::fs::read(&out).unwrap() == a);
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let e = expect_merge_error(dir.path(), &[empty], &[]);
    assert!(
        e.contains("empty") && e.contains("folder without images"),
        "{e}"
    );
}

#[test]
fn cli_rejects_a_single_image() {
    let dir = tempfile::tempdir().unwrap();
    let files = small_brackets(dir.path(), 1, true);
    let e = expect_merge_error(dir.path(), &files, &[]);
    assert!(
        e.contains("bracket_00.tif") && e.contains("only one image"),
        "{e}"
    );
}

#[test]
fn cli_rejects_mismatched_sizes() {
    let dir = tempfile::tempdir().unwrap();
    let mut files = small_brackets(dir.path(), 2, true);
    let big = dir.path().join("big");
    std::fs::create_dir_all(&big).unwrap();
    files.extend(
        synth::write_brackets(
            &SyntheticScene::new(20, 8),
            &CameraModel::default(),
            &[1.0],
            &big,
            &BracketOptions::default(),
        )
        .unwrap(),
    );
    let e = expect_merge_error(dir.path(), &files, &[]);
    assert!(
        e.contains("big/bracket_00.tif") && e.contains("20×8") && e.contains("16×8"),
        "{e}"
    );
}

#[test]
fn cli_rejects_unreadable_files() {
    let dir = tempfile::tempdir().unwrap();
    let mut files = small_brackets(dir.path(), 2, true);
    files.push(dir.path().join("missing.jpg"));
    let e = expect_merge_error(dir.path(), &files, &[]);
    assert!(e.contains("missing.jpg"), "{e}");
    // A text file posing as a PNG.
    let fake = dir.path().join("fake.png");
    std::fs::write(&fake, "this is not an image\n").unwrap();
    files.pop();
    files.push(fake);
    let e = expect_merge_error(dir.path(), &files, &[]);
    assert!(e.contains("fake.png"), "{e}");
}

#[test]
fn cli_rejects_missing_exposure_times() {
    let dir = tempfile::tempdir().unwrap();
    let files = small_brackets(dir.path(), 3, false);
    let e = expect_merge_error(dir.path(), &files, &[]);
    assert!(
        e.contains("bracket_00.tif") && e.contains("no exposure time") && e.contains("--exposures"),
        "{e}"
    );
    // With --exposures they merge.
    let out = dir.path().join("ok.exr");
    let mut args: Vec<&std::ffi::OsStr> = vec!["hdr".as_ref(), "merge".as_ref()];
    args.extend(files.iter().map(|f| f.as_os_str()));
    args.extend([
        "-o".as_ref(),
        out.as_os_str(),
        "--exposures".as_ref(),
        "1/30,1/15,1/8".as_ref(),
    ]);
    let output = plsr(&args);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(out.exists());
}

#[test]
fn cli_rejects_a_wrong_count_of_exposures() {
    let dir = tempfile::tempdir().unwrap();
    let files = small_brackets(dir.path(), 3, true);
    let e = expect_merge_error(dir.path(), &files, &["--exposures", "1/30,1/15"]);
    assert!(e.contains("--exposures has 2 value(s) but 3 images"), "{e}");
    let e = expect_merge_error(dir.path(), &files, &["--exposures", "1/30,abc,1"]);
    assert!(e.contains("--exposures") && e.contains("abc"), "{e}");
}

#[test]
fn oiio_errors_are_errors_with_its_message() {
    let dir = tempfile::tempdir().unwrap();
    let fake = dir.path().join("fake.png");
    std::fs::write(&fake, "this is not an image\n").unwrap();
    let e = ImageReader::open(&fake).unwrap_err().to_string();
    eprintln!("{e}");
    assert!(e.contains("fake.png"), "{e}");
    // OpenImageIO's own words follow the file name.
    let message = e.split_once("fake.png: ").map(|x| x.1).unwrap_or("");
    assert!(message.len() > 5, "{e}");
    // Writing to a folder that does not exist, or an unknown format, fails
    // with an error too.
    let e = oiio::write_image(
        &dir.path().join("no/such/dir/x.exr"),
        2,
        2,
        3,
        PixelType::F32,
        &[],
        &[0f32; 12],
    )
    .unwrap_err();
    assert!(e.to_string().contains("x.exr"), "{e}");
    let e = oiio::write_image(
        &dir.path().join("x.unknownformat"),
        2,
        2,
        3,
        PixelType::F32,
        &[],
        &[0f32; 12],
    )
    .unwrap_err();
    assert!(e.to_string().contains("x.unknownformat"), "{e}");
}

/// OpenImageIO 2.4 divides by zero (SIGFPE) reading scanlines of some
/// tiled EXR files, such as the `exr` crate writes by default: plsr reads
/// tiled files by tiles, whole or a few rows at a time.
#[test]
fn tiled_exr_files_are_read_by_tiles() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tiled.exr");
    let (w, h) = (150usize, 100usize);
    let value = |x: usize, y: usize| (x as f32 * 0.25, y as f32 * 0.5, (x + y) as f32);
    exr::prelude::write_rgb_file(&path, w, h, value).unwrap();
    let mut r = ImageReader::open(&path).unwrap();
    assert_eq!((r.info().width, r.info().height), (w, h));
    let px: Vec<f32> = r.read_all().unwrap();
    let c = r.info().channels;
    for (x, y) in [(0, 0), (149, 0), (64, 63), (65, 64), (149, 99)] {
        let i = (y * w + x) * c;
        let (r_, g, b) = value(x, y);
        assert_eq!(&px[i..i + 3], &[r_, g, b], "pixel ({x}, {y})");
    }
    // Rows that straddle a tile boundary.
    let mut r = ImageReader::open(&path).unwrap();
    let mut rows = vec![0f32; 3 * w * c];
    r.read_rows(62, 65, &mut rows).unwrap();
    let i = (2 * w + 7) * c;
    assert_eq!(rows[i + 1], 64.0 * 0.5);
}

/// The libraries the dynamic loader opened while `plsr ARGS` ran (its
/// `LD_DEBUG=files` report), or the report itself when the run failed.
fn libraries_loaded_by(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(args)
        .env("LD_DEBUG", "files")
        .output()
        .unwrap();
    let report = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "plsr {args:?} failed:\n{report}");
    report
}

/// OpenImageIO (and its ~260 libraries) is loaded only by the commands that
/// read or write images through it: `plsr --version` and a render to EXR
/// and PNG (written by plsr's own encoders) start without it, while a
/// command that reads a JPEG bracket loads it on first use.
#[test]
fn openimageio_is_loaded_only_when_an_image_is_read_or_written() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("tiny.toml");
    std::fs::write(
        &scene,
        r#"[render]
spp = 1
max_depth = 1
[camera]
type = "pinhole"
position = [0, 0, 3]
look_at = [0, 0, 0]
up = [0, 1, 0]
vfov = 40
resolution = [8, 8]
[[materials]]
name = "m"
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "m"
[[lights]]
type = "point"
position = [0, 2, 3]
intensity = [10, 10, 10]
"#,
    )
    .unwrap();
    let oiio = "libOpenImageIO";
    let version = libraries_loaded_by(&["--version"]);
    // The report is real: it lists the libraries plsr does link.
    assert!(version.contains("libembree3"), "{version}");
    assert!(!version.contains(oiio), "{version}");
    let exr = dir.path().join("tiny.exr");
    let png = dir.path().join("tiny.png");
    let render = libraries_loaded_by(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
    ]);
    assert!(!render.contains(oiio), "{render}");
    assert!(exr.is_file() && png.is_file());
    // Reading an image through OpenImageIO loads it.
    let jpg = dir.path().join("photo.jpg");
    let pixels = vec![128u8; 8 * 8 * 3];
    oiio::write_image(&jpg, 8, 8, 3, PixelType::U8, &[], &pixels).unwrap();
    let compare = libraries_loaded_by(&[
        "compare",
        jpg.to_str().unwrap(),
        jpg.to_str().unwrap(),
        "--metric",
        "rmse",
    ]);
    assert!(compare.contains(oiio), "{compare}");
}

// ---- Absolute units -------------------------------------------------------

/// The true mean luminance (Rec. 709) of a window of the synthetic scene.
fn true_luminance(sc: &SyntheticScene, [x0, y0, x1, y1]: [usize; 4]) -> f64 {
    let mut sum = 0f64;
    for y in y0..y1 {
        for x in x0..x1 {
            assert_eq!(sc.kind(x, y), PixelKind::Gradient, "window pixel {x},{y}");
            let r = sc.radiance(x, y);
            sum += 0.2126 * r[0] as f64 + 0.7152 * r[1] as f64 + 0.0722 * r[2] as f64;
        }
    }
    sum / ((x1 - x0) * (y1 - y0)) as f64
}

/// A window of known luminance brings a merge whose relative units are far
/// off (the filmic camera's Debevec curve is anchored at pixel 0.5) to the
/// true radiance; the header says so.
#[test]
fn a_known_window_calibrates_to_absolute_radiance() {
    use plsr_hdr::merge::Calibration;
    let dir = tempfile::tempdir().unwrap();
    let camera = CameraModel::default();
    let files = brackets(dir.path(), &camera, &BracketOptions::default());
    let plain = dir.path().join("plain.exr");
    run_merge(&files, &plain, &with(ResponseMethod::Debevec));
    let before = synth::accuracy(&plain, &scene(), &camera, &PAPER_EXPOSURES).unwrap();
    let window = [28, 4, 36, 12];
    let calibrated = dir.path().join("calibrated.exr");
    let s = run_merge(
        &files,
        &calibrated,
        &MergeOptions {
            calibration: Calibration::Region {
                window,
                luminance: true_luminance(&scene(), window),
                source: "test window".into(),
            },
            ..with(ResponseMethod::Debevec)
        },
    );
    let after = synth::accuracy(&calibrated, &scene(), &camera, &PAPER_EXPOSURES).unwrap();
    eprintln!("relative {before:?}\ncalibrated {after:?}");
    assert!(
        (before.scale - 1.0).abs() > 0.5,
        "relative units happen to be right: {before:?}"
    );
    assert!((after.scale - 1.0).abs() < 0.03, "{after:?}");
    // Calibration scales; it does not change the merge's shape.
    assert!((after.log_rmse - before.log_rmse).abs() < 1e-4);
    let (scale, source) = s.calibration.unwrap();
    let r = ImageReader::open(&calibrated).unwrap();
    assert!((r.float_attribute("plsr:radiance_scale").unwrap() / scale - 1.0).abs() < 1e-6);
    assert_eq!(r.string_attribute("plsr:calibration").unwrap(), source);
    assert!(r
        .string_attribute("plsr:units")
        .unwrap()
        .starts_with("absolute"));
}

/// EXIF calibration: a linear camera whose pixel value is L·t at f/8, ISO
/// 100 follows `L = K·N²·v/(t·S)/683` with K = 683·100/64; the merge then
/// reads the true radiance. The reference bracket's f-number enters squared.
#[test]
fn exif_calibration_follows_the_exposure_triangle() {
    use plsr_hdr::merge::Calibration;
    let dir = tempfile::tempdir().unwrap();
    let camera = CameraModel {
        filmic: None,
        black: 0.0,
        ..CameraModel::default()
    };
    let k = 683.0 * 100.0 / 64.0;
    // JPEG: OpenImageIO 2.4 writes no ISO into TIFF's EXIF (and garbles
    // some JPEG exposure times, so they are given).
    let jpeg = BracketOptions {
        extension: "jpg".into(),
        ..Default::default()
    };
    let files = brackets(dir.path(), &camera, &jpeg);
    let out = dir.path().join("exif.exr");
    let options = MergeOptions {
        calibration: Calibration::Exif { constant: k },
        exposures: Some(PAPER_EXPOSURES.to_vec()),
        ..with(ResponseMethod::Linear)
    };
    run_merge(&files, &out, &options);
    let a = synth::accuracy(&out, &scene(), &camera, &PAPER_EXPOSURES).unwrap();
    assert!((a.scale - 1.0).abs() < 0.02, "{a:?}");
    // The same scene photographed at f/4 and ISO 400 throughout (the
    // simulation keeps the exposures): the triangle says 16 × brighter...
    let dir2 = tempfile::tempdir().unwrap();
    let files = brackets(
        dir2.path(),
        &camera,
        &BracketOptions {
            f_numbers: vec![4.0; 10],
            isos: vec![400.0; 10],
            ..jpeg.clone()
        },
    );
    run_merge(&files, &out, &options);
    let b = synth::accuracy(&out, &scene(), &camera, &PAPER_EXPOSURES).unwrap();
    // ... N² / S: (4² / 400) / (8² / 100) = 1/16.
    assert!((b.scale * 16.0 - 1.0).abs() < 0.02, "{b:?}");
    // Without ISO in the metadata, EXIF calibration is refused clearly.
    let dir3 = tempfile::tempdir().unwrap();
    let files = brackets(
        dir3.path(),
        &camera,
        &BracketOptions {
            exif: false,
            ..Default::default()
        },
    );
    let e = merge(&files, &out, &options, &|_, _, _| {})
        .unwrap_err()
        .to_string();
    assert!(e.contains("bracket_00") && e.contains("f-number"), "{e}");
}

/// Every format `hdr merge` writes is read back: `.hdr` and `.tif` by
/// `tonemap` and `info` like the `.exr`, with the merged values within the
/// format's precision (RGBE's 8-bit mantissa; float TIFF exactly), and the
/// `.hdr` by the reader environment maps use.
#[test]
fn merged_hdr_and_tif_files_are_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let files = brackets(
        dir.path(),
        &CameraModel::default(),
        &BracketOptions::default(),
    );
    let mut merged = Vec::new();
    for ext in ["exr", "hdr", "tif"] {
        let out = dir.path().join(format!("pano.{ext}"));
        run_merge(&files, &out, &with(ResponseMethod::Debevec));
        for args in [
            vec!["tonemap", "--exposure", "0", "-o", "pano.png"],
            vec!["info"],
        ] {
            let (cmd, rest) = args.split_first().unwrap();
            let o = Command::new(env!("CARGO_BIN_EXE_plsr"))
                .current_dir(dir.path())
                .arg(cmd)
                .arg(format!("pano.{ext}"))
                .args(rest)
                .output()
                .unwrap();
            let text = String::from_utf8_lossy(&o.stdout).to_string()
                + &String::from_utf8_lossy(&o.stderr);
            assert!(o.status.success(), "plsr {cmd} pano.{ext}: {text}");
            assert!(
                text.contains(&format!("{W}×{H}")),
                "plsr {cmd} pano.{ext}: {text}"
            );
        }
        let png = image::open(dir.path().join("pano.png")).unwrap().to_rgb8();
        merged.push(png);
    }
    let exr = oiio::read_image_f32(&dir.path().join("pano.exr"))
        .unwrap()
        .1;
    let tif = oiio::read_image_f32(&dir.path().join("pano.tif"))
        .unwrap()
        .1;
    assert_eq!(tif, exr, "a float TIFF keeps every value");
    let (w, h, hdr) =
        plsr::film::radiance::read_radiance_hdr(&dir.path().join("pano.hdr")).unwrap();
    assert_eq!((w as usize, h as usize), (W, H));
    // RGBE shares one exponent per pixel: each channel is within a part in
    // 128 of the pixel's largest (and a step of its mantissa).
    for (p, e) in hdr.iter().zip(exr.chunks_exact(3)) {
        let largest = e[0].max(e[1]).max(e[2]);
        for c in 0..3 {
            assert!((p[c] - e[c]).abs() <= largest / 64.0, "RGBE {p:?} vs {e:?}");
        }
    }
    // The tone-mapped PNGs agree: the TIFF's exactly, RGBE's within a level.
    assert_eq!(merged[2], merged[0]);
    let worst = merged[1]
        .as_raw()
        .iter()
        .zip(merged[0].as_raw())
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap();
    assert!(worst <= 2, "PNG of the .hdr differs by {worst} levels");
}

/// A curve written by `--curve` and read back by `--response-curve` merges
/// the same panorama as recovering it again (one camera's calibration
/// serves its later stacks), through the library and the command line.
#[test]
fn a_written_curve_read_back_merges_the_same_panorama() {
    let dir = tempfile::tempdir().unwrap();
    let files = brackets(
        dir.path(),
        &CameraModel::default(),
        &BracketOptions::default(),
    );
    let (recovered, given) = (
        dir.path().join("recovered.exr"),
        dir.path().join("given.exr"),
    );
    let csv = dir.path().join("camera.csv");
    run_merge(
        &files,
        &recovered,
        &MergeOptions {
            curve_csv: Some(csv.clone()),
            ..with(ResponseMethod::Debevec)
        },
    );
    let s = run_merge(
        &files,
        &given,
        &MergeOptions {
            response_curve: Some(csv.clone()),
            ..with(ResponseMethod::Debevec)
        },
    );
    assert_eq!(s.curve.method, ResponseMethod::Given);
    let a = oiio::read_image_f32(&recovered).unwrap().1;
    let b = oiio::read_image_f32(&given).unwrap().1;
    assert_eq!(a, b, "the curve's CSV keeps every f32 exactly");
    // The command line, from a copy of the brackets' curve.
    let out = dir.path().join("cli.exr");
    let o = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(["hdr", "merge", "--response-curve"])
        .arg(&csv)
        .args(&files)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(oiio::read_image_f32(&out).unwrap().1, a);
    // Both a curve and a method is a usage error; so is a broken curve.
    let o = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(["hdr", "merge", "--response", "srgb", "--response-curve"])
        .arg(&csv)
        .args(&files)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    std::fs::write(&csv, "level,pixel_value,r\n0,0,1\n1,1,0.5\n").unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(["hdr", "merge", "--response-curve"])
        .arg(&csv)
        .args(&files)
        .arg("-o")
        .arg(dir.path().join("broken.exr"))
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("camera.csv") && e.contains("line 3"), "{e}");
    assert!(!dir.path().join("broken.exr").exists());
}

/// The same files in any order merge to the same values, calibrated or not,
/// also when the ISO changes from bracket to bracket (the reference is the
/// bracket of least exposure, not the first file given).
#[test]
fn exif_calibration_gives_the_same_result_in_any_order() {
    use plsr_hdr::merge::Calibration;
    let dir = tempfile::tempdir().unwrap();
    let camera = CameraModel {
        filmic: None,
        black: 0.0,
        ..CameraModel::default()
    };
    let isos = vec![
        100.0, 200.0, 100.0, 400.0, 800.0, 100.0, 200.0, 1600.0, 100.0, 400.0,
    ];
    let files = brackets(
        dir.path(),
        &camera,
        &BracketOptions {
            extension: "jpg".into(),
            isos,
            ..Default::default()
        },
    );
    for calibration in [
        Calibration::Relative,
        Calibration::Exif {
            constant: plsr_hdr::merge::DEFAULT_CALIBRATION_CONSTANT,
        },
    ] {
        let mut merged = Vec::new();
        let n = files.len();
        for order in [
            (0..n).collect::<Vec<_>>(),
            (0..n).rev().collect(),
            (0..n).map(|i| (i * 3 + 1) % n).collect(),
        ] {
            let given: Vec<PathBuf> = order.iter().map(|&i| files[i].clone()).collect();
            let times: Vec<f64> = order.iter().map(|&i| PAPER_EXPOSURES[i]).collect();
            let out = dir.path().join("order.exr");
            let options = MergeOptions {
                calibration: calibration.clone(),
                exposures: Some(times),
                ..with(ResponseMethod::Linear)
            };
            let summary = run_merge(&given, &out, &options);
            merged.push((oiio::read_image_f32(&out).unwrap().1, summary.calibration));
        }
        for (data, scale) in &merged[1..] {
            assert_eq!(scale, &merged[0].1, "{calibration:?}");
            assert_eq!(
                data, &merged[0].0,
                "{calibration:?}: values depend on the order"
            );
        }
    }
}

/// The command line: a grey card under a measured illuminance, reported and
/// written to the header; bad windows are refused.
#[test]
fn grey_card_calibration_from_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let camera = CameraModel::default();
    let files = brackets(dir.path(), &camera, &BracketOptions::default());
    let window = [28, 4, 36, 12];
    // The illuminance under which an 18 % card has the window's luminance.
    let lux = true_luminance(&scene(), window) * 683.0 * std::f64::consts::PI / 0.18;
    let out = dir.path().join("card.exr");
    let mut args: Vec<std::ffi::OsString> = vec!["hdr".into(), "merge".into()];
    args.extend(files.iter().map(|f| f.clone().into_os_string()));
    args.extend(["-o".into(), out.clone().into_os_string()]);
    let mut good = args.clone();
    good.extend([
        "--grey-card".into(),
        "28,4,36,12".into(),
        "--illuminance".into(),
        format!("{lux}").into(),
    ]);
    let refs: Vec<&std::ffi::OsStr> = good.iter().map(|a| a.as_os_str()).collect();
    let o = plsr(&refs);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("absolute radiance") && err.contains("grey card"),
        "{err}"
    );
    let a = synth::accuracy(&out, &scene(), &camera, &PAPER_EXPOSURES).unwrap();
    assert!((a.scale - 1.0).abs() < 0.03, "{a:?}");
    std::fs::remove_file(&out).unwrap();
    for (extra, wanted) in [
        (vec!["--grey-card", "28,4,36"], "X0,Y0,X1,Y1"),
        (
            vec!["--grey-card", "28,4,36,99", "--illuminance", "100"],
            "Y1 ≤ 32",
        ),
        (vec!["--known-luminance", "1,1,5,5=-3"], "must be positive"),
        (
            vec!["--known-luminance", "10,10,20x20=100"],
            "in plsr: --known-luminance 10,10,30,30=100",
        ),
        (vec!["--grey-card", "1,1,5,5"], "--illuminance"),
    ] {
        let mut bad = args.clone();
        bad.extend(extra.iter().map(std::ffi::OsString::from));
        let refs: Vec<&std::ffi::OsStr> = bad.iter().map(|a| a.as_os_str()).collect();
        let o = plsr(&refs);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && err.contains(wanted),
            "{extra:?}: {err}"
        );
        assert!(!out.exists(), "{extra:?} left an output");
    }
}

/// Not a test: prints the shifts found and the accuracy of aligned and
/// plain merges for three scenes (`cargo test --test hdr align_report --
/// --ignored --nocapture`; set `PLSR_ALIGN_REPORT_DIR` to keep the stacks).
#[test]
#[ignore]
fn align_report() {
    let textured = SyntheticScene::textured(256, 128);
    let room = DarkRoom::new(256, 128);
    let windowless = DarkRoom::windowless(256, 128);
    let scenes: [(&str, &dyn RadianceImage); 3] = [
        ("textured", &textured),
        ("room", &room),
        ("windowless", &windowless),
    ];
    let mut still = SHAKE;
    still[5] = (0, 0);
    let ln2 = std::f64::consts::LN_2;
    for (name, scene) in scenes {
        for (cfg, sh) in [("tripod", &[][..]), ("shake", &still[..])] {
            let dir = tempfile::tempdir().unwrap();
            let (found, a, b) = aligned_and_plain(scene, sh, dir.path());
            // PLSR_ALIGN_REPORT_DIR keeps the stacks, e.g. for OpenCV.
            if let Some(keep) = std::env::var_os("PLSR_ALIGN_REPORT_DIR") {
                let keep = Path::new(&keep).join(format!("{name}-{cfg}"));
                std::fs::create_dir_all(&keep).unwrap();
                for e in std::fs::read_dir(dir.path()).unwrap() {
                    let p = e.unwrap().path();
                    std::fs::copy(&p, keep.join(p.file_name().unwrap())).unwrap();
                }
            }
            let want = if sh.is_empty() {
                vec![(0, 0); 10]
            } else {
                undo(sh)
            };
            println!(
                "{name} {cfg}: log2 RMSE aligned {:.3} unaligned {:.3}\n  want  {want:?}\n  found {found:?}",
                a.log_rmse / ln2,
                b.log_rmse / ln2
            );
        }
    }
}
