//! HDR merge on a real bracket stack (issue 51): Paul Debevec's Memorial
//! Church photographs (16 exposures, 32 s … 1/1024 s, scans with a pedestal
//! at codes 12–18 and a pure-blue registration border), halved by
//! decimation, merged with the defaults and compared with Debevec's own
//! radiance map of them (`tests/data/realworld/hdr/memorial/`, see its
//! README; `scripts/hdr_memorial_fixture.py` made the copy).

use plsr_hdr::merge::{merge, parse_exposure, MergeOptions};
use plsr_hdr::oiio;
use plsr_hdr::reference::reference_errors;
use std::path::{Path, PathBuf};

fn memorial_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/realworld/hdr/memorial")
}

/// The brackets (longest first) and their exposure times in seconds.
fn memorial_stack() -> (Vec<PathBuf>, Vec<f64>) {
    let dir = memorial_dir();
    let times: Vec<f64> = std::fs::read_to_string(dir.join("shutter_times.txt"))
        .unwrap()
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| parse_exposure(l.trim()).unwrap())
        .collect();
    let files = (61..77)
        .map(|n| dir.join(format!("memorial{n:04}.png")))
        .collect();
    (files, times)
}

#[test]
fn the_default_merge_of_a_real_stack_is_close_to_its_authors_map() {
    let (files, times) = memorial_stack();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("memorial.exr");
    let options = MergeOptions {
        exposures: Some(times),
        ..Default::default()
    };
    let summary = merge(&files, &out, &options, &|_, _, _| {}).unwrap();
    // The scans' pedestal (codes 13, 18 and 16–17 at the peak, about one
    // code of noise) is found, and nothing clips below the top code.
    for (c, r) in summary.ranges.iter().enumerate() {
        let black = r.black * 255.0;
        assert!(
            (13.0..=22.0).contains(&black),
            "channel {c}: black level {black}"
        );
        assert_eq!(r.white, 1.0, "channel {c}");
    }
    let (_, merged) = oiio::read_image_f32(&out).unwrap();
    let (info, reference) = oiio::read_image_f32(&memorial_dir().join("memorial.hdr")).unwrap();
    assert_eq!((info.width, info.height, info.channels), (256, 384, 3));
    let e = reference_errors(&merged, &reference);
    let (all, windows, shadows) = (e.all, e.brightest, e.darkest);
    eprintln!(
        "Memorial, log2-RMSE: all {all:.3}, brightest 1 % {windows:.3}, darkest 10 % {shadows:.3}"
    );
    // Measured 0.110, 0.056 and 0.237 (on the full 512×768 stack 0.113,
    // 0.059, 0.212). Before black levels were found: 0.78, 0.78, 1.86.
    // OpenCV 5 on this copy: Debevec 0.477, 0.247, 1.130; Robertson 0.174,
    // 0.382, 0.232. The darkest tenth is bounded by the reference more than
    // by the merge: its error is a green offset (+0.3 stops) that no black
    // level, curve shape or weighting tried moved, and noise.
    assert!(all <= 0.17, "all pixels: {all}");
    assert!(windows <= 0.21, "brightest 1 %: {windows}");
    assert!(shadows <= 0.25, "darkest 10 %: {shadows}");
}

/// Side of the patch pasted along a path across the brackets, in pixels.
const PATCH: usize = 40;
/// Where the patch is copied from: a textured region that no bracket of
/// the best-exposed few clips.
const PATCH_FROM: (usize, usize) = (88, 104);

/// Where bracket `i` (file `memorial{61 + i}`) has the patch: 12 pixels
/// further right in each.
fn patch_at(i: usize) -> (usize, usize) {
    (8 + 12 * i, 300)
}

/// Copies the patch of `from` in `src` (w × h × 3) to `to`.
fn paste<T: Copy>(img: &mut [T], w: usize, from: (usize, usize), to: (usize, usize)) {
    let src: Vec<T> = img.to_vec();
    for y in 0..PATCH {
        for x in 0..PATCH {
            for c in 0..3 {
                img[((to.1 + y) * w + to.0 + x) * 3 + c] =
                    src[((from.1 + y) * w + from.0 + x) * 3 + c];
            }
        }
    }
}

/// log2-RMSE over the pixels `mask` selects, after the one global offset
/// (the median log ratio over all pixels).
fn masked_error(merged: &[f32], truth: &[f32], mask: &[bool]) -> f64 {
    let mut d: Vec<(f64, bool)> = Vec::new();
    for (p, (m, t)) in merged.chunks(3).zip(truth.chunks(3)).enumerate() {
        for c in 0..3 {
            if m[c] > 0.0 && t[c] > 0.0 {
                d.push(((m[c] as f64 / t[c] as f64).log2(), mask[p]));
            }
        }
    }
    let mut all: Vec<f64> = d.iter().map(|v| v.0).collect();
    all.sort_by(f64::total_cmp);
    let offset = all[all.len() / 2];
    let sel: Vec<f64> = d
        .iter()
        .filter(|v| v.1)
        .map(|v| (v.0 - offset).powi(2))
        .collect();
    (sel.iter().sum::<f64>() / sel.len() as f64).sqrt()
}

#[test]
fn deghosting_removes_a_moving_patch_and_keeps_the_still_scene() {
    // A patch moves 12 pixels between brackets of the real stack (each
    // bracket pastes its own copy of the same region, so the patch's
    // radiance is consistent): without deghosting the path is a trail of
    // ghosts; with it the patch appears once, where the reference bracket
    // has it.
    let (files, times) = memorial_stack();
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (256, 384);
    let mut moved = Vec::new();
    for (i, f) in files.iter().enumerate() {
        let mut img = image::open(f).unwrap().to_rgb8();
        paste(img.as_mut(), w, PATCH_FROM, patch_at(i));
        let p = dir.path().join(f.file_name().unwrap());
        img.save(&p).unwrap();
        moved.push(p);
    }
    let merge_with = |inputs: &[PathBuf], name: &str, deghost: bool| {
        let out = dir.path().join(name);
        let options = MergeOptions {
            exposures: Some(times.clone()),
            deghost,
            ..Default::default()
        };
        let s = merge(inputs, &out, &options, &|_, _, _| {}).unwrap();
        (s, oiio::read_image_f32(&out).unwrap().1)
    };
    let (_, plain) = merge_with(&moved, "plain.exr", false);
    let (s, deghosted) = merge_with(&moved, "deghosted.exr", true);
    let (reference, fraction) = s.deghost.clone().unwrap();
    // The truth: Debevec's map with the patch where the reference has it.
    let (_, mut truth) = oiio::read_image_f32(&memorial_dir().join("memorial.hdr")).unwrap();
    let r = moved.iter().position(|p| *p == reference).unwrap();
    paste(&mut truth, w, PATCH_FROM, patch_at(r));
    let mut path = vec![false; w * h];
    for i in 0..files.len() {
        let (x0, y0) = patch_at(i);
        for y in y0..y0 + PATCH {
            for x in x0..x0 + PATCH {
                path[y * w + x] = true;
            }
        }
    }
    let outside: Vec<bool> = path.iter().map(|v| !v).collect();
    let (pi, po) = (
        masked_error(&plain, &truth, &path),
        masked_error(&plain, &truth, &outside),
    );
    let (di, dout) = (
        masked_error(&deghosted, &truth, &path),
        masked_error(&deghosted, &truth, &outside),
    );
    eprintln!(
        "reference {}, {:.1} % of blocks deghosted; log2-RMSE inside the path: {pi:.3} plain, \
         {di:.3} deghosted; outside: {po:.3} plain, {dout:.3} deghosted",
        reference.display(),
        100.0 * fraction
    );
    // Measured 0.720 → 0.370 inside, 0.109 → 0.113 outside.
    assert!(di < 0.6 * pi, "inside: {di} deghosted, {pi} plain");
    assert!(dout < po + 0.01, "outside: {dout} deghosted, {po} plain");
    // On the untouched stack, deghosting costs little.
    let (_, still_plain) = merge_with(&files, "still_plain.exr", false);
    let (_, still_deghosted) = merge_with(&files, "still_deghosted.exr", true);
    let (_, map) = oiio::read_image_f32(&memorial_dir().join("memorial.hdr")).unwrap();
    let a = reference_errors(&still_plain, &map).all;
    let b = reference_errors(&still_deghosted, &map).all;
    eprintln!("still stack: {a:.3} plain, {b:.3} deghosted");
    assert!(b < a + 0.01, "still stack: {b} deghosted, {a} plain");
}
