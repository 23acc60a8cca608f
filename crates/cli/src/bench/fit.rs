//! `plsr bench fit`: what an Adam iteration of `plsr fit` costs against a
//! plain render of the same scene, and against Mitsuba 3's `prb`
//! integrator on the same room and parameters when Mitsuba is installed.

use crate::error::{Error, Result};
use plsr::render::{render, RenderJob, RenderOptions};
use plsr::scene::Scene;
use plsr_apps::fit::{fit_scene_file, FitOptions};
use plsr_base::Vocabulary;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The demo room (`assets/scenes/fit-room`).
const ROOM: &str = "assets/scenes/fit-room";

/// The parameters fitted (10): every colour and roughness, and the ball's
/// metallic, as `crates/apps/examples/fit_demo.rs` and the Mitsuba script fit them.
const PARAMS: [&str; 4] = [
    "*.base_color",
    "*.reflectance",
    "*.roughness",
    "ball.metallic",
];

/// Options of `plsr bench fit`.
pub struct FitBenchOptions {
    /// Worker threads (`None`: every core).
    pub threads: Option<usize>,
    /// The Python that runs Mitsuba (`None`: no peer).
    pub python: Option<PathBuf>,
    /// Timed iterations.
    pub iterations: u32,
}

fn copy_room(dir: &Path) -> Result<()> {
    for f in ["fit-room.toml", "truth.toml", "photo.exr"] {
        let src = Path::new(ROOM).join(f);
        std::fs::copy(&src, dir.join(f)).map_err(|source| Error::io(src, source))?;
    }
    Ok(())
}

/// Mitsuba's seconds per iteration and per render, from
/// `scripts/bench_fit_mitsuba.py`, or why not.
fn mitsuba(
    python: &Path,
    photo: &Path,
    o: &FitBenchOptions,
) -> std::result::Result<(f64, f64, String), String> {
    let mut cmd = std::process::Command::new(python);
    cmd.arg("scripts/bench_fit_mitsuba.py")
        .arg("--photo")
        .arg(photo)
        .arg("--iterations")
        .arg(o.iterations.to_string())
        .arg("--spp")
        .arg("16");
    if let Some(t) = o.threads {
        cmd.arg("--threads").arg(t.to_string());
    }
    let (v, line) = super::python_json(&mut cmd, python)?;
    let get = |k: &str| {
        v.get(k)
            .and_then(serde_json::Value::as_f64)
            .ok_or(format!("no {k} in {line}"))
    };
    let variant = v.get("variant").and_then(|x| x.as_str()).unwrap_or("?");
    let version = v
        .get("mitsuba_version")
        .and_then(|x| x.as_str())
        .unwrap_or("?");
    Ok((
        get("seconds_per_iteration")?,
        get("render_seconds")?,
        format!("Mitsuba {version} {variant}"),
    ))
}

/// Runs the benchmark; returns seconds per iteration ÷ seconds per render.
pub fn run(o: &FitBenchOptions) -> Result<f64> {
    let dir = super::bench_dir("fit")?;
    copy_room(&dir)?;
    let scene_path = dir.join("fit-room.toml");
    let scene = Scene::load(&scene_path)?;
    let options = RenderOptions {
        threads: o.threads,
        ..Default::default()
    };
    let job = RenderJob {
        spp: 16,
        ..scene.default_job()
    };
    // The plain render: best of three after a warm-up.
    render(&scene, &job, &options, &|_, _| true)?;
    let mut best_render = f64::INFINITY;
    for _ in 0..3 {
        let start = Instant::now();
        render(&scene, &job, &options, &|_, _| true)?;
        best_render = best_render.min(start.elapsed().as_secs_f64());
    }
    // The fit: one warm-up iteration, then the timed ones.
    let fit_options = FitOptions {
        iterations: o.iterations + 1,
        params: PARAMS.iter().map(|s| s.to_string()).collect(),
        threads: o.threads,
        ..FitOptions::default()
    };
    let mut times = Vec::new();
    let mut n_params = 0;
    let outcome = fit_scene_file(
        &scene_path,
        &dir.join("fitted.toml"),
        &fit_options,
        &mut |it, p| {
            if it.index > 0 {
                times.push(it.seconds);
            }
            n_params = p.len();
            true
        },
    )?;
    let per_iteration = times.iter().sum::<f64>() / times.len().max(1) as f64;
    let ratio = per_iteration / best_render;
    let cam = scene.camera();
    println!(
        "plsr bench fit: {} parameters of the demo room ({}), {}×{}, 16 spp, max depth {}, {} timed iterations",
        n_params,
        ROOM,
        cam.width(),
        cam.height(),
        job.max_depth,
        times.len()
    );
    println!();
    println!("| work | seconds | ÷ plsr's render |");
    println!("|---|---|---|");
    println!("| plsr: one 16-spp render (best of 3) | {best_render:.3} | 1.000× |");
    println!(
        "| plsr: one Adam iteration (primal render, gradient pass, step) | {per_iteration:.3} | {ratio:.3}× |"
    );
    match &o.python {
        None => println!("\nMitsuba 3: skipped (--no-peer)"),
        Some(python) => match mitsuba(python, &dir.join("photo.exr"), o) {
            Ok((mi_iteration, mi_render, name)) => {
                println!(
                    "| {name}: one 16-spp render (`path`) | {mi_render:.3} | {:.3}× |",
                    mi_render / best_render
                );
                println!(
                    "| {name}: one Adam iteration (`prb`: render, backward, step) | {mi_iteration:.3} | {:.3}× |",
                    mi_iteration / best_render
                );
                println!();
                println!(
                    "plsr's iteration is {:.2}× as fast as Mitsuba's",
                    mi_iteration / per_iteration
                );
            }
            Err(why) => println!(
                "\nMitsuba 3: not measured ({why}); install it with `pip install mitsuba` and Debian's libllvm19"
            ),
        },
    }
    println!();
    println!(
        "loss {:.4e} → {:.4e} over the {} iterations",
        outcome.losses[0],
        outcome.losses.last().copied().unwrap_or(0.0),
        fit_options.iterations
    );
    let _ = std::fs::remove_dir_all(&dir);
    Ok(ratio)
}
