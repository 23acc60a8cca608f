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
    // Measured 0.111, 0.057 and 0.238 (on the full 512×768 stack 0.113,
    // 0.059, 0.212). Before black levels were found: 0.78, 0.78, 1.86.
    // OpenCV 5 on this copy: Debevec 0.468, 0.257, 1.129; Robertson 0.153,
    // 0.381, 0.229. The darkest tenth is bounded by the reference more than
    // by the merge: its error is a green offset (+0.3 stops) that no black
    // level, curve shape or weighting tried moved, and noise.
    assert!(all <= 0.17, "all pixels: {all}");
    assert!(windows <= 0.21, "brightest 1 %: {windows}");
    assert!(shadows <= 0.25, "darkest 10 %: {shadows}");
}
