//! The `plsr` program: the command line over the plsr library. One module
//! per subcommand; `bench/` holds the benchmark suites.

mod bench;
mod compare;
mod composite;
mod error;
mod experiment;
mod farm;
mod fit;
mod hdr;
mod import;
mod info;
mod linear_image;
mod merge;
mod pls;
mod progress;
mod render;
mod scene_params;
mod tonemap;

use crate::error::Result;
use clap::{Parser, Subcommand};
use std::ffi::OsString;
use std::process::ExitCode;

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
    /// render` also reads such XML directly (see docs/scene-format.md).
    Import(import::ImportArgs),
    /// Fit the real surfaces' materials (and lights' brightness) to the
    /// scene's photos by differentiable rendering and Adam.
    Fit(fit::FitArgs),
    /// Score an image against a reference as the paper does (CW-SSIM) and
    /// by SSIM, PSNR and RMSE, over a crop and a mask (see docs/metrics.md).
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
enum Outcome {
    Done,
    Usage,
}

/// Runs the program on the given arguments (including the program name).
fn run<I, T>(args: I) -> Result<Outcome>
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let cli = match Cli::try_parse_from(args) {
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
    match cli.command {
        Command::Render(a) => render::run(&a),
        Command::Composite(a) => composite::run(&a),
        Command::Merge(a) => merge::run(&a),
        Command::Farm(c) => farm::run(c),
        Command::Tonemap(a) => tonemap::run(&a),
        Command::Info(a) => info::run(&a),
        Command::Import(a) => import::run(&a),
        Command::Fit(a) => fit::run(&a),
        Command::Compare(a) => compare::run(&a),
        Command::Bench(a) => bench::run(a),
        Command::Pls(c) => pls::run(c),
        Command::Hdr(c) => hdr::run(c),
        Command::Experiment(c) => experiment::run(c),
    }?;
    Ok(Outcome::Done)
}

/// On SIGINT (Ctrl-C), SIGTERM and SIGHUP: removes the temporary files of
/// outputs being written, then ends the process by the same signal, so the
/// shell sees what it sent. Without this the hidden `.partial` files of an
/// interrupted `hdr merge` (hundreds of MB) would stay behind.
fn remove_partial_outputs_on_signals() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        return;
    };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            plsr::atomic_write::remove_partial_outputs();
            // Restores the default action and raises the signal again.
            let _ = signal_hook::low_level::emulate_default_handler(signal);
            std::process::exit(128 + signal);
        }
    });
}

/// A closed standard output or error (`plsr info x.exr | head`) ends the
/// command quietly, as SIGPIPE ends a C program. Rust ignores SIGPIPE, so
/// writing to a closed pipe fails and `println!` panics ("failed printing
/// to stdout: Broken pipe"); for that panic alone this hook removes the
/// outputs not yet in place and ends the process by SIGPIPE's default
/// action (status 141 in a shell), with no message. Every other panic
/// goes to the default hook.
fn end_quietly_on_a_closed_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or("");
        if message.starts_with("failed printing to std")
            && message.contains(&format!("(os error {})", libc::EPIPE))
        {
            plsr::atomic_write::remove_partial_outputs();
            let _ = signal_hook::low_level::emulate_default_handler(libc::SIGPIPE);
            std::process::exit(128 + libc::SIGPIPE);
        }
        default(info);
    }));
}

fn main() -> ExitCode {
    remove_partial_outputs_on_signals();
    end_quietly_on_a_closed_pipe();
    match run(std::env::args_os()) {
        Ok(Outcome::Done) => ExitCode::SUCCESS,
        Ok(Outcome::Usage) => ExitCode::from(2),
        Err(e) => {
            eprintln!("plsr: error: {e}");
            ExitCode::FAILURE
        }
    }
}
