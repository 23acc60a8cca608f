//! Camera raw brackets (issue 51, point 2): Bayer DNGs written here from a
//! known radiance field, with a black level, a white level below the 16-bit
//! top and a white balance, are read through LibRaw and merged as linear
//! data; the merge gives the field back up to one scale.

use plsr_hdr::merge::{merge, MergeOptions};
use plsr_hdr::oiio::{self, ImageReader};
use plsr_hdr::response::ResponseMethod;
use std::path::{Path, PathBuf};

/// The sensor's black level and white level (16-bit codes) and its response
/// to white light per channel (DNG `AsShotNeutral`): red half as sensitive
/// as green, blue 0.7.
const BLACK: u16 = 512;
const WHITE: u16 = 15000;
const NEUTRAL: [f64; 3] = [0.5, 1.0, 0.7];

const W: usize = 96;
const H: usize = 64;

/// The radiance field photographed: a smooth image spanning 10 stops from
/// left to right, with colour varying from top to bottom.
fn radiance(x: usize, y: usize) -> [f64; 3] {
    let u = (x as f64 + 0.5) / W as f64;
    let v = (y as f64 + 0.5) / H as f64;
    let level = (2f64).powf(10.0 * u - 4.0);
    let wave = 1.0 + 0.15 * (6.0 * v + 3.0 * u).sin();
    [
        level * wave * (0.6 + 0.4 * v),
        level * wave,
        level * wave * (1.0 - 0.5 * v),
    ]
}

/// A small deterministic noise, ±2 codes.
fn noise(x: usize, y: usize, k: usize) -> f64 {
    let mut h = (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ (k as u64).wrapping_mul(0x1656_67B1_9E37_79F9);
    h ^= h >> 29;
    h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h ^= h >> 32;
    (h % 5) as f64 - 2.0
}

/// The RGGB mosaic of the field exposed for `t` seconds: code
/// `black + (white − black) · L · neutral · t · gain`, clipped at the white
/// level.
fn mosaic(t: f64, k: usize) -> Vec<u16> {
    let gain = 4.0;
    let mut out = Vec::with_capacity(W * H);
    for y in 0..H {
        for x in 0..W {
            let c = match (y % 2, x % 2) {
                (0, 0) => 0,
                (1, 1) => 2,
                _ => 1,
            };
            let signal = radiance(x, y)[c] * NEUTRAL[c] * t * gain;
            let code = BLACK as f64 + (WHITE - BLACK) as f64 * signal + noise(x, y, k);
            out.push(code.round().clamp(0.0, WHITE as f64) as u16);
        }
    }
    out
}

/// One TIFF directory entry: tag, type, count and the value's bytes.
struct Entry {
    tag: u16,
    kind: u16,
    count: u32,
    bytes: Vec<u8>,
}

fn short(tag: u16, v: &[u16]) -> Entry {
    Entry {
        tag,
        kind: 3,
        count: v.len() as u32,
        bytes: v.iter().flat_map(|x| x.to_le_bytes()).collect(),
    }
}

fn long(tag: u16, v: u32) -> Entry {
    Entry {
        tag,
        kind: 4,
        count: 1,
        bytes: v.to_le_bytes().to_vec(),
    }
}

fn byte(tag: u16, v: &[u8]) -> Entry {
    Entry {
        tag,
        kind: 1,
        count: v.len() as u32,
        bytes: v.to_vec(),
    }
}

fn ascii(tag: u16, v: &str) -> Entry {
    let mut bytes = v.as_bytes().to_vec();
    bytes.push(0);
    Entry {
        tag,
        kind: 2,
        count: bytes.len() as u32,
        bytes,
    }
}

/// RATIONAL (5) or SRATIONAL (10) values, as n/10000.
fn rational(tag: u16, v: &[f64], signed: bool) -> Entry {
    let mut bytes = Vec::new();
    for x in v {
        let n = (x * 10000.0).round() as i64;
        bytes.extend_from_slice(&(n as i32).to_le_bytes());
        bytes.extend_from_slice(&10000u32.to_le_bytes());
    }
    Entry {
        tag,
        kind: if signed { 10 } else { 5 },
        count: v.len() as u32,
        bytes,
    }
}

/// Lays out an IFD at `at` (entries sorted by tag; values longer than four
/// bytes after it): the IFD's bytes, whose last word points to no next IFD.
fn ifd(mut entries: Vec<Entry>, at: u32) -> Vec<u8> {
    entries.sort_by_key(|e| e.tag);
    let table = 2 + 12 * entries.len() as u32 + 4;
    let mut data: Vec<u8> = Vec::new();
    let mut out = Vec::new();
    out.extend_from_slice(&(entries.len() as u16).to_le_bytes());
    for e in &entries {
        out.extend_from_slice(&e.tag.to_le_bytes());
        out.extend_from_slice(&e.kind.to_le_bytes());
        out.extend_from_slice(&e.count.to_le_bytes());
        if e.bytes.len() <= 4 {
            let mut v = e.bytes.clone();
            v.resize(4, 0);
            out.extend_from_slice(&v);
        } else {
            let off = at + table + data.len() as u32;
            out.extend_from_slice(&off.to_le_bytes());
            data.extend_from_slice(&e.bytes);
            if data.len() % 2 == 1 {
                data.push(0);
            }
        }
    }
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&data);
    out
}

/// Writes an uncompressed 16-bit RGGB Bayer DNG 1.4: the mosaic, the
/// sensor's black and white levels and as-shot neutral, a colour matrix
/// that makes the camera's RGB linear sRGB (D65), and the exposure in an
/// EXIF directory.
fn write_dng(path: &Path, cfa: &[u16], t: f64, f_number: f64, iso: u16) {
    // Linear sRGB from CIE XYZ (D65): DNG's ColorMatrix1 maps XYZ to camera.
    let xyz_to_srgb = [
        3.2404542, -1.5371385, -0.4985314, -0.9692660, 1.8760108, 0.0415560, 0.0556434, -0.2040259,
        1.0572252,
    ];
    let exif = |at: u32| {
        ifd(
            vec![
                rational(33434, &[t], false),
                rational(33437, &[f_number], false),
                short(34855, &[iso]),
            ],
            at,
        )
    };
    let pixels: Vec<u8> = cfa.iter().flat_map(|v| v.to_le_bytes()).collect();
    // Header (8 bytes), pixels, then IFD0, then the EXIF IFD. Offsets of
    // IFD0 and EXIF depend on IFD0's size, which does not depend on them.
    let pixel_at = 8u32;
    let ifd0_at = pixel_at + pixels.len() as u32;
    let main = |exif_at: u32| {
        vec![
            long(254, 0),
            long(256, W as u32),
            long(257, H as u32),
            short(258, &[16]),
            short(259, &[1]),
            short(262, &[32803]),
            ascii(271, "plsr"),
            ascii(272, "test sensor"),
            long(273, pixel_at),
            short(274, &[1]),
            short(277, &[1]),
            long(278, H as u32),
            long(279, pixels.len() as u32),
            short(284, &[1]),
            short(33421, &[2, 2]),
            byte(33422, &[0, 1, 1, 2]),
            long(34665, exif_at),
            byte(50706, &[1, 4, 0, 0]),
            byte(50707, &[1, 1, 0, 0]),
            ascii(50708, "plsr test sensor"),
            short(50713, &[1, 1]),
            long(50714, BLACK as u32),
            long(50717, WHITE as u32),
            rational(50721, &xyz_to_srgb, true),
            rational(50728, &NEUTRAL, false),
            short(50778, &[21]),
        ]
    };
    let size0 = ifd(main(0), ifd0_at).len() as u32;
    let exif_at = ifd0_at + size0 + (size0 % 2);
    let mut file = b"II*\0".to_vec();
    file.extend_from_slice(&ifd0_at.to_le_bytes());
    file.extend_from_slice(&pixels);
    file.extend_from_slice(&ifd(main(exif_at), ifd0_at));
    if file.len() % 2 == 1 {
        file.push(0);
    }
    assert_eq!(file.len() as u32, exif_at);
    file.extend_from_slice(&exif(exif_at));
    std::fs::write(path, file).unwrap();
}

/// Five raw brackets two stops apart, 1/1000 s to 1/4 s.
const TIMES: [f64; 5] = [0.001, 0.004, 0.016, 0.064, 0.256];

fn write_stack(dir: &Path) -> Vec<PathBuf> {
    TIMES
        .iter()
        .enumerate()
        .map(|(k, &t)| {
            let p = dir.join(format!("raw_{k}.dng"));
            write_dng(&p, &mosaic(t, k), t, 4.0, 200);
            p
        })
        .collect()
}

#[test]
fn a_dng_reads_as_linear_black_subtracted_white_balanced_rgb() {
    let dir = tempfile::tempdir().unwrap();
    let files = write_stack(dir.path());
    assert!(oiio::is_camera_raw(&files[0]));
    let mut r = ImageReader::open(&files[2]).unwrap();
    let info = r.info().clone();
    assert_eq!((info.width, info.height, info.channels), (W, H, 3));
    let exif = r.exif();
    assert!(
        (exif.exposure_time.unwrap() - 0.016).abs() < 1e-6,
        "{exif:?}"
    );
    assert_eq!(exif.f_number, Some(4.0));
    assert_eq!(exif.iso, Some(200.0));
    // A pixel in the middle of the frame: LibRaw's value is the signal
    // above black, scaled so the white level is 65535, times the white
    // balance (1 / neutral, green = 1): the radiance times t · gain.
    let px: Vec<u16> = r.read_all().unwrap();
    let (x, y) = (W / 2, H / 2);
    let l = radiance(x, y);
    for c in 0..3 {
        let expected = l[c] * 0.016 * 4.0 * 65535.0;
        let got = px[(y * W + x) * 3 + c] as f64;
        assert!(
            (got / expected - 1.0).abs() < 0.05,
            "channel {c}: {got} against {expected}"
        );
    }
}

#[test]
fn raw_brackets_merge_to_the_radiance_field() {
    let dir = tempfile::tempdir().unwrap();
    let files = write_stack(dir.path());
    let out = dir.path().join("pano.exr");
    // Asked for Robertson: raw brackets are linear, so the response is not
    // recovered, and the summary says so.
    let s = merge(
        &files,
        &out,
        &MergeOptions {
            response: ResponseMethod::Robertson,
            ..Default::default()
        },
        &|_, _, _| {},
    )
    .unwrap();
    assert!(s.camera_raw);
    assert_eq!(s.curve.method, ResponseMethod::Linear);
    assert!(
        s.warnings.iter().any(|w| w.contains("linear")),
        "{:?}",
        s.warnings
    );
    let times: Vec<f64> = s.brackets.iter().map(|b| b.exposure_time).collect();
    for (a, b) in times.iter().zip(TIMES) {
        assert!((a / b - 1.0).abs() < 1e-6, "{times:?}");
    }
    let r = ImageReader::open(&out).unwrap();
    assert!(r.string_attribute("plsr:camera_raw").is_some());
    let (info, px) = oiio::read_image_f32(&out).unwrap();
    assert_eq!((info.width, info.height), (W, H));
    // log2 error after one global scale, away from the 2-pixel border
    // (demosaicing has no neighbours there).
    let mut diffs = Vec::new();
    let mut ratio = [0f64; 3];
    for y in 2..H - 2 {
        for x in 2..W - 2 {
            let l = radiance(x, y);
            for c in 0..3 {
                let v = px[(y * W + x) * 3 + c] as f64;
                assert!(v.is_finite() && v > 0.0, "{x},{y},{c}: {v}");
                diffs.push((v / l[c]).log2());
                ratio[c] += v / l[c];
            }
        }
    }
    let mean = diffs.iter().sum::<f64>() / diffs.len() as f64;
    let rmse = (diffs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / diffs.len() as f64).sqrt();
    eprintln!("log2-RMSE {rmse:.4}, channel scales {ratio:?}");
    assert!(rmse < 0.03, "log2-RMSE {rmse}");
    // White balance: every channel has the same scale (red would be half
    // and blue 0.7 of green without it).
    for c in [0, 2] {
        assert!(
            (ratio[c] / ratio[1] - 1.0).abs() < 0.02,
            "channel {c} scale {} against green {}",
            ratio[c],
            ratio[1]
        );
    }
}

#[test]
fn raw_and_developed_brackets_are_not_mixed() {
    let dir = tempfile::tempdir().unwrap();
    let mut files = write_stack(dir.path());
    let png = dir.path().join("developed.png");
    image::RgbImage::from_pixel(W as u32, H as u32, image::Rgb([100, 100, 100]))
        .save(&png)
        .unwrap();
    files[1] = png;
    let out = dir.path().join("pano.exr");
    let err = merge(&files, &out, &MergeOptions::default(), &|_, _, _| {})
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("raw_0.dng") && err.contains("developed.png"),
        "{err}"
    );
    assert!(!out.exists());
}
