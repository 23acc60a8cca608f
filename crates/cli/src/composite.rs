//! `plsr composite`: virtual objects into a photograph, with their shadows.

use crate::error::{Error, Result};
use crate::progress::progress_bar;
use plsr::atomic_write::{check_extension, same_file, OutputSet};
use plsr::render::RenderOptions;
use plsr_apps::composite::{composite_scene, CompositeOptions, Mode, Retrace};
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
    /// Render the scene without the virtual objects as a second whole
    /// render, not alongside the one with them (the same image, bit for
    /// bit, in about 1.7× the time: for checking).
    #[arg(long)]
    pub two_renders: bool,
    /// Composite frames A to B−1 of a video (A..=B includes B): `{frame}`
    /// in the [photo] file names each frame's photo, and in -o, --png and
    /// --matte each frame's outputs. Each frame's camera is the [[views]]
    /// entry whose photo is that frame's (as `plsr import` writes a COLMAP
    /// model), else the camera path's pose, else the scene's camera.
    #[arg(long, value_name = "A..B")]
    pub frames: Option<String>,
    /// With --frames: fit an "auto" exposure for every frame (default: fit
    /// it on the first frame and keep it, so the video does not flicker).
    #[arg(long, requires = "frames")]
    pub refit_exposure: bool,
    /// Denoising of both renders (with and without the virtual objects)
    /// before their difference is taken.
    #[command(flatten)]
    pub denoise: crate::denoise::DenoiseFlags,
    /// Print nothing but warnings and errors: no progress, no summary.
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
        retrace: if a.two_renders {
            Retrace::All
        } else {
            Retrace::Touched
        },
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
    if let Some(frames) = &a.frames {
        let frames = crate::render::parse_frames(frames)?;
        let done = run_frames(a, contents, frames, &options, &progress);
        bar.finish_and_clear();
        return done;
    }
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
        None => match &report.exposure_source {
            Some(source) => format!("exposure k = {:.5} (from {source})", result.k),
            None => format!("exposure k = {} (from the scene)", result.k),
        },
    };
    let paths = report.samples / 2;
    let forked = if a.two_renders || paths == 0 {
        String::new()
    } else {
        format!(
            " ({:.1} % of paths met a virtual object and were traced apart)",
            100.0 * report.rays.forked as f64 / paths as f64
        )
    };
    crate::note!(
        "composited {}×{} ({}) in {:.2} s of rendering{forked}{}, {exposure} → {}{}",
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

/// `plsr composite --frames`: one composite per frame, into that frame's
/// photo through that frame's camera, on one built scene.
fn run_frames(
    a: &CompositeArgs,
    contents: plsr::scene::file::SceneFileContents,
    frames: std::ops::RangeInclusive<u32>,
    options: &CompositeOptions,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<()> {
    use crate::render::frame_path;
    let spec = contents.photo.clone().ok_or_else(|| {
        Error::input(
            &a.scene,
            "photo",
            "required for compositing: a [photo] table",
        )
    })?;
    let field = "{frame}";
    let many = frames.start() != frames.end();
    for (flag, path) in std::iter::once(("-o", &a.output))
        .chain(a.png.iter().map(|p| ("--png", p)))
        .chain(a.matte.iter().map(|p| ("--matte", p)))
    {
        if many && !path.to_string_lossy().contains(field) {
            return Err(Error::output(
                path.clone(),
                format!(
                    "{flag}: --frames writes one file per frame: the name must contain {field}"
                ),
            ));
        }
    }
    if !spec.file.to_string_lossy().contains(field) {
        return Err(Error::input(
            &a.scene,
            "photo.file",
            format!("--frames: the photo's name must contain {field}, which each frame's number replaces"),
        ));
    }
    let views = contents.views.clone();
    let inputs = contents.inputs.clone();
    let path = contents.camera_path.clone();
    let base_camera = contents.description.camera.clone();
    if !contents.description.meshes.iter().any(|m| m.is_virtual) {
        return Err(Error::input(
            &a.scene,
            "shapes",
            "no shape is virtual: mark the objects to insert with `virtual = true`",
        ));
    }
    let mut scene = plsr::scene::Scene::build(contents.description)?;
    // The exposure fitted on the first frame, kept for the others.
    let mut kept: Option<f32> = None;
    for frame in frames {
        let photo_file = frame_path(&spec.file, Some(frame));
        let camera = match views.iter().find(|v| v.photo.file == photo_file) {
            Some(v) => v.camera.clone(),
            None => match &path {
                Some(p) => base_camera.with_pose(p.pose_at(frame).map_err(|e| {
                    Error::input(&a.scene, "camera.path", format!("frame {frame}: {e}"))
                })?),
                None => base_camera.clone(),
            },
        };
        scene.set_camera(camera);
        let frame_spec = plsr::scene::photo::PhotoSpec {
            file: photo_file.clone(),
            ..spec.clone()
        };
        let photo = plsr_apps::composite::Photo::load(&frame_spec)?;
        let (cw, ch) = (scene.camera().width(), scene.camera().height());
        if (photo.width, photo.height) != (cw, ch) {
            return Err(Error::input(
                &photo_file,
                "",
                format!(
                    "{}×{} pixels but frame {frame}'s camera renders {cw}×{ch}",
                    photo.width, photo.height
                ),
            ));
        }
        let (output, png, matte) = (
            frame_path(&a.output, Some(frame)),
            a.png.as_ref().map(|p| frame_path(p, Some(frame))),
            a.matte.as_ref().map(|p| frame_path(p, Some(frame))),
        );
        // No frame's output may replace its photo or a file the scene reads.
        for out in std::iter::once(&output).chain(&png).chain(&matte) {
            if let Some(input) = std::iter::once(&photo_file)
                .chain(&inputs)
                .find(|i| same_file(out, i))
            {
                return Err(Error::output(
                    out.clone(),
                    format!(
                        "frame {frame}: is {}, an input: it would be overwritten",
                        input.display()
                    ),
                ));
            }
        }
        // A given exposure (a number, or each frame's EXIF) holds; else
        // the first frame's fit, unless asked to fit every frame.
        let exposure = match photo.exposure {
            Some(k) => Some(k),
            None if a.refit_exposure => None,
            None => kept,
        };
        let (result, report) =
            plsr_apps::composite::composite_built(&scene, &photo, exposure, options, progress)?;
        kept.get_or_insert(result.k);
        let mut outputs = OutputSet::new();
        result.stage_exr(&mut outputs, &output)?;
        if let Some(p) = &png {
            result.stage_png(&mut outputs, p, &photo.transfer)?;
        }
        if let Some(m) = &matte {
            result.stage_matte_png(&mut outputs, m)?;
        }
        outputs.commit()?;
        let how = match (&report.fit, &photo.exposure_source) {
            (Some(_), _) => "fitted".to_string(),
            (None, Some(source)) => format!("from {source}"),
            (None, None) if photo.exposure.is_none() => "kept from the first frame".to_string(),
            (None, None) => "from the scene".to_string(),
        };
        crate::note!(
            "frame {frame}: composited {}×{} ({}) in {:.2} s, exposure k = {:.5} ({how}) → {}",
            result.width,
            result.height,
            a.mode,
            report.render_seconds,
            result.k,
            output.display()
        );
    }
    Ok(())
}
