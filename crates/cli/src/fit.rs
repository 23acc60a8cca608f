//! `plsr fit`: materials (and light brightness) fitted to photographs.

use crate::error::{Error, Result};
use crate::progress::progress_bar;
use plsr::atomic_write::{check_extension, same_file};
use plsr_apps::fit::{fit_scene_file, FitOptions};
use plsr_base::Vocabulary;
use std::path::{Path, PathBuf};

/// Arguments of `plsr fit`.
#[derive(Debug, clap::Args)]
pub struct FitArgs {
    /// The scene file, with a [photo] (and optionally [[views]]) of the
    /// real scene.
    pub scene: PathBuf,
    /// The fitted scene file to write (the same format as the scene).
    #[arg(short, long, value_name = "FITTED.toml")]
    pub output: PathBuf,
    /// Adam iterations.
    #[arg(long, default_value_t = 100)]
    pub iterations: u32,
    /// Adam's learning rate (light parameters: in units of their start value).
    #[arg(long, default_value_t = 0.05)]
    pub lr: f32,
    /// Samples per pixel of each render (the primal and the gradient each).
    #[arg(long, default_value_t = 16)]
    pub spp: u32,
    /// The parameters to fit, as OWNER.FIELD with `*` wildcards
    /// (`wall.reflectance`, `floor.*`, `*.roughness`, `lamp.b`); repeat for
    /// more. Default: every real surface's colour, roughness, metallic and
    /// anisotropic.
    #[arg(long = "param", value_name = "PATTERN")]
    pub params: Vec<String>,
    /// A PLS light (by name) whose window — divergence `a` and soft-edge
    /// width `penumbra` — and brightness `b` are found first, by a
    /// derivative-free search; repeat for more. Without --param, only the
    /// windows are fitted.
    #[arg(long = "window", value_name = "LIGHT")]
    pub windows: Vec<String>,
    /// With --window: also turn each light's direction `n` (two tilts
    /// about its outline's centre; every step rebuilds the scene).
    #[arg(long)]
    pub window_direction: bool,
    /// With --window: also scale each light's outline about its centre
    /// (its size shows only as the blur of the beam's edge, as a soft edge
    /// does, so the penumbra is then held).
    #[arg(long)]
    pub window_size: bool,
    /// With --window: also fit each light's outline shape: the length of
    /// its axis and each of its four half-widths `d` on their own (this
    /// includes the size; the penumbra is held; up to 400 renders). A
    /// circle light comes out as an explicit outline.
    #[arg(long)]
    pub window_shape: bool,
    /// Random seed (default: the scene's `[render] seed`, as `render` and
    /// `composite` use it).
    #[arg(long)]
    pub seed: Option<u64>,
    /// The loss curve as CSV (default: FITTED.loss.csv beside -o).
    #[arg(long, value_name = "LOSS.csv")]
    pub loss_csv: Option<PathBuf>,
    /// The loss curve plotted (default: FITTED.loss.png beside -o).
    #[arg(long, value_name = "LOSS.png")]
    pub loss_png: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print nothing but warnings and errors: no progress, no summary.
    #[arg(short, long)]
    pub quiet: bool,
}

/// `FITTED.EXT` → `FITTED.loss.EXT2`.
fn beside(out: &Path, ext: &str) -> PathBuf {
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "fitted".into());
    out.with_file_name(format!("{stem}.loss.{ext}"))
}

/// Runs `plsr fit`.
pub fn run(a: &FitArgs) -> Result<()> {
    let output_error = |file: &Path, message: String| Error::output(file.to_path_buf(), message);
    let scene_ext = a
        .scene
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let (ext, format) = if scene_ext == "json" {
        ("json", "JSON")
    } else {
        ("toml", "TOML")
    };
    check_extension(&a.output, ext, format)
        .map_err(|m| output_error(&a.output, format!("-o: {m} (the scene is {format})")))?;
    let loss_csv = a
        .loss_csv
        .clone()
        .unwrap_or_else(|| beside(&a.output, "csv"));
    let loss_png = a
        .loss_png
        .clone()
        .unwrap_or_else(|| beside(&a.output, "png"));
    check_extension(&loss_csv, "csv", "CSV")
        .map_err(|m| output_error(&loss_csv, format!("--loss-csv: {m}")))?;
    check_extension(&loss_png, "png", "PNG")
        .map_err(|m| output_error(&loss_png, format!("--loss-png: {m}")))?;
    if a.iterations == 0 {
        return Err(Error::invalid_argument("--iterations must be at least 1"));
    }
    if a.spp == 0 {
        return Err(Error::invalid_argument("--spp must be at least 1"));
    }
    if !(a.lr.is_finite() && a.lr > 0.0) {
        return Err(Error::invalid_argument(format!(
            "--lr {} must be a positive number",
            a.lr
        )));
    }
    let contents = plsr::scene::file::load_contents(&a.scene)?;
    let mut inputs = contents.inputs.clone();
    inputs.push(a.scene.clone());
    for out in [&a.output, &loss_csv, &loss_png] {
        if let Some(input) = inputs.iter().find(|i| same_file(out, i)) {
            return Err(output_error(
                out,
                format!(
                    "is {}, which the scene reads: it would be overwritten",
                    input.display()
                ),
            ));
        }
    }
    drop(contents);
    // The outputs' folder is made (before the fit, so that a folder that
    // cannot be made fails at once, not after minutes of fitting).
    for out in [&a.output, &loss_csv, &loss_png] {
        if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| {
                output_error(
                    out,
                    format!("cannot make its folder {}: {e}", dir.display()),
                )
            })?;
        }
    }
    let options = FitOptions {
        iterations: a.iterations,
        learning_rate: a.lr,
        spp: a.spp,
        seed: a.seed,
        params: a.params.clone(),
        threads: a.threads,
        windows: a.windows.clone(),
        window_direction: a.window_direction,
        window_size: a.window_size,
        window_shape: a.window_shape,
        window_evaluations: None,
    };
    let bar = progress_bar(
        a.quiet,
        "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} iterations, {msg} (eta {eta})",
    );
    bar.set_length(a.iterations as u64);
    // Until the first iteration reports its loss (window searches come
    // first when asked).
    bar.set_message("rendering the first iteration");
    let mut first = None;
    let mut progress = |it: &plsr_apps::fit::Iteration, _: &[plsr_apps::fit::Parameter]| {
        first.get_or_insert(it.loss);
        bar.set_message(format!("loss {:.4e}", it.loss));
        bar.set_position(it.index as u64 + 1);
        true
    };
    let outcome = fit_scene_file(&a.scene, &a.output, &options, &mut progress)?;
    bar.finish_and_clear();
    outcome.write(&a.output, &loss_csv, &loss_png, &inputs)?;
    for w in &outcome.warnings {
        eprintln!("warning: {w}");
    }
    for (name, w) in &outcome.windows {
        crate::note!(
            "window of {name}: n = [{:.4}, {:.4}, {:.4}], a = {:.3}°, penumbra = {:.3}°, size ×{:.3}, b = {:.5} ({} renders, loss {:.4e})",
            w.n.x, w.n.y, w.n.z, w.a_deg, w.penumbra_deg, w.size, w.b, w.evaluations, w.loss
        );
    }
    let fmt = |v: &[f32]| {
        let parts: Vec<String> = v.iter().map(|x| format!("{x:.4}")).collect();
        if parts.len() == 1 {
            parts[0].clone()
        } else {
            format!("[{}]", parts.join(", "))
        }
    };
    for p in &outcome.parameters {
        crate::note!("  {:<32} {} → {}", p.name, fmt(&p.initial), fmt(&p.value));
    }
    let (l0, l1) = (
        outcome.losses.first().copied().unwrap_or(0.0),
        outcome.losses.last().copied().unwrap_or(0.0),
    );
    let outputs = format!(
        "{}, {}, {}",
        a.output.display(),
        loss_csv.display(),
        loss_png.display()
    );
    if outcome.losses.len() > 1 {
        crate::note!(
            "fitted {} parameters on {} pixels in {} iterations ({:.3} s each): loss {l0:.4e} → {l1:.4e} ({:.1}× lower) → {outputs}",
            outcome.parameters.len(),
            outcome.pixels,
            a.iterations,
            outcome.seconds_per_iteration,
            if l1 > 0.0 { l0 / l1 } else { f64::INFINITY },
        );
    } else {
        // Only windows were searched: no Adam iterations.
        crate::note!(
            "fitted the windows of {} lights on {} pixels: loss {l1:.4e} → {outputs}",
            outcome.windows.len(),
            outcome.pixels
        );
    }
    Ok(())
}
