//! `plsr hdr capture`: a simulated 360° bracket capture, to close the loop
//! of the HDR pipeline.
//!
//! The scene is rendered by an equirectangular camera at a position (the
//! panorama a 360° camera there would record, in the convention of
//! [`plsr::equirect`]), then photographed at each exposure time through a
//! simulated camera ([`CameraModel`]: response curve, shot and read noise,
//! clipping, 8-bit quantisation) and written as bracketed photos with their
//! EXIF exposure time, f-number and ISO, ready for `plsr hdr merge`. The
//! rendered panorama itself is written as `truth.exr` next to them.

use crate::error::{Error, Result};
use glam::Vec3;
use plsr::camera::{Camera, EquirectCamera, Pose};
use plsr::render::{render, RenderOptions};
use plsr::scene::{file, Scene};
use plsr_base::Vocabulary;
pub use plsr_hdr::synth::PAPER_EXPOSURES;
use plsr_hdr::synth::{auto_exposures, write_brackets, BracketOptions, CameraModel, ExposurePlan};
use std::path::{Path, PathBuf};

/// What [`capture`] does.
#[derive(Debug, Clone)]
pub struct CaptureOptions {
    /// Position of the 360° camera (scene units).
    pub at: Vec3,
    /// Zenith of the panorama; `None`: the scene camera's up.
    pub up: Option<Vec3>,
    /// Direction of the panorama's centre column; `None`: the scene
    /// camera's viewing direction.
    pub forward: Option<Vec3>,
    /// Panorama size in pixels (2:1).
    pub size: (u32, u32),
    /// Samples per pixel (`None`: the scene's).
    pub spp: Option<u32>,
    /// Exposure times in seconds; `None`: chosen from the rendered
    /// panorama's dynamic range ([`auto_exposures`]).
    pub exposures: Option<Vec<f64>>,
    /// The simulated camera.
    pub camera: CameraModel,
    /// Photo format by extension: `jpg`, `png` or `tif`.
    pub format: String,
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
}

/// What [`capture`] wrote.
#[derive(Debug, Clone)]
pub struct Captured {
    /// The bracket photos, shortest exposure first.
    pub paths: Vec<PathBuf>,
    /// Their exposure times in seconds.
    pub exposures: Vec<f64>,
    /// How the times were chosen, when they were chosen automatically.
    pub plan: Option<ExposurePlan>,
}

/// Renders the panorama at `options.at` and writes the brackets and
/// `truth.exr` into the new folder `out` (which must not exist, or be
/// empty). Everything is written to a temporary sibling folder first and
/// renamed at the end, so a failure leaves nothing behind. `progress`
/// receives the render's `(tiles done, tiles)`; returning `false` cancels.
pub fn capture(
    scene_path: &Path,
    out: &Path,
    options: &CaptureOptions,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<Captured> {
    let invalid = |m: String| Error::invalid_argument(m);
    if !options.at.is_finite() {
        return Err(invalid("--at must be three finite numbers".into()));
    }
    if let Some(times) = &options.exposures {
        if times.len() < 2 || times.iter().any(|t| !(t.is_finite() && *t > 0.0)) {
            return Err(invalid(
                "at least two positive exposure times are needed".into(),
            ));
        }
    }
    if !["jpg", "jpeg", "png", "tif", "tiff"].contains(&options.format.as_str()) {
        return Err(invalid(format!(
            "unknown photo format `{}` (jpg, png, tif)",
            options.format
        )));
    }
    if out.exists()
        && std::fs::read_dir(out)
            .map(|mut d| d.next().is_some())
            .unwrap_or(true)
    {
        return Err(Error::output(
            out.to_path_buf(),
            "the output folder exists and is not empty",
        ));
    }
    let mut desc = file::load(scene_path)?;
    let pose = *desc.camera.pose();
    let up = options.up.unwrap_or(pose.up);
    let forward = options.forward.unwrap_or(pose.forward);
    let panorama_pose = Pose::look_at(options.at, options.at + forward, up)
        .map_err(|e| invalid(format!("--up/--forward: {e}")))?;
    let (w, h) = options.size;
    desc.camera = Camera::Equirect(
        EquirectCamera::new(panorama_pose, w, h).map_err(|e| invalid(format!("--size: {e}")))?,
    );
    let mut job = desc.job;
    if let Some(spp) = options.spp {
        job.spp = spp.max(1);
    }
    let scene = Scene::build(desc)?;
    let (film, _) = render(
        &scene,
        &job,
        &RenderOptions {
            threads: options.threads,
            ..Default::default()
        },
        progress,
    )?;
    let (exposures, plan) = match &options.exposures {
        Some(times) => (times.clone(), None),
        None => {
            let plan = auto_exposures(&FilmRadiance(&film), &options.camera).map_err(|m| {
                invalid(format!(
                    "cannot choose exposures for the panorama at {}: {m}; give --exposures",
                    options.at
                ))
            })?;
            (plan.times.clone(), Some(plan))
        }
    };

    // Staged as a hidden folder next to `out`, removed on failure or
    // signal, swept if a killed run left it.
    plsr_base::atomic_write::sweep_stale_partials(out);
    let staging = plsr_base::atomic_write::partial_path(out);
    plsr_base::atomic_write::register_partial(&staging);
    let io = |e: std::io::Error, f: &Path| Error::io(f.to_path_buf(), e);
    std::fs::create_dir_all(&staging).map_err(|e| io(e, &staging))?;
    let result = (|| -> Result<Vec<PathBuf>> {
        film.write_exr(&staging.join("truth.exr"))?;
        let bracket_options = BracketOptions {
            extension: options.format.clone(),
            exif: true,
            ..Default::default()
        };
        Ok(write_brackets(
            &FilmRadiance(&film),
            &options.camera,
            &exposures,
            &staging,
            &bracket_options,
        )?)
    })();
    let placed = result.and_then(|paths| {
        if out.exists() {
            std::fs::remove_dir(out).map_err(|e| io(e, out))?;
        }
        std::fs::rename(&staging, out).map_err(|e| io(e, out))?;
        Ok(paths)
    });
    if placed.is_err() {
        let _ = std::fs::remove_dir_all(&staging);
    }
    plsr_base::atomic_write::forget_partial(&staging);
    let staged = placed?;
    Ok(Captured {
        paths: staged
            .iter()
            .map(|p| out.join(p.file_name().expect("bracket files have names")))
            .collect(),
        exposures,
        plan,
    })
}

/// A rendered image (its colour), e.g. a 360° panorama of a scene, as the
/// radiance a simulated camera photographs.
pub struct FilmRadiance<'a>(pub &'a plsr::film::Film);

impl plsr_hdr::synth::RadianceImage for FilmRadiance<'_> {
    fn size(&self) -> (usize, usize) {
        (self.0.width as usize, self.0.height as usize)
    }
    fn radiance(&self, x: usize, y: usize) -> [f32; 3] {
        self.0.color[y * self.0.width as usize + x].to_array()
    }
}
