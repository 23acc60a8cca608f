//! `plsr render`: a scene file to OpenEXR (and PNG).

use crate::progress::progress_bar;
use plsr::atomic_write::{check_extension, same_file, OutputSet};
use plsr::error::{Error, Result};
use plsr::film::{check_exposure_stops, ToneMap};
use plsr::job::{JobError, MAX_DEPTH, MAX_SPP};
use plsr::render::{render, RenderOptions, DEFAULT_TILE_SIZE, MAX_TILE_SIZE};
use plsr::scene::Scene;
use std::path::{Path, PathBuf};

/// Arguments of `plsr render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// The scene file.
    pub scene: PathBuf,
    /// Output OpenEXR file (linear float, all layers).
    #[arg(short, long, value_name = "OUT.exr")]
    pub output: PathBuf,
    /// Also write an 8-bit sRGB PNG here.
    #[arg(long, value_name = "OUT.png")]
    pub png: Option<PathBuf>,
    /// Samples per pixel (overrides the scene's render.spp).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Maximum number of scattering events (overrides render.max_depth).
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Scattering events after which Russian roulette may end a path
    /// (overrides render.rr_depth; default 4).
    #[arg(long)]
    pub rr_depth: Option<u32>,
    /// Random seed (overrides render.seed); the image depends only on the
    /// scene, seed and spp, never on the thread count.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Tile edge in pixels.
    #[arg(long, default_value_t = DEFAULT_TILE_SIZE)]
    pub tile_size: u32,
    /// PNG exposure compensation in stops (+1 doubles brightness).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub exposure: f32,
    /// PNG tone mapping: a filmic curve (ACES fit) instead of a plain clamp.
    #[arg(long)]
    pub filmic: bool,
    /// Render with the general integrator even where the vectorised kernel
    /// applies (Lambert materials, textured or not, with or without vertex normals, real or
    /// virtual, lit by point, area and PLS lights and environments). The image is
    /// the same, bit for bit; this is for checking and timing.
    #[arg(long)]
    pub scalar: bool,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Checks an output path before any work is done: its folder exists, it
/// is not a folder itself, and its extension is the format written
/// (`extension`), so that no file is ever written under the wrong name.
fn check_output(flag: &str, path: &Path, extension: &str, format: &str) -> Result<()> {
    let fail = |message: String| Error::Output {
        file: path.to_path_buf(),
        message,
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(fail(format!("folder {} does not exist", dir.display())));
    }
    if path.is_dir() {
        return Err(fail(format!("{flag}: is a folder, not a file")));
    }
    check_extension(path, extension, format).map_err(|m| fail(format!("{flag}: {m}")))
}

/// Runs `plsr render`.
pub fn run(a: &RenderArgs) -> Result<()> {
    // Options are checked as strictly as scene files, before any work.
    check_exposure_stops(a.exposure)
        .map_err(|m| Error::InvalidArgument(format!("--exposure: {m}")))?;
    if a.tile_size == 0 || a.tile_size > MAX_TILE_SIZE {
        return Err(Error::InvalidArgument(format!(
            "--tile-size {}: must be between 1 and {MAX_TILE_SIZE} pixels",
            a.tile_size
        )));
    }
    // Every output is checked before the render, and none may replace an
    // input or another output.
    check_output("-o", &a.output, "exr", "OpenEXR")?;
    if let Some(p) = &a.png {
        check_output("--png", p, "png", "PNG")?;
        if same_file(p, &a.output) {
            return Err(Error::Output {
                file: p.clone(),
                message: "--png names the same file as -o".into(),
            });
        }
    }
    for out in std::iter::once(&a.output).chain(&a.png) {
        if same_file(out, &a.scene) {
            return Err(Error::Output {
                file: out.clone(),
                message: format!(
                    "is the scene file {}: it would be overwritten",
                    a.scene.display()
                ),
            });
        }
    }
    // No output may replace a file the scene reads either: its meshes,
    // MTL libraries, textures, environment image or PLS files.
    let (description, inputs) = plsr::scene::file::load_with_inputs(&a.scene)?;
    for out in std::iter::once(&a.output).chain(&a.png) {
        if let Some(input) = inputs.iter().find(|i| same_file(out, i)) {
            return Err(Error::Output {
                file: out.clone(),
                message: format!(
                    "is {}, which the scene reads: it would be overwritten",
                    input.display()
                ),
            });
        }
    }
    let scene = Scene::build(description)?;
    let mut job = scene.default_job();
    if let Some(spp) = a.spp {
        if spp == 0 {
            return Err(Error::InvalidArgument("--spp must be at least 1".into()));
        }
        job.spp = spp;
    }
    if let Some(d) = a.max_depth {
        if d == 0 {
            return Err(Error::InvalidArgument(
                "--max-depth must be at least 1".into(),
            ));
        }
        job.max_depth = d;
    }
    if let Some(s) = a.seed {
        job.seed = s;
    }
    if let Some(d) = a.rr_depth {
        job.rr_depth = d;
    }
    job.validate().map_err(|e| {
        Error::InvalidArgument(match e {
            JobError::Spp(v) => format!("--spp {v}: at most {MAX_SPP}"),
            JobError::MaxDepth(v) => format!("--max-depth {v}: at most {MAX_DEPTH}"),
            JobError::RrDepth(v) => format!("--rr-depth {v}: at most {MAX_DEPTH}"),
            other => other.to_string(),
        })
    })?;
    let options = RenderOptions {
        threads: a.threads,
        tile_size: a.tile_size,
        vectorised: !a.scalar,
        ..Default::default()
    };
    // Named against the scene file, before anything is allocated.
    plsr::render::check_memory(&scene, &options)
        .map_err(|m| Error::input(&a.scene, "camera.resolution", m))?;
    let bar = progress_bar(
        a.quiet,
        "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} tiles (eta {eta})",
    );
    let progress = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
        true
    };
    let (film, stats) = render(&scene, &job, &options, &progress)?;
    bar.finish_and_clear();
    // Both outputs are written first and replace their targets together.
    let mut outputs = OutputSet::new();
    film.stage_exr(&mut outputs, &a.output)?;
    if let Some(p) = &a.png {
        let tone = ToneMap {
            exposure: a.exposure,
            filmic: a.filmic,
        };
        film.stage_png(&mut outputs, p, tone)?;
    }
    outputs.commit()?;
    eprintln!(
        "rendered {}×{} at {} spp in {:.2} s: {:.3} Msamples/s, {:.2} Mrays/s on {} threads{} → {}{}",
        film.width,
        film.height,
        film.spp,
        stats.seconds,
        stats.msamples_per_s(),
        stats.mrays_per_s(),
        stats.threads,
        stats
            .vectorised
            .map(|isa| format!(", vectorised ({})", isa.name()))
            .unwrap_or_default(),
        a.output.display(),
        a.png
            .as_ref()
            .map(|p| format!(", {}", p.display()))
            .unwrap_or_default()
    );
    Ok(())
}
