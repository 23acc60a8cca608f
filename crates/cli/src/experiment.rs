//! `plsr experiment`: reproducible experiments; `plsr experiment paper`
//! redoes the paper's experiment on a synthetic, physically lit room.

use crate::error::Result;
use plsr_apps::experiment::paper::{run as run_paper, PaperOptions, Settings};
use plsr_apps::experiment::paper_room::PaperRoom;
use std::path::PathBuf;

/// The experiments.
#[derive(Debug, clap::Subcommand)]
pub enum ExperimentCommand {
    /// The paper's Table 4 on a synthetic room: a flashlight and a ceiling
    /// lamp modelled as real fixtures, photographed as ground truth; their
    /// PLS lights derived from the geometry, and PLS lights and albedos
    /// fitted from the photos; an HDR panorama captured and
    /// merged; the bunny and a metal ball composited with each lighting at
    /// two positions and scored by CW-SSIM, LPIPS and FLIP against photos
    /// of the real objects (see docs/paper-experiment.md).
    Paper(PaperArgs),
}

/// Arguments of `plsr experiment paper`.
#[derive(Debug, clap::Args)]
pub struct PaperArgs {
    /// The new folder to write everything into (scenes, photos, panorama,
    /// composites, results.md, results.json, figure.png); it must not
    /// exist or be empty. Default: out/paper (out/paper-quick with --quick).
    #[arg(short, long, value_name = "DIR")]
    pub output: Option<PathBuf>,
    /// Run the whole pipeline small (under two minutes on two cores)
    /// instead of the full experiment (about 20 minutes, 6 of them the fit from photos).
    #[arg(long)]
    pub quick: bool,
    /// The Stanford bunny's OBJ file.
    #[arg(
        long,
        value_name = "OBJ",
        default_value = "assets/meshes/stanford-bunny.obj"
    )]
    pub bunny: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Only write the room's files (meshes, room.toml, lights.pls.toml)
    /// into DIR, as in assets/scenes/paper-room/, and stop.
    #[arg(long, value_name = "DIR")]
    pub write_scenes: Option<PathBuf>,
}

/// Runs `plsr experiment …`.
pub fn run(command: ExperimentCommand) -> Result<()> {
    match command {
        ExperimentCommand::Paper(a) => paper(&a),
    }
}

fn paper(a: &PaperArgs) -> Result<()> {
    if let Some(dir) = &a.write_scenes {
        PaperRoom::new().write_assets(dir, &a.bunny)?;
        crate::note!("wrote the paper-room into {}", dir.display());
        return Ok(());
    }
    let out = a.output.clone().unwrap_or_else(|| {
        PathBuf::from(if a.quick {
            "out/paper-quick"
        } else {
            "out/paper"
        })
    });
    let options = PaperOptions {
        out: out.clone(),
        bunny: a.bunny.clone(),
        settings: if a.quick {
            Settings::quick()
        } else {
            Settings::full()
        },
        threads: a.threads,
    };
    let results = run_paper(&options, &|line| crate::note!("{line}"))?;
    println!("{}", results.table());
    crate::note!(
        "wrote {} (results.md, results.json, figure.png) in {:.0} s",
        out.display(),
        results.seconds
    );
    Ok(())
}
