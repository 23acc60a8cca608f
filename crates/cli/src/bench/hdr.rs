//! `plsr bench hdr`: merging 10 brackets at the Ricoh Theta Z1's size
//! (6720×3360) with plsr and with OpenCV's `MergeDebevec`.
//!
//! Synthetic 8-bit brackets of [`SyntheticScene`] at the paper's exposure
//! times (1/30 s … 15 s) are written as uncompressed TIFF (with EXIF exposure
//! metadata) into a temporary folder. Then, in the same run and on the same
//! files, each merger runs as its own process:
//! - `plsr hdr merge … --response debevec` (float EXR, uncompressed), which reports
//!   its peak resident memory (`VmHWM`);
//! - a Python script with OpenCV (`cv2.createCalibrateDebevec` +
//!   `cv2.createMergeDebevec`, writing Radiance HDR), which reports its
//!   `ru_maxrss`. It is skipped, with a message, if `import cv2` fails.
//!
//! Both outputs are compared with the truth (log-space RMSE after the best
//! global scale, over the recoverable pixels) and a table is printed.

use crate::error::{Error, Result};
use plsr_base::Vocabulary;
use plsr_hdr::oiio::AttrValue;
use plsr_hdr::synth::{self, BracketOptions, CameraModel, SyntheticScene, PAPER_EXPOSURES};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// What `plsr bench hdr` runs.
#[derive(Debug, Clone)]
pub struct HdrBenchOptions {
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
    /// Python interpreter for the OpenCV peer, or `None` to skip it.
    pub python: Option<PathBuf>,
    /// Worker threads for plsr (None: all cores).
    pub threads: Option<usize>,
    /// Folder for the brackets, kept afterwards and reused when it already
    /// holds brackets of the right size; `None`: a temporary folder.
    pub dir: Option<PathBuf>,
    /// The Memorial stack's folder (`None`: the repository's copy, if found).
    pub memorial: Option<PathBuf>,
}

/// OpenCV's merge: `script METHOD OUT TIMES FILE…` with METHOD `debevec`
/// or `robertson`; prints one JSON line of phase times and `ru_maxrss`.
pub(crate) const OPENCV_SCRIPT: &str = r#"
import json, resource, sys, time
t0 = time.perf_counter()
import cv2
import numpy as np
t_import = time.perf_counter()
method = sys.argv[1]
out = sys.argv[2]
times = np.array([float(x) for x in sys.argv[3].split(",")], dtype=np.float32)
files = sys.argv[4:]
imgs = [cv2.imread(f, cv2.IMREAD_COLOR) for f in files]
if any(i is None for i in imgs):
    print(json.dumps({"error": "cv2.imread failed"}))
    sys.exit(1)
t_read = time.perf_counter()
if method == "robertson":
    calibrate, merge = cv2.createCalibrateRobertson(), cv2.createMergeRobertson()
else:
    calibrate, merge = cv2.createCalibrateDebevec(), cv2.createMergeDebevec()
response = calibrate.process(imgs, times)
t_cal = time.perf_counter()
hdr = merge.process(imgs, times, response)
t_merge = time.perf_counter()
ok = cv2.imwrite(out, hdr)
t_write = time.perf_counter()
print(json.dumps({
    "ok": bool(ok),
    "import": t_import - t0, "read": t_read - t_import, "calibrate": t_cal - t_read,
    "merge": t_merge - t_cal, "write": t_write - t_merge,
    "maxrss_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
    "threads": cv2.getNumThreads(), "version": cv2.__version__,
}))
"#;

/// One merger's result.
#[derive(Debug, Clone)]
pub(crate) struct Run {
    pub(crate) wall: f64,
    pub(crate) peak_mib: Option<f64>,
    accuracy: Option<synth::Accuracy>,
    note: String,
}

/// Runs the benchmark and prints the table.
pub fn run(o: &HdrBenchOptions) -> Result<()> {
    let dir = o.dir.clone().unwrap_or_else(|| {
        std::env::temp_dir().join(format!("plsr-bench-hdr-{}", std::process::id()))
    });
    std::fs::create_dir_all(&dir).map_err(|source| Error::io(dir.clone(), source))?;
    let result = run_in(o, &dir).and_then(|()| {
        match super::hdr_memorial::find(o.memorial.as_deref()) {
            Some(stack) => super::hdr_memorial::run(&stack, o.python.as_deref(), o.threads, &dir),
            None => {
                println!(
                    "\nMemorial stack skipped: no tests/data/realworld/hdr/memorial here (give --hdr-memorial DIR)"
                );
                Ok(())
            }
        }
    });
    if o.dir.is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
    result
}

/// Whether `files` exist with the expected size (brackets to reuse).
fn reusable(files: &[PathBuf], width: usize, height: usize) -> bool {
    files.iter().all(|f| {
        plsr_hdr::oiio::ImageReader::open(f)
            .map(|r| r.info().width == width && r.info().height == height)
            .unwrap_or(false)
    })
}

fn run_in(o: &HdrBenchOptions, dir: &Path) -> Result<()> {
    let scene = SyntheticScene::new(o.width, o.height);
    let camera = CameraModel::default();
    let times = PAPER_EXPOSURES;
    let float_image_mib = (o.width * o.height * 3 * 4) as f64 / (1u64 << 20) as f64;
    println!(
        "plsr bench hdr: {} synthetic 8-bit brackets at {}×{} (exposures 1/30 s … 15 s), uncompressed TIFF with EXIF",
        times.len(),
        o.width,
        o.height
    );
    let t = Instant::now();
    let expected: Vec<PathBuf> = (0..times.len())
        .map(|i| dir.join(format!("bracket_{i:02}.tif")))
        .collect();
    let files = if o.dir.is_some() && reusable(&expected, o.width, o.height) {
        println!("  reusing the brackets in {}", dir.display());
        expected
    } else {
        let files = synth::write_brackets(
            &scene,
            &camera,
            &times,
            dir,
            &BracketOptions {
                attributes: vec![("compression".into(), AttrValue::Str("none".into()))],
                ..Default::default()
            },
        )?;
        println!(
            "  brackets written in {:.1} s to {}",
            t.elapsed().as_secs_f64(),
            dir.display()
        );
        files
    };

    // plsr, as a child process.
    let out = dir.join("plsr.exr");
    let merged = plsr_merge(&files, &out, &["--response", "debevec"], o.threads)?;
    let plsr = Run {
        accuracy: Some(synth::accuracy(&out, &scene, &camera, &times)?),
        note: "float EXR (uncompressed)".into(),
        ..merged
    };
    let _ = std::fs::remove_file(&out);

    // OpenCV, as a Python child process.
    let opencv = match &o.python {
        None => None,
        Some(py) => {
            let probe = Command::new(py).args(["-c", "import cv2"]).output();
            match probe {
                Ok(p) if p.status.success() => {
                    Some(run_opencv(py, dir, &files, &times, &scene, &camera)?)
                }
                _ => {
                    println!(
                        "  OpenCV skipped: `{} -c \"import cv2\"` failed (pip install opencv-python-headless)",
                        py.display()
                    );
                    None
                }
            }
        }
    };

    println!();
    println!(
        "| merger | wall time (s) | peak memory (MiB) | peak / float image | log-RMSE vs truth | scale | non-finite values | output |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let row = |name: &str, r: &Run| {
        let (rmse, scale, bad) = match &r.accuracy {
            Some(a) => (
                format!("{:.4}", a.log_rmse),
                format!("{:.3}", a.scale),
                a.bad_values.to_string(),
            ),
            None => ("-".into(), "-".into(), "-".into()),
        };
        println!(
            "| {name} | {:.2} | {} | {} | {rmse} | {scale} | {bad} | {} |",
            r.wall,
            r.peak_mib.map_or("-".into(), |m| format!("{m:.0}")),
            r.peak_mib
                .map_or("-".into(), |m| format!("{:.2}", m / float_image_mib)),
            r.note
        );
    };
    row("plsr (debevec)", &plsr);
    if let Some(cv) = &opencv {
        row("OpenCV MergeDebevec", cv);
    }
    println!();
    println!(
        "one full-size float RGB image: {float_image_mib:.0} MiB; target peak < 3 images = {:.0} MiB: {}",
        3.0 * float_image_mib,
        match plsr.peak_mib {
            Some(m) if m < 3.0 * float_image_mib => "met",
            Some(_) => "NOT met",
            None => "unknown",
        }
    );
    if let Some(cv) = &opencv {
        let ratio = cv.wall / plsr.wall;
        println!(
            "speed: plsr is {ratio:.2}× faster than OpenCV (target ≥ 3×: {}); accuracy: {}",
            if ratio >= 3.0 { "met" } else { "NOT met" },
            match (&plsr.accuracy, &cv.accuracy) {
                (Some(a), Some(b)) if a.log_rmse <= b.log_rmse => "plsr at least as accurate (met)",
                (Some(_), Some(_)) => "plsr less accurate (NOT met)",
                _ => "unknown",
            }
        );
    }
    Ok(())
}

/// Runs `plsr hdr merge FILES -o OUT ARGS --quiet` as a child process of
/// this executable; its wall time and the peak memory it reports.
pub(crate) fn plsr_merge(
    files: &[PathBuf],
    out: &Path,
    args: &[&str],
    threads: Option<usize>,
) -> Result<Run> {
    let exe = std::env::current_exe().map_err(|source| Error::io(PathBuf::from("plsr"), source))?;
    let mut cmd = Command::new(&exe);
    cmd.args(["hdr", "merge"])
        .args(files)
        .arg("-o")
        .arg(out)
        .args(args)
        // Not --quiet: the summary line says the peak memory. Progress
        // goes nowhere.
        .env("PLSR_PROGRESS", "none");
    if let Some(n) = threads {
        cmd.args(["--threads", &n.to_string()]);
    }
    let t = Instant::now();
    let output = cmd
        .output()
        .map_err(|e| Error::invalid_argument(format!("cannot run {}: {e}", exe.display())))?;
    let wall = t.elapsed().as_secs_f64();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    if !output.status.success() {
        return Err(Error::invalid_argument(format!(
            "plsr hdr merge failed: {stderr}"
        )));
    }
    let peak_mib = stderr
        .split("peak memory ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|s| s.parse::<f64>().ok());
    Ok(Run {
        wall,
        peak_mib,
        accuracy: None,
        note: String::new(),
    })
}

fn run_opencv(
    py: &Path,
    dir: &Path,
    files: &[PathBuf],
    times: &[f64],
    scene: &SyntheticScene,
    camera: &CameraModel,
) -> Result<Run> {
    let out = dir.join("opencv.hdr");
    let mut run = opencv_merge(py, dir, "debevec", files, times, &out)?;
    run.accuracy = synth::accuracy(&out, scene, camera, times).ok();
    let _ = std::fs::remove_file(&out);
    Ok(run)
}

/// Runs [`OPENCV_SCRIPT`] with `method` on `files` into `out` (Radiance
/// HDR), printing its phase times; the result has no accuracy yet.
pub(crate) fn opencv_merge(
    py: &Path,
    dir: &Path,
    method: &str,
    files: &[PathBuf],
    times: &[f64],
    out: &Path,
) -> Result<Run> {
    let script = dir.join("opencv_merge.py");
    std::fs::write(&script, OPENCV_SCRIPT).map_err(|source| Error::io(script.clone(), source))?;
    let list: Vec<String> = times.iter().map(|t| format!("{t}")).collect();
    let t = Instant::now();
    let output = Command::new(py)
        .arg(&script)
        .arg(method)
        .arg(out)
        .arg(list.join(","))
        .args(files)
        .output()
        .map_err(|e| Error::invalid_argument(format!("cannot run {}: {e}", py.display())))?;
    let wall = t.elapsed().as_secs_f64();
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let json: serde_json::Value = stdout
        .lines()
        .last()
        .and_then(|l| serde_json::from_str(l).ok())
        .ok_or_else(|| {
            Error::invalid_argument(format!(
                "the OpenCV script printed no result: {stdout}{}",
                String::from_utf8_lossy(&output.stderr)
            ))
        })?;
    let f = |k: &str| json.get(k).and_then(|v| v.as_f64()).unwrap_or(f64::NAN);
    println!(
        "  OpenCV {method} {} ({} threads): import {:.2} s, read {:.2} s, calibrate {:.2} s, merge {:.2} s, write {:.2} s",
        json.get("version").and_then(|v| v.as_str()).unwrap_or("?"),
        f("threads"),
        f("import"),
        f("read"),
        f("calibrate"),
        f("merge"),
        f("write")
    );
    Ok(Run {
        wall,
        peak_mib: Some(f("maxrss_kib") / 1024.0),
        accuracy: None,
        note: "Radiance HDR (RGBE)".into(),
    })
}
