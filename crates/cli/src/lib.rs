//! The `plsr` program's commands, as a library: one module per subcommand
//! (`bench/` holds the benchmark suites) and [`run`], which parses a command
//! line and runs it. `src/main.rs` is the program around it (signals, a
//! closed pipe, the exit status); the fuzz targets (`fuzz/`) reach the
//! parsers of the commands' own files, such as farm plans, through it.

pub mod bench;
pub mod compare;
pub mod composite;
pub mod denoise;
pub mod error;
pub mod experiment;
pub mod farm;
pub mod fit;
pub mod hdr;
pub mod import;
pub mod info;
pub mod linear_image;
pub mod merge;
pub mod pixel_args;
pub mod pls;
pub mod progress;
pub mod render;
pub mod say;
pub mod scene_params;
pub mod tonemap;
pub mod undistort;

use crate::error::Result;
use clap::{Parser, Subcommand};
use std::ffi::OsString;

/// plsr: a physically based renderer for placing virtual objects into
/// photographs, lit by parametric light sources or HDR panoramas.
#[derive(Debug, Parser)]
#[command(name = "plsr", version, about, long_about = None)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a scene file (TOML or JSON; see docs/scene-format.md) to OpenEXR
    /// (colour plus variance, alpha, object id, depth, normal and albedo
    /// layers) and optionally to a tone-mapped PNG.
    Render(render::RenderArgs),
    /// Composite a scene's virtual objects (`virtual = true`) into its
    /// photograph ([photo]), with the shadows and reflected light they cast
    /// on the real surfaces (see docs/compositing.md).
    Composite(composite::CompositeArgs),
    /// Merge the parts of a render (`plsr render --samples START..END` or
    /// `--crop X0,Y0,X1,Y1`) into the image one render of their union gives
    /// (see docs/farm.md)
    Merge(merge::MergeArgs),
    /// Denoise a render's OpenEXR, guided by its albedo and normal layers
    /// (Intel Open Image Denoise's network, run by plsr; see
    /// docs/denoising.md). The output keeps the noisy colour beside.
    Denoise(denoise::DenoiseArgs),
    /// Render on a batch system: cut a render (and an animation's frames)
    /// into pieces for a Slurm job array or a Kubernetes Indexed Job, and
    /// merge them exactly (see docs/farm.md).
    #[command(subcommand)]
    Farm(farm::FarmCommand),
    /// Tone-map an OpenEXR image (a render, a merge, an HDR panorama) to an
    /// 8-bit sRGB PNG, with automatic exposure by default.
    Tonemap(tonemap::TonemapArgs),
    /// Print what an OpenEXR file holds: size, channels, header attributes.
    Info(info::InfoArgs),
    /// Translate a Mitsuba 3 XML scene into a plsr scene file (TOML); `plsr
    /// render` also reads such XML directly (see docs/scene-format.md). Or
    /// import a camera calibration (OpenCV, ROS, COLMAP) as the scene's
    /// [camera] (see docs/calibration.md).
    Import(import::ImportArgs),
    /// Resample a photo into the ideal pinhole image of its calibrated
    /// camera (OpenCV's undistort; see docs/calibration.md).
    Undistort(undistort::UndistortArgs),
    /// Fit the real surfaces' materials (and lights' brightness) to the
    /// scene's photos by differentiable rendering and Adam. Its renders
    /// stay unbiased (never denoised): the fit's gradients need them so.
    Fit(fit::FitArgs),
    /// Score an image against a reference as the paper does (CW-SSIM) and
    /// by LPIPS, FLIP, SSIM, PSNR and RMSE, over a crop and a mask (see
    /// docs/metrics.md).
    Compare(compare::CompareArgs),
    /// Measure throughput. `plsr bench` (suite `core`): raw Embree rays, path
    /// tracing, and Embree's own `pathtracer` (Debian's embree-tools) on the
    /// same Cornell box. `plsr bench pls`: transforming 10,000 PLS lights
    /// through their parameters versus their vertices, and the cost of the
    /// window function in a render.
    Bench(bench::BenchArgs),
    /// Parametric light sources: check, tessellate and transform PLS files
    /// (see docs/pls-format.md).
    #[command(subcommand)]
    Pls(pls::PlsCommand),
    /// HDR panoramas: merge bracketed exposures into one HDR image (see
    /// docs/hdr.md).
    #[command(subcommand)]
    Hdr(hdr::HdrCommand),
    /// Reproducible experiments: `plsr experiment paper` redoes the paper's
    /// experiment (see docs/paper-experiment.md).
    #[command(subcommand)]
    Experiment(experiment::ExperimentCommand),
}

/// How the program ends: success, a failure (1) or a usage error (2).
pub enum Outcome {
    /// The command ran (or printed its help).
    Done,
    /// The command line was wrong; clap printed why.
    Usage,
}

/// Runs the program on the given arguments (including the program name).
pub fn run<I, T>(args: I) -> Result<Outcome>
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let args: Vec<OsString> = args.into_iter().map(Into::into).collect();
    let cli = match Cli::try_parse_from(args.iter().cloned()) {
        Ok(c) => c,
        Err(e) => {
            // --help and --version print and succeed; usage errors print and fail.
            let _ = e.print();
            return Ok(if e.use_stderr() {
                Outcome::Usage
            } else {
                Outcome::Done
            });
        }
    };
    // Every command's `--quiet` (`-q`) also silences its summaries; clap
    // accepted the flag, so the command has it. Arguments after `--` are
    // not flags.
    say::set_quiet(
        args.iter()
            .skip(1)
            .take_while(|a| *a != "--")
            .any(|a| a == "--quiet" || a == "-q"),
    );
    match cli.command {
        Command::Render(a) => render::run(&a),
        Command::Composite(a) => composite::run(&a),
        Command::Merge(a) => merge::run(&a),
        Command::Denoise(a) => denoise::run(&a),
        Command::Farm(c) => farm::run(c),
        Command::Tonemap(a) => tonemap::run(&a),
        Command::Info(a) => info::run(&a),
        Command::Import(a) => import::run(&a),
        Command::Undistort(a) => undistort::run(&a),
        Command::Fit(a) => fit::run(&a),
        Command::Compare(a) => compare::run(&a),
        Command::Bench(a) => bench::run(a),
        Command::Pls(c) => pls::run(c),
        Command::Hdr(c) => hdr::run(c),
        Command::Experiment(c) => experiment::run(c),
    }?;
    Ok(Outcome::Done)
}
