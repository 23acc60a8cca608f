//! Statistical regression test: the Cornell box against a stored reference
//! and its variance, judged per 8×8 pixel block by a z-test (as Mitsuba 3's
//! render tests do), not by exact match.

use plsr::film::Film;
use plsr::render::{render, RenderOptions};
use plsr::scene::Scene;
use std::path::Path;

const BLOCK: u32 = 8;

/// Two-sided critical z for 1 % overall significance, Bonferroni-corrected
/// over 64 blocks × 3 channels (p = 0.01 / 192 = 5.2e-5 ⇒ z ≈ 4.05).
const Z_CRITICAL: f64 = 4.05;

/// Per block and channel: (mean difference, its standard error).
fn block_z_scores(test: &Film, reference: &Film) -> Vec<f64> {
    assert_eq!(
        (test.width, test.height),
        (reference.width, reference.height)
    );
    let mut z = Vec::new();
    for by in (0..test.height).step_by(BLOCK as usize) {
        for bx in (0..test.width).step_by(BLOCK as usize) {
            for c in 0..3 {
                let (mut dt, mut dr, mut vt, mut vr, mut n) =
                    (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
                for y in by..(by + BLOCK).min(test.height) {
                    for x in bx..(bx + BLOCK).min(test.width) {
                        let i = test.index(x, y);
                        dt += test.color[i][c] as f64;
                        dr += reference.color[i][c] as f64;
                        vt += test.variance[i][c] as f64;
                        vr += reference.variance[i][c] as f64;
                        n += 1.0;
                    }
                }
                let se = ((vt + vr) / (n * n)).sqrt();
                let diff = (dt - dr) / n;
                z.push(if se > 0.0 {
                    diff / se
                } else if diff == 0.0 {
                    0.0
                } else {
                    f64::INFINITY
                });
            }
        }
    }
    z
}

#[test]
fn cornell_box_matches_its_reference() {
    let scene = Scene::load(Path::new("tests/data/cornell-64.toml")).unwrap();
    let reference = Film::read_exr(Path::new("tests/data/cornell-64-ref.exr")).unwrap();
    let (film, _) = render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap();
    let z = block_z_scores(&film, &reference);
    let worst = z.iter().map(|v| v.abs()).fold(0.0, f64::max);
    eprintln!("worst block |z| against the reference: {worst:.2}");
    assert!(
        worst < Z_CRITICAL,
        "worst block |z| = {worst:.2}: the render differs from the reference"
    );

    // The test has power: a 10 % brighter image is rejected.
    let mut brighter = film.clone();
    for c in &mut brighter.color {
        *c *= 1.1;
    }
    let worst = block_z_scores(&brighter, &reference)
        .iter()
        .map(|v| v.abs())
        .fold(0.0, f64::max);
    assert!(
        worst >= Z_CRITICAL,
        "a 10 % error went unnoticed (worst |z| = {worst:.2})"
    );
}
