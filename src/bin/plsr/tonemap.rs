//! `plsr tonemap`: an OpenEXR image (a render, a merge, an HDR panorama)
//! to an 8-bit sRGB PNG, with automatic or given exposure; and the
//! `--exposure auto|STOPS` value every command writing a PNG takes.

use crate::render::check_output;
use plsr::atomic_write::{same_file, OutputSet};
use plsr::error::{Error, Result};
use plsr::film::{auto_exposure_stops, check_exposure_stops, Film, ToneMap};
use std::path::PathBuf;

/// Arguments of `plsr tonemap`.
#[derive(Debug, clap::Args)]
pub struct TonemapArgs {
    /// The image (OpenEXR with R, G and B channels, linear).
    #[arg(value_name = "IN.exr")]
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
            Error::InvalidArgument(format!(
                "--exposure {s}: expected `auto` or a number of stops"
            ))
        })?;
        check_exposure_stops(stops)
            .map(Exposure::Stops)
            .map_err(|m| Error::InvalidArgument(format!("--exposure: {m}")))
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

/// Runs `plsr tonemap`.
pub fn run(a: &TonemapArgs) -> Result<()> {
    let exposure = Exposure::parse(&a.exposure)?;
    check_output("-o", &a.output, "png", "PNG")?;
    if same_file(&a.output, &a.input) {
        return Err(Error::Output {
            file: a.output.clone(),
            message: "is the input image: it would be overwritten".into(),
        });
    }
    plsr::input::check_input_file(&a.input)?;
    let film = Film::read_exr(&a.input)?;
    let tone = exposure.tone_map(&film, a.filmic);
    let mut outputs = OutputSet::new();
    film.stage_png(&mut outputs, &a.output, tone)?;
    outputs.commit()?;
    eprintln!(
        "{}×{} at {:+.2} stops{} → {}",
        film.width,
        film.height,
        tone.exposure,
        if a.filmic { ", filmic" } else { "" },
        a.output.display()
    );
    Ok(())
}
