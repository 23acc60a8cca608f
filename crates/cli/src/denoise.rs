//! `plsr denoise`: denoises a render's EXR from its own layers, and the
//! `--denoise` flags that `render`, `merge` and `farm merge` share (see
//! docs/denoising.md).

use crate::error::{Error, Result};
use crate::tonemap::{Exposure, SequenceExposure};
use plsr::atomic_write::{same_file, OutputSet};
use plsr::film::denoise::DenoiseSettings;
use plsr::film::Film;
use plsr_base::Vocabulary;
use std::path::{Path, PathBuf};

/// The `--denoise` flags of the commands that write a finished image.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct DenoiseFlags {
    /// Denoise the image (Intel Open Image Denoise's network, run by plsr)
    /// guided by its albedo and normal layers. The EXR keeps the noisy
    /// colour as its `noisy.R/G/B` layer. `render` and `composite` first
    /// trace the guides through smooth glass; `merge` has no scene and uses
    /// the first hit's layers. Denoising is biased: leave it off for
    /// renders compared against ground truth.
    #[arg(long)]
    pub denoise: bool,
    /// With --denoise: clean the albedo and normal layers with their own
    /// networks first (about three times the time; better where the first
    /// hit varies within a pixel: depth of field, rough glass).
    #[arg(long, requires = "denoise")]
    pub denoise_prefilter: bool,
}

impl DenoiseFlags {
    /// Denoises `film`, a whole render of `job` of `scene`, if asked: its
    /// albedo and normal layers are first traced through smooth glass
    /// ([`plsr::integrator::guides`]); a note for the summary line.
    pub fn apply_to_render(
        &self,
        film: &mut Film,
        scene: &plsr::scene::Scene,
        job: &plsr::job::RenderJob,
    ) -> Result<String> {
        if self.denoise {
            plsr::integrator::guides::see_through_glass(scene, job, film);
        }
        self.apply(film, None)
    }

    /// Denoises `film` if asked; a note for the command's summary line
    /// (", denoised (colour + albedo + normal) in 4.9 s") or nothing.
    /// `source` names the file the image came from, for errors; `None`: a
    /// render or merge of this run.
    pub fn apply(&self, film: &mut Film, source: Option<&Path>) -> Result<String> {
        if !self.denoise {
            return Ok(String::new());
        }
        let settings = DenoiseSettings {
            prefilter: self.denoise_prefilter,
            ..DenoiseSettings::default()
        };
        denoise_film(film, &settings, source)
    }
}

/// Denoises `film` (from `source`, named in errors); the summary's note.
fn denoise_film(
    film: &mut Film,
    settings: &DenoiseSettings,
    source: Option<&Path>,
) -> Result<String> {
    let report = film.denoise(settings).map_err(|e| match (e, source) {
        (plsr::Error::Denoise(fault), Some(file)) => Error::input(file, "", fault.to_string()),
        (plsr::Error::Denoise(fault), None) => {
            Error::invalid_argument(format!("cannot denoise the image: {fault}"))
        }
        (other, _) => other.into(),
    })?;
    Ok(format!(
        ", denoised ({}) in {:.1} s",
        report.guides, report.seconds
    ))
}

/// Arguments of `plsr denoise`.
#[derive(Debug, clap::Args)]
pub struct DenoiseArgs {
    /// An OpenEXR render (`plsr render`, `plsr merge`): its colour `R G B`,
    /// guided by its `albedo.R/G/B` and `normal.X/Y/Z` layers where it has
    /// them. A render denoised before is denoised again from its
    /// `noisy.R/G/B` layer.
    #[arg(value_name = "IN.exr")]
    pub input: PathBuf,
    /// Output OpenEXR file: the input's layers, the colour denoised and the
    /// noisy colour kept as `noisy.R/G/B`.
    #[arg(short, long, value_name = "OUT.exr")]
    pub output: PathBuf,
    /// Also write an 8-bit sRGB PNG of the denoised image here.
    #[arg(long, value_name = "OUT.png")]
    pub png: Option<PathBuf>,
    /// Clean the albedo and normal layers with their own networks first
    /// (about three times the time; for layers that are noisy themselves).
    #[arg(long, conflicts_with = "color_only")]
    pub prefilter: bool,
    /// Ignore the albedo and normal layers: denoise the colour alone.
    #[arg(long)]
    pub color_only: bool,
    /// PNG exposure compensation in stops, or `auto` (default: the
    /// render's own exposure where its header states one, else `auto`).
    #[arg(long, allow_hyphen_values = true)]
    pub exposure: Option<String>,
    /// PNG tone mapping: a filmic curve (ACES fit) instead of a plain clamp.
    #[arg(long)]
    pub filmic: bool,
}

/// Which of `names` the EXR at `path` holds.
fn has_channels(path: &Path, names: &[&str]) -> Result<bool> {
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| Error::input(path, "", format!("not a readable OpenEXR file: {e}")))?;
    Ok(meta.headers.iter().any(|h| {
        names
            .iter()
            .all(|n| h.channels.list.iter().any(|c| c.name.to_string() == *n))
    }))
}

/// Runs `plsr denoise`.
pub fn run(a: &DenoiseArgs) -> Result<()> {
    crate::render::check_exr_and_png(&a.output, a.png.as_ref())?;
    for out in std::iter::once(&a.output).chain(&a.png) {
        if same_file(out, &a.input) {
            return Err(Error::output(
                out.clone(),
                "is the input: it would be overwritten (the denoised EXR keeps the noisy colour as noisy.R/G/B; write it beside)",
            ));
        }
    }
    let mut film = Film::read_exr(&a.input)?;
    let albedo = !a.color_only && has_channels(&a.input, &["albedo.R", "albedo.G", "albedo.B"])?;
    let normal = albedo && has_channels(&a.input, &["normal.X", "normal.Y", "normal.Z"])?;
    if !a.color_only && !albedo {
        crate::note!(
            "note: {} has no albedo.R/G/B layer: denoising the colour alone (a render's albedo and normal layers make it sharper)",
            a.input.display()
        );
    } else if !a.color_only && !normal {
        crate::note!(
            "note: {} has no normal.X/Y/Z layer: denoising with the albedo alone",
            a.input.display()
        );
    }
    if albedo && !has_channels(&a.input, &["A"])? {
        // Without a coverage layer every pixel counts as covered (the
        // albedo guide of a sky is 1 only where coverage says so).
        film.alpha.fill(1.0);
    }
    let settings = DenoiseSettings {
        albedo,
        normal,
        prefilter: a.prefilter,
        input_scale: None,
    };
    let note = denoise_film(&mut film, &settings, Some(&a.input))?;
    let mut outputs = OutputSet::new();
    film.stage_exr(&mut outputs, &a.output)?;
    let mut png_note = String::new();
    if let Some(p) = &a.png {
        let mut exposure = SequenceExposure::new(Exposure::parse_optional(a.exposure.as_deref())?);
        let tone = exposure.tone_map(&film, a.filmic);
        film.stage_png(&mut outputs, p, tone)?;
        png_note = format!(", {} ({:+.2} stops)", p.display(), tone.exposure);
    }
    outputs.commit()?;
    crate::note!(
        "{}×{}{note} → {}{png_note}",
        film.width,
        film.height,
        a.output.display()
    );
    Ok(())
}
