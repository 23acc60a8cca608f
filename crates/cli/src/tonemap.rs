//! `plsr tonemap`: an OpenEXR image (a render, a merge, an HDR panorama)
//! to an 8-bit sRGB PNG, with automatic or given exposure; and the
//! `--exposure auto|STOPS` value every command writing a PNG takes.

use crate::error::{Error, Result};
use crate::render::check_output;
use plsr::atomic_write::{same_file, OutputSet};
use plsr::film::{auto_exposure_stops, check_exposure_stops, Film, FilmSettings, ToneMap};
use plsr_base::Vocabulary;
use std::path::PathBuf;

/// Arguments of `plsr tonemap`.
#[derive(Debug, clap::Args)]
pub struct TonemapArgs {
    /// The linear image: OpenEXR (R, G, B channels), Radiance HDR (.hdr) or
    /// float TIFF (.tif).
    #[arg(value_name = "IN.exr|IN.hdr|IN.tif")]
    pub input: PathBuf,
    /// The PNG to write.
    #[arg(short, long, value_name = "OUT.png")]
    pub output: PathBuf,
    /// Exposure compensation in stops (+1 doubles brightness), or `auto`:
    /// middle grey at the image's log-average luminance, lowered until at
    /// most 2 % of the lit pixels clip.
    #[arg(long, default_value = "auto", allow_hyphen_values = true)]
    pub exposure: String,
    /// A filmic curve (ACES fit) instead of a plain clamp.
    #[arg(long)]
    pub filmic: bool,
}

/// An exposure given on the command line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Exposure {
    /// Chosen from the image ([`auto_exposure_stops`]).
    Auto,
    /// This many stops.
    Stops(f32),
}

impl Exposure {
    /// Reads `auto` or a number of stops within ±64.
    pub fn parse(s: &str) -> Result<Exposure> {
        if s.trim().eq_ignore_ascii_case("auto") {
            return Ok(Exposure::Auto);
        }
        let stops: f32 = s.trim().parse().map_err(|_| {
            Error::invalid_argument(format!(
                "--exposure {s}: expected `auto` or a number of stops"
            ))
        })?;
        check_exposure_stops(stops)
            .map(Exposure::Stops)
            .map_err(|m| Error::invalid_argument(format!("--exposure: {m}")))
    }

    /// What `render --png` and `merge --png` use without `--exposure`: the
    /// scene's own exposure where its `[film]` states one (a nonzero
    /// `exposure_ev` or a camera's shutter, ISO and f-number, already in
    /// the image's values, so no further stops), otherwise [`Exposure::Auto`],
    /// so that a scene without a stated exposure gives a PNG that is neither
    /// blown out nor black.
    pub fn scene_default(settings: &FilmSettings) -> Exposure {
        if settings.exposure_ev != 0.0 || settings.camera_exposure.is_some() {
            Exposure::Stops(0.0)
        } else {
            Exposure::Auto
        }
    }

    /// Reads an optional `--exposure`: `None` is [`Exposure::scene_default`],
    /// decided once the image is there.
    pub fn parse_optional(s: Option<&str>) -> Result<Option<Exposure>> {
        s.map(Exposure::parse).transpose()
    }

    /// The tone mapping of `film` with this exposure.
    pub fn tone_map(self, film: &Film, filmic: bool) -> ToneMap {
        ToneMap {
            exposure: match self {
                Exposure::Auto => auto_exposure_stops(&film.color),
                Exposure::Stops(s) => s,
            },
            filmic,
        }
    }
}

/// The exposure of a sequence of PNGs (frames of a camera path): chosen for
/// the first image, as asked or by default, and then kept, so that a
/// sequence with `auto` exposure does not flicker.
#[derive(Debug, Clone, Copy)]
pub struct SequenceExposure {
    asked: Option<Exposure>,
    chosen: Option<f32>,
}

impl SequenceExposure {
    /// `asked` is the `--exposure` given, or `None` for the scene's default.
    pub fn new(asked: Option<Exposure>) -> SequenceExposure {
        SequenceExposure {
            asked,
            chosen: None,
        }
    }

    /// Whether the next image would be exposed `auto` (asked, or the
    /// default of a scene with film `settings`) and no exposure is chosen
    /// yet.
    pub fn auto_pending(&self, settings: &FilmSettings) -> bool {
        self.chosen.is_none()
            && matches!(
                self.asked
                    .unwrap_or_else(|| Exposure::scene_default(settings)),
                Exposure::Auto
            )
    }

    /// The tone mapping of the next image of the sequence, `film`.
    pub fn tone_map(&mut self, film: &Film, filmic: bool) -> ToneMap {
        let exposure = match self.chosen {
            Some(stops) => Exposure::Stops(stops),
            None => self
                .asked
                .unwrap_or_else(|| Exposure::scene_default(&film.settings)),
        };
        let tone = exposure.tone_map(film, filmic);
        self.chosen = Some(tone.exposure);
        tone
    }
}

/// Runs `plsr tonemap`.
pub fn run(a: &TonemapArgs) -> Result<()> {
    let exposure = Exposure::parse(&a.exposure)?;
    check_output("-o", &a.output, "png", "PNG")?;
    if same_file(&a.output, &a.input) {
        return Err(Error::output(
            a.output.clone(),
            "is the input image: it would be overwritten",
        ));
    }
    plsr::input::check_input_file(&a.input)?;
    let film = crate::linear_image::read_linear(&a.input)?;
    let tone = exposure.tone_map(&film, a.filmic);
    let mut outputs = OutputSet::new();
    film.stage_png(&mut outputs, &a.output, tone)?;
    outputs.commit()?;
    crate::note!(
        "{}×{} at {:+.2} stops{} → {}",
        film.width,
        film.height,
        tone.exposure,
        if a.filmic { ", filmic" } else { "" },
        a.output.display()
    );
    Ok(())
}
