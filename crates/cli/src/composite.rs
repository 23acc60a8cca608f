//! `plsr composite`: virtual objects into a photograph, with their shadows.

use crate::error::{Error, Result};
use crate::progress::progress_bar;
use plsr::atomic_write::{check_extension, same_file, OutputSet};
use plsr::render::RenderOptions;
use plsr_apps::composite::{composite_scene, CompositeOptions, Mode};
use plsr_base::Vocabulary;
use std::path::PathBuf;

/// Arguments of `plsr composite`.
#[derive(Debug, clap::Args)]
pub struct CompositeArgs {
    /// The scene file, with a [photo] table and shapes marked `virtual = true`.
    pub scene: PathBuf,
    /// Output OpenEXR (linear: composite RGB, matte A, difference.R/G/B).
    #[arg(short, long, value_name = "OUT.exr")]
    pub output: PathBuf,
    /// Also write an 8-bit PNG encoded through the photo's response.
    #[arg(long, value_name = "OUT.png")]
    pub png: Option<PathBuf>,
    /// `differential` (objects, their shadows scaling the photo's colour
    /// and the light they reflect added), `additive` (Debevec's original:
    /// the render's change added, clamped at 0, which can shift a shadow's
    /// hue) or `superimpose` (objects pasted over the photo).
    #[arg(long, default_value = "differential")]
    pub mode: Mode,
    /// Samples per pixel of each render (default: the scene's render.spp).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Random seed (default: the scene's render.seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Also write the matte (the virtual objects' coverage) as an 8-bit grey
    /// PNG: the mask to score the composite with (`plsr compare --mask`).
    #[arg(long, value_name = "MATTE.png")]
    pub matte: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Denoising of both renders (with and without the virtual objects)
    /// before their difference is taken.
    #[command(flatten)]
    pub denoise: crate::denoise::DenoiseFlags,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Runs `plsr composite`.
pub fn run(a: &CompositeArgs) -> Result<()> {
    let output_error = |file: &PathBuf, message: String| Error::output(file.clone(), message);
    check_extension(&a.output, "exr", "OpenEXR")
        .map_err(|m| output_error(&a.output, format!("-o: {m}")))?;
    if let Some(p) = &a.png {
        check_extension(p, "png", "PNG").map_err(|m| output_error(p, format!("--png: {m}")))?;
        if same_file(p, &a.output) {
            return Err(output_error(p, "--png names the same file as -o".into()));
        }
    }
    if let Some(m) = &a.matte {
        check_extension(m, "png", "PNG").map_err(|e| output_error(m, format!("--matte: {e}")))?;
        if same_file(m, &a.output) || a.png.as_ref().is_some_and(|p| same_file(m, p)) {
            return Err(output_error(
                m,
                "--matte names the same file as another output".into(),
            ));
        }
    }
    if a.spp == Some(0) {
        return Err(Error::invalid_argument("--spp must be at least 1"));
    }
    let contents = plsr::scene::file::load_contents(&a.scene)?;
    for out in std::iter::once(&a.output).chain(&a.png).chain(&a.matte) {
        if let Some(input) = std::iter::once(&a.scene)
            .chain(&contents.inputs)
            .find(|i| same_file(out, i))
        {
            return Err(output_error(
                out,
                format!(
                    "is {}, which the scene reads: it would be overwritten",
                    input.display()
                ),
            ));
        }
    }
    let options = CompositeOptions {
        mode: a.mode,
        spp: a.spp,
        seed: a.seed,
        render: RenderOptions {
            threads: a.threads,
            ..Default::default()
        },
        denoise: a
            .denoise
            .denoise
            .then(|| plsr::film::denoise::DenoiseSettings {
                prefilter: a.denoise.denoise_prefilter,
                ..Default::default()
            }),
    };
    let bar = progress_bar(
        a.quiet,
        "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} tiles, with and without the virtual objects (eta {eta})",
    );
    let progress = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
        true
    };
    let (result, transfer, report) = composite_scene(&a.scene, contents, &options, &progress)?;
    bar.finish_and_clear();
    let mut outputs = OutputSet::new();
    result.stage_exr(&mut outputs, &a.output)?;
    if let Some(p) = &a.png {
        result.stage_png(&mut outputs, p, &transfer)?;
    }
    if let Some(m) = &a.matte {
        result.stage_matte_png(&mut outputs, m)?;
    }
    outputs.commit()?;
    let exposure = match report.fit {
        Some(f) => format!(
            "exposure k = {:.5} fitted on {} of {} pixels (relative RMS residual {:.3})",
            f.k, f.used, f.considered, f.relative_rms
        ),
        None => format!("exposure k = {} (from the scene)", result.k),
    };
    eprintln!(
        "composited {}×{} ({}) in {:.2} s of rendering{}, {exposure} → {}{}",
        result.width,
        result.height,
        a.mode,
        report.render_seconds,
        if a.denoise.denoise {
            format!(" and {:.2} s of denoising", report.denoise_seconds)
        } else {
            String::new()
        },
        a.output.display(),
        a.png
            .as_ref()
            .map(|p| format!(", {}", p.display()))
            .unwrap_or_default()
    );
    Ok(())
}
