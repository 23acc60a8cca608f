//! `plsr bench farm`: what splitting a render into parts costs. One
//! `plsr render` of S spp against N `plsr render --samples` parts of S/N
//! spp each, run one after another, plus `plsr merge`, all as separate
//! processes of this binary on the same machine, so every part pays what
//! a part on a farm pays: start-up, scene load, Embree's build, writing its
//! EXR; and the merge reads them all.

use crate::error::{Error, Result};
use plsr::film::Film;
use plsr_base::Vocabulary;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

/// The Cornell box of `assets/scenes/cornell/`, at the benchmark's size.
fn scene(obj: &Path, size: u32, spp: u32) -> String {
    format!(
        "[render]\nspp = {spp}\nmax_depth = 8\nseed = 0\n\n\
         [camera]\ntype = \"pinhole\"\nposition = [278, 273, -800]\nlook_at = [278, 273, 0]\n\
         up = [0, 1, 0]\nvfov = 37\nresolution = [{size}, {size}]\n\n\
         [[shapes]]\ntype = \"obj\"\nname = \"cornell box\"\nfile = \"{}\"\n",
        obj.display().to_string().replace('\\', "/")
    )
}

/// Runs this binary with `args`; its wall-clock seconds.
fn timed(args: &[String]) -> Result<f64> {
    let exe = std::env::current_exe().map_err(|source| Error::io("plsr", source))?;
    let clock = Instant::now();
    let out = Command::new(&exe)
        .args(args)
        .output()
        .map_err(|source| Error::io(exe, source))?;
    if !out.status.success() {
        return Err(Error::invalid_argument(format!(
            "plsr {}: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    Ok(clock.elapsed().as_secs_f64())
}

/// `plsr bench farm`: the Cornell box at `size`², `spp` samples per pixel,
/// in one render and in `parts` parts plus the merge; prints both times,
/// the overhead and whether the merged image matches. Returns the
/// overhead (parts and merge over one render, minus 1).
pub fn run(threads: Option<usize>, size: u32, spp: u32, parts: u32) -> Result<f64> {
    if parts == 0 || !spp.is_multiple_of(parts) {
        return Err(Error::invalid_argument(format!(
            "--parts {parts} must divide --spp {spp}"
        )));
    }
    let dir = super::bench_dir("farm")?;
    let obj = std::fs::canonicalize("assets/scenes/cornell/cornell.obj")
        .map_err(|source| Error::io("assets/scenes/cornell/cornell.obj", source))?;
    let scene_path = dir.join("cornell.toml");
    std::fs::write(&scene_path, scene(&obj, size, spp))
        .map_err(|source| Error::io(scene_path.clone(), source))?;
    let s = |p: &Path| p.display().to_string();
    let mut common = vec!["--quiet".to_string()];
    if let Some(t) = threads {
        common.extend(["--threads".into(), t.to_string()]);
    }
    let one_path = dir.join("one.exr");
    let one_args: Vec<String> = ["render".into(), s(&scene_path), "-o".into(), s(&one_path)]
        .into_iter()
        .chain(common.clone())
        .collect();
    let step = spp / parts;
    let part_paths: Vec<_> = (0..parts)
        .map(|i| dir.join(format!("part-{i}.exr")))
        .collect();
    let merged = dir.join("merged.exr");
    // Interleaved, best of two, so drift hits both alike.
    let (mut one, mut split, mut merge_s) = (f64::INFINITY, f64::INFINITY, 0.0);
    for _ in 0..2 {
        one = one.min(timed(&one_args)?);
        let mut total = 0.0;
        for (i, p) in part_paths.iter().enumerate() {
            let i = i as u32;
            let args: Vec<String> = [
                "render".into(),
                s(&scene_path),
                "-o".into(),
                s(p),
                "--samples".into(),
                format!("{}..{}", i * step, (i + 1) * step),
            ]
            .into_iter()
            .chain(common.clone())
            .collect();
            total += timed(&args)?;
        }
        let mut args = vec!["merge".to_string()];
        args.extend(part_paths.iter().map(|p| s(p)));
        args.extend(["-o".into(), s(&merged)]);
        let m = timed(&args)?;
        if total + m < split {
            (split, merge_s) = (total + m, m);
        }
    }
    let (a, b) = (Film::read_exr(&one_path)?, Film::read_exr(&merged)?);
    let max_rel = a
        .color
        .iter()
        .zip(&b.color)
        .flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).abs() / x[c].abs().max(1e-30)))
        .fold(0.0f32, f32::max);
    let _ = std::fs::remove_dir_all(&dir);
    let overhead = split / one - 1.0;
    println!(
        "plsr bench farm: Cornell box at {size}×{size}, {spp} spp, {parts} parts, best of 2 interleaved runs, each a separate process"
    );
    println!();
    println!("| run | seconds | per part |");
    println!("|---|---|---|");
    println!("| one render | {one:.2} | |");
    println!(
        "| {parts} parts of {step} spp, one after another, + merge | {split:.2} | {:.3} |",
        (split - merge_s) / parts as f64
    );
    println!("| of which the merge | {merge_s:.2} | |");
    println!();
    println!(
        "overhead of the split: {:+.1} % (target ≤ 5 %); merged image against the single render: largest relative difference {max_rel:.1e}",
        overhead * 100.0
    );
    Ok(overhead)
}
