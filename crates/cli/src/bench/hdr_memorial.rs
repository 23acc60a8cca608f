//! `plsr bench hdr`, on a real stack: Paul Debevec's Memorial Church scans
//! (16 exposures, 32 s … 1/1024 s), merged by plsr's defaults and by
//! OpenCV's Debevec and Robertson in the same run, each scored against
//! Debevec's own radiance map (log2-RMSE over every pixel, the brightest
//! 1 % and the darkest 10 %; [`plsr_hdr::reference`]).
//!
//! The stack is the halved copy in `tests/data/realworld/hdr/memorial/`
//! (found from the working folder or the executable's), or the folder
//! `--hdr-memorial DIR` names (e.g. the full 512×768 original): it must
//! hold `memorial0061.png` … `memorial0076.png`, `shutter_times.txt` and
//! `memorial.hdr`.

use super::hdr::{opencv_merge, plsr_merge};
use crate::error::{Error, Result};
use plsr_base::Vocabulary;
use plsr_hdr::reference::{reference_errors, ReferenceErrors};
use std::path::{Path, PathBuf};
use std::process::Command;

const FIXTURE: &str = "tests/data/realworld/hdr/memorial";

/// The stack's folder: `given`, or the repository's copy.
pub fn find(given: Option<&Path>) -> Option<PathBuf> {
    if let Some(d) = given {
        return Some(d.to_path_buf());
    }
    let from_cwd = std::env::current_dir().ok().map(|d| d.join(FIXTURE));
    let from_exe = std::env::current_exe()
        .ok()
        .and_then(|e| e.ancestors().nth(3).map(|root| root.join(FIXTURE)));
    [from_cwd, from_exe]
        .into_iter()
        .flatten()
        .find(|d| d.join("shutter_times.txt").is_file())
}

/// Runs the comparison in `work` (a scratch folder) and prints its table.
pub fn run(stack: &Path, python: Option<&Path>, threads: Option<usize>, work: &Path) -> Result<()> {
    let text = std::fs::read_to_string(stack.join("shutter_times.txt"))
        .map_err(|source| Error::io(stack.join("shutter_times.txt"), source))?;
    let times = text
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            plsr_hdr::merge::parse_exposure(l.trim()).map_err(|e| {
                Error::invalid_argument(format!(
                    "{}: {e}",
                    stack.join("shutter_times.txt").display()
                ))
            })
        })
        .collect::<Result<Vec<f64>>>()?;
    let files: Vec<PathBuf> = (61..61 + times.len())
        .map(|n| stack.join(format!("memorial{n:04}.png")))
        .collect();
    let reference = read_reference(&stack.join("memorial.hdr"))?;
    let info = plsr_hdr::oiio::ImageReader::open(&files[0])?.info().clone();
    println!();
    println!(
        "Memorial Church, {} real 8-bit brackets at {}×{} ({}), against Debevec's radiance map:",
        files.len(),
        info.width,
        info.height,
        stack.display()
    );
    let list: Vec<String> = times.iter().map(|t| format!("{t}")).collect();
    let out = work.join("memorial-plsr.exr");
    let plsr = plsr_merge(&files, &out, &["--exposures", &list.join(",")], threads)?;
    let mut rows = vec![(
        "plsr (defaults)".to_string(),
        plsr.clone(),
        score(&out, &reference)?,
    )];
    let _ = std::fs::remove_file(&out);
    if let Some(py) = python {
        let probe = Command::new(py).args(["-c", "import cv2"]).output();
        if matches!(probe, Ok(p) if p.status.success()) {
            for method in ["debevec", "robertson"] {
                let out = work.join(format!("memorial-opencv-{method}.hdr"));
                let run = opencv_merge(py, work, method, &files, &times, &out)?;
                rows.push((format!("OpenCV {method}"), run, score(&out, &reference)?));
                let _ = std::fs::remove_file(&out);
            }
        } else {
            println!(
                "  OpenCV skipped: `{} -c \"import cv2\"` failed",
                py.display()
            );
        }
    }
    println!();
    println!("| merger | wall time (s) | peak memory (MiB) | log2-RMSE, all | brightest 1 % | darkest 10 % |");
    println!("|---|---|---|---|---|---|");
    for (name, run, e) in &rows {
        println!(
            "| {name} | {:.2} | {} | {:.3} | {:.3} | {:.3} |",
            run.wall,
            run.peak_mib.map_or("-".into(), |m| format!("{m:.0}")),
            e.all,
            e.brightest,
            e.darkest
        );
    }
    let peers = &rows[1..];
    if !peers.is_empty() {
        let best = |f: fn(&ReferenceErrors) -> f64| {
            peers
                .iter()
                .map(|(_, _, e)| f(e))
                .fold(f64::INFINITY, f64::min)
        };
        let fastest = peers
            .iter()
            .map(|(_, r, _)| r.wall)
            .fold(f64::INFINITY, f64::min);
        let e = &rows[0].2;
        let verdict = |ours: f64, theirs: f64| if ours <= theirs { "met" } else { "NOT met" };
        println!();
        println!(
            "plsr's default against OpenCV's best: all {:.3} vs {:.3} ({}), brightest {:.3} vs {:.3} ({}), darkest {:.3} vs {:.3} ({}); speed {:.2}× OpenCV's fastest (target ≥ 3×: {})",
            e.all,
            best(|e| e.all),
            verdict(e.all, best(|e| e.all)),
            e.brightest,
            best(|e| e.brightest),
            verdict(e.brightest, best(|e| e.brightest)),
            e.darkest,
            best(|e| e.darkest),
            verdict(e.darkest, best(|e| e.darkest)),
            fastest / plsr.wall,
            if fastest / plsr.wall >= 3.0 { "met" } else { "NOT met" }
        );
    }
    Ok(())
}

/// The reference map as RGB floats, through plsr's Radiance reader (which
/// takes the header lines Radiance's own tools write before the `#?`
/// magic line, as in Debevec's map, and OpenImageIO refuses).
fn read_reference(path: &Path) -> Result<Vec<f32>> {
    let (_, _, pixels) = plsr::film::radiance::read_radiance_hdr(path)?;
    Ok(pixels.iter().flat_map(|p| p.to_array()).collect())
}

fn score(merged: &Path, reference: &[f32]) -> Result<ReferenceErrors> {
    let (info, data) = plsr_hdr::oiio::read_image_f32(merged)?;
    if info.channels != 3 || data.len() != reference.len() {
        return Err(Error::invalid_argument(format!(
            "{}: not an RGB image of the reference's size",
            merged.display()
        )));
    }
    Ok(reference_errors(&data, reference))
}
