//! `plsr render`: a scene file to OpenEXR (and PNG).

use crate::error::{Error, Result};
use crate::progress::progress_bar;
use crate::tonemap::{Exposure, SequenceExposure};
use plsr::atomic_write::{check_extension, same_file, OutputSet};
use plsr::film::part::{
    image_window, scene_files_hasher, Part, PartInfo, Provenance, StableHasher,
};
use plsr::film::{FilmSums, Tile};
use plsr::job::RenderJob;
use plsr::job::{JobError, MAX_DEPTH, MAX_SPP};
use plsr::light::LightPicking;
use plsr::render::{
    continue_window_sums, render_window_sums, RenderOptions, DEFAULT_TILE_SIZE, MAX_TILE_SIZE,
};
use plsr::scene::Scene;
use plsr_base::Vocabulary;
use std::path::{Path, PathBuf};

/// Arguments of `plsr render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// The scene file.
    pub scene: PathBuf,
    #[command(flatten)]
    pub params: crate::scene_params::SceneParams,
    /// Output OpenEXR file (linear float, all layers).
    #[arg(short, long, value_name = "OUT.exr")]
    pub output: PathBuf,
    /// Also write an 8-bit sRGB PNG here.
    #[arg(long, value_name = "OUT.png")]
    pub png: Option<PathBuf>,
    /// Samples per pixel (overrides the scene's render.spp).
    #[arg(long, conflicts_with = "samples")]
    pub spp: Option<u32>,
    /// Render only sample indices [START, END) of every pixel (START..=LAST
    /// includes LAST), as a part that `plsr merge` combines with the others
    /// (see docs/farm.md).
    #[arg(long, value_name = "START..END")]
    pub samples: Option<String>,
    /// Add samples to -o instead of starting over: if -o is a render of
    /// this scene (same files and settings) holding samples 0..N, render
    /// samples N..SPP (--spp, or the scene's) and write the image of all of
    /// them, bit for bit what one render of 0..SPP writes; if -o does not
    /// exist, render 0..SPP. Every render keeps what resuming needs unless
    /// written with --no-resume-data (see docs/farm.md).
    #[arg(long, conflicts_with = "samples")]
    pub resume: bool,
    /// Write the image's layers only, without the exact per-pixel sums that
    /// --resume continues from (a file about 40 % smaller).
    #[arg(long, conflicts_with_all = ["samples", "crop", "resume"])]
    pub no_resume_data: bool,
    /// Render only the window of columns [X0, X1) and rows [Y0, Y1), as a
    /// part that `plsr merge` stitches with the others (see docs/farm.md).
    #[arg(long, value_name = "X0,Y0,X1,Y1")]
    pub crop: Option<String>,
    /// Image size in pixels (overrides camera.resolution; the vertical
    /// field of view is kept).
    #[arg(long, value_name = "W,H")]
    pub resolution: Option<String>,
    /// Render frame N of the scene's camera path ([[camera.path]]); `{frame}`
    /// in -o and --png becomes the frame number, four digits or more.
    #[arg(long, value_name = "N", conflicts_with = "frames")]
    pub frame: Option<u32>,
    /// Render frames A to B−1 of the camera path (A..=B includes B), one
    /// output per frame: -o (and --png) must contain `{frame}`.
    #[arg(long, value_name = "A..B")]
    pub frames: Option<String>,
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
    /// PNG exposure compensation in stops (+1 doubles brightness), or
    /// `auto` (middle grey at the image's log-average luminance, lowered
    /// until at most 2 % of the lit pixels clip). Default: the scene's
    /// exposure where its `[film]` states one (`exposure_ev` or a camera's
    /// shutter, ISO and f-number), otherwise `auto`. With several frames the
    /// first frame's choice is kept for all.
    #[arg(long, allow_hyphen_values = true)]
    pub exposure: Option<String>,
    /// PNG tone mapping: a filmic curve (ACES fit) instead of a plain clamp.
    #[arg(long)]
    pub filmic: bool,
    /// Render with the general integrator (the reference) instead of the
    /// vectorised kernel. The image is the same, bit for bit; this is for
    /// checking and timing.
    #[arg(long)]
    pub scalar: bool,
    /// How next-event estimation picks a light, instead of the scene's
    /// `[render] light_picking`: `spatial` (plsr's default) weighs each
    /// light's power by its distance and orientation at the shading point,
    /// `power` by power alone, `uniform` every light equally (Mitsuba's
    /// rule). All are unbiased; they differ in noise.
    #[arg(long, value_parser = ["spatial", "power", "uniform"])]
    pub light_picking: Option<String>,
    #[command(flatten)]
    pub denoise: crate::denoise::DenoiseFlags,
    /// Print nothing but warnings and errors: no progress, no summary.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Checks an output path before any work is done: its folder exists, it
/// is not a folder itself, and its extension is the format written
/// (`extension`), so that no file is ever written under the wrong name.
pub(crate) fn check_output(flag: &str, path: &Path, extension: &str, format: &str) -> Result<()> {
    let fail = |message: String| Error::output(path.to_path_buf(), message);
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

/// Checks the outputs `-o OUT.exr` and `--png OUT.png` of a command that
/// writes an image (see [`check_output`]), and that they are two files.
pub(crate) fn check_exr_and_png(output: &Path, png: Option<&PathBuf>) -> Result<()> {
    check_output("-o", output, "exr", "OpenEXR")?;
    if let Some(p) = png {
        check_output("--png", p, "png", "PNG")?;
        if same_file(p, output) {
            return Err(Error::output(p.clone(), "--png names the same file as -o"));
        }
    }
    Ok(())
}

/// Runs `plsr render`.
pub fn run(a: &RenderArgs) -> Result<()> {
    // Options are checked as strictly as scene files, before any work.
    let mut exposure = SequenceExposure::new(Exposure::parse_optional(a.exposure.as_deref())?);
    if a.tile_size == 0 || a.tile_size > MAX_TILE_SIZE {
        return Err(Error::invalid_argument(format!(
            "--tile-size {}: must be between 1 and {MAX_TILE_SIZE} pixels",
            a.tile_size
        )));
    }
    if a.denoise.denoise && (a.samples.is_some() || a.crop.is_some()) {
        return Err(Error::invalid_argument(
            "--denoise with a part (--samples or --crop): parts are merged exactly, \
             then denoised: `plsr merge PARTS… -o OUT.exr --denoise`",
        ));
    }
    let contents = plsr::scene::file::load_contents_with(&a.scene, &a.params.options())?;
    for n in &contents.notes {
        crate::note!("note: {n}");
    }
    let inputs = contents.inputs;
    let frames = frames_asked(a, contents.camera_path.as_ref())?;
    let outputs_of = outputs_of_frames(a, &frames, &inputs)?;
    let (mut scene, picking_changed) = build_scene(a, contents.description)?;
    let (job, window) = job_and_window(a, &scene)?;
    let options = RenderOptions {
        threads: a.threads,
        tile_size: a.tile_size,
        vectorised: !a.scalar,
        ..Default::default()
    };
    // The thread count first: the memory estimate grows with it.
    plsr_base::threads::check_thread_count(a.threads)?;
    // Named against the scene file, before anything is allocated.
    plsr::render::check_memory(&scene, &options)
        .map_err(|m| Error::input(&a.scene, "camera.resolution", m.to_string()))?;
    let mut files = vec![a.scene.clone()];
    files.extend(inputs.iter().cloned());
    let parts = a.samples.is_some() || window.is_some();
    // Parts, and plain renders unless told otherwise, keep their sums.
    let keeps_sums = parts || !a.no_resume_data;
    let files_hasher = if keeps_sums {
        let mut h = scene_files_hasher(&files)?;
        // A Mitsuba scene's -D parameters and a glTF's --anim-time are part of
        // the scene, and so is a light picking chosen on the command line.
        for field in a.params.hash_fields() {
            h.field(field.as_bytes());
        }
        if let Some(p) = picking_changed {
            h.field(format!("--light-picking {}", p.name()).as_bytes());
        }
        h
    } else {
        StableHasher::default()
    };
    let frames_run = FramesRun {
        a,
        base_camera: scene.camera().clone(),
        camera_path: contents.camera_path.as_ref(),
        job,
        size: (scene.camera().width(), scene.camera().height()),
        window,
        parts,
        keeps_sums,
        files_hasher,
        options,
    };
    for (frame, (output, png)) in frames.iter().zip(&outputs_of) {
        frames_run.render_frame(&mut scene, *frame, output, png.as_ref(), &mut exposure)?;
    }
    Ok(())
}

/// The frames asked for, checked against the scene's camera path (`None`:
/// the scene's own camera).
fn frames_asked(
    a: &RenderArgs,
    camera_path: Option<&plsr::camera_path::CameraPath>,
) -> Result<Vec<Option<u32>>> {
    Ok(match (a.frame, &a.frames, camera_path) {
        (None, None, _) => vec![None],
        (_, _, None) => {
            return Err(Error::invalid_argument(format!(
            "--frame/--frames: {} has no camera path ([[camera.path]]; see docs/scene-format.md)",
            a.scene.display()
        )))
        }
        (Some(f), _, Some(path)) => {
            check_frame(f, path)?;
            vec![Some(f)]
        }
        (None, Some(range), Some(path)) => {
            let frames = parse_frames(range)?;
            for f in [*frames.start(), *frames.end()] {
                check_frame(f, path)?;
            }
            frames.map(Some).collect()
        }
    })
}

/// Every output of every frame (the OpenEXR file and the PNG), checked
/// before the render: none may replace an input (the scene file, its
/// meshes, MTL libraries, textures, environment image or PLS files) or
/// another output.
fn outputs_of_frames(
    a: &RenderArgs,
    frames: &[Option<u32>],
    inputs: &[PathBuf],
) -> Result<Vec<(PathBuf, Option<PathBuf>)>> {
    let many = frames.len() > 1;
    for (flag, path) in std::iter::once(("-o", &a.output)).chain(a.png.iter().map(|p| ("--png", p)))
    {
        if many && !path.to_string_lossy().contains(FRAME_FIELD) {
            return Err(Error::output(path.clone(), format!(
                    "{flag}: --frames writes one file per frame: the name must contain {FRAME_FIELD}"
                )));
        }
    }
    let mut outputs_of = Vec::with_capacity(frames.len());
    for frame in frames {
        let output = frame_path(&a.output, *frame);
        let png = a.png.as_ref().map(|p| frame_path(p, *frame));
        check_outputs(a, &output, png.as_ref(), inputs)?;
        outputs_of.push((output, png));
    }
    Ok(outputs_of)
}

/// The scene at `--resolution`, with `--light-picking`, and the picking
/// if `--light-picking` changed it (which the parts' scene hash records).
fn build_scene(
    a: &RenderArgs,
    mut description: plsr::scene::SceneDescription,
) -> Result<(Scene, Option<LightPicking>)> {
    if let Some(r) = &a.resolution {
        let (w, h) = parse_resolution(r)?;
        description.camera = description
            .camera
            .with_resolution(w, h)
            .map_err(|e| Error::invalid_argument(format!("--resolution {r}: {e}")))?;
    }
    let mut scene = Scene::build(description)?;
    let picking = a
        .light_picking
        .as_deref()
        .and_then(LightPicking::from_name)
        .filter(|&p| p != scene.light_picking());
    if let Some(picking) = picking {
        scene.set_light_picking(picking);
    }
    Ok((scene, picking))
}

/// The scene's job with the command line's overrides, checked, and the
/// `--crop` window.
fn job_and_window(a: &RenderArgs, scene: &Scene) -> Result<(RenderJob, Option<Tile>)> {
    let mut job = scene.default_job();
    if let Some(spp) = a.spp {
        if spp == 0 {
            return Err(Error::invalid_argument("--spp must be at least 1"));
        }
        job.spp = spp;
    }
    if let Some(d) = a.max_depth {
        if d == 0 {
            return Err(Error::invalid_argument("--max-depth must be at least 1"));
        }
        job.max_depth = d;
    }
    if let Some(s) = a.seed {
        job.seed = s;
    }
    if let Some(d) = a.rr_depth {
        job.rr_depth = d;
    }
    if let Some(s) = &a.samples {
        let (start, end) = parse_samples(s)?;
        job.sample_start = start;
        job.spp = end - start;
    }
    let (width, height) = (scene.camera().width(), scene.camera().height());
    let window = a
        .crop
        .as_deref()
        .map(|c| parse_crop(c, width, height))
        .transpose()?;
    job.validate().map_err(|e| {
        Error::invalid_argument(match e {
            JobError::Spp(v) => format!("--spp {v}: at most {MAX_SPP}"),
            JobError::MaxDepth(v) => format!("--max-depth {v}: at most {MAX_DEPTH}"),
            JobError::RrDepth(v) => format!("--rr-depth {v}: at most {MAX_DEPTH}"),
            other => other.to_string(),
        })
    })?;
    Ok((job, window))
}

/// What every frame of a render shares.
struct FramesRun<'a> {
    a: &'a RenderArgs,
    /// The scene's camera, which each frame of the path moves.
    base_camera: plsr::camera::Camera,
    /// The scene's camera path, if it has one.
    camera_path: Option<&'a plsr::camera_path::CameraPath>,
    /// The job of every frame (before `--resume`).
    job: RenderJob,
    /// The image size (pixels).
    size: (u32, u32),
    /// The `--crop` window.
    window: Option<Tile>,
    /// Whether the outputs are parts (`--samples`, `--crop`).
    parts: bool,
    /// Whether the outputs keep their exact sums (parts, and plain renders
    /// unless `--no-resume-data`).
    keeps_sums: bool,
    /// The scene files' hash, for the parts' identity.
    files_hasher: StableHasher,
    /// How to render.
    options: RenderOptions,
}

impl FramesRun<'_> {
    /// Renders one frame into its outputs (with `--resume`, only the
    /// samples the output lacks, or nothing).
    fn render_frame(
        &self,
        scene: &mut Scene,
        frame: Option<u32>,
        output: &Path,
        png: Option<&PathBuf>,
        exposure: &mut SequenceExposure,
    ) -> Result<()> {
        let a = self.a;
        if let (Some(f), Some(path)) = (frame, self.camera_path) {
            let pose = path
                .pose_at(f)
                .map_err(|e| Error::input(&a.scene, "camera.path", e.to_string()))?;
            scene.set_camera(self.base_camera.with_pose(pose));
        }
        let (width, height) = self.size;
        // Resuming: the samples the output holds already, and the rest.
        let mut job = self.job;
        let scene_hash = part_hash(self.files_hasher, &job, frame);
        let provenance = Provenance {
            files_hash: self.files_hasher.finish(),
            settings: job_identity(&job, frame),
        };
        // What a render keeps the sums of: the `--crop` window, or the
        // film's crop window, or the whole image.
        let window = self
            .window
            .unwrap_or(image_window(*scene.film(), (width, height)));
        let previous = if a.resume && output.exists() {
            let old = resumed_part(output, (width, height), window, (scene_hash, &provenance))?;
            let have = old.info.sample_end;
            if have >= job.spp && a.denoise.denoise {
                // Denoised again from the file's sums (with these
                // settings), nothing rendered.
                job.sample_start = have;
                job.spp = 0;
                Some(old)
            } else if have >= job.spp {
                crate::note!(
                    "{} holds {have} samples already (asked for {}): nothing to render",
                    output.display(),
                    job.spp
                );
                // The PNG asked for is still written, of the file's image.
                if let Some(p) = png {
                    let film = plsr::film::Film::read_exr(output)?;
                    let tone = exposure.tone_map(&film, a.filmic);
                    let mut outputs = OutputSet::new();
                    film.stage_png(&mut outputs, p, tone)?;
                    outputs.commit()?;
                    crate::note!("{} ({:+.2} stops)", p.display(), tone.exposure);
                }
                return Ok(());
            } else {
                job.sample_start = have;
                job.spp -= have;
                Some(old)
            }
        } else {
            None
        };
        let part = self.keeps_sums.then(|| PartInfo {
            scene_hash,
            image: (width, height),
            window,
            sample_start: job.sample_start,
            sample_end: job.sample_start + job.spp,
        });
        render_one(
            a,
            scene,
            &job,
            &self.options,
            (self.window, self.parts, part, previous),
            &provenance,
            (output, png),
            frame,
            exposure,
        )
    }
}

/// The render `--resume` continues: the output, which must hold the sums
/// of samples 0..N of the whole image (a plain render, or a part of them).
fn resumed_part(
    output: &Path,
    (width, height): (u32, u32),
    window: Tile,
    (scene_hash, provenance): (u64, &Provenance),
) -> Result<Part> {
    let old = Part::read_exr(output)?;
    if old.info.scene_hash != scene_hash {
        let what = match old
            .provenance
            .as_ref()
            .and_then(|p| p.differences(provenance))
        {
            Some(d) => format!("it was rendered otherwise: {d}"),
            None => "the file is a render of another scene, or of other settings (seed, \
                     depths, -D, --light-picking)"
                .to_string(),
        };
        return Err(Error::input(
            output,
            "plsrPartScene",
            format!(
                "scene hash {:016x} differs from this render's {scene_hash:016x}: {what}",
                old.info.scene_hash
            ),
        ));
    }
    if old.info.image != (width, height) {
        return Err(Error::input(
            output,
            "plsrPartImage",
            format!(
                "the file is a {}×{} image, this render {width}×{height} (--resolution or the \
                 scene's camera.resolution changed)",
                old.info.image.0, old.info.image.1
            ),
        ));
    }
    if old.info.sample_start != 0 || old.info.window != window {
        return Err(Error::input(
            output,
            "",
            format!(
                "--resume continues a render of the whole image (or of the film's crop window) \
                 holding samples 0..N, or with --crop of that window; this file holds samples \
                 {}..{} of the window {},{},{},{} (X0,Y0,X1,Y1) of a {}×{} image, this render \
                 the window {},{},{},{} (merge parts with `plsr merge`)",
                old.info.sample_start,
                old.info.sample_end,
                old.info.window.x0,
                old.info.window.y0,
                old.info.window.x0 + old.info.window.width,
                old.info.window.y0 + old.info.window.height,
                old.info.image.0,
                old.info.image.1,
                window.x0,
                window.y0,
                window.x0 + window.width,
                window.y0 + window.height
            ),
        ));
    }
    Ok(old)
}

/// What `--frame`/`--frames` replace in output names.
const FRAME_FIELD: &str = "{frame}";

/// `path` with `{frame}` replaced by the frame number (at least four
/// digits: `0007`, `12345`), or unchanged when no frame is rendered.
pub(crate) fn frame_path(path: &Path, frame: Option<u32>) -> PathBuf {
    match frame {
        Some(f) => PathBuf::from(
            path.to_string_lossy()
                .replace(FRAME_FIELD, &format!("{f:04}")),
        ),
        None => path.to_path_buf(),
    }
}

/// A frame the camera path covers.
fn check_frame(frame: u32, path: &plsr::camera_path::CameraPath) -> Result<()> {
    let frames = path.frames();
    if !frames.contains(&frame) {
        return Err(Error::invalid_argument(format!(
            "frame {frame}: the camera path runs from frame {} to {}",
            frames.start(),
            frames.end()
        )));
    }
    Ok(())
}

/// `A..B` or `A..=B` cut at the dots: the two ends, and whether the second
/// is included (`None` without `..`).
fn split_range(s: &str) -> Option<(&str, &str, bool)> {
    match s.split_once("..=") {
        Some((a, b)) => Some((a, b, true)),
        None => s.split_once("..").map(|(a, b)| (a, b, false)),
    }
}

/// `--frames A..B` (B excluded) or `A..=B` (B included): a non-empty range.
pub(crate) fn parse_frames(s: &str) -> Result<std::ops::RangeInclusive<u32>> {
    let bad = |why: &str| Error::invalid_argument(format!("--frames {s}: {why}"));
    let (a, b, inclusive) =
        split_range(s).ok_or_else(|| bad("expected A..B (B excluded) or A..=B, e.g. 0..24"))?;
    let parse = |x: &str| {
        x.trim()
            .parse::<u32>()
            .map_err(|_| bad(&format!("{x:?} is not a frame number")))
    };
    let (start, end) = (parse(a)?, parse(b)?);
    let last = if inclusive {
        end
    } else {
        end.checked_sub(1)
            .filter(|&l| l >= start)
            .ok_or_else(|| bad("no frames: A must be below B"))?
    };
    if last < start {
        return Err(bad("no frames: A must not be above B"));
    }
    Ok(start..=last)
}

/// Checks one frame's outputs: folders exist, extensions match, and no
/// output replaces the scene, a file it reads, or the other output.
fn check_outputs(
    a: &RenderArgs,
    output: &Path,
    png: Option<&PathBuf>,
    inputs: &[PathBuf],
) -> Result<()> {
    check_exr_and_png(output, png)?;
    for out in std::iter::once(output).chain(png.map(|p| p.as_path())) {
        if same_file(out, &a.scene) {
            return Err(Error::output(
                out.to_path_buf(),
                format!(
                    "is the scene file {}: it would be overwritten",
                    a.scene.display()
                ),
            ));
        }
        if let Some(input) = inputs.iter().find(|i| same_file(out, i)) {
            return Err(Error::output(
                out.to_path_buf(),
                format!(
                    "is {}, which the scene reads: it would be overwritten",
                    input.display()
                ),
            ));
        }
    }
    Ok(())
}

/// Renders one image (one frame) and writes it: a whole image, or a part
/// when `part` says which.
#[allow(clippy::too_many_arguments)]
fn render_one(
    a: &RenderArgs,
    scene: &Scene,
    job: &RenderJob,
    options: &RenderOptions,
    (window, is_part, part, previous): (Option<Tile>, bool, Option<PartInfo>, Option<Part>),
    provenance: &Provenance,
    (output, png): (&Path, Option<&PathBuf>),
    frame: Option<u32>,
    exposure: &mut SequenceExposure,
) -> Result<()> {
    let bar = progress_bar(
        a.quiet,
        "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} tiles (eta {eta})",
    );
    let progress = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
        true
    };
    // A crop's PNG takes the exposure of the whole frame, so that crops
    // of one image match: an `auto` exposure is found on a preview of the
    // whole frame at a few samples, and kept.
    let mut whole_frame_note = "";
    if window.is_some() && png.is_some() && exposure.auto_pending(scene.film()) {
        let preview = RenderJob {
            spp: job.spp.min(CROP_PREVIEW_SPP),
            sample_start: 0,
            ..*job
        };
        let (sums, _) = render_window_sums(scene, &preview, options, None, &|_, _| true)?;
        exposure.tone_map(&sums.develop(preview.spp), a.filmic);
        whole_frame_note = ", the whole frame's";
    }
    // Resumed: the new samples are added to the old sums one by one, as
    // one render of all of them adds them.
    let resumed = previous.is_some();
    let (sums, stats) = match previous {
        Some(old) => {
            let (width, height) = old.info.image;
            let mut full = FilmSums::new(width, height, 0, old.sums.settings());
            full.add_tile(old.info.window, old.sums.pixels());
            drop(old);
            if job.spp == 0 {
                // No new samples (`--resume --denoise` of a complete file).
                (full, plsr::render::RenderStats::default())
            } else {
                continue_window_sums(scene, job, options, window, &full, &progress)?
            }
        }
        None => render_window_sums(scene, job, options, window, &progress)?,
    };
    bar.finish_and_clear();
    let spp = job.sample_start + job.spp;
    // Both outputs are written first and replace their targets together.
    let mut outputs = OutputSet::new();
    let mut denoise_note = String::new();
    let film = match part {
        Some(info) if is_part => {
            // A part: the window's sums, exactly, and what merging checks
            // (resumed: all its samples from 0).
            let info = PartInfo {
                sample_start: if resumed { 0 } else { info.sample_start },
                ..info
            };
            let part = Part {
                provenance: Some(provenance.clone()),
                ..Part::from_render(info, &sums)
            };
            part.stage_exr(&mut outputs, output)?;
            part.sums
                .develop(part.info.sample_end - part.info.sample_start)
        }
        _ => {
            let mut film = sums.develop(spp);
            // The image, and the sums `--resume` continues from.
            let stage = |film: &plsr::film::Film, outputs: &mut OutputSet| match part {
                Some(info) => Part {
                    provenance: Some(provenance.clone()),
                    ..Part::from_render(
                        PartInfo {
                            sample_start: 0,
                            ..info
                        },
                        &sums,
                    )
                }
                .stage_exr_beside(film, outputs, output, true),
                None => film.stage_exr(outputs, output),
            };
            let noisy = a.denoise.denoise.then(|| film.clone());
            // The guides of all the samples, as one render would take them.
            let whole_job = RenderJob {
                sample_start: 0,
                spp,
                ..*job
            };
            if let Err(e) = a
                .denoise
                .apply_to_render(&mut film, scene, &whole_job)
                .map(|note| {
                    denoise_note = note;
                })
            {
                // Nothing is lost: the render is written undenoised.
                if let Some(noisy) = noisy {
                    let mut kept = OutputSet::new();
                    stage(&noisy, &mut kept)?;
                    kept.commit()?;
                    crate::note!(
                        "note: the render was written undenoised to {}",
                        output.display()
                    );
                }
                return Err(e);
            }
            stage(&film, &mut outputs)?;
            film
        }
    };
    let mut png_note = String::new();
    if let Some(p) = png {
        let tone = exposure.tone_map(&film, a.filmic);
        film.stage_png(&mut outputs, p, tone)?;
        png_note = format!(
            ", {} ({:+.2} stops{whole_frame_note})",
            p.display(),
            tone.exposure
        );
    }
    outputs.commit()?;
    let samples = if resumed {
        format!(", {} new samples, {spp} in all,", job.spp)
    } else if is_part {
        format!(
            " samples {}..{} ({} spp)",
            job.sample_start,
            job.sample_start + job.spp,
            job.spp
        )
    } else {
        format!(" at {spp} spp")
    };
    if job.spp == 0 {
        // Nothing rendered: the file's samples, denoised again.
        crate::note!(
            "{} holds {spp} samples already: nothing to render{denoise_note} → {}{}",
            output.display(),
            output.display(),
            png_note
        );
        return Ok(());
    }
    crate::note!(
        "rendered {}{}×{}{samples} in {:.2} s: {:.3} Msamples/s, {:.2} Mrays/s on {} threads{}{denoise_note} → {}{}",
        frame.map(|f| format!("frame {f}, ")).unwrap_or_default(),
        film.width,
        film.height,
        stats.seconds,
        stats.msamples_per_s(),
        stats.mrays_per_s(),
        stats.threads,
        stats
            .vectorised
            .map(|isa| format!(", vectorised ({})", isa.name()))
            .unwrap_or_default(),
        output.display(),
        png_note
    );
    Ok(())
}

/// The scene hash of a part (see [`plsr::film::part::scene_hash`]): of the
/// files hashed into `files_hasher` (the scene file, then every file it
/// reads, in the loader's order), the job's settings and the frame.
pub(crate) fn part_hash(
    mut files_hasher: StableHasher,
    job: &RenderJob,
    frame: Option<u32>,
) -> u64 {
    files_hasher.field(job_identity(job, frame).as_bytes());
    files_hasher.finish()
}

/// What of a job besides the sample range changes the image, for the
/// parts' scene hash.
fn job_identity(job: &RenderJob, frame: Option<u32>) -> String {
    format!(
        "seed {} max_depth {} rr_depth {} hide_virtual {}{}",
        job.seed,
        job.max_depth,
        job.rr_depth,
        job.hide_virtual,
        frame.map(|f| format!(" frame {f}")).unwrap_or_default()
    )
}

/// `--samples START..END`: `START < END`.
fn parse_samples(s: &str) -> Result<(u32, u32)> {
    let bad = |why: &str| Error::invalid_argument(format!("--samples {s}: {why}"));
    // START..END (END excluded) or START..=LAST, as --frames.
    let (a, b, inclusive) =
        split_range(s).ok_or_else(|| bad("expected START..END, e.g. 0..64 (or 0..=63)"))?;
    let parse = |x: &str| {
        x.trim()
            .parse::<u32>()
            .map_err(|_| bad(&format!("{x:?} is not a sample index")))
    };
    let (start, end) = (parse(a)?, parse(b)?);
    let end = if inclusive {
        end.checked_add(1).ok_or_else(|| bad("LAST is too large"))?
    } else {
        end
    };
    if start >= end {
        return Err(bad("START must be below END"));
    }
    if end - start > MAX_SPP {
        return Err(bad(&format!("at most {MAX_SPP} samples")));
    }
    Ok((start, end))
}

/// `--resolution W,H`: a width and height of 1 to 65 536 pixels.
fn parse_resolution(s: &str) -> Result<(u32, u32)> {
    crate::pixel_args::parse_size("--resolution", s, 1 << 16)
}

/// Samples per pixel of the whole-frame preview that sets a crop's `auto`
/// PNG exposure (fewer when the render has fewer).
const CROP_PREVIEW_SPP: u32 = 16;

/// `--crop X0,Y0,X1,Y1`: a non-empty window inside the `width × height` image.
fn parse_crop(s: &str, width: u32, height: u32) -> Result<Tile> {
    let [x0, y0, x1, y1] = crate::pixel_args::parse_rect("--crop", s, Some((width, height)))?;
    Ok(Tile {
        x0,
        y0,
        width: x1 - x0,
        height: y1 - y0,
    })
}
