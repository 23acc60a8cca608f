//! `plsr bench`: throughput of plsr against a peer measured in the same run
//! on the same work. One module per suite: `core` (Embree rays and path
//! tracing against Embree's own `pathtracer`), `pls` (PLS transforms and the
//! window's cost), `materials` (diffuse against principled), `hdr`
//! (bracket merging against OpenCV), `composite` (a composite against
//! one render), `fit` (an Adam iteration of `plsr fit` against one
//! render, and against Mitsuba 3's `prb`) and `compare` (CW-SSIM and LPIPS
//! against their reference implementations in Python), `farm` (one render
//! against the same render in parts plus their merge) and `peers` (plsr
//! against Mitsuba 3 on a glossy scene lit by an HDR sky, the Cornell box
//! and the PLS room: samples/s, error at equal spp, time to equal error).

mod compare;
mod composite;
mod core;
mod denoise;
mod farm;
mod fit;
mod hdr;
mod hdr_memorial;
mod materials;
mod peers;
mod peers_denoised;
mod pls;

use crate::error::{Error, Result};
use plsr_base::Vocabulary;
use std::path::PathBuf;

/// Arguments of `plsr bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Which benchmark: `core`, `pls`, `materials` (all-diffuse versus
    /// all-principled Cornell box), `hdr` (merging 10 brackets at
    /// 6720×3360, plsr against OpenCV's MergeDebevec) or `composite` (a
    /// composite against one render of the same scene) or `fit` (an Adam
    /// iteration of `plsr fit` against one render, and against Mitsuba 3's
    /// `prb` when it is installed) or `compare` (CW-SSIM and LPIPS on a
    /// 400×300 crop and a panorama, against pyiqa and the lpips package).
    /// `peers` (plsr against Mitsuba 3 on a glossy scene lit by an HDR sky,
    /// the Cornell box, the PLS room and Mitsuba's material preview: samples/s, error at equal spp and
    /// time to equal error). `farm` (one render of the Cornell box against
    /// the same render in `--parts` parts plus `plsr merge`). `denoise`
    /// (plsr's denoiser against Intel Open Image Denoise's, pyoidn, on the
    /// same 1920×1080 render, and the memory of denoising a 8192×4096
    /// panorama).
    #[arg(default_value = "core", value_parser = ["core", "pls", "materials", "hdr", "composite", "fit", "compare", "peers", "farm", "denoise"])]
    pub suite: String,
    /// Image size for `plsr bench hdr` and the panorama of `plsr bench
    /// compare`, `W,H` in pixels.
    #[arg(long, default_value = "6720,3360", value_name = "W,H")]
    pub hdr_size: String,
    /// Folder for the brackets of `plsr bench hdr` (kept afterwards; reused
    /// if it already holds them). Default: a temporary folder, removed.
    #[arg(long)]
    pub hdr_dir: Option<PathBuf>,
    /// The real bracket stack of `plsr bench hdr` (Memorial Church:
    /// memorial0061.png …, shutter_times.txt, memorial.hdr). Default: the
    /// repository's halved copy, tests/data/realworld/hdr/memorial.
    #[arg(long, value_name = "DIR")]
    pub hdr_memorial: Option<PathBuf>,
    /// Timed Adam iterations for `plsr bench fit`.
    #[arg(long, default_value_t = 5)]
    pub iterations: u32,
    /// Python interpreter with OpenCV for `plsr bench hdr` (Mitsuba 3 for
    /// `plsr bench fit`; torch, pyiqa and lpips for `plsr bench compare`).
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
    /// Samples per pixel for the path-tracing comparison and `peers`
    /// (default 64) and for `farm` (default 256).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Random rays for the raw Embree measurement (millions).
    #[arg(long, default_value_t = 4.0)]
    pub mrays: f64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Samples per pixel of `plsr bench peers`' reference images.
    #[arg(long, default_value_t = 1024)]
    pub reference_spp: u32,
    /// Work folder of `plsr bench peers` (scenes in both formats, cached
    /// references, Mitsuba's images).
    #[arg(long, default_value = "out/bench-peers")]
    pub peers_dir: PathBuf,
    /// Only these scenes of `plsr bench peers` (comma-separated:
    /// glossy-env, cornell, pls-room, matpreview).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Timed renders per renderer and scene in `plsr bench peers` (seeds
    /// 1 to N): each time is their best and each relMSE their mean. More
    /// seeds give a steadier relMSE where a few rare bright paths carry the
    /// error, as the glass sphere's do in the glossy scene.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub seeds: u32,
    /// Parts of `plsr bench farm` (they must divide its spp).
    #[arg(long, default_value_t = 8)]
    pub parts: u32,
    /// Python with Blender's `bpy` 4.5 for `plsr bench peers`: adds Cycles
    /// with and without OIDN, and plsr with and without its denoiser, on
    /// the Cornell box and the glossy scene.
    #[arg(long, value_name = "PYTHON")]
    pub blender_python: Option<PathBuf>,
    /// Image size of `plsr bench denoise`, `W,H` in pixels.
    #[arg(long, default_value = "1920,1080", value_name = "W,H")]
    pub denoise_size: String,
    /// Panorama size of `plsr bench denoise`'s memory measurement, `W,H`
    /// in pixels, or `none`.
    #[arg(long, default_value = "8192,4096", value_name = "W,H|none")]
    pub denoise_panorama: String,
    /// The memory measurement alone, at this size (the child process of
    /// `plsr bench denoise`).
    #[arg(long, hide = true)]
    pub denoise_probe: Option<String>,
    /// Skip the peer (Embree's pathtracer; OpenCV for `hdr`).
    #[arg(long)]
    pub no_peer: bool,
}

/// Runs one bench suite.
pub fn run(mut a: BenchArgs) -> Result<()> {
    enter_repository(&mut a)?;
    match a.suite.as_str() {
        "pls" => pls::run(a.threads),
        "materials" => materials::run(a.threads).map(|_| ()),
        "denoise" => denoise::run(&denoise::DenoiseBenchOptions {
            threads: a.threads,
            python: (!a.no_peer).then_some(a.python),
            size: parse_size("--denoise-size", &a.denoise_size)?,
            panorama: match a.denoise_panorama.as_str() {
                "none" => None,
                s => Some(parse_size("--denoise-panorama", s)?),
            },
            probe: a
                .denoise_probe
                .as_deref()
                .map(|s| parse_size("--denoise-probe", s))
                .transpose()?,
        }),
        "farm" => farm::run(a.threads, a.size, a.spp.unwrap_or(256), a.parts).map(|_| ()),
        "composite" => composite::run(a.threads).map(|_| ()),
        "fit" => fit::run(&fit::FitBenchOptions {
            threads: a.threads,
            python: (!a.no_peer).then_some(a.python),
            iterations: a.iterations,
        })
        .map(|_| ()),
        "peers" => peers::run(&peers::PeersBenchOptions {
            threads: a.threads,
            python: (!a.no_peer).then_some(a.python),
            spp: a.spp.unwrap_or(64),
            reference_spp: a.reference_spp,
            dir: a.peers_dir,
            only: a.scenes,
            seeds: a.seeds,
            blender_python: a.blender_python,
        }),
        "compare" => compare::run(&compare::CompareBenchOptions {
            threads: a.threads,
            python: (!a.no_peer).then_some(a.python),
            panorama: parse_size("--hdr-size", &a.hdr_size)?,
        }),
        "hdr" => {
            let (width, height) = parse_size("--hdr-size", &a.hdr_size)?;
            hdr::run(&hdr::HdrBenchOptions {
                width,
                height,
                python: (!a.no_peer).then_some(a.python),
                threads: a.threads,
                dir: a.hdr_dir,
                memorial: a.hdr_memorial,
            })
        }
        _ => core::run(&core::BenchOptions {
            scene: a.scene,
            pathtracer: (!a.no_peer).then_some(a.pathtracer),
            ecs: a.ecs,
            size: a.size,
            spp: a.spp.unwrap_or(64),
            random_rays: (a.mrays * 1e6) as usize,
            threads: a.threads,
        }),
    }
}

/// Works from plsr's repository, whose scenes and assets the benchmarks
/// use: the current folder if it holds `assets/scenes`, else the first
/// folder above the running program that does (a build inside the
/// repository: `target/release/plsr`). Paths given relative to the
/// current folder are made absolute first: inputs that exist here, and the
/// output folders.
fn enter_repository(a: &mut BenchArgs) -> Result<()> {
    let marker = |dir: &std::path::Path| dir.join("assets/scenes").is_dir();
    let here = std::env::current_dir().map_err(|source| Error::io(".", source))?;
    if marker(&here) {
        return Ok(());
    }
    let exe = std::env::current_exe().map_err(|source| Error::io("plsr", source))?;
    let Some(root) = exe.ancestors().skip(1).find(|d| marker(d)) else {
        return Err(Error::invalid_argument(format!(
            "plsr bench uses the scenes and assets of plsr's repository (assets/scenes), which \
             neither {} nor the folders above {} hold: run it from the repository, or run a \
             plsr built inside it",
            here.display(),
            exe.display()
        )));
    };
    let absolute_if_here = |p: &mut PathBuf| {
        if p.is_relative() && here.join(&*p).exists() {
            *p = here.join(&*p);
        }
    };
    for p in [&mut a.scene, &mut a.python, &mut a.pathtracer, &mut a.ecs] {
        absolute_if_here(p);
    }
    for p in [&mut a.hdr_memorial, &mut a.blender_python]
        .into_iter()
        .flatten()
    {
        absolute_if_here(p);
    }
    for p in std::iter::once(&mut a.peers_dir).chain(a.hdr_dir.as_mut()) {
        if p.is_relative() {
            *p = here.join(&*p);
        }
    }
    std::env::set_current_dir(root).map_err(|source| Error::io(root, source))?;
    crate::note!(
        "plsr bench: working from the repository at {}",
        root.display()
    );
    Ok(())
}

/// Parses a size `W,H` (both at least 16; `flag` names it in errors).
fn parse_size(flag: &str, s: &str) -> Result<(usize, usize)> {
    let (w, h) = crate::pixel_args::parse_size(flag, s, 1 << 17)?;
    if w < 16 || h < 16 {
        return Err(Error::invalid_argument(format!(
            "{flag} {s}: at least 16 pixels a side"
        )));
    }
    Ok((w as usize, h as usize))
}

/// A fresh temporary folder for suite `suite`'s files (the caller removes
/// it).
fn bench_dir(suite: &str) -> Result<PathBuf> {
    let dir = std::env::temp_dir().join(format!("plsr-bench-{suite}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|source| Error::io(dir.clone(), source))?;
    Ok(dir)
}

/// Runs a peer script (`cmd`, started with the interpreter `python`) that
/// prints its result as one line of JSON last on stdout; the value and
/// that line, or why not (the last line of its stderr when it fails).
fn python_json(
    cmd: &mut std::process::Command,
    python: &std::path::Path,
) -> std::result::Result<(serde_json::Value, String), String> {
    let out = cmd
        .output()
        .map_err(|e| format!("{}: {e}", python.display()))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        return Err(err.lines().last().unwrap_or("failed").to_string());
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text.lines().last().unwrap_or_default().to_string();
    let v = serde_json::from_str(&line).map_err(|e| format!("{e}: {line}"))?;
    Ok((v, line))
}
