//! `plsr bench compare`: the paper's two metrics, CW-SSIM and LPIPS, on a
//! 400×300 crop and on a 6720×3360 panorama, against their reference
//! implementations (pyiqa's `cw_ssim`, the `lpips` package) on the same
//! images in the same run.

use crate::error::{Error, Result};
use plsr_base::Vocabulary;
use plsr_metrics::{cwssim, lpips, MetricImage};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of `plsr bench compare`.
pub struct CompareBenchOptions {
    /// Worker threads (`None`: every core).
    pub threads: Option<usize>,
    /// The Python with pyiqa and lpips (`None`: no peer).
    pub python: Option<PathBuf>,
    /// Panorama size (width, height).
    pub panorama: (usize, usize),
}

/// A test pair of `w`×`h` display images: a reference with structure at
/// many scales (smooth shading, edges, texture), and the same with noise, a
/// slight blur and a brightness change — the differences a render has
/// against a photo.
fn pair(w: usize, h: usize) -> (MetricImage, MetricImage) {
    let mut a = Vec::with_capacity(w * h * 3);
    let mut b = Vec::with_capacity(w * h * 3);
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut noise = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32 - 0.5
    };
    for y in 0..h {
        for x in 0..w {
            let (u, v) = (x as f32 / w as f32, y as f32 / h as f32);
            let shade = 0.35 + 0.3 * (6.0 * u).sin() * (4.0 * v).cos();
            let tiles = if ((x / 24) + (y / 24)) % 2 == 0 {
                0.15
            } else {
                0.0
            };
            let rings = 0.1 * ((u - 0.5).hypot(v - 0.5) * 80.0).sin();
            let base = [shade + tiles, shade + rings, 0.5 * shade + tiles + rings];
            for c in base {
                a.push(c.clamp(0.0, 1.0));
                b.push((0.93 * c + 0.03 * noise()).clamp(0.0, 1.0));
            }
        }
    }
    (
        MetricImage::from_display(w, h, a),
        MetricImage::from_display(w, h, b),
    )
}

fn write_png(img: &MetricImage, path: &Path) -> Result<()> {
    let bytes: Vec<u8> = img.rgb.iter().map(|v| (v * 255.0).round() as u8).collect();
    image::RgbImage::from_raw(img.width as u32, img.height as u32, bytes)
        .expect("the buffer fits")
        .save(path)
        .map_err(|e| Error::output(path.to_path_buf(), e.to_string()))
}

/// Best time of `repeat` runs of `f` (after a warm-up when `warm`).
fn best<T>(repeat: usize, warm: bool, mut f: impl FnMut() -> Result<T>) -> Result<(T, f64)> {
    if warm {
        f()?;
    }
    let mut t = f64::INFINITY;
    let mut value = None;
    for _ in 0..repeat {
        let start = Instant::now();
        value = Some(f()?);
        t = t.min(start.elapsed().as_secs_f64());
    }
    Ok((value.expect("repeat ≥ 1"), t))
}

/// Runs the benchmark.
pub fn run(o: &CompareBenchOptions) -> Result<()> {
    if let Some(t) = o.threads {
        // The metrics run on rayon's global pool.
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global();
    }
    let dir = super::bench_dir("compare")?;
    let sizes = [(400, 300), o.panorama];
    let mut files = Vec::new();
    let mut ours = Vec::new();
    for &(w, h) in &sizes {
        let (a, b) = pair(w, h);
        // The pair as 8-bit files, read back: both sides score the same
        // values.
        let (pa, pb) = (
            dir.join(format!("ref-{w}x{h}.png")),
            dir.join(format!("test-{w}x{h}.png")),
        );
        write_png(&a, &pa)?;
        write_png(&b, &pb)?;
        let (a, b) = (MetricImage::load(&pa)?, MetricImage::load(&pb)?);
        let small = w * h < 4_000_000;
        let repeat = if small { 3 } else { 1 };
        let (ga, gb) = (a.grey(), b.grey());
        let (c, tc) = best(repeat, small, || {
            Ok(cwssim::cwssim(&ga, &gb, &cwssim::CwSsimOptions::default())?)
        })?;
        let (l, tl) = best(repeat, small, || Ok(lpips::lpips(&a, &b)?))?;
        ours.push((w, h, c, tc, l, tl));
        files.push((pa, pb));
    }
    let peer = match &o.python {
        None => Err("skipped (--no-peer)".to_string()),
        Some(python) => python_peer(python, &files, o.threads),
    };
    println!(
        "plsr bench compare: CW-SSIM (level 4, 8 orientations) and LPIPS (AlexNet v0.1) of a \
         test image against a reference, {} threads",
        o.threads.map_or(rayon::current_num_threads(), |t| t)
    );
    println!();
    println!("| image | metric | plsr s | plsr Mpixel/s | reference s | plsr ÷ reference speed | values |");
    println!("|---|---|---|---|---|---|---|");
    for (k, &(w, h, c, tc, l, tl)) in ours.iter().enumerate() {
        let mp = (w * h) as f64 / 1e6;
        let row = |name: &str, ours_s: f64, ours_v: f64, theirs: Option<(f64, Option<f64>)>| {
            let (peer_s, ratio, values) = match theirs {
                Some((s, v)) => (
                    format!("{s:.3}"),
                    format!("{:.2}×", s / ours_s),
                    match v {
                        Some(v) => format!("plsr {ours_v:.6}, reference {v:.6}"),
                        None => format!("plsr {ours_v:.6}"),
                    },
                ),
                None => ("—".into(), "—".into(), format!("plsr {ours_v:.6}")),
            };
            println!(
                "| {w}×{h} | {name} | {ours_s:.3} | {:.1} | {peer_s} | {ratio} | {values} |",
                mp / ours_s
            );
        };
        let p = peer.as_ref().ok().and_then(|v| v.get(k));
        row("CW-SSIM", tc, c, p.map(|r| (r.0, Some(r.1))));
        row("LPIPS", tl, l, p.map(|r| (r.2, None)));
    }
    if let Err(why) = &peer {
        println!(
            "\nreference implementations: not measured ({why}); install them with \
             `pip install torch torchvision pyiqa lpips`"
        );
    } else {
        println!(
            "\nreference: pyiqa's cw_ssim and the lpips package (PyTorch on the CPU; LPIPS with \
             random AlexNet weights, which cost the same, so its value is not shown)"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// The reference's (CW-SSIM seconds, CW-SSIM value, LPIPS seconds) per
/// pair, from `scripts/bench_compare_python.py`, or why not.
fn python_peer(
    python: &Path,
    files: &[(PathBuf, PathBuf)],
    threads: Option<usize>,
) -> std::result::Result<Vec<(f64, f64, f64)>, String> {
    let mut cmd = std::process::Command::new(python);
    cmd.arg("scripts/bench_compare_python.py");
    for (a, b) in files {
        cmd.arg("--pair").arg(a).arg(b);
    }
    if let Some(t) = threads {
        cmd.arg("--threads").arg(t.to_string());
    }
    let (v, line) = super::python_json(&mut cmd, python)?;
    let pairs = v["pairs"].as_array().ok_or(format!("no pairs in {line}"))?;
    pairs
        .iter()
        .map(|p| {
            let get = |k: &str| p[k].as_f64().ok_or(format!("no {k} in {line}"));
            Ok((
                get("cwssim_seconds")?,
                get("cwssim")?,
                get("lpips_seconds")?,
            ))
        })
        .collect()
}
