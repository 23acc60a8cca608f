//! The `plsr` command-line program.

use crate::bench::{self, BenchOptions};
use crate::error::{Error, Result};
use crate::film::ToneMap;
use crate::render::{render, RenderOptions, DEFAULT_TILE_SIZE};
use crate::scene::Scene;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::ffi::OsString;
use std::path::{Path, PathBuf};

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
    Render(RenderArgs),
    /// Measure throughput. `plsr bench` (suite `core`): raw Embree rays, path
    /// tracing, and Embree's own `pathtracer` (Debian's embree-tools) on the
    /// same Cornell box. `plsr bench pls`: transforming 10,000 PLS lights
    /// through their parameters versus their vertices, and the cost of the
    /// window function in a render.
    Bench(BenchArgs),
    /// Parametric light sources: check, tessellate and transform PLS files
    /// (see docs/pls-format.md).
    #[command(subcommand)]
    Pls(PlsCommand),
    /// HDR panoramas: merge bracketed exposures into one HDR image (see
    /// docs/hdr.md).
    #[command(subcommand)]
    Hdr(HdrCommand),
}

/// `plsr hdr …` subcommands.
#[derive(Debug, Subcommand)]
pub enum HdrCommand {
    /// Merge bracketed exposures (any order, any format OpenImageIO reads:
    /// JPEG, PNG, TIFF 8/16-bit, EXR, HDR, camera raw) into one float or half
    /// OpenEXR (or Radiance .hdr), recovering the camera response. Exposure
    /// times come from EXIF (ExposureTime, with FNumber and ISO when they
    /// differ) or from --exposures.
    Merge(HdrMergeArgs),
    /// Simulate a 360° camera's bracket capture: render the scene's
    /// equirectangular panorama at a position and write bracketed 8-bit
    /// photos through a camera response, with noise, clipping and EXIF
    /// exposure data (and the rendered truth as truth.exr), ready for
    /// `plsr hdr merge`.
    Capture(HdrCaptureArgs),
}

/// Arguments of `plsr hdr capture`.
#[derive(Debug, clap::Args)]
pub struct HdrCaptureArgs {
    /// The scene file.
    pub scene: PathBuf,
    /// Camera position `X,Y,Z` (scene units).
    #[arg(long, value_name = "X,Y,Z")]
    pub at: String,
    /// Output folder (created; must not exist or be empty).
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Zenith of the panorama `X,Y,Z` (default: the scene camera's up).
    #[arg(long, value_name = "X,Y,Z")]
    pub up: Option<String>,
    /// Centre column direction `X,Y,Z` (default: the scene camera's view).
    #[arg(long, value_name = "X,Y,Z")]
    pub forward: Option<String>,
    /// Panorama size `WxH` (the Theta Z1 records 6720x3360).
    #[arg(long, default_value = "512x256")]
    pub size: String,
    /// Samples per pixel (default: the scene's).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Exposure times, seconds (default: the paper's 1/30 … 15 s).
    #[arg(long, value_name = "1/30,1/15,…")]
    pub exposures: Option<String>,
    /// Camera response: `filmic` (an 8-bit camera's curve) or `linear` (raw).
    #[arg(long, default_value = "filmic")]
    pub response: String,
    /// Turn off shot and read noise.
    #[arg(long)]
    pub no_noise: bool,
    /// Photo format: tif, png or jpg. (OpenImageIO 2.4's JPEG writer
    /// garbles some EXIF exposure times, e.g. 1/8 s; TIFF keeps them.)
    #[arg(long, default_value = "tif")]
    pub format: String,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// Arguments of `plsr hdr merge`.
#[derive(Debug, clap::Args)]
pub struct HdrMergeArgs {
    /// The bracketed images (at least two, same size).
    #[arg(required = true, value_name = "IMG")]
    pub images: Vec<PathBuf>,
    /// Output: OpenEXR (.exr) or Radiance HDR (.hdr).
    #[arg(short, long, value_name = "PANO.exr")]
    pub output: PathBuf,
    /// Exposure times in seconds, one per image in the order given
    /// ("1/30,1/15,0.5,2"); default: from each image's EXIF.
    #[arg(long, value_name = "T1,T2,…")]
    pub exposures: Option<String>,
    /// Camera response: recovered (debevec, robertson) or a preset (linear
    /// for raw/linear data, srgb).
    #[arg(long, default_value = "debevec", value_parser = ["debevec", "robertson", "linear", "srgb"])]
    pub response: String,
    /// Align the brackets first (translation, median threshold bitmaps).
    #[arg(long)]
    pub align: bool,
    /// Write the response curve as CSV here, and its plot as PNG next to it.
    #[arg(long, value_name = "CURVE.csv")]
    pub curve: Option<PathBuf>,
    /// Store half floats instead of 32-bit floats (EXR only).
    #[arg(long)]
    pub half: bool,
    /// Debevec smoothness weight λ.
    #[arg(long, default_value_t = crate::hdr::response::DEFAULT_LAMBDA)]
    pub lambda: f64,
    /// Debevec sample pixels (default: ≥ 100, from bit depth and bracket count).
    #[arg(long)]
    pub samples: Option<usize>,
    /// OpenEXR compression (zip, piz, zips, rle, dwaa, none, …); default:
    /// zip for --half, none for float (noisy float data barely compresses).
    #[arg(long)]
    pub compression: Option<String>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
}

/// `plsr pls …` subcommands.
#[derive(Debug, Subcommand)]
pub enum PlsCommand {
    /// Validate a PLS file and print a table of its lights: area, centre,
    /// normal, cone angle and total emitted power.
    Check {
        /// The PLS file (TOML or JSON).
        file: PathBuf,
        /// Quads along each light's axis for the tessellated area.
        #[arg(long, default_value_t = crate::pls::DEFAULT_NF)]
        nf: u32,
    },
    /// Export the tessellated emitters as a Wavefront OBJ (one object per light).
    Mesh {
        /// The PLS file.
        file: PathBuf,
        /// Output OBJ file.
        #[arg(short, long)]
        output: PathBuf,
        /// Quads along each light's axis.
        #[arg(long, default_value_t = crate::pls::DEFAULT_NF)]
        nf: u32,
    },
    /// Transform every light through its parameters (paper eq. 15–21) and
    /// write a new PLS file. Give a matrix, or any of translate/rotate/scale
    /// (applied scale, then rotate, then translate).
    Transform {
        /// The PLS file.
        file: PathBuf,
        /// Output PLS file (TOML, or JSON by extension).
        #[arg(short, long)]
        output: PathBuf,
        /// A 4×4 affine matrix, 16 numbers row by row ("m00 m01 … m33").
        #[arg(long, allow_hyphen_values = true)]
        matrix: Option<String>,
        /// Translation "x,y,z" (metres).
        #[arg(long, allow_hyphen_values = true)]
        translate: Option<String>,
        /// Rotation axis "x,y,z" (with --rotate-deg).
        #[arg(long, allow_hyphen_values = true)]
        rotate_axis: Option<String>,
        /// Rotation angle in degrees (with --rotate-axis).
        #[arg(long, allow_hyphen_values = true)]
        rotate_deg: Option<f32>,
        /// Uniform scale factor.
        #[arg(long)]
        scale: Option<f32>,
    },
}

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
    /// applies (plain Lambert materials lit by point and area lights). The image is
    /// the same, bit for bit; this is for checking and timing.
    #[arg(long)]
    pub scalar: bool,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Arguments of `plsr bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Which benchmark: `core`, `pls`, `materials` (all-diffuse versus
    /// all-principled Cornell box) or `hdr` (merging 10 brackets at
    /// 6720×3360, plsr against OpenCV's MergeDebevec).
    #[arg(default_value = "core", value_parser = ["core", "pls", "materials", "hdr"])]
    pub suite: String,
    /// Image size for `plsr bench hdr`, WIDTHxHEIGHT.
    #[arg(long, default_value = "6720x3360")]
    pub hdr_size: String,
    /// Folder for the brackets of `plsr bench hdr` (kept afterwards; reused
    /// if it already holds them). Default: a temporary folder, removed.
    #[arg(long)]
    pub hdr_dir: Option<PathBuf>,
    /// Python interpreter with OpenCV for `plsr bench hdr`.
    #[arg(long, default_value = "python3")]
    pub python: PathBuf,
    /// The plsr scene reproducing Embree's demo configuration.
    #[arg(long, default_value = "assets/scenes/cornell/embree-demo.toml")]
    pub scene: PathBuf,
    /// Embree's `pathtracer` binary (skipped if it cannot be found).
    #[arg(long, default_value = "pathtracer")]
    pub pathtracer: PathBuf,
    /// Embree's model configuration (.ecs) for its pathtracer.
    #[arg(long, default_value = "/usr/share/doc/embree3/models/cornell_box.ecs")]
    pub ecs: PathBuf,
    /// Image size (square) for the path-tracing comparison.
    #[arg(long, default_value_t = 512)]
    pub size: u32,
    /// Samples per pixel for the path-tracing comparison.
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
    /// Random rays for the raw Embree measurement (millions).
    #[arg(long, default_value_t = 4.0)]
    pub mrays: f64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Skip the peer (Embree's pathtracer; OpenCV for `hdr`).
    #[arg(long)]
    pub no_peer: bool,
}

/// Runs the program on the given arguments (including the program name).
pub fn run<I, T>(args: I) -> Result<()>
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let cli = match Cli::try_parse_from(args) {
        Ok(c) => c,
        Err(e) => {
            // --help and --version print and succeed; usage errors print and fail.
            let _ = e.print();
            if e.use_stderr() {
                std::process::exit(2);
            }
            return Ok(());
        }
    };
    match cli.command {
        Command::Render(a) => render_command(&a),
        Command::Bench(a) if a.suite == "pls" => crate::pls::bench::run(a.threads),
        Command::Bench(a) if a.suite == "materials" => bench::materials(a.threads).map(|_| ()),
        Command::Bench(a) if a.suite == "hdr" => {
            let (width, height) = parse_size(&a.hdr_size)?;
            crate::hdr::bench::run(&crate::hdr::bench::HdrBenchOptions {
                width,
                height,
                python: (!a.no_peer).then_some(a.python),
                threads: a.threads,
                dir: a.hdr_dir,
            })
        }
        Command::Bench(a) => bench::run(&BenchOptions {
            scene: a.scene,
            pathtracer: (!a.no_peer).then_some(a.pathtracer),
            ecs: a.ecs,
            size: a.size,
            spp: a.spp,
            random_rays: (a.mrays * 1e6) as usize,
            threads: a.threads,
        }),
        Command::Pls(c) => crate::pls::cli::run(c),
        Command::Hdr(c) => crate::hdr::cli::run(c),
    }
}

/// Parses `WIDTHxHEIGHT` (both at least 16).
fn parse_size(s: &str) -> Result<(usize, usize)> {
    let bad = || {
        Error::InvalidArgument(format!(
            "--hdr-size {s:?}: expected WIDTHxHEIGHT, e.g. 6720x3360"
        ))
    };
    let (w, h) = s.split_once(['x', 'X', '×']).ok_or_else(bad)?;
    let w: usize = w.trim().parse().map_err(|_| bad())?;
    let h: usize = h.trim().parse().map_err(|_| bad())?;
    if w < 16 || h < 16 {
        return Err(bad());
    }
    Ok((w, h))
}

fn check_output_dir(path: &Path) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(Error::Output {
            file: path.to_path_buf(),
            message: format!("folder {} does not exist", dir.display()),
        });
    }
    Ok(())
}

fn render_command(a: &RenderArgs) -> Result<()> {
    check_output_dir(&a.output)?;
    if let Some(p) = &a.png {
        check_output_dir(p)?;
    }
    let mut scene = Scene::load(&a.scene)?;
    if let Some(spp) = a.spp {
        if spp == 0 {
            return Err(Error::InvalidArgument("--spp must be at least 1".into()));
        }
        scene.settings.spp = spp;
    }
    if let Some(d) = a.max_depth {
        if d == 0 {
            return Err(Error::InvalidArgument(
                "--max-depth must be at least 1".into(),
            ));
        }
        scene.settings.max_depth = d;
    }
    if let Some(s) = a.seed {
        scene.settings.seed = s;
    }
    let options = RenderOptions {
        threads: a.threads,
        tile_size: a.tile_size,
        vectorised: !a.scalar,
        ..Default::default()
    };
    let bar = progress_bar(
        a.quiet,
        "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} tiles (eta {eta})",
    );
    let progress = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
        true
    };
    let (film, stats) = render(&scene, &options, &progress)?;
    bar.finish_and_clear();
    film.write_exr(&a.output)?;
    if let Some(p) = &a.png {
        film.write_png(
            p,
            ToneMap {
                exposure: a.exposure,
                filmic: a.filmic,
            },
        )?;
    }
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

/// A progress bar drawn with the indicatif `template` on stderr, or a hidden
/// one when `quiet`.
pub(crate) fn progress_bar(quiet: bool, template: &str) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(0);
    bar.set_style(ProgressStyle::with_template(template).expect("valid template"));
    bar
}
