//! `plsr merge`: combines the parts of a render (`plsr render --samples` or
//! `--crop`) into the image one render of their union gives, with the
//! merged sums beside it (so that it can be resumed).

use crate::error::{Error, Result};
use crate::tonemap::{Exposure, SequenceExposure};
use plsr::atomic_write::{same_file, OutputSet};
use plsr::film::part::{image_window, merge_parts, Part, PartInfo};
use plsr_base::Vocabulary;
use std::path::PathBuf;

/// Arguments of `plsr merge`.
#[derive(Debug, clap::Args)]
pub struct MergeArgs {
    /// The parts (OpenEXR files written by `plsr render --samples … / --crop …`).
    #[arg(required = true, value_name = "PART.exr")]
    pub parts: Vec<PathBuf>,
    /// Output OpenEXR file: the whole image, as `plsr render` writes it.
    #[arg(short, long, value_name = "OUT.exr")]
    pub output: PathBuf,
    /// Also write an 8-bit sRGB PNG here.
    #[arg(long, value_name = "OUT.png")]
    pub png: Option<PathBuf>,
    /// PNG exposure compensation in stops (+1 doubles brightness), or
    /// `auto` (middle grey at the image's log-average luminance, lowered
    /// until at most 2 % of the lit pixels clip). Default: the scene's
    /// exposure where its `[film]` states one, otherwise `auto`.
    #[arg(long, allow_hyphen_values = true)]
    pub exposure: Option<String>,
    /// PNG tone mapping: a filmic curve (ACES fit) instead of a plain clamp.
    #[arg(long)]
    pub filmic: bool,
    /// Denoising of the merged image (never of the parts: the exact merge
    /// comes first).
    #[command(flatten)]
    pub denoise: crate::denoise::DenoiseFlags,
    /// Write the image's layers only, without the merged exact sums that
    /// `plsr render --resume` continues from (a file about 40 % smaller).
    #[arg(long)]
    pub no_resume_data: bool,
}

/// Runs `plsr merge`.
pub fn run(a: &MergeArgs) -> Result<()> {
    let mut exposure = SequenceExposure::new(Exposure::parse_optional(a.exposure.as_deref())?);
    run_in_sequence(a, &mut exposure)
}

/// Runs `plsr merge` as one image of a sequence (a frame of a camera path
/// that `plsr farm merge` merges), whose PNG exposure `exposure` keeps.
pub fn run_in_sequence(a: &MergeArgs, exposure: &mut SequenceExposure) -> Result<()> {
    crate::render::check_exr_and_png(&a.output, a.png.as_ref())?;
    for out in std::iter::once(&a.output).chain(&a.png) {
        if let Some(part) = a.parts.iter().find(|p| same_file(out, p)) {
            return Err(Error::output(
                out.clone(),
                format!("is the part {}: it would be overwritten", part.display()),
            ));
        }
    }
    let mut parts = Vec::with_capacity(a.parts.len());
    for path in &a.parts {
        if parts
            .iter()
            .any(|(p, _): &(PathBuf, Part)| same_file(p, path))
        {
            return Err(Error::input(path, "", "named twice"));
        }
        parts.push((path.clone(), Part::read_exr(path)?));
    }
    let (sums, spp) = merge_parts(&parts)?;
    let mut film = sums.develop(spp);
    let denoise_note = a.denoise.apply(&mut film, None)?;
    let mut outputs = OutputSet::new();
    if a.no_resume_data {
        film.stage_exr(&mut outputs, &a.output)?;
    } else {
        // The merged sums beside the image, as a render keeps them: the
        // merged image can be resumed (`plsr render --resume`) or merged
        // again.
        let first = &parts[0].1.info;
        let info = PartInfo {
            scene_hash: first.scene_hash,
            image: first.image,
            window: image_window(sums.settings(), first.image),
            sample_start: sums.sample_start(),
            sample_end: sums.sample_start() + spp,
        };
        Part {
            provenance: parts[0].1.provenance.clone(),
            ..Part::from_render(info, &sums)
        }
        .stage_exr_beside(&film, &mut outputs, &a.output, true)?;
    }
    let mut png_note = String::new();
    if let Some(p) = &a.png {
        let tone = exposure.tone_map(&film, a.filmic);
        film.stage_png(&mut outputs, p, tone)?;
        png_note = format!(", {} ({:+.2} stops)", p.display(), tone.exposure);
    }
    outputs.commit()?;
    crate::note!(
        "merged {} into {}×{} at {} spp{denoise_note} → {}{png_note}",
        match parts.len() {
            1 => "1 part".to_string(),
            n => format!("{n} parts"),
        },
        film.width,
        film.height,
        spp,
        a.output.display()
    );
    Ok(())
}
