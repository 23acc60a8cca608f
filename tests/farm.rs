//! Pieces of a render (`plsr render --samples` / `--crop`) and `plsr
//! merge`: merged sample ranges give the image of one render of their
//! union, stitched windows the full image bit for bit, and bad sets of
//! parts are refused with the file named and no output written.

use plsr::film::Film;
use std::path::{Path, PathBuf};
use std::process::Command;

const SCENE: &str = "tests/data/cornell-64.toml";

/// Runs `plsr ARGS` and returns (success, stderr).
fn plsr(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(args)
        .arg("--quiet")
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

/// `plsr merge` takes no `--quiet`.
fn merge(parts: &[&Path], out: &Path) -> (bool, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_plsr"));
    cmd.arg("merge");
    for p in parts {
        cmd.arg(p);
    }
    let out = cmd.arg("-o").arg(out).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

/// Renders a part of the test scene with `extra` arguments into `dir/name`.
fn part(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let path = dir.join(name);
    let mut args = vec![
        "render",
        SCENE,
        "-o",
        path.to_str().unwrap(),
        "--max-depth",
        "3",
    ];
    args.extend_from_slice(extra);
    let (ok, err) = plsr(&args);
    assert!(ok, "{name}: {err}");
    path
}

fn layers(f: &Film) -> Vec<(&'static str, Vec<f32>)> {
    let v3 = |v: &[glam::Vec3]| v.iter().flat_map(|c| c.to_array()).collect::<Vec<f32>>();
    vec![
        ("color", v3(&f.color)),
        ("variance", v3(&f.variance)),
        ("normal", v3(&f.normal)),
        ("albedo", v3(&f.albedo)),
        ("alpha", f.alpha.clone()),
        ("depth", f.depth.clone()),
        ("object_id", f.object_id.clone()),
    ]
}

/// Every layer equal within `rel` (relative to the value; 0: bit for bit).
fn assert_close(what: &str, a: &Film, b: &Film, rel: f32) {
    assert_eq!(
        (a.width, a.height, a.spp),
        (b.width, b.height, b.spp),
        "{what}"
    );
    for ((name, x), (_, y)) in layers(a).into_iter().zip(layers(b)) {
        for (i, (&p, &q)) in x.iter().zip(&y).enumerate() {
            let ok = if rel == 0.0 {
                p.to_bits() == q.to_bits()
            } else {
                (p - q).abs() <= rel * p.abs().max(q.abs()) + 1e-30
            };
            assert!(ok, "{what}: layer {name} element {i}: {p} vs {q}");
        }
    }
}

#[test]
fn sample_ranges_merge_into_the_render_of_their_union() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let whole = part(d, "whole.exr", &["--spp", "16"]);
    // Uneven ranges, given to merge out of order.
    let parts = [
        part(d, "c.exr", &["--samples", "8..9"]),
        part(d, "a.exr", &["--samples", "0..3"]),
        part(d, "d.exr", &["--samples", "9..16"]),
        part(d, "b.exr", &["--samples", "3..8"]),
    ];
    let merged = d.join("merged.exr");
    let refs: Vec<&Path> = parts.iter().map(|p| p.as_path()).collect();
    let (ok, err) = merge(&refs, &merged);
    assert!(ok, "{err}");
    let (w, m) = (
        Film::read_exr(&whole).unwrap(),
        Film::read_exr(&merged).unwrap(),
    );
    assert!(w.color.iter().any(|c| c.max_element() > 0.0));
    // The sums add in another grouping than one render's, so the means may
    // differ in the last bits of their f64 sums: ulp-level.
    assert_close("4 sample ranges", &w, &m, 1e-6);
    // One part of the whole range is the render itself, bit for bit.
    let all = part(d, "all.exr", &["--samples", "0..16"]);
    let one = d.join("one.exr");
    assert!(merge(&[&all], &one).0);
    assert_close("one part", &w, &Film::read_exr(&one).unwrap(), 0.0);
}

#[test]
fn windows_stitch_into_the_full_image_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let whole = part(d, "whole.exr", &["--spp", "5"]);
    let parts = [
        part(d, "a.exr", &["--spp", "5", "--crop", "0,0,40,25"]),
        part(d, "b.exr", &["--spp", "5", "--crop", "40,0,64,25"]),
        part(d, "c.exr", &["--spp", "5", "--crop", "0,25,30,64"]),
        part(d, "d.exr", &["--spp", "5", "--crop", "30,25,64,64"]),
    ];
    let merged = d.join("merged.exr");
    let refs: Vec<&Path> = parts.iter().map(|p| p.as_path()).collect();
    let (ok, err) = merge(&refs, &merged);
    assert!(ok, "{err}");
    assert_close(
        "4 windows",
        &Film::read_exr(&whole).unwrap(),
        &Film::read_exr(&merged).unwrap(),
        0.0,
    );
    // Windows and sample ranges together.
    let mixed = [
        part(d, "e.exr", &["--samples", "0..2", "--crop", "0,0,64,30"]),
        part(d, "f.exr", &["--samples", "2..5", "--crop", "0,0,64,30"]),
        part(d, "g.exr", &["--samples", "0..4", "--crop", "0,30,64,64"]),
        part(d, "h.exr", &["--samples", "4..5", "--crop", "0,30,64,64"]),
    ];
    let refs: Vec<&Path> = mixed.iter().map(|p| p.as_path()).collect();
    assert!(merge(&refs, &merged).0);
    assert_close(
        "windows × ranges",
        &Film::read_exr(&whole).unwrap(),
        &Film::read_exr(&merged).unwrap(),
        1e-6,
    );
}

#[test]
fn bad_sets_of_parts_are_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = part(d, "a.exr", &["--samples", "0..4"]);
    let b = part(d, "b.exr", &["--samples", "4..8"]);
    let other_seed = part(d, "seed.exr", &["--samples", "4..8", "--seed", "7"]);
    let gap = part(d, "gap.exr", &["--samples", "6..8"]);
    let overlap = part(d, "overlap.exr", &["--samples", "2..8"]);
    let window = part(
        d,
        "window.exr",
        &["--samples", "0..8", "--crop", "0,0,64,32"],
    );
    let plain = d.join("plain.exr");
    assert!(plsr(&["render", SCENE, "-o", plain.to_str().unwrap(), "--spp", "2"]).0);
    let truncated = d.join("truncated.exr");
    let bytes = std::fs::read(&b).unwrap();
    std::fs::write(&truncated, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let out = d.join("out.exr");
    for (what, parts, file, says) in [
        (
            "another seed",
            vec![&a, &other_seed],
            &other_seed,
            "scene hash",
        ),
        ("a gap", vec![&a, &gap], &gap, "samples 4..6 are missing"),
        (
            "an overlap",
            vec![&a, &overlap],
            &overlap,
            "overlap samples 0..4",
        ),
        (
            "a truncated part",
            vec![&a, &truncated],
            &truncated,
            "cannot read EXR",
        ),
        ("a plain render", vec![&a, &plain], &plain, "not a part"),
        (
            "a missing window",
            vec![&window],
            &window,
            "no part covers pixel (0, 32)",
        ),
    ] {
        let refs: Vec<&Path> = parts.iter().map(|p| p.as_path()).collect();
        let (ok, err) = merge(&refs, &out);
        assert!(!ok, "{what}: merged");
        let name = file.file_name().unwrap().to_str().unwrap();
        assert!(
            err.contains(says) && (what == "a missing window" || err.contains(name)),
            "{what}: {err}"
        );
        assert!(!out.exists(), "{what}: left an output");
    }
    // The good pair merges.
    assert!(merge(&[&a, &b], &out).0);
    // Bad options.
    for (args, says) in [
        (vec!["--samples", "5..5"], "START must be below END"),
        (vec!["--samples", "x..4"], "not a sample index"),
        (
            vec!["--samples", "0..4", "--spp", "4"],
            "cannot be used with",
        ),
        (vec!["--crop", "0,0,65,10"], "reaches past the 64×64 image"),
        (vec!["--crop", "3,0,3,10"], "empty"),
        (vec!["--crop", "1,2,3"], "expected X0,Y0,X1,Y1"),
    ] {
        let o = d.join("bad.exr");
        let mut full = vec!["render", SCENE, "-o", o.to_str().unwrap()];
        full.extend(args.iter().copied());
        let (ok, err) = plsr(&full);
        assert!(!ok && err.contains(says), "{args:?}: {err}");
        assert!(!o.exists());
    }
}
