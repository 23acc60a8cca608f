//! Merging bracketed exposures into one HDR image, streaming rows.
//!
//! 1. Open every bracket (any format OpenImageIO reads), check that sizes,
//!    channels and bit depths agree, and find each one's exposure time
//!    (given, or EXIF `ExposureTime`). The *relative exposure* of a bracket
//!    is `t · (N₀/N)² · (ISO/ISO₀)` (f-number N and ISO from EXIF, used when
//!    every bracket has them and they differ; index 0 is the bracket of
//!    least exposure `t · ISO / N²`, so the order of the files does not
//!    matter). Brackets are sorted by it.
//! 2. Optionally align them by median threshold bitmaps ([`super::align`]).
//! 3. Read a lattice of pixels from every bracket (one row in `stride`),
//!    find each channel's black and white levels on it
//!    ([`super::levels`]), and for `debevec` and `robertson` recover the
//!    curve from it ([`super::response`]); `linear` and `srgb` are presets.
//! 4. Merge band by band: a reader thread reads the same rows of every
//!    bracket in its own bit depth, the rows are merged in parallel (rayon),
//!    and a writer thread streams them into the output. Memory stays a few
//!    bands deep: all brackets are never held at once, not even one full
//!    image.
//!
//! Per pixel and channel, with weights `w(v)` (the hat between the channel's
//! black and white levels, [`super::levels`], times its noise gate: zero on
//! the pedestal and where clipped) and the inverse response `I(v)`:
//! - `debevec`, `linear`, `srgb`: `ln E = Σ w (ln I(v) − ln k) / Σ w`;
//! - `robertson`: `E = Σ w k I(v) / Σ w k²`;
//! - if every weight is zero: a value clipped high in some bracket (and not
//!   dark in a longer one) takes the clipped estimate `I(1)/k` of the shortest such bracket (suns stay the
//!   brightest pixels), otherwise the pixel is dark everywhere and takes the
//!   longest bracket's estimate, floored at half a quantisation step (never
//!   zero, never NaN).
//!
//! Integer inputs clip at their white level (by default the top code);
//! float inputs are taken as normalised, clipping at 1.0.
//!
//! Camera raw brackets (DNG, CR2, NEF, …; [`super::oiio::is_camera_raw`])
//! come out of LibRaw linear, black-subtracted and white-balanced: they are
//! merged with the `linear` response and a black level of 0, whatever
//! response was asked for. An aligned merge is cropped to the area every
//! bracket covers ([`CropMode`], [`common_window`]).

use super::align;
use super::deghost::{self, GhostMask, GhostVotes};
use super::levels::{self, SignalRange};
use super::oiio::{AttrValue, Attribute, ImageInfo, ImageReader, ImageWriter, PixelType, Sample};
use super::response::{self, ResponseCurve, ResponseMethod, SampleSet, BINNED_LEVELS};
use crate::error::{BadExposure, Error, Result};
use plsr_base::Vocabulary;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::mpsc::sync_channel;
use std::time::Instant;

/// Options of [`merge`].
#[derive(Debug, Clone)]
pub struct MergeOptions {
    /// How the camera response is obtained.
    pub response: ResponseMethod,
    /// A response curve to use instead (CSV, as `curve_csv` writes it or
    /// OpenCV's 256×3): `response` is then ignored.
    pub response_curve: Option<PathBuf>,
    /// Exposure times in seconds, one per input in the order given; `None`
    /// reads them from EXIF.
    pub exposures: Option<Vec<f64>>,
    /// Align brackets by median threshold bitmaps first.
    pub align: bool,
    /// Store the output as half floats (EXR only).
    pub half: bool,
    /// Smoothness weight λ of Debevec–Malik.
    pub lambda: f64,
    /// Number of Debevec samples (`None`: chosen from the bit depth and the
    /// number of brackets, ≥ 100).
    pub samples: Option<usize>,
    /// Also write the response curve here as CSV, and its plot next to it
    /// with the extension `.png`.
    pub curve_csv: Option<PathBuf>,
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
    /// OpenEXR compression (OpenImageIO name: `zip`, `piz`, `none`, …);
    /// `None`: `zip` for half output, `none` for float output (merged float
    /// data is noisy in its low mantissa bits: ZIP saves about 17 % of the
    /// size for about three times the merge time).
    pub compression: Option<String>,
    /// How the output is brought to absolute units, if at all.
    pub calibration: Calibration,
    /// The camera's black level: the code value at and below which values
    /// are its pedestal and noise and carry no signal (0–255 for 8-bit
    /// input, 0–65535 for 16-bit, 0–1 for float); `None` finds it from the
    /// brackets ([`levels::detect`]).
    pub black_level: Option<f64>,
    /// The code value at and above which values are clipped; `None` finds
    /// it from the brackets.
    pub white_level: Option<f64>,
    /// Whether the output is cropped to the area every aligned bracket
    /// covers (see [`CropMode`]).
    pub crop: CropMode,
    /// Leave out, where something moved between exposures, the brackets
    /// that disagree with the best-exposed one ([`super::deghost`]).
    pub deghost: bool,
}

/// Whether an aligned merge keeps the frame's border, where some brackets
/// were shifted out of the picture (their edge pixels repeat there), or
/// crops it off.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CropMode {
    /// Crop when alignment moved any bracket (the default).
    #[default]
    Auto,
    /// Always crop to the common area (nothing is cropped when no bracket
    /// moved).
    Always,
    /// Keep the whole frame; the uncovered border repeats each shifted
    /// bracket's edge pixels.
    Never,
}

impl std::str::FromStr for CropMode {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "auto" => Ok(CropMode::Auto),
            "yes" | "on" | "always" => Ok(CropMode::Always),
            "no" | "off" | "never" => Ok(CropMode::Never),
            _ => Err(format!("`{s}`: expected auto, yes or no")),
        }
    }
}

/// The window `[x0, y0, x1, y1]` (`x1`, `y1` exclusive) of a `w`×`h` frame
/// that every bracket covers after its shift (pixel `x` of the output
/// takes pixel `x − dx` of a bracket shifted by `dx`); empty (`x0 ≥ x1`)
/// when the shifts leave nothing in common.
pub fn common_window(shifts: &[(i32, i32)], w: usize, h: usize) -> [usize; 4] {
    let (w, h) = (w as i64, h as i64);
    let x0 = shifts
        .iter()
        .map(|s| s.0 as i64)
        .fold(0, i64::max)
        .clamp(0, w);
    let y0 = shifts
        .iter()
        .map(|s| s.1 as i64)
        .fold(0, i64::max)
        .clamp(0, h);
    let x1 = shifts
        .iter()
        .map(|s| w + s.0 as i64)
        .fold(w, i64::min)
        .clamp(0, w);
    let y1 = shifts
        .iter()
        .map(|s| h + s.1 as i64)
        .fold(h, i64::min)
        .clamp(0, h);
    [
        x0 as usize,
        y0 as usize,
        x1.max(x0) as usize,
        y1.max(y0) as usize,
    ]
}

/// Reflected-light calibration constant of [`Calibration::Exif`] by
/// default, in cd/m²: ISO 12232's saturation-based speed, `78 / q` with the
/// usual lens factor `q = 0.65`. A linear pixel value `v` (1 at clipping)
/// in a photo taken at `t` seconds, f-number `N` and ISO `S` then sees a
/// luminance `L = K · N² · v / (t · S)`.
pub const DEFAULT_CALIBRATION_CONSTANT: f64 = 78.0 / 0.65;

/// Luminous efficacy plsr assumes between photometric and radiometric
/// units: 683 lm/W, so a luminance of 683 cd/m² is a radiance of 1
/// W/(m²·sr) in plsr's units.
pub const LUMENS_PER_WATT: f64 = 683.0;

/// How a merged panorama is brought to absolute radiance, W/(m²·sr) (plsr's
/// units, luminance-weighted with Rec. 709 weights).
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Calibration {
    /// Relative units: exposure per second at the aperture and ISO of the
    /// bracket of least exposure.
    #[default]
    Relative,
    /// From the EXIF f-number and ISO of the bracket of least exposure, with
    /// the reflected-light constant `constant` (cd/m²; see
    /// [`DEFAULT_CALIBRATION_CONSTANT`]).
    Exif {
        /// `K` of `L = K · N² · v / (t · S)`, cd/m².
        constant: f64,
    },
    /// So that the mean luminance of a window of the panorama is a known
    /// value (a grey card under a measured illuminance, a surface measured
    /// with a luminance meter).
    Region {
        /// Window `x0, y0, x1, y1` in pixels (`x1`, `y1` exclusive).
        window: [usize; 4],
        /// Its mean luminance, W/(m²·sr).
        luminance: f64,
        /// Where the value comes from, for the header (`grey card 18 % under
        /// 500 lx`).
        source: String,
    },
}

impl Default for MergeOptions {
    fn default() -> Self {
        MergeOptions {
            response: ResponseMethod::Debevec,
            response_curve: None,
            exposures: None,
            align: false,
            half: false,
            lambda: response::DEFAULT_LAMBDA,
            samples: None,
            curve_csv: None,
            threads: None,
            compression: None,
            calibration: Calibration::Relative,
            black_level: None,
            white_level: None,
            crop: CropMode::Auto,
            deghost: false,
        }
    }
}

/// One input as merged.
#[derive(Debug, Clone, PartialEq)]
pub struct BracketInfo {
    /// The file.
    pub path: PathBuf,
    /// Exposure time in seconds.
    pub exposure_time: f64,
    /// f-number from EXIF, if any.
    pub f_number: Option<f64>,
    /// ISO from EXIF, if any.
    pub iso: Option<f64>,
    /// Relative exposure `t · (N₀/N)² · (ISO/ISO₀)` (seconds at the aperture
    /// and ISO of the bracket of least exposure).
    pub relative_exposure: f64,
    /// Translation applied, in pixels (see [`align::mtb_shift`] and
    /// [`align::stack_shifts`]).
    pub shift: (i32, i32),
}

/// What [`merge`] did.
#[derive(Debug, Clone)]
pub struct MergeSummary {
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
    /// Output channels (3, or 1 for grey input).
    pub channels: usize,
    /// The inputs' pixel type.
    pub format: PixelType,
    /// The inputs' significant bits per sample.
    pub bits: u32,
    /// The brackets, sorted by relative exposure (shortest first).
    pub brackets: Vec<BracketInfo>,
    /// The response curve used.
    pub curve: ResponseCurve,
    /// Per channel, the black and white levels the values were weighted
    /// between.
    pub ranges: Vec<SignalRange>,
    /// Channel values clipped high in every bracket.
    pub saturated_values: u64,
    /// Channel values at zero in every bracket.
    pub dark_values: u64,
    /// Wall time in seconds.
    pub seconds: f64,
    /// What the user should know but did not stop the merge (brackets of
    /// equal exposure), one sentence each.
    pub warnings: Vec<String>,
    /// The factor applied to reach absolute units and where it came from
    /// (`None`: relative units).
    pub calibration: Option<(f64, String)>,
    /// The window `[x0, y0, x1, y1]` of the brackets' frame the output was
    /// cropped to (`None`: the whole frame).
    pub crop: Option<[usize; 4]>,
    /// The brackets were camera raw files, merged as linear data (black
    /// and white levels and white balance from each file, through LibRaw).
    pub camera_raw: bool,
    /// With deghosting: the reference bracket (the best-exposed one) and
    /// the fraction of the image where some bracket was left out.
    pub deghost: Option<(PathBuf, f64)>,
}

/// The largest finite half float: what `--half` stores values above it as.
const HALF_MAX: f32 = 65504.0;

/// The shortest exposure time a bracket may have (s): a nanosecond.
pub const MIN_EXPOSURE_S: f64 = 1e-9;

/// The longest exposure time a bracket may have (s): about 30 years.
pub const MAX_EXPOSURE_S: f64 = 1e9;

/// Parses an exposure time: `1/30`, `0.5`, `15` (seconds).
pub fn parse_exposure(s: &str) -> std::result::Result<f64, BadExposure> {
    let s = s.trim();
    let number = |t: &str| {
        t.trim()
            .parse::<f64>()
            .map_err(|_| BadExposure::NotANumber(s.into()))
    };
    let v = match s.split_once('/') {
        Some((a, b)) => number(a)? / number(b)?,
        None => number(s)?,
    };
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(BadExposure::NotPositive(s.into()))
    }
}

/// Parses a comma-separated list of exposure times (see [`parse_exposure`]).
pub fn parse_exposures(s: &str) -> std::result::Result<Vec<f64>, BadExposure> {
    s.split(',').map(parse_exposure).collect()
}

/// An opened bracket.
struct Input {
    reader: ImageReader,
    info: BracketInfo,
}

/// Opens and checks the inputs; returns them sorted by relative exposure.
fn open_inputs(inputs: &[PathBuf], options: &MergeOptions) -> Result<Vec<Input>> {
    match inputs.len() {
        0 => {
            return Err(Error::invalid_argument(
                "no images given; merging needs at least two brackets",
            ))
        }
        1 => {
            return Err(Error::input(
                &inputs[0],
                "",
                "only one image given; merging needs at least two bracketed exposures",
            ))
        }
        _ => {}
    }
    if let Some(e) = &options.exposures {
        if e.len() != inputs.len() {
            return Err(Error::invalid_argument(format!(
                "--exposures has {} value(s) but {} images were given",
                e.len(),
                inputs.len()
            )));
        }
        if let Some(t) = e.iter().find(|t| !(t.is_finite() && **t > 0.0)) {
            return Err(Error::invalid_argument(format!(
                "exposure time {t} is not positive"
            )));
        }
    }
    let mut opened: Vec<(ImageReader, super::oiio::Exif)> = Vec::new();
    for p in inputs {
        let r = ImageReader::open(p)?;
        let exif = r.exif();
        opened.push((r, exif));
    }
    let first = opened[0].0.info().clone();
    for (r, _) in &opened[1..] {
        let i = r.info();
        if (i.width, i.height) != (first.width, first.height) {
            return Err(Error::input(
                r.path(),
                "",
                format!(
                    "size {}×{} differs from {}×{} of {}",
                    i.width,
                    i.height,
                    first.width,
                    first.height,
                    inputs[0].display()
                ),
            ));
        }
        if i.channels != first.channels {
            return Err(Error::input(
                r.path(),
                "",
                format!(
                    "{} channels, but {} has {}",
                    i.channels,
                    inputs[0].display(),
                    first.channels
                ),
            ));
        }
        if i.format != first.format {
            return Err(Error::input(
                r.path(),
                "",
                format!(
                    "pixel type {:?} differs from {:?} of {}",
                    i.format,
                    first.format,
                    inputs[0].display()
                ),
            ));
        }
    }
    let mut times = Vec::new();
    for (k, (r, exif)) in opened.iter().enumerate() {
        let t = match &options.exposures {
            Some(e) => e[k],
            None => exif.exposure_time.ok_or_else(|| {
                Error::input(
                    r.path(),
                    "",
                    "no exposure time in its EXIF metadata (ExposureTime); give the times with --exposures",
                )
            })?,
        };
        // Outside this range a pixel's radiance (value / time) leaves f32.
        if !(MIN_EXPOSURE_S..=MAX_EXPOSURE_S).contains(&t) {
            let source = if options.exposures.is_some() {
                "--exposures"
            } else {
                "ExposureTime"
            };
            return Err(Error::input(
                r.path(),
                "",
                format!(
                    "exposure time {t:.3e} s ({source}) is outside {MIN_EXPOSURE_S:e} s to {MAX_EXPOSURE_S:e} s"
                ),
            ));
        }
        times.push(t);
    }
    let all_f = opened.iter().all(|(_, e)| e.f_number.is_some());
    let all_iso = opened.iter().all(|(_, e)| e.iso.is_some());
    // The reference bracket, whose aperture and ISO the output's units
    // are at: the one of least exposure `t · ISO / N²`, whatever order the
    // files come in (ties by time, then file name), so that the same files
    // merge to the same values in any order.
    let exposure_value = |t: f64, e: &super::oiio::Exif| {
        let mut v = t;
        if all_f {
            v /= e.f_number.unwrap_or(1.0).powi(2);
        }
        if all_iso {
            v *= e.iso.unwrap_or(100.0);
        }
        v
    };
    let reference = (0..opened.len())
        .min_by(|&a, &b| {
            exposure_value(times[a], &opened[a].1)
                .total_cmp(&exposure_value(times[b], &opened[b].1))
                .then(times[a].total_cmp(&times[b]))
                .then(opened[a].0.path().cmp(opened[b].0.path()))
        })
        .unwrap_or(0);
    let f0 = opened[reference].1.f_number.unwrap_or(1.0);
    let iso0 = opened[reference].1.iso.unwrap_or(100.0);
    let mut out: Vec<Input> = opened
        .into_iter()
        .zip(times)
        .map(|((reader, exif), t)| {
            let mut k = t;
            if all_f {
                k *= (f0 / exif.f_number.unwrap_or(f0)).powi(2);
            }
            if all_iso {
                k *= exif.iso.unwrap_or(iso0) / iso0;
            }
            let info = BracketInfo {
                path: reader.path().to_path_buf(),
                exposure_time: t,
                f_number: exif.f_number,
                iso: exif.iso,
                relative_exposure: k,
                shift: (0, 0),
            };
            Input { reader, info }
        })
        .collect();
    // The same order as the reference's choice: the reference first.
    out.sort_by(|a, b| {
        a.info
            .relative_exposure
            .total_cmp(&b.info.relative_exposure)
            .then(a.info.exposure_time.total_cmp(&b.info.exposure_time))
            .then(a.info.path.cmp(&b.info.path))
    });
    let infos: Vec<&BracketInfo> = out.iter().map(|i| &i.info).collect();
    if equal_exposure(infos[0], infos[infos.len() - 1]) {
        return Err(Error::invalid_argument(format!(
            "all {} brackets have the same exposure ({}): merging needs at least two \
             different ones (was the camera in an automatic exposure mode?)",
            infos.len(),
            describe_exposure(infos[0])
        )));
    }
    Ok(out)
}

/// A warning when the brackets' f-numbers differ: their exposures account
/// for it, but depth of field (and vignetting) differ between them, so
/// edges at other distances than the focus blend from differently sharp
/// brackets.
pub fn aperture_warning(brackets: &[BracketInfo]) -> Option<String> {
    let f: Vec<f64> = brackets.iter().map(|b| b.f_number).collect::<Option<_>>()?;
    let (lo, hi) = f
        .iter()
        .fold((f64::INFINITY, 0f64), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    (hi > lo * 1.01).then(|| {
        format!(
            "the brackets' apertures differ (f/{lo} to f/{hi}): their exposures take it into \
             account, but depth of field differs between them; bracket with the shutter time \
             at one aperture where you can"
        )
    })
}

/// Whether two brackets have the same relative exposure (within 0.1 %,
/// below what any camera's exposure steps tell apart).
fn equal_exposure(a: &BracketInfo, b: &BracketInfo) -> bool {
    (a.relative_exposure - b.relative_exposure).abs()
        <= 1e-3 * a.relative_exposure.max(b.relative_exposure)
}

/// A bracket's exposure for messages: `1/60 s at f/8, ISO 100`.
fn describe_exposure(b: &BracketInfo) -> String {
    let t = b.exposure_time;
    let mut s = if t < 1.0 && (1.0 / t - (1.0 / t).round()).abs() < 1e-6 {
        format!("1/{} s", (1.0 / t).round())
    } else {
        format!("{t} s")
    };
    if let Some(f) = b.f_number {
        s += &format!(" at f/{f}");
    }
    if let Some(iso) = b.iso {
        s += &format!(", ISO {iso}");
    }
    s
}

/// One warning per pair of neighbouring brackets (sorted by exposure) of
/// equal exposure: the second adds no dynamic range, and usually means a
/// mistyped `--exposures` or a camera that chose its own exposure.
pub fn duplicate_exposure_warnings(brackets: &[BracketInfo]) -> Vec<String> {
    brackets
        .windows(2)
        .filter(|w| equal_exposure(&w[0], &w[1]))
        .map(|w| {
            format!(
                "{} and {} have the same exposure ({}): one adds no dynamic range",
                w[0].path.display(),
                w[1].path.display(),
                describe_exposure(&w[0])
            )
        })
        .collect()
}

/// Levels of the curve domain for a pixel type.
fn domain_levels(format: PixelType, method: ResponseMethod) -> usize {
    match (format, method.is_recovered()) {
        (PixelType::U8, _) => 256,
        (_, true) => BINNED_LEVELS,
        _ => 256,
    }
}

/// Per-element access for the merge: normalised value and integer index.
trait Px: Sample {
    /// Normalised value in [0, 1] (floats unclamped).
    fn norm(self) -> f32;
    /// Index into a lookup table (integers), or 0.
    fn index(self) -> usize;
    /// Whether lookup tables index by value.
    const TABLE: bool;
    /// Table size for integer types.
    const SIZE: usize;
}
impl Px for u8 {
    fn norm(self) -> f32 {
        self as f32 / 255.0
    }
    fn index(self) -> usize {
        self as usize
    }
    const TABLE: bool = true;
    const SIZE: usize = 256;
}
impl Px for u16 {
    fn norm(self) -> f32 {
        self as f32 / 65535.0
    }
    fn index(self) -> usize {
        self as usize
    }
    const TABLE: bool = true;
    const SIZE: usize = 65536;
}
impl Px for f32 {
    fn norm(self) -> f32 {
        self
    }
    fn index(self) -> usize {
        0
    }
    const TABLE: bool = false;
    const SIZE: usize = 0;
}

/// Quantises a normalised value to a curve level.
#[inline]
fn level_of(v: f32, levels: usize) -> u16 {
    let v = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    (v * (levels - 1) as f32).round() as u16
}

/// Lookup of (weight, ln I, I, clipped-high) per channel and value.
struct Lookup {
    curve: ResponseCurve,
    /// Per channel, the black and white levels.
    ranges: Vec<SignalRange>,
    /// For float inputs: per channel, the noise gate at each level of the
    /// curve's domain (at least 256), looked up by the nearest level
    /// rather than computed for every value.
    gate: Vec<Vec<f32>>,
    /// For integer inputs: per channel, SIZE entries each.
    w: Vec<Vec<f32>>,
    clip: Vec<Vec<bool>>,
    ln_i: Vec<Vec<f32>>,
    lin: Vec<Vec<f32>>,
    /// I at the clip level and at half a quantisation step, per channel.
    top: Vec<f32>,
    floor: Vec<f32>,
}

const TINY: f32 = 1e-30;

impl Lookup {
    fn new<T: Px>(curve: ResponseCurve, ranges: &[SignalRange], channels: usize) -> Lookup {
        let (mut w, mut ln_i, mut lin, mut clip) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let half_step = if T::TABLE {
            0.5 / (T::SIZE - 1) as f32
        } else {
            0.5 / 65535.0
        };
        let mut top = Vec::new();
        let mut floor = Vec::new();
        for (c, r) in ranges.iter().enumerate().take(channels) {
            if T::TABLE {
                let n = T::SIZE;
                let vals: Vec<f32> = (0..n)
                    .map(|z| curve.eval(c, z as f32 / (n - 1) as f32))
                    .collect();
                w.push(
                    (0..n)
                        .map(|z| {
                            let v = z as f32 / (n - 1) as f32;
                            r.weight(v) * levels::noise_gate(&curve, c, v)
                        })
                        .collect(),
                );
                clip.push(
                    (0..n)
                        .map(|z| r.is_clipped(z as f32 / (n - 1) as f32))
                        .collect(),
                );
                ln_i.push(vals.iter().map(|v| v.max(TINY).ln()).collect());
                lin.push(vals);
            }
            top.push(curve.eval(c, 1.0).max(TINY));
            floor.push(curve.eval(c, half_step).max(TINY));
        }
        let gate = if T::TABLE {
            Vec::new()
        } else {
            let n = curve.levels().max(256);
            (0..channels)
                .map(|c| {
                    (0..n)
                        .map(|z| levels::noise_gate(&curve, c, z as f32 / (n - 1) as f32))
                        .collect()
                })
                .collect()
        };
        Lookup {
            curve,
            ranges: ranges.to_vec(),
            gate,
            w,
            clip,
            ln_i,
            lin,
            top,
            floor,
        }
    }

    /// (weight, ln I, I, clipped high) of value `z` in channel `c`.
    #[inline(always)]
    fn get<T: Px>(&self, c: usize, z: T) -> (f32, f32, f32, bool) {
        if T::TABLE {
            let i = z.index();
            // SAFETY-free indexing: tables have T::SIZE entries and i < SIZE.
            let w = self.w[c][i];
            (w, self.ln_i[c][i], self.lin[c][i], self.clip[c][i])
        } else {
            let v = z.norm();
            let v = if v.is_nan() { 0.0 } else { v };
            let i = self.curve.eval(c, v).max(TINY);
            let r = &self.ranges[c];
            let gate = &self.gate[c];
            let level = (v.clamp(0.0, 1.0) * (gate.len() - 1) as f32).round() as usize;
            let w = r.weight(v) * gate[level];
            (w, i.ln(), i, r.is_clipped(v))
        }
    }
}

/// Rows of one bracket for one band: the first source row and the data.
struct BandRows<T> {
    first_row: usize,
    data: Vec<T>,
}

/// The merged value of channel `c` for output pixel `x` given each
/// bracket's source row.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn merge_value<T: Px>(
    lk: &Lookup,
    rows: &[&[T]],
    ch_in: usize,
    x: usize,
    c: usize,
    ln_k: &[f32],
    k: &[f32],
    robertson: bool,
    skip: u64,
    stats: &mut (u64, u64),
) -> f32 {
    let (mut sw, mut acc, mut den) = (0f32, 0f32, 0f32);
    let mut clipped: Option<f32> = None;
    let mut contradicted = false;
    let mut last_i = 0f32;
    for (b, row) in rows.iter().enumerate() {
        if skip >> b & 1 == 1 {
            continue;
        }
        let z = row[x * ch_in + c];
        let (w, ln_i, i, high) = lk.get(c, z);
        if w > 0.0 {
            sw += w;
            if robertson {
                acc += w * k[b] * i;
                den += w * k[b] * k[b];
            } else {
                acc += w * (ln_i - ln_k[b]);
            }
        } else if high {
            if clipped.is_none() {
                clipped = Some(lk.top[c] / k[b]);
            }
        } else if clipped.is_some() {
            // Dark in a longer exposure than one it is clipped in: not a
            // sun but a marker (a scan's coloured border) or a ghost.
            contradicted = true;
        }
        last_i = i;
    }
    let v = if sw > 0.0 {
        if robertson {
            acc / den
        } else {
            (acc / sw).exp()
        }
    } else {
        f32::NAN
    };
    if v.is_finite() && v > 0.0 {
        return v;
    }
    if skip != 0 {
        // Every bracket left is clipped or dark here: deghosting must not
        // leave the pixel without an estimate.
        return merge_value(lk, rows, ch_in, x, c, ln_k, k, robertson, 0, stats);
    }
    if let (Some(s), false) = (clipped, contradicted) {
        stats.0 += 1;
        return s;
    }
    stats.1 += 1;
    let n = k.len() - 1;
    (last_i.max(lk.floor[c]) / k[n]).max(f32::MIN_POSITIVE)
}

/// `row` moved right by `dx` pixels (pixel `x` takes `x − dx`, clamped).
fn shift_row<T: Px>(row: &[T], dx: i32, w: usize, ch: usize) -> std::borrow::Cow<'_, [T]> {
    if dx == 0 {
        return std::borrow::Cow::Borrowed(row);
    }
    let mut out = Vec::with_capacity(row.len());
    for x in 0..w {
        let sx = (x as i64 - dx as i64).clamp(0, w as i64 - 1) as usize;
        out.extend_from_slice(&row[sx * ch..sx * ch + ch]);
    }
    std::borrow::Cow::Owned(out)
}

/// Per bracket and channel, for each integer level `z`: the numerator and
/// denominator terms of the merge (`w·(ln I − ln k)` and `w` for the log
/// estimator, `w·k·I` and `w·k²` for Robertson's).
struct Tables {
    size: usize,
    channels: usize,
    /// `(numerator, denominator)` per bracket, channel and level.
    terms: Vec<[f32; 2]>,
}

impl Tables {
    fn new(lk: &Lookup, k: &[f32], ln_k: &[f32], robertson: bool) -> Tables {
        let channels = lk.w.len();
        let size = lk.w.first().map_or(0, Vec::len);
        let mut terms = Vec::with_capacity(k.len() * channels * size);
        for b in 0..k.len() {
            for c in 0..channels {
                for z in 0..size {
                    let w = lk.w[c][z];
                    terms.push(if robertson {
                        [w * k[b] * lk.lin[c][z], w * k[b] * k[b]]
                    } else {
                        [w * (lk.ln_i[c][z] - ln_k[b]), w]
                    });
                }
            }
        }
        Tables {
            size,
            channels,
            terms,
        }
    }

    fn table(&self, b: usize, c: usize) -> &[[f32; 2]] {
        let base = (b * self.channels + c) * self.size;
        &self.terms[base..base + self.size]
    }
}

/// Merges one row of integer input through [`Tables`]: branch-free sums
/// over the brackets, then the clipped/dark fallbacks of [`merge_value`]
/// only where no bracket had weight.
#[allow(clippy::too_many_arguments)]
fn merge_row_tables<T: Px>(
    t: &Tables,
    lk: &Lookup,
    rows: &[&[T]],
    ch_in: usize,
    ch_out: usize,
    out: &mut [f32],
    ln_k: &[f32],
    k: &[f32],
    robertson: bool,
    stats: &mut (u64, u64),
) {
    let w = out.len() / ch_out;
    let mut den = vec![0f32; out.len()];
    out.fill(0.0);
    for (b, row) in rows.iter().enumerate() {
        if ch_out == 3 && t.channels == 3 {
            let (t0, t1, t2) = (t.table(b, 0), t.table(b, 1), t.table(b, 2));
            // Levels are below T::SIZE = table length: lets the compiler
            // drop the bounds checks in the loop.
            assert!(t0.len() >= T::SIZE && t1.len() >= T::SIZE && t2.len() >= T::SIZE);
            for ((px, o), d) in row
                .chunks_exact(ch_in)
                .zip(out.chunks_exact_mut(3))
                .zip(den.chunks_exact_mut(3))
            {
                let a = t0[px[0].index()];
                let bb = t1[px[1].index()];
                let cc = t2[px[2].index()];
                o[0] += a[0];
                d[0] += a[1];
                o[1] += bb[0];
                d[1] += bb[1];
                o[2] += cc[0];
                d[2] += cc[1];
            }
        } else {
            for c in 0..ch_out.min(t.channels) {
                let tc = t.table(b, c);
                for x in 0..w {
                    let e = tc[row[x * ch_in + c].index()];
                    out[x * ch_out + c] += e[0];
                    den[x * ch_out + c] += e[1];
                }
            }
        }
    }
    for x in 0..w {
        for c in 0..ch_out {
            let i = x * ch_out + c;
            let d = den[i];
            let v = if d > 0.0 {
                if robertson {
                    out[i] / d
                } else {
                    (out[i] / d).exp()
                }
            } else {
                f32::NAN
            };
            out[i] = if v.is_finite() && v > 0.0 {
                v
            } else {
                merge_value(lk, rows, ch_in, x, c, ln_k, k, robertson, 0, stats)
            };
        }
    }
}

/// OpenEXR's compression methods, by OpenImageIO's names.
pub const EXR_COMPRESSIONS: [&str; 10] = [
    "none", "rle", "zips", "zip", "piz", "pxr24", "b44", "b44a", "dwaa", "dwab",
];

/// Checks an output compression: one of [`EXR_COMPRESSIONS`], optionally
/// with a numeric level (`zip:9`, `dwaa:45`), and only for an EXR output
/// (`ext`, lower case).
fn check_compression(c: &str, ext: &str) -> Result<()> {
    let bad = |why: String| Error::invalid_argument(format!("compression `{c}`: {why}"));
    if ext != "exr" {
        return Err(bad("only OpenEXR (.exr) outputs are compressed".into()));
    }
    let (name, level) = match c.split_once(':') {
        Some((n, l)) => (n, Some(l)),
        None => (c, None),
    };
    if !EXR_COMPRESSIONS.contains(&name) {
        return Err(bad(format!(
            "not an OpenEXR compression (known: {})",
            EXR_COMPRESSIONS.join(", ")
        )));
    }
    if let Some(l) = level {
        if l.parse::<f32>()
            .map_or(true, |v| !(v.is_finite() && v >= 0.0))
        {
            return Err(bad(format!("the level `{l}` is not a number ≥ 0")));
        }
    }
    Ok(())
}

/// Merges `inputs` into `output` (OpenEXR `.exr`, Radiance `.hdr` or float
/// TIFF `.tif`),
/// reporting progress as `(phase, done, total)`. On any error no output (and
/// no curve file) is left behind.
pub fn merge(
    inputs: &[PathBuf],
    output: &Path,
    options: &MergeOptions,
    progress: &dyn Fn(&str, u64, u64),
) -> Result<MergeSummary> {
    let start = Instant::now();
    let ext = output
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if !matches!(ext.as_str(), "exr" | "hdr" | "tif" | "tiff") {
        return Err(Error::output(
            output.to_path_buf(),
            "the output must be an OpenEXR (.exr), Radiance (.hdr) or 32-bit float TIFF \
             (.tif) file",
        ));
    }
    if options.half && ext != "exr" {
        return Err(Error::output(
            output.to_path_buf(),
            "--half needs an OpenEXR (.exr) output",
        ));
    }
    let plot = options.curve_csv.as_ref().map(|c| c.with_extension("png"));
    for p in std::iter::once(output)
        .chain(options.curve_csv.as_deref())
        .chain(plot.as_deref())
    {
        if p.is_dir() {
            return Err(Error::output(p.to_path_buf(), "is a folder, not a file"));
        }
        let dir = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if !dir.is_dir() {
            return Err(Error::output(
                p.to_path_buf(),
                format!("folder {} does not exist", dir.display()),
            ));
        }
    }
    if let Some(c) = &options.compression {
        check_compression(c, &ext)?;
    }
    // No output may replace a bracket (or the other output).
    let outputs: Vec<&Path> = std::iter::once(output)
        .chain(options.curve_csv.as_deref())
        .collect();
    for out in &outputs {
        if let Some(input) = inputs
            .iter()
            .find(|i| plsr_base::atomic_write::same_file(i, out))
        {
            return Err(Error::output(
                out.to_path_buf(),
                format!("is the input {}: it would be overwritten", input.display()),
            ));
        }
    }
    if let [out, curve] = outputs[..] {
        if plsr_base::atomic_write::same_file(out, curve) {
            return Err(Error::output(
                curve.to_path_buf(),
                "--curve names the same file as the output",
            ));
        }
    }
    // Camera raw brackets are linear: no response to recover, and LibRaw
    // has already subtracted the black level the file gives.
    let raw = inputs
        .iter()
        .filter(|p| super::oiio::is_camera_raw(p))
        .count();
    let mut raw_notes = Vec::new();
    let raw_options;
    let options = if raw == 0 {
        options
    } else if raw < inputs.len() {
        let (r, other) = (
            inputs.iter().find(|p| super::oiio::is_camera_raw(p)),
            inputs.iter().find(|p| !super::oiio::is_camera_raw(p)),
        );
        return Err(Error::invalid_argument(format!(
            "{} is a camera raw file but {} is not: merge brackets of one kind (raw brackets \
             are linear, others go through a response curve)",
            r.map(|p| p.display().to_string()).unwrap_or_default(),
            other.map(|p| p.display().to_string()).unwrap_or_default()
        )));
    } else {
        if options.response_curve.is_some()
            || !matches!(
                options.response,
                ResponseMethod::Debevec | ResponseMethod::Linear
            )
        {
            raw_notes.push(format!(
                "camera raw brackets are linear: the response {} was not used",
                options
                    .response_curve
                    .as_ref()
                    .map(|c| c.display().to_string())
                    .unwrap_or_else(|| options.response.to_string())
            ));
        }
        raw_options = MergeOptions {
            response: ResponseMethod::Linear,
            response_curve: None,
            black_level: Some(options.black_level.unwrap_or(0.0)),
            ..options.clone()
        };
        &raw_options
    };
    let mut brackets = open_inputs(inputs, options)?;
    let infos: Vec<BracketInfo> = brackets.iter().map(|b| b.info.clone()).collect();
    let warnings = [
        raw_notes,
        duplicate_exposure_warnings(&infos),
        aperture_warning(&infos).into_iter().collect(),
    ]
    .concat();
    let info = brackets[0].reader.info().clone();
    let pool = plsr_base::threads::thread_pool(options.threads)?;
    let summary = match info.format {
        PixelType::U8 => run::<u8>(&mut brackets, output, options, &pool, progress, start),
        PixelType::U16 => run::<u16>(&mut brackets, output, options, &pool, progress, start),
        _ => run::<f32>(&mut brackets, output, options, &pool, progress, start),
    }?;
    Ok(MergeSummary {
        warnings: [warnings, summary.warnings.clone()].concat(),
        camera_raw: raw > 0,
        ..summary
    })
}

/// The merge of opened, sorted brackets: alignment, the response curve,
/// calibration, then the streamed merge into `output` and the curve files.
fn run<T: Px>(
    brackets: &mut [Input],
    output: &Path,
    options: &MergeOptions,
    pool: &rayon::ThreadPool,
    progress: &dyn Fn(&str, u64, u64),
    start: Instant,
) -> Result<MergeSummary> {
    let info = brackets[0].reader.info().clone();
    let (w, h, ch_in) = (info.width, info.height, info.channels);
    let ch_out = if ch_in >= 3 { 3 } else { 1 };
    if options.align {
        align_brackets(brackets, options, pool, progress)?;
    }
    let shifts: Vec<(i32, i32)> = brackets.iter().map(|b| b.info.shift).collect();
    let moved = shifts.iter().any(|s| *s != (0, 0));
    let window = match options.crop {
        CropMode::Always => common_window(&shifts, w, h),
        CropMode::Auto if moved => common_window(&shifts, w, h),
        _ => [0, 0, w, h],
    };
    if window[0] >= window[2] || window[1] >= window[3] {
        return Err(Error::invalid_argument(format!(
            "alignment shifted the brackets so far apart ({}) that no pixel is in all of them: \
             these are not brackets of one view",
            shifts
                .iter()
                .map(|s| format!("{},{}", s.0, s.1))
                .collect::<Vec<_>>()
                .join(" ")
        )));
    }
    let crop = (window != [0, 0, w, h]).then_some(window);
    let (curve, ranges, best_exposed) =
        recover_curve::<T>(brackets, &info, options, ch_out, progress)?;

    // Merge pass, from row 0 again: a reader of a sequential format goes
    // back by itself (OpenImageIO re-opens the file; plsr's PNG reader
    // kept a small image decoded).
    let lk = Lookup::new::<T>(curve.clone(), &ranges, ch_out);
    let calibration = calibrate::<T>(brackets, &lk, (w, h, ch_in, ch_out), window, options)?;
    let ghosts = match best_exposed {
        Some(reference) => Some(ghost_mask::<T>(
            brackets,
            &lk,
            reference,
            (w, h, ch_in, ch_out),
            pool,
            progress,
        )?),
        None => None,
    };
    let kernel = MergeKernel::new::<T>(
        brackets,
        lk,
        calibration.as_ref(),
        ghosts.clone(),
        options,
        (w, h, ch_in, ch_out),
    );

    let mut attrs = header(brackets, &curve, &ranges, options, calibration.as_ref());
    if let Some([x0, y0, x1, y1]) = crop {
        attrs.push((
            "plsr:crop".into(),
            AttrValue::Str(format!("{x0} {y0} {x1} {y1} of {w}x{h}")),
        ));
    }
    let (out_w, out_h) = (window[2] - window[0], window[3] - window[1]);
    let stored = if options.half {
        PixelType::Half
    } else {
        PixelType::F32
    };
    let writer = ImageWriter::create(output, out_w, out_h, ch_out, stored, &attrs)?;
    let (writer, stats, clamped) =
        stream_merge::<T>(brackets, writer, &kernel, window, options, pool, progress)?;
    // The curve files and the image are renamed into place together, once
    // all are written: a failure writing any leaves every old file.
    let mut outputs = plsr_base::atomic_write::OutputSet::new();
    if let Some(csv) = &options.curve_csv {
        curve.stage_csv(&mut outputs, csv)?;
        curve.stage_plot_png(&mut outputs, &csv.with_extension("png"), 640, 480)?;
    }
    writer.finish_into(&mut outputs)?;
    outputs.commit()?;
    Ok(MergeSummary {
        width: out_w,
        height: out_h,
        channels: ch_out,
        format: info.format,
        bits: info.bits,
        brackets: brackets.iter().map(|b| b.info.clone()).collect(),
        curve,
        ranges,
        saturated_values: stats.0,
        dark_values: stats.1,
        seconds: start.elapsed().as_secs_f64(),
        calibration,
        crop,
        camera_raw: false,
        deghost: ghosts
            .as_ref()
            .zip(best_exposed)
            .map(|(g, r)| (brackets[r].info.path.clone(), g.0.ghost_fraction())),
        warnings: if clamped > 0 {
            vec![format!(
                "{clamped} value(s) above {HALF_MAX}, the largest half float, were stored as {HALF_MAX}: \
                 leave out --half to keep them"
            )]
        } else {
            Vec::new()
        },
    })
}

/// Aligns the brackets relative to the middle exposure, each bracket to
/// its neighbour towards it (brackets are sorted by exposure): sets each
/// bracket's `shift`.
fn align_brackets(
    brackets: &mut [Input],
    options: &MergeOptions,
    pool: &rayon::ThreadPool,
    progress: &dyn Fn(&str, u64, u64),
) -> Result<()> {
    debug_assert!(options.align);
    let info = brackets[0].reader.info().clone();
    let n = brackets.len();
    let levels = align::default_levels(info.width, info.height);
    progress("aligning", 0, n as u64);
    let mut done = 0;
    let shifts = align::stack_shifts(n, levels, Some(pool), |b| {
        // Separate readers, so the merge's readers stay at row 0.
        let g = align::read_grey(&mut ImageReader::open(&brackets[b].info.path)?)?;
        done += 1;
        progress("aligning", done, n as u64);
        Ok(g)
    })?;
    for (bracket, shift) in brackets.iter_mut().zip(shifts) {
        bracket.info.shift = shift;
    }
    Ok(())
}

/// The black and white levels of each channel, and the response curve:
/// a fixed one (linear, sRGB), or one recovered from the brackets' pixels
/// (Debevec–Malik, Robertson).
fn recover_curve<T: Px>(
    brackets: &mut [Input],
    info: &ImageInfo,
    options: &MergeOptions,
    ch_out: usize,
    progress: &dyn Fn(&str, u64, u64),
) -> Result<(ResponseCurve, Vec<SignalRange>, Option<usize>)> {
    let levels = domain_levels(info.format, options.response);
    // The lattice the levels are found on (and curves recovered from), on
    // the recovery's domain: 256 levels for 8-bit input, bins otherwise.
    let lattice_levels = domain_levels(info.format, ResponseMethod::Debevec);
    let lattice = sample_lattice::<T>(brackets, lattice_levels, ch_out, progress)?;
    let ranges = signal_ranges(&lattice.samples, options, info.format)?;
    let best = options
        .deghost
        .then(|| best_exposed(&lattice.samples, &ranges));
    if let Some(path) = &options.response_curve {
        return Ok((ResponseCurve::read_csv(path)?, ranges, best));
    }
    let curve = match options.response {
        ResponseMethod::Linear => ResponseCurve::linear(levels, ch_out),
        ResponseMethod::Srgb => ResponseCurve::srgb(levels, ch_out),
        ResponseMethod::Given => {
            return Err(Error::invalid_argument(
                "the response method `given` needs a curve file (--response-curve)",
            ))
        }
        method => {
            let k: Vec<f64> = brackets.iter().map(|b| b.info.relative_exposure).collect();
            if method == ResponseMethod::Debevec {
                // Every lattice point by default: the least squares stay a
                // levels × levels system however many there are, and a
                // uniform lattice weights the curve's levels as the image
                // uses them. (Samples chosen evenly over the middle
                // exposure's intensities, the earlier default, over-weight
                // rare highlights: 0.20 against 0.12 log2-RMSE on the
                // Memorial stack.)
                match options.samples {
                    None => response::debevec(&lattice.samples, &k, options.lambda, &ranges)?,
                    Some(wanted) => {
                        let chosen = choose_samples(&lattice, wanted, &ranges);
                        response::debevec(&chosen, &k, options.lambda, &ranges)?
                    }
                }
            } else {
                response::robertson(&lattice.samples, &k, 50, 1e-4, &ranges)?
            }
        }
    };
    Ok((curve, ranges, best))
}

/// The bracket whose lattice values carry the most weight (between the
/// black and white levels): the best-exposed one, deghosting's reference.
fn best_exposed(samples: &SampleSet, ranges: &[SignalRange]) -> usize {
    let (n, ch) = (samples.brackets, samples.channels);
    let top = (samples.levels - 1).max(1) as f32;
    let mut total = vec![0f64; n];
    for point in samples.values.chunks_exact(n * ch) {
        for (b, values) in point.chunks_exact(ch).enumerate() {
            for (c, &z) in values.iter().enumerate() {
                total[b] += ranges[c.min(ranges.len() - 1)].weight(z as f32 / top) as f64;
            }
        }
    }
    (0..n)
        .max_by(|&a, &b| total[a].total_cmp(&total[b]).then(b.cmp(&a)))
        .unwrap_or(n / 2)
}

/// Each channel's black and white levels: the ones given in `options`,
/// the others found from the lattice.
fn signal_ranges(
    samples: &SampleSet,
    options: &MergeOptions,
    format: PixelType,
) -> Result<Vec<SignalRange>> {
    let full = match format {
        PixelType::U8 => 255.0,
        PixelType::U16 => 65535.0,
        _ => 1.0,
    };
    levels::detect(samples)
        .into_iter()
        .map(|found| {
            let range = SignalRange {
                pedestal: found.pedestal.min(
                    options
                        .black_level
                        .map_or(found.pedestal, |b| (b / full) as f32),
                ),
                black: options
                    .black_level
                    .map_or(found.black, |b| (b / full) as f32),
                white: options
                    .white_level
                    .map_or(found.white, |w| (w / full) as f32),
            };
            if range.black < range.white && range.black >= 0.0 && range.white <= 1.0 {
                Ok(range)
            } else {
                Err(Error::invalid_argument(format!(
                    "the black level {} is not below the white level {} (code values of the \
                     input, 0–{full}); give both with --black-level and --white-level",
                    range.black as f64 * full,
                    range.white as f64 * full
                )))
            }
        })
        .collect()
}

/// Absolute units: the factor every merged value is multiplied by (every
/// relative exposure is divided by it) and where it came from; `None` for
/// relative units. `dims` is (width, height, input channels, output channels).
fn calibrate<T: Px>(
    brackets: &mut [Input],
    lk: &Lookup,
    dims: (usize, usize, usize, usize),
    frame: [usize; 4],
    options: &MergeOptions,
) -> Result<Option<(f64, String)>> {
    let (w, h, ch_in, ch_out) = dims;
    Ok(match &options.calibration {
        Calibration::Relative => None,
        Calibration::Exif { constant } => Some(exif_scale(brackets, *constant)?),
        Calibration::Region {
            window,
            luminance,
            source,
        } => {
            let mean = region_luminance::<T>(
                brackets,
                lk,
                *window,
                frame,
                (w, h, ch_in, ch_out),
                options,
            )?;
            if !(mean.is_finite() && mean > 0.0) {
                return Err(Error::invalid_argument(format!(
                    "calibration: the window {},{},{},{} merges to luminance {mean}: it must \
                     be lit and unclipped in some bracket",
                    window[0], window[1], window[2], window[3]
                )));
            }
            Some((*luminance / mean, source.clone()))
        }
    })
}

/// What merging a row needs: the curve's lookup, each bracket's exposure
/// (calibrated) and its log, the alignment shifts, the image's size.
struct MergeKernel {
    lk: Lookup,
    k: Vec<f32>,
    ln_k: Vec<f32>,
    shifts: Vec<(i32, i32)>,
    robertson: bool,
    fast: Option<Tables>,
    ghosts: Option<(GhostMask, GhostTest)>,
    w: usize,
    h: usize,
    ch_in: usize,
    ch_out: usize,
}

impl MergeKernel {
    fn new<T: Px>(
        brackets: &[Input],
        lk: Lookup,
        calibration: Option<&(f64, String)>,
        ghosts: Option<(GhostMask, GhostTest)>,
        options: &MergeOptions,
        (w, h, ch_in, ch_out): (usize, usize, usize, usize),
    ) -> MergeKernel {
        let scale = calibration.map_or(1.0, |c| c.0);
        let k: Vec<f32> = brackets
            .iter()
            .map(|b| (b.info.relative_exposure / scale) as f32)
            .collect();
        let ln_k: Vec<f32> = k.iter().map(|v| v.ln()).collect();
        let shifts: Vec<(i32, i32)> = brackets.iter().map(|b| b.info.shift).collect();
        let robertson = options.response == ResponseMethod::Robertson;
        let fast = T::TABLE.then(|| Tables::new(&lk, &k, &ln_k, robertson));
        MergeKernel {
            lk,
            k,
            ln_k,
            shifts,
            robertson,
            fast,
            ghosts,
            w,
            h,
            ch_in,
            ch_out,
        }
    }

    /// Merges output row `y` from the bands' `rows` into `orow`; returns
    /// the (saturated, dark) value counts.
    fn merge_row<T: Px>(&self, y: usize, rows: &[BandRows<T>], orow: &mut [f32]) -> (u64, u64) {
        let (w, ch_in, ch_out) = (self.w, self.ch_in, self.ch_out);
        let src = shifted_rows(rows, &self.shifts, y, w, self.h, ch_in);
        let src: Vec<&[T]> = src.iter().map(|r| r.as_ref()).collect();
        let mut st = (0u64, 0u64);
        if let Some(ft) = &self.fast {
            merge_row_tables(
                ft,
                &self.lk,
                &src,
                ch_in,
                ch_out,
                orow,
                &self.ln_k,
                &self.k,
                self.robertson,
                &mut st,
            );
        } else {
            for x in 0..w {
                for c in 0..ch_out {
                    orow[x * ch_out + c] = self.value(&src, x, c, 0, &mut st);
                }
            }
        }
        // Where something moved, again without the brackets that saw it.
        if let Some((mask, test)) = &self.ghosts {
            let mut ghost_stats = (0u64, 0u64);
            let mut est = Vec::with_capacity(src.len());
            for x in 0..w {
                // In a block where something moved, a bracket is left out
                // unless it agrees with the reference at this very pixel
                // (so still edges in the block keep every bracket).
                let block = mask.skip(x, y);
                if block == 0 {
                    continue;
                }
                let (bad, tested) = test.pixel(&self.lk, &src, x, ch_in, &mut est);
                let skip = block & !(tested & !bad);
                if skip == 0 {
                    continue;
                }
                for c in 0..ch_out {
                    orow[x * ch_out + c] = self.value(&src, x, c, skip, &mut ghost_stats);
                }
            }
        }
        st
    }

    /// [`merge_value`] of channel `c` at pixel `x` of the shifted rows
    /// `src`, without the brackets in `skip`.
    #[inline]
    fn value<T: Px>(
        &self,
        src: &[&[T]],
        x: usize,
        c: usize,
        skip: u64,
        stats: &mut (u64, u64),
    ) -> f32 {
        merge_value(
            &self.lk,
            src,
            self.ch_in,
            x,
            c,
            &self.ln_k,
            &self.k,
            self.robertson,
            skip,
            stats,
        )
    }
}

/// Each bracket's row `y` of the output, moved by its alignment shift
/// (`rows` hold the rows the band needs).
fn shifted_rows<'a, T: Px>(
    rows: &'a [BandRows<T>],
    shifts: &[(i32, i32)],
    y: usize,
    w: usize,
    h: usize,
    ch_in: usize,
) -> Vec<std::borrow::Cow<'a, [T]>> {
    rows.iter()
        .zip(shifts)
        .map(|(br, &(dx, dy))| {
            let sy = (y as i64 - dy as i64).clamp(0, h as i64 - 1) as usize;
            let off = (sy - br.first_row) * w * ch_in;
            shift_row(&br.data[off..off + w * ch_in], dx, w, ch_in)
        })
        .collect()
}

/// The deghosting mask ([`super::deghost`]): a pass over every bracket's
/// rows comparing each pixel's estimates with the reference bracket's.
fn ghost_mask<T: Px>(
    brackets: &[Input],
    lk: &Lookup,
    reference: usize,
    (w, h, ch_in, ch_out): (usize, usize, usize, usize),
    pool: &rayon::ThreadPool,
    progress: &dyn Fn(&str, u64, u64),
) -> Result<(GhostMask, GhostTest)> {
    let n = brackets.len();
    if n > deghost::MAX_BRACKETS {
        return Err(Error::invalid_argument(format!(
            "--deghost handles at most {} brackets; {n} were given",
            deghost::MAX_BRACKETS
        )));
    }
    let ln_k: Vec<f32> = brackets
        .iter()
        .map(|b| (b.info.relative_exposure as f32).ln())
        .collect();
    let test = GhostTest::new(lk, ln_k, reference, ch_out);
    let mut readers = brackets
        .iter()
        .map(|b| ImageReader::open(&b.info.path))
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let shifts: Vec<(i32, i32)> = brackets.iter().map(|b| b.info.shift).collect();
    let band = (deghost::BLOCK * 8).min(h);
    let mut votes = GhostVotes::new(w, h, n);
    let test = &test;
    progress("deghosting", 0, h as u64);
    std::thread::scope(|scope| -> Result<()> {
        let (to_votes, from_reader) = sync_channel::<Result<Band<T>>>(2);
        let refs: Vec<&mut ImageReader> = readers.iter_mut().collect();
        let read_shifts = shifts.clone();
        scope.spawn(move || read_bands(refs, &read_shifts, w, h, ch_in, (0, h, band), to_votes));
        for item in from_reader {
            let (y0, y1, rows) = item?;
            let per_row: Vec<Vec<(u64, u64)>> = pool.install(|| {
                (y0..y1)
                    .into_par_iter()
                    .map(|y| {
                        let src = shifted_rows(&rows, &shifts, y, w, h, ch_in);
                        let src: Vec<&[T]> = src.iter().map(|r| r.as_ref()).collect();
                        let mut est = Vec::with_capacity(n);
                        (0..w)
                            .map(|x| test.pixel(lk, &src, x, ch_in, &mut est))
                            .collect()
                    })
                    .collect()
            });
            for (r, row) in per_row.iter().enumerate() {
                for (x, &(bad, tested)) in row.iter().enumerate() {
                    votes.vote(x, y0 + r, bad, tested);
                }
            }
            progress("deghosting", y1 as u64, h as u64);
        }
        Ok(())
    })?;
    Ok((votes.mask(), test.clone()))
}

/// The per-pixel consistency test of deghosting: each bracket's estimate
/// against the reference bracket's ([`deghost::disagreeing`]).
#[derive(Debug, Clone)]
struct GhostTest {
    /// `ln k` per bracket.
    ln_k: Vec<f32>,
    /// Per channel, the relative error of the exposure at each level.
    noise: Vec<Vec<f32>>,
    /// The image's reference bracket (the best-exposed one).
    reference: usize,
    channels: usize,
}

impl GhostTest {
    fn new(lk: &Lookup, ln_k: Vec<f32>, reference: usize, channels: usize) -> GhostTest {
        let levels = lk.curve.levels().max(256);
        let noise = (0..channels)
            .map(|c| {
                (0..levels)
                    .map(|z| levels::exposure_noise(&lk.curve, c, z as f32 / (levels - 1) as f32))
                    .collect()
            })
            .collect();
        GhostTest {
            ln_k,
            noise,
            reference,
            channels,
        }
    }

    /// The brackets that disagree with the reference at pixel `x` of the
    /// (shifted) rows `src` in any channel, and the ones compared.
    fn pixel<T: Px>(
        &self,
        lk: &Lookup,
        src: &[&[T]],
        x: usize,
        ch_in: usize,
        est: &mut Vec<deghost::Estimate>,
    ) -> (u64, u64) {
        let (mut bad, mut tested) = (0u64, 0u64);
        for c in 0..self.channels {
            est.clear();
            let noise = &self.noise[c];
            for (b, row) in src.iter().enumerate() {
                let z = row[x * ch_in + c];
                let (wt, ln_i, _, high) = lk.get(c, z);
                est.push(deghost::Estimate {
                    ln_e: ln_i - self.ln_k[b],
                    noise: noise[level_of(z.norm(), noise.len()) as usize],
                    weight: wt,
                    valid: wt > deghost::MIN_WEIGHT,
                    clipped: high,
                });
            }
            let (b, t) = deghost::disagreeing(est, self.reference);
            bad |= b;
            tested |= t;
        }
        (bad, tested)
    }
}

/// The streamed merge: a reader thread reads bands of rows of every
/// bracket, the pool merges them, a writer thread writes them. Returns the
/// writer (not yet finished), the (saturated, dark) counts and how many
/// values were clamped to the largest half float.
fn stream_merge<T: Px>(
    brackets: &mut [Input],
    writer: ImageWriter,
    kernel: &MergeKernel,
    window: [usize; 4],
    options: &MergeOptions,
    pool: &rayon::ThreadPool,
    progress: &dyn Fn(&str, u64, u64),
) -> Result<(ImageWriter, (u64, u64), u64)> {
    let (w, h, ch_in, ch_out) = (kernel.w, kernel.h, kernel.ch_in, kernel.ch_out);
    let [x0, wy0, x1, wy1] = window;
    let out_w = x1 - x0;
    let n = brackets.len();
    // Rows per band: about 16 MB of input per band.
    let bytes = std::mem::size_of::<T>().max(1);
    let band = (16usize << 20) / (n * w * ch_in * bytes).max(1);
    let band = band.clamp(4, 256).min(wy1 - wy0);

    let (to_merge, from_reader) = sync_channel::<Result<Band<T>>>(2);
    let (to_writer, from_merge) = sync_channel::<(usize, usize, Vec<f32>)>(2);
    let readers: Vec<&mut ImageReader> = brackets.iter_mut().map(|b| &mut b.reader).collect();
    let mut stats = (0u64, 0u64);
    let mut clamped = 0u64;
    let result: Result<ImageWriter> = std::thread::scope(|scope| {
        let shifts = kernel.shifts.clone();
        scope.spawn(move || read_bands(readers, &shifts, w, h, ch_in, (wy0, wy1, band), to_merge));
        let writer_thread = scope.spawn(move || -> Result<ImageWriter> {
            let mut writer = writer;
            for (y0, y1, data) in from_merge {
                writer.write_rows(y0, y1, &data)?;
            }
            Ok(writer)
        });
        // Merge.
        let merged: Result<()> = (|| {
            for item in from_reader {
                let (y0, y1, rows) = item?;
                let mut out = vec![0f32; (y1 - y0) * out_w * ch_out];
                let band_stats: Vec<(u64, u64)> = pool.install(|| {
                    out.par_chunks_mut(out_w * ch_out)
                        .enumerate()
                        .map(|(r, orow)| {
                            if out_w == w {
                                kernel.merge_row(y0 + r, &rows, orow)
                            } else {
                                // Merged over the whole width (the kernel's
                                // tables run along full rows), then cropped.
                                let mut full = vec![0f32; w * ch_out];
                                let st = kernel.merge_row(y0 + r, &rows, &mut full);
                                orow.copy_from_slice(&full[x0 * ch_out..x1 * ch_out]);
                                st
                            }
                        })
                        .collect()
                });
                for s in band_stats {
                    stats.0 += s.0;
                    stats.1 += s.1;
                }
                // Half floats end at 65504: beyond it they would be infinite.
                if options.half {
                    for v in out.iter_mut().filter(|v| **v > HALF_MAX) {
                        *v = HALF_MAX;
                        clamped += 1;
                    }
                }
                progress("merging", (y1 - wy0) as u64, (wy1 - wy0) as u64);
                if to_writer.send((y0 - wy0, y1 - wy0, out)).is_err() {
                    break;
                }
            }
            Ok(())
        })();
        drop(to_writer);
        let writer = writer_thread
            .join()
            .map_err(|_| Error::invalid_argument("the EXR writer thread panicked"))?;
        merged?;
        writer
    });
    Ok((result?, stats, clamped))
}

/// Rows `y0..y1` of the output as each bracket's rows: `(y0, y1, rows)`.
type Band<T> = (usize, usize, Vec<BandRows<T>>);

/// The reader thread of [`stream_merge`]: bands of `band` output rows
/// `first..end` of every bracket (each moved by its vertical shift), sent
/// until the window ends, a read fails (the error is sent) or the merge
/// stops listening.
fn read_bands<T: Px>(
    mut readers: Vec<&mut ImageReader>,
    shifts: &[(i32, i32)],
    w: usize,
    h: usize,
    ch_in: usize,
    (first, end, band): (usize, usize, usize),
    to_merge: std::sync::mpsc::SyncSender<Result<Band<T>>>,
) {
    let mut y0 = first;
    while y0 < end {
        let y1 = (y0 + band).min(end);
        let mut rows = Vec::with_capacity(readers.len());
        for (b, r) in readers.iter_mut().enumerate() {
            let dy = shifts[b].1 as i64;
            let s0 = (y0 as i64 - dy).clamp(0, h as i64 - 1) as usize;
            let s1 = (y1 as i64 - 1 - dy).clamp(0, h as i64 - 1) as usize + 1;
            let mut data = vec![T::default(); (s1 - s0) * w * ch_in];
            if let Err(e) = r.read_rows(s0, s1, &mut data) {
                let _ = to_merge.send(Err(e.into()));
                return;
            }
            rows.push(BandRows {
                first_row: s0,
                data,
            });
        }
        if to_merge.send(Ok((y0, y1, rows))).is_err() {
            return;
        }
        y0 = y1;
    }
}

/// The factor from relative to absolute units given by the reference
/// bracket's exposure triangle: `K · N² / (S · 683)` (relative values are
/// exposures per second at the f-number `N` and ISO `S` of the bracket of
/// least exposure, the first after sorting).
fn exif_scale(brackets: &[Input], constant: f64) -> Result<(f64, String)> {
    let first = &brackets[0].info;
    let (Some(n), Some(iso)) = (first.f_number, first.iso) else {
        return Err(Error::input(
            &first.path,
            "",
            "EXIF calibration needs the f-number (FNumber) and ISO (ISOSpeedRatings) in the \
             metadata of every image (this one, of least exposure, is the reference); \
             calibrate from a known window instead (--known-luminance, --grey-card)",
        ));
    };
    if !(constant.is_finite() && constant > 0.0) {
        return Err(Error::invalid_argument(format!(
            "--calibration-constant {constant}: must be positive"
        )));
    }
    let scale = constant * n * n / (iso * LUMENS_PER_WATT);
    Ok((
        scale,
        format!(
            "EXIF: f/{n}, ISO {iso} of the bracket of least exposure ({}), K = {constant} \
             cd/m^2 (L = K N^2 v / (t S)), 683 lm/W",
            first
                .path
                .file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_default()
        ),
    ))
}

/// The mean luminance (Rec. 709 weights; the one channel of a grey image)
/// of a window of the merged image in relative units, merged from the
/// window's rows of every bracket with their alignment shifts.
#[allow(clippy::too_many_arguments)]
fn region_luminance<T: Px>(
    brackets: &[Input],
    lk: &Lookup,
    window: [usize; 4],
    frame: [usize; 4],
    (w, h, ch_in, ch_out): (usize, usize, usize, usize),
    options: &MergeOptions,
) -> Result<f64> {
    let [x0, y0, x1, y1] = window;
    let (fw, fh) = (frame[2] - frame[0], frame[3] - frame[1]);
    if !(x0 < x1 && y0 < y1 && x1 <= fw && y1 <= fh) {
        let what = if (fw, fh) == (w, h) {
            "the images' size"
        } else {
            "the output's size, cropped to the area every aligned bracket covers"
        };
        return Err(Error::invalid_argument(format!(
            "calibration window {x0},{y0},{x1},{y1}: must be X0,Y0,X1,Y1 with X0 < X1 ≤ {fw} \
             and Y0 < Y1 ≤ {fh} ({what})"
        )));
    }
    // The window is in the output's pixels: move it into the frame's.
    let [x0, y0, x1, y1] = [x0 + frame[0], y0 + frame[1], x1 + frame[0], y1 + frame[1]];
    let k: Vec<f32> = brackets
        .iter()
        .map(|b| b.info.relative_exposure as f32)
        .collect();
    let ln_k: Vec<f32> = k.iter().map(|v| v.ln()).collect();
    let robertson = options.response == ResponseMethod::Robertson;
    // Each bracket's rows that the window's rows come from.
    let mut rows: Vec<BandRows<T>> = Vec::with_capacity(brackets.len());
    for b in brackets {
        let dy = b.info.shift.1 as i64;
        let s0 = (y0 as i64 - dy).clamp(0, h as i64 - 1) as usize;
        let s1 = (y1 as i64 - 1 - dy).clamp(0, h as i64 - 1) as usize + 1;
        let mut data = vec![T::default(); (s1 - s0) * w * ch_in];
        ImageReader::open(&b.info.path)?.read_rows(s0, s1, &mut data)?;
        rows.push(BandRows {
            first_row: s0,
            data,
        });
    }
    let weights: &[f64] = if ch_out == 3 {
        &[0.2126, 0.7152, 0.0722]
    } else {
        &[1.0]
    };
    let shifts: Vec<(i32, i32)> = brackets.iter().map(|b| b.info.shift).collect();
    let mut sum = 0f64;
    let mut stats = (0u64, 0u64);
    for y in y0..y1 {
        let src = shifted_rows(&rows, &shifts, y, w, h, ch_in);
        let src: Vec<&[T]> = src.iter().map(|r| r.as_ref()).collect();
        for x in x0..x1 {
            for (c, wt) in weights.iter().enumerate() {
                let v = merge_value(lk, &src, ch_in, x, c, &ln_k, &k, robertson, 0, &mut stats);
                sum += wt * v as f64;
            }
        }
    }
    Ok(sum / ((x1 - x0) * (y1 - y0)) as f64)
}

/// The header attributes of the merged image.
fn header(
    brackets: &[Input],
    curve: &ResponseCurve,
    ranges: &[SignalRange],
    options: &MergeOptions,
    calibration: Option<&(f64, String)>,
) -> Vec<Attribute> {
    let join = |f: &dyn Fn(&BracketInfo) -> String| {
        brackets
            .iter()
            .map(|b| f(&b.info))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let s = |v: String| AttrValue::Str(v);
    let mut a: Vec<Attribute> = vec![
        (
            "compression".into(),
            s(options.compression.clone().unwrap_or_else(|| {
                if options.half { "zip" } else { "none" }.to_string()
            })),
        ),
        (
            "Software".into(),
            s(format!("plsr {} hdr merge", env!("CARGO_PKG_VERSION"))),
        ),
        ("plsr:response".into(), s(curve.method.to_string())),
        (
            "plsr:exposure_times".into(),
            s(join(&|b| format!("{}", b.exposure_time))),
        ),
        (
            "plsr:relative_exposures".into(),
            s(join(&|b| format!("{}", b.relative_exposure))),
        ),
        (
            "plsr:inputs".into(),
            s(join(&|b| {
                b.path
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default()
            })),
        ),
        (
            "plsr:units".into(),
            s(match calibration {
                None => "relative radiance: linear exposure per second at the aperture and ISO of the bracket of least exposure; pixel level 0.5 of the curve's domain maps to exposure 0.5".into(),
                Some(_) => "absolute radiance, W/(m^2 sr) per linear Rec. 709 channel (683 cd/m^2 of luminance = 1)".into(),
            }),
        ),
        ("plsr:response_curve".into(), s(curve.to_header_string())),
        (
            "plsr:black_level".into(),
            s(ranges.iter().map(|r| format!("{}", r.black)).collect::<Vec<_>>().join(" ")),
        ),
        (
            "plsr:white_level".into(),
            s(ranges.iter().map(|r| format!("{}", r.white)).collect::<Vec<_>>().join(" ")),
        ),
    ];
    if brackets.iter().all(|b| b.info.f_number.is_some()) {
        a.push((
            "plsr:f_numbers".into(),
            s(join(&|b| format!("{}", b.f_number.unwrap_or(0.0)))),
        ));
    }
    if brackets.iter().all(|b| b.info.iso.is_some()) {
        a.push((
            "plsr:iso".into(),
            s(join(&|b| format!("{}", b.iso.unwrap_or(0.0)))),
        ));
    }
    if let Some((scale, source)) = calibration {
        a.push((
            "plsr:radiance_scale".into(),
            AttrValue::Float(*scale as f32),
        ));
        a.push(("plsr:calibration".into(), s(source.clone())));
    }
    if brackets
        .first()
        .is_some_and(|b| super::oiio::is_camera_raw(&b.info.path))
    {
        a.push((
            "plsr:camera_raw".into(),
            s(
                "linear (LibRaw): each file's black and white levels and as-shot white balance, \
               sRGB primaries"
                    .into(),
            ),
        ));
    }
    if options.align {
        a.push((
            "plsr:alignment".into(),
            s(join(&|b| format!("{},{}", b.shift.0, b.shift.1))),
        ));
    }
    a
}

/// Lattice of pixels read from every bracket.
struct Lattice {
    /// All lattice points as a sample set (bracket order: sorted).
    samples: SampleSet,
    /// Lattice columns and rows.
    cols: usize,
    rows: usize,
}

/// Reads one row in `stride` (and one pixel in `stride` of it) of every
/// bracket, with the bracket's alignment shift, as curve levels: about
/// 40,000 points (22,000–90,000 as the stride rounds; every pixel of a
/// smaller image). The Debevec solve's time grows with them.
fn sample_lattice<T: Px>(
    brackets: &mut [Input],
    levels: usize,
    ch_out: usize,
    progress: &dyn Fn(&str, u64, u64),
) -> Result<Lattice> {
    let info = brackets[0].reader.info().clone();
    let (w, h, ch_in) = (info.width, info.height, info.channels);
    let stride = (((w * h) as f64 / 40_000.0).sqrt().round() as usize).max(1);
    let cols = w.div_ceil(stride);
    let rows = h.div_ceil(stride);
    let n = brackets.len();
    // Each bracket's lattice values (point-major), the brackets read in
    // parallel; then interleaved bracket by bracket for each point.
    progress("sampling", 0, n as u64);
    let per_bracket = brackets
        .par_iter_mut()
        .map(|br| -> Result<Vec<u16>> {
            let (dx, dy) = br.info.shift;
            let mut row = vec![T::default(); w * ch_in];
            let mut mine = vec![0u16; cols * rows * ch_out];
            for ry in 0..rows {
                let y = (ry * stride + stride / 2).min(h - 1);
                let sy = (y as i64 - dy as i64).clamp(0, h as i64 - 1) as usize;
                br.reader.read_rows(sy, sy + 1, &mut row)?;
                for rx in 0..cols {
                    let x = (rx * stride + stride / 2).min(w - 1);
                    let sx = (x as i64 - dx as i64).clamp(0, w as i64 - 1) as usize;
                    let p = ry * cols + rx;
                    for c in 0..ch_out {
                        mine[p * ch_out + c] = level_of(row[sx * ch_in + c].norm(), levels);
                    }
                }
            }
            Ok(mine)
        })
        .collect::<Result<Vec<_>>>()?;
    progress("sampling", n as u64, n as u64);
    let mut values = vec![0u16; cols * rows * n * ch_out];
    for (b, mine) in per_bracket.iter().enumerate() {
        for (p, point) in mine.chunks_exact(ch_out).enumerate() {
            values[(p * n + b) * ch_out..][..ch_out].copy_from_slice(point);
        }
    }
    Ok(Lattice {
        samples: SampleSet {
            levels,
            brackets: n,
            channels: ch_out,
            values,
        },
        cols,
        rows,
    })
}

/// Chooses `wanted` lattice points spread over the image (a grid of about
/// `wanted` cells, least-used cell first) and over the middle exposure's
/// intensity range (`wanted` equal-width strata, visited in turn), preferring
/// points in smooth regions; points with no usable value in any bracket are
/// skipped.
fn choose_samples(lattice: &Lattice, wanted: usize, ranges: &[SignalRange]) -> SampleSet {
    let s = &lattice.samples;
    let (n, ch, l) = (s.brackets, s.channels, s.levels);
    let points = s.len();
    let mid = n / 2;
    let luma = |p: usize| -> f32 {
        (0..ch)
            .map(|c| s.values[(p * n + mid) * ch + c] as f32)
            .sum::<f32>()
            / (ch as f32 * (l - 1) as f32)
    };
    let usable = |p: usize| {
        (0..n).any(|b| {
            (0..ch).all(|c| {
                let z = s.values[(p * n + b) * ch + c];
                ranges[c.min(ranges.len() - 1)].weight(z as f32 / (l - 1) as f32) > 0.0
            })
        })
    };
    let (cols, rows) = (lattice.cols, lattice.rows);
    // Local contrast in the middle exposure (to prefer flat regions).
    let contrast = |p: usize| -> f32 {
        let (x, y) = (p % cols, p / cols);
        let mut m = 0f32;
        let v = luma(p);
        if x + 1 < cols {
            m = m.max((luma(p + 1) - v).abs());
        }
        if y + 1 < rows {
            m = m.max((luma(p + cols) - v).abs());
        }
        m
    };
    let strata = wanted.max(1);
    let mut by_stratum: Vec<Vec<(usize, f32)>> = vec![Vec::new(); strata];
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    let lumas: Vec<f32> = (0..points).map(luma).collect();
    for (p, &v) in lumas.iter().enumerate() {
        if usable(p) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    for (p, &luma_p) in lumas.iter().enumerate() {
        if !usable(p) {
            continue;
        }
        let t = if hi > lo {
            (luma_p - lo) / (hi - lo)
        } else {
            0.5
        };
        let k = ((t * strata as f32) as usize).min(strata - 1);
        by_stratum[k].push((p, contrast(p)));
    }
    // Spatial grid of about `wanted` cells with the image's aspect.
    let gx = ((wanted as f64 * cols as f64 / rows as f64).sqrt().ceil() as usize).clamp(1, cols);
    let gy = wanted.div_ceil(gx).clamp(1, rows);
    let cell = |p: usize| ((p / cols) * gy / rows) * gx + (p % cols) * gx / cols;
    let mut used = vec![0u32; gx * gy];
    let mut taken = vec![false; points];
    let mut chosen = Vec::with_capacity(wanted);
    loop {
        let before = chosen.len();
        for cands in &by_stratum {
            if chosen.len() >= wanted {
                break;
            }
            let best = cands.iter().filter(|(p, _)| !taken[*p]).min_by(|a, b| {
                used[cell(a.0)]
                    .cmp(&used[cell(b.0)])
                    .then(a.1.total_cmp(&b.1))
                    .then(plsr_base::rng::mix64(a.0 as u64).cmp(&plsr_base::rng::mix64(b.0 as u64)))
            });
            if let Some(&(p, _)) = best {
                taken[p] = true;
                used[cell(p)] += 1;
                chosen.push(p);
            }
        }
        if chosen.len() >= wanted || chosen.len() == before {
            break;
        }
    }
    let mut values = Vec::with_capacity(chosen.len() * n * ch);
    for p in chosen {
        values.extend_from_slice(&s.values[p * n * ch..(p + 1) * n * ch]);
    }
    SampleSet {
        levels: l,
        brackets: n,
        channels: ch,
        values,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_exposures() {
        assert_eq!(
            parse_exposures("1/30,0.5, 15").unwrap(),
            vec![1.0 / 30.0, 0.5, 15.0]
        );
        assert!(parse_exposure("0").is_err());
        assert!(parse_exposure("1/0").is_err());
        assert!(parse_exposure("abc").is_err());
        assert!(parse_exposure("-1").is_err());
    }

    #[test]
    fn samples_spread_over_intensity_and_space() {
        // A 100×50 lattice, 3 brackets, a horizontal ramp in the middle one.
        let (cols, rows, n) = (100, 50, 3);
        let mut values = Vec::new();
        for p in 0..cols * rows {
            let x = p % cols;
            for b in 0..n {
                let z = ((x * 255 / cols) as f32 * [0.5, 1.0, 2.0][b]).min(255.0) as u16;
                values.push(z);
            }
        }
        let lattice = Lattice {
            samples: SampleSet {
                levels: 256,
                brackets: n,
                channels: 1,
                values,
            },
            cols,
            rows,
        };
        let s = choose_samples(&lattice, 100, &[SignalRange::FULL]);
        assert_eq!(s.len(), 100);
        // Intensities in the middle bracket cover the range.
        let mids: Vec<u16> = (0..100).map(|i| s.values[i * n + 1]).collect();
        assert!(*mids.iter().min().unwrap() < 20 && *mids.iter().max().unwrap() > 230);
    }
}
