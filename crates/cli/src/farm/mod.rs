//! `plsr farm`: a render cut into pieces for a batch system — Slurm job
//! arrays and Kubernetes Indexed Jobs — and merged exactly (see
//! docs/farm.md).
//!
//! `plsr farm slurm` / `plsr farm k8s` write the plan (`OUTDIR/farm.toml`,
//! [`plan`]) and the batch system's files; every piece then runs
//! `plsr farm piece OUTDIR/farm.toml INDEX` and the merge
//! `plsr farm merge OUTDIR/farm.toml`. A piece whose part is already there
//! (the same scene, settings and samples) returns at once, so running the
//! whole array again re-renders only what is missing.

mod k8s;
pub mod plan;
mod slurm;

use crate::error::{Error, Result};
use crate::render::{parse_frames, RenderArgs};
use plan::{index_list, relative_path, DoneCheck, FarmPlan, PLAN_FILE};
use plsr::atomic_write::same_file;
use plsr::render::DEFAULT_TILE_SIZE;
use plsr_base::Vocabulary;
use std::path::{Path, PathBuf};

/// The `plsr farm` subcommands.
#[derive(Debug, clap::Subcommand)]
pub enum FarmCommand {
    /// Write (and with --submit, submit) a Slurm job array rendering the
    /// pieces, and a merge job that runs after all of them succeed.
    Slurm(slurm::SlurmArgs),
    /// Write a Kubernetes Indexed Job rendering the pieces and the merge
    /// Job, with the scene and outputs on a persistent volume.
    K8s(k8s::K8sArgs),
    /// Render one piece of a plan (what each array task or pod runs).
    Piece(PieceArgs),
    /// Merge the pieces of a plan into its images.
    Merge(FarmMergeArgs),
    /// List which pieces of a plan are done and which are missing.
    Status(StatusArgs),
}

/// What every batch system's plan takes.
#[derive(Debug, clap::Args)]
pub struct PlanArgs {
    /// The scene file (on a folder every node sees).
    pub scene: PathBuf,
    #[command(flatten)]
    pub params: crate::scene_params::SceneParams,
    /// Parts per frame: each renders spp/parts of the samples.
    #[arg(long)]
    pub parts: u32,
    /// Samples per pixel of each frame, all parts together (default: the
    /// scene's render.spp).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Frames A to B−1 of the scene's camera path (A..=B includes B); each
    /// frame is cut into --parts pieces.
    #[arg(long, value_name = "A..B")]
    pub frames: Option<String>,
    /// The output folder (on a folder every node sees): the plan, the
    /// batch files, the parts, the logs and the merged images.
    #[arg(short, long, value_name = "OUTDIR")]
    pub output_dir: PathBuf,
    /// Random seed (default: the scene's render.seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Image size in pixels (overrides camera.resolution; the vertical
    /// field of view is kept).
    #[arg(long, value_name = "W,H")]
    pub resolution: Option<String>,
    /// Name of the merged images: NAME.exr, or NAME-NNNN.exr per frame.
    #[arg(long, default_value = "image")]
    pub name: String,
    /// No PNG beside each merged EXR.
    #[arg(long)]
    pub no_png: bool,
    /// Print nothing but the submitted jobs' ids.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Arguments of `plsr farm piece`.
#[derive(Debug, clap::Args)]
pub struct PieceArgs {
    /// The plan (OUTDIR/farm.toml).
    pub plan: PathBuf,
    /// The piece's index; default: $SLURM_ARRAY_TASK_ID or
    /// $JOB_COMPLETION_INDEX (Kubernetes), whichever is set.
    pub index: Option<u32>,
    /// Worker threads (default: all cores the process may use).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Render it again even if its part is there.
    #[arg(long)]
    pub force: bool,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Arguments of `plsr farm merge`.
#[derive(Debug, clap::Args)]
pub struct FarmMergeArgs {
    /// The plan (OUTDIR/farm.toml).
    pub plan: PathBuf,
    /// Denoising of each merged image (after the exact merge of its
    /// pieces, never per piece).
    #[command(flatten)]
    pub denoise: crate::denoise::DenoiseFlags,
}

/// Arguments of `plsr farm status`.
#[derive(Debug, clap::Args)]
pub struct StatusArgs {
    /// The plan (OUTDIR/farm.toml), or the folder holding it.
    pub plan: PathBuf,
}

/// Runs `plsr farm …`.
pub fn run(c: FarmCommand) -> Result<()> {
    match c {
        FarmCommand::Slurm(a) => slurm::run(&a),
        FarmCommand::K8s(a) => k8s::run(&a),
        FarmCommand::Piece(a) => piece(&a),
        FarmCommand::Merge(a) => merge(&a),
        FarmCommand::Status(a) => status(&a),
    }
}

/// Makes the output folder and writes the plan of `a` into it; returns the
/// plan, the folder (absolute) and the plan file. `writes` names the other
/// files the caller will write into the folder: none of them, nor the plan,
/// may be the scene or a file it reads.
pub fn make_plan(a: &PlanArgs, writes: &[&str]) -> Result<(FarmPlan, PathBuf, PathBuf)> {
    let contents = plsr::scene::file::load_contents_with(&a.scene, &a.params.options())?;
    let spp = a.spp.unwrap_or(contents.description.job.spp);
    if spp == 0 {
        return Err(Error::invalid_argument("--spp must be at least 1"));
    }
    if spp > plsr::job::MAX_SPP {
        return Err(Error::invalid_argument(format!(
            "--spp {spp}: at most {}",
            plsr::job::MAX_SPP
        )));
    }
    let frames = match (&a.frames, &contents.camera_path) {
        (None, _) => None,
        (Some(_), None) => {
            return Err(Error::invalid_argument(format!(
                "--frames: {} has no camera path ([[camera.path]]; see docs/scene-format.md)",
                a.scene.display()
            )))
        }
        (Some(s), Some(path)) => {
            let range = parse_frames(s)?;
            let have = path.frames();
            if range.start() < have.start() || range.end() > have.end() {
                return Err(Error::invalid_argument(format!(
                    "--frames {s}: the camera path runs from frame {} to {}",
                    have.start(),
                    have.end()
                )));
            }
            Some([*range.start(), *range.end()])
        }
    };
    // Checked before the output folder is made.
    let mut plan = FarmPlan {
        scene: PathBuf::new(),
        spp,
        parts: a.parts,
        frames,
        name: a.name.clone(),
        png: !a.no_png,
        defines: a
            .params
            .define
            .iter()
            .map(|(n, v)| [n.clone(), v.clone()])
            .collect(),
        time: a.params.anim_time,
        seed: a.seed,
        resolution: a
            .resolution
            .as_deref()
            .map(|r| crate::pixel_args::parse_size("--resolution", r, 1 << 16))
            .transpose()?
            .map(|(w, h)| [w, h]),
    };
    plan.check().map_err(|(field, m)| {
        let flag = match field {
            "name" => "--name",
            "frames" => "--frames",
            _ => "--parts",
        };
        Error::invalid_argument(format!("{flag}: {m}"))
    })?;
    std::fs::create_dir_all(&a.output_dir)
        .map_err(|source| Error::io(a.output_dir.clone(), source))?;
    let dir = std::fs::canonicalize(&a.output_dir)
        .map_err(|source| Error::io(a.output_dir.clone(), source))?;
    // No file written into the folder — the plan, the caller's files, the
    // merged images — may replace the scene or a file it reads.
    let merged = plan.frame_list().into_iter().flat_map(|f| {
        let (exr, png) = plan.output_paths(&dir, f);
        std::iter::once(exr).chain(png)
    });
    for out in std::iter::once(PLAN_FILE)
        .chain(writes.iter().copied())
        .map(|name| dir.join(name))
        .chain(merged)
    {
        if let Some(input) = std::iter::once(&a.scene)
            .chain(&contents.inputs)
            .find(|i| same_file(&out, i))
        {
            return Err(Error::output(
                out,
                format!(
                    "is {}, which the scene reads: it would be overwritten (choose another -o)",
                    input.display()
                ),
            ));
        }
    }
    let scene_dir = match a.scene.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let scene_name = a.scene.file_name().ok_or_else(|| {
        Error::invalid_argument(format!("{}: not a file name", a.scene.display()))
    })?;
    plan.scene = relative_path(&dir, scene_dir)?.join(scene_name);
    let plan_file = dir.join(PLAN_FILE);
    if plan_file.exists() {
        if let Ok(old) = FarmPlan::read(&plan_file) {
            if old != plan && !a.quiet {
                crate::note!(
                    "replacing the plan in {} (its pieces that no longer fit are rendered again)",
                    dir.display()
                );
            }
        }
    }
    plan.write(&dir)?;
    Ok((plan, dir, plan_file))
}

/// Reads a plan given as its file or the folder holding it; returns it,
/// its folder and its file.
fn read_plan(path: &Path) -> Result<(FarmPlan, PathBuf, PathBuf)> {
    let file = if path.is_dir() {
        path.join(PLAN_FILE)
    } else {
        path.to_path_buf()
    };
    let plan = FarmPlan::read(&file)?;
    let dir = match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    Ok((plan, dir, file))
}

/// The index a piece runs: given, or from the batch system's environment.
fn piece_index(given: Option<u32>) -> Result<u32> {
    if let Some(i) = given {
        return Ok(i);
    }
    for var in ["SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"] {
        if let Ok(v) = std::env::var(var) {
            return v.trim().parse().map_err(|_| {
                Error::invalid_argument(format!("${var} is {v:?}, not a piece index"))
            });
        }
    }
    Err(Error::invalid_argument(
        "no piece index: give INDEX, or run inside a Slurm array task ($SLURM_ARRAY_TASK_ID) \
         or a Kubernetes Indexed Job ($JOB_COMPLETION_INDEX)",
    ))
}

/// `plsr farm piece`.
fn piece(a: &PieceArgs) -> Result<()> {
    let (plan, dir, file) = read_plan(&a.plan)?;
    let index = piece_index(a.index)?;
    let piece = plan.piece(index).ok_or_else(|| {
        Error::invalid_argument(format!(
            "piece {index}: {} has pieces 0 to {}",
            file.display(),
            plan.piece_count() - 1
        ))
    })?;
    let output = plan.part_path(&dir, &piece);
    // The scene is read for the check only when there is a part to check.
    if !a.force && output.is_file() && DoneCheck::new(&plan, &dir)?.is_done(&plan, &dir, &piece) {
        if !a.quiet {
            crate::note!(
                "piece {index} is done already ({}); nothing to render",
                output.display()
            );
        }
        return Ok(());
    }
    let created = match output.parent() {
        Some(folder) => create_missing_folders(folder)?,
        None => Vec::new(),
    };
    if !a.quiet {
        crate::note!(
            "piece {index} of {}: {}samples {}..{}",
            plan.piece_count(),
            piece
                .frame
                .map(|f| format!("frame {f}, "))
                .unwrap_or_default(),
            piece.samples.start,
            piece.samples.end
        );
    }
    let rendered = crate::render::run(&RenderArgs {
        scene: plan.scene_path(&dir),
        params: plan.scene_params(),
        output,
        png: None,
        spp: None,
        samples: Some(format!("{}..{}", piece.samples.start, piece.samples.end)),
        crop: None,
        resolution: plan.resolution.map(|[w, h]| format!("{w},{h}")),
        frame: piece.frame,
        frames: None,
        max_depth: None,
        rr_depth: None,
        seed: plan.seed,
        threads: a.threads,
        tile_size: DEFAULT_TILE_SIZE,
        exposure: None,
        filmic: false,
        scalar: false,
        light_picking: None,
        resume: false,
        no_resume_data: false,
        denoise: Default::default(),
        quiet: true,
    });
    if rendered.is_err() {
        // A failed piece leaves no empty `parts/` behind (a folder another
        // piece has written into since is not empty, and stays).
        for folder in created.iter().rev() {
            let _ = std::fs::remove_dir(folder);
        }
    }
    rendered
}

/// Creates `folder` and its missing ancestors; returns the ones this call
/// created, outermost first.
fn create_missing_folders(folder: &Path) -> Result<Vec<PathBuf>> {
    let missing: Vec<&Path> = folder.ancestors().take_while(|d| !d.exists()).collect();
    let mut created = Vec::new();
    for d in missing.into_iter().rev() {
        match std::fs::create_dir(d) {
            Ok(()) => created.push(d.to_path_buf()),
            // Another piece made it meanwhile.
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(source) => return Err(Error::io(d.to_path_buf(), source)),
        }
    }
    Ok(created)
}

/// `plsr farm merge`: every frame's parts into its image; refuses, before
/// writing anything, while pieces are missing.
fn merge(a: &FarmMergeArgs) -> Result<()> {
    let (plan, dir, file) = read_plan(&a.plan)?;
    let missing = DoneCheck::new(&plan, &dir)?.missing(&plan, &dir);
    if !missing.is_empty() {
        return Err(Error::invalid_argument(format!(
            "{}: {} of {} pieces are missing or stale ({}): render them first \
             (`plsr farm piece {} INDEX`, or submit again: only they are rendered)",
            file.display(),
            missing.len(),
            plan.piece_count(),
            index_list(&missing),
            file.display()
        )));
    }
    // One exposure for every frame's PNG, chosen on the first.
    let mut exposure = crate::tonemap::SequenceExposure::new(None);
    for frame in plan.frame_list() {
        let parts = plan
            .pieces()
            .filter(|p| p.frame == frame)
            .map(|p| plan.part_path(&dir, &p))
            .collect();
        let (output, png) = plan.output_paths(&dir, frame);
        crate::merge::run_in_sequence(
            &crate::merge::MergeArgs {
                parts,
                output,
                png,
                exposure: None,
                filmic: false,
                denoise: a.denoise.clone(),
                no_resume_data: false,
            },
            &mut exposure,
        )?;
    }
    Ok(())
}

/// `plsr farm status`.
fn status(a: &StatusArgs) -> Result<()> {
    let (plan, dir, _) = read_plan(&a.plan)?;
    let check = DoneCheck::new(&plan, &dir)?;
    let not_done = check.missing(&plan, &dir);
    let stale = check.stale(&plan, &dir);
    let missing: Vec<u32> = not_done
        .iter()
        .copied()
        .filter(|i| !stale.contains(i))
        .collect();
    let total = plan.piece_count();
    let mut line = format!("{} of {total} pieces done", total - not_done.len() as u32);
    if !missing.is_empty() {
        line += &format!("; missing: {}", index_list(&missing));
    }
    if !stale.is_empty() {
        line += &format!(
            "; stale (rendered before the scene or its settings changed; `farm piece` renders \
             them again): {}",
            index_list(&stale)
        );
    }
    println!("{line}");
    // A merged image is current when its sums are those of the plan's
    // samples of the scene as it is now.
    let frames = plan.frame_list();
    let (mut current, mut stale_images) = (0, Vec::new());
    for &frame in &frames {
        let path = plan.output_paths(&dir, frame).0;
        if !path.is_file() {
            continue;
        }
        if check.is_current(&path, frame, 0..plan.spp) {
            current += 1;
        } else {
            stale_images.push(path.display().to_string());
        }
    }
    let mut line = format!("{current} of {} merged images written", frames.len());
    if !stale_images.is_empty() {
        line += &format!(
            "; stale (of other pieces, or without the sums that tell): {}",
            stale_images.join(", ")
        );
    }
    println!("{line}");
    Ok(())
}

/// Quotes `s` for a POSIX shell (single quotes).
pub fn shell_quote(s: &str) -> String {
    if !s.is_empty()
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || b"/._-+=:,@".contains(&b))
    {
        return s.to_string();
    }
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// The absolute path of this `plsr` program.
pub fn this_program() -> Result<PathBuf> {
    std::env::current_exe()
        .and_then(std::fs::canonicalize)
        .map_err(|e| Error::invalid_argument(format!("cannot find the plsr program's path: {e}")))
}
