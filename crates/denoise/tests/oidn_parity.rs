//! plsr's denoiser against Intel Open Image Denoise 2.5.1 on the same
//! input: a 37×29 noisy image with its albedo and normal, filtered by OIDN
//! (through `pyoidn`, `scripts/oidn_fixtures.py`) in every mode plsr ships
//! weights for. OIDN runs the network in f32 on this machine's CPUs, as
//! plsr does, so the outputs agree to rounding.

use plsr_denoise::{denoise, prefilter, Aux, Image, Options};
use std::path::Path;

/// A PFM image (three float32 channels, rows bottom to top) as rows from
/// the top.
fn read_pfm(name: &str) -> (usize, usize, Vec<[f32; 3]>) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name);
    let bytes = std::fs::read(&path).unwrap();
    let mut lines = bytes.splitn(4, |&b| b == b'\n');
    assert_eq!(lines.next().unwrap(), b"PF");
    let dims = std::str::from_utf8(lines.next().unwrap()).unwrap();
    let (w, h) = dims.split_once(' ').unwrap();
    let (w, h): (usize, usize) = (w.parse().unwrap(), h.parse().unwrap());
    assert_eq!(lines.next().unwrap(), b"-1.0", "little-endian");
    let data = lines.next().unwrap();
    let floats: Vec<f32> = data
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    assert_eq!(floats.len(), w * h * 3);
    let mut pixels = vec![[0.0; 3]; w * h];
    for y in 0..h {
        for x in 0..w {
            let at = ((h - 1 - y) * w + x) * 3;
            pixels[y * w + x] = [floats[at], floats[at + 1], floats[at + 2]];
        }
    }
    (w, h, pixels)
}

/// PSNR (dB) of two images after a simple tone map (x / (1 + x), then
/// sRGB-like gamma), as the issue compares them.
fn psnr_tonemapped(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let tone = |v: f32| (f64::from(v) / (1.0 + f64::from(v))).powf(1.0 / 2.2);
    let mse: f64 = a
        .iter()
        .zip(b)
        .flat_map(|(p, q)| (0..3).map(move |c| (tone(p[c]) - tone(q[c])).powi(2)))
        .sum::<f64>()
        / (a.len() * 3) as f64;
    10.0 * (1.0 / mse.max(1e-30)).log10()
}

fn check(reference: &str, color: &str, albedo: bool, normal: bool, hdr: bool, clean_aux: bool) {
    let (w, h, color) = read_pfm(color);
    let (_, _, alb) = read_pfm("albedo.pfm");
    let (_, _, nrm) = read_pfm("normal.pfm");
    let image = |pixels| Image {
        pixels,
        width: w,
        height: h,
    };
    let options = Options {
        hdr,
        clean_aux,
        input_scale: None,
    };
    let ours = denoise(
        image(&color),
        albedo.then(|| image(&alb)),
        normal.then(|| image(&nrm)),
        &options,
    )
    .unwrap();
    let (_, _, theirs) = read_pfm(reference);
    assert_eq!(theirs.len(), ours.len(), "{reference}");
    let psnr = psnr_tonemapped(&ours, &theirs);
    let worst = ours
        .iter()
        .zip(&theirs)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs() / (1e-3 + q[c].abs())))
        .fold(0.0f32, f32::max);
    eprintln!("{reference}: PSNR {psnr:.1} dB, largest relative difference {worst:.2e}");
    assert!(psnr >= 45.0, "{reference}: PSNR {psnr:.1} dB");
    assert!(worst < 1e-3, "{reference}: a pixel differs by {worst:.2e}");
    // Denoising changed the image (the test is not vacuous).
    assert!(psnr_tonemapped(&ours, &color) < 40.0);
}

#[test]
fn hdr_colour_alone_is_denoised_as_oidn_does() {
    check("rt_hdr.pfm", "color.pfm", false, false, true, false);
}

#[test]
fn hdr_colour_with_albedo_is_denoised_as_oidn_does() {
    check("rt_hdr_alb.pfm", "color.pfm", true, false, true, false);
}

#[test]
fn hdr_colour_with_noisy_albedo_and_normal_is_denoised_as_oidn_does() {
    check("rt_hdr_alb_nrm.pfm", "color.pfm", true, true, true, false);
}

#[test]
fn hdr_colour_with_clean_albedo_and_normal_is_denoised_as_oidn_does() {
    check("rt_hdr_calb_cnrm.pfm", "color.pfm", true, true, true, true);
}

#[test]
fn ldr_colour_with_albedo_and_normal_is_denoised_as_oidn_does() {
    check("rt_ldr_alb_nrm.pfm", "ldr.pfm", true, true, false, false);
}

/// A prefilter's output against OIDN's: every value within 1e-4 (albedos
/// lie in [0, 1], normals in [−1, 1]), and the layer was changed.
fn check_prefilter(reference: &str, noisy: &str, kind: Aux) {
    let (w, h, input) = read_pfm(noisy);
    let ours = prefilter(
        Image {
            pixels: &input,
            width: w,
            height: h,
        },
        kind,
    )
    .unwrap();
    let (_, _, theirs) = read_pfm(reference);
    assert_eq!(theirs.len(), ours.len(), "{reference}");
    let largest = |a: &[[f32; 3]], b: &[[f32; 3]]| {
        a.iter()
            .zip(b)
            .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs()))
            .fold(0.0f32, f32::max)
    };
    let worst = largest(&ours, &theirs);
    eprintln!("{reference}: largest difference {worst:.2e}");
    assert!(worst < 1e-4, "{reference}: a value differs by {worst:.2e}");
    assert!(
        largest(&ours, &input) > 0.1,
        "{reference}: nothing was filtered"
    );
}

#[test]
fn a_noisy_albedo_is_prefiltered_as_oidn_does() {
    check_prefilter("rt_alb.pfm", "noisy_albedo.pfm", Aux::Albedo);
}

#[test]
fn a_noisy_normal_is_prefiltered_as_oidn_does() {
    check_prefilter("rt_nrm.pfm", "noisy_normal.pfm", Aux::Normal);
}
