//! Synthetic HDR scenes and simulated bracketed photos, for tests and for
//! `plsr bench hdr`.
//!
//! [`SyntheticScene::radiance`] is a deterministic function of the pixel, so
//! the truth never has to be held in memory: smooth gradients spanning about
//! five decades (≈ 5·10⁻⁴ to 50), a few "sun" discs far above what the
//! shortest exposure can hold (10⁴) and a few dark spots below what the
//! longest one can see (10⁻⁷). [`CameraModel`] turns radiance × exposure time
//! into pixel values through a known non-linear response with shot and read
//! noise, clipping and quantisation.

use super::oiio::{AttrValue, Attribute, ImageReader, ImageWriter, PixelType};
use crate::error::{Error, NoExposurePlan, Result};
use plsr_base::rng::{mix64, Rng};
use plsr_base::Vocabulary;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::path::{Path, PathBuf};

/// The exposure times of the paper's capture, in seconds (DESIGN.md).
pub const PAPER_EXPOSURES: [f64; 10] = [
    1.0 / 30.0,
    1.0 / 15.0,
    1.0 / 8.0,
    1.0 / 4.0,
    1.0 / 2.0,
    1.0,
    2.0,
    4.0,
    8.0,
    15.0,
];

/// Radiance of the "sun" pixels (relative units: pixel value per second).
pub const SUN_RADIANCE: f32 = 1.0e4;
/// Radiance of the very dark pixels.
pub const DARK_RADIANCE: f32 = 1.0e-7;

/// A synthetic HDR image of `width`×`height` pixels (RGB, linear).
#[derive(Debug, Clone, Copy)]
pub struct SyntheticScene {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Modulate the gradient by a checkerboard of ±40 % (sharp edges in
    /// both directions, for alignment tests).
    pub checker: bool,
}

/// What kind of pixel a scene pixel is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PixelKind {
    /// Part of the smooth gradient.
    Gradient,
    /// A sun pixel (saturated in every exposure).
    Sun,
    /// A dark pixel (black in every exposure).
    Dark,
}

impl SyntheticScene {
    /// The scene at the given size.
    pub fn new(width: usize, height: usize) -> SyntheticScene {
        SyntheticScene {
            width,
            height,
            checker: false,
        }
    }

    /// The scene with a checkerboard texture of 12-pixel squares.
    pub fn textured(width: usize, height: usize) -> SyntheticScene {
        SyntheticScene {
            checker: true,
            ..SyntheticScene::new(width, height)
        }
    }

    /// Centres of the sun discs, of the dark discs, and their radius (pixels).
    #[allow(clippy::type_complexity)]
    fn discs(&self) -> (Vec<(f32, f32)>, Vec<(f32, f32)>, f32) {
        let r = (self.width as f32 / 80.0).max(1.6);
        let w = self.width as f32;
        let h = self.height as f32;
        (
            vec![(0.82 * w, 0.28 * h), (0.55 * w, 0.7 * h)],
            vec![(0.12 * w, 0.72 * h), (0.3 * w, 0.2 * h)],
            r,
        )
    }

    /// What pixel `(x, y)` is.
    pub fn kind(&self, x: usize, y: usize) -> PixelKind {
        let (suns, darks, r) = self.discs();
        let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
        let inside = |c: &(f32, f32)| (px - c.0).powi(2) + (py - c.1).powi(2) <= r * r;
        if suns.iter().any(inside) {
            PixelKind::Sun
        } else if darks.iter().any(inside) {
            PixelKind::Dark
        } else {
            PixelKind::Gradient
        }
    }

    /// The true radiance of pixel `(x, y)` (relative units: a pixel with
    /// radiance L exposed for t seconds receives exposure L·t, and exposure 1
    /// is where the simulated camera clips).
    pub fn radiance(&self, x: usize, y: usize) -> [f32; 3] {
        match self.kind(x, y) {
            PixelKind::Sun => return [SUN_RADIANCE, 0.95 * SUN_RADIANCE, 0.9 * SUN_RADIANCE],
            PixelKind::Dark => return [DARK_RADIANCE; 3],
            PixelKind::Gradient => {}
        }
        let u = (x as f32 + 0.5) / self.width as f32;
        let v = (y as f32 + 0.5) / self.height as f32;
        // Five decades along x, a gentle wave along y, colour variations.
        let l = 10f32.powf(-3.3 + 5.0 * u + 0.25 * (2.0 * PI * 2.0 * v).sin())
            * (1.0 + 0.3 * (2.0 * PI * 9.0 * u).sin() * (2.0 * PI * 5.0 * v).sin())
            * if self.checker && ((x / 12) + (y / 12)) % 2 == 1 {
                0.6
            } else {
                1.0
            };
        [
            l * (0.75 + 0.2 * (2.0 * PI * v).sin()),
            l * (0.85 + 0.1 * (2.0 * PI * (u + 2.0 * v)).cos()),
            l * (0.7 + 0.25 * (2.0 * PI * (3.0 * u - v)).sin()),
        ]
    }
}

/// A simulated camera: exposure `X = L·t` (plus noise) → pixel value
/// `f(X)` clipped to [0, 1] and quantised to `bits`. Exposures below the
/// black level map to 0 (as in-camera processing crushes the noise floor).
#[derive(Debug, Clone, Copy)]
pub struct CameraModel {
    /// Response shape: `None` is linear (a raw camera), `Some(a)` the
    /// filmic curve `f(X) = (1 + a)·X^(1/2.2) / (X^(1/2.2) + a)`, which
    /// reaches 1 at X = 1; applied to `(X − black) / (1 − black)`.
    pub filmic: Option<f32>,
    /// Black level in exposure units (0 for a raw camera).
    pub black: f32,
    /// Standard deviation of the additive read noise, in exposure units.
    pub read_noise: f32,
    /// Shot noise: standard deviation `shot_noise·√X`.
    pub shot_noise: f32,
    /// Output bits (8 or 16).
    pub bits: u32,
    /// Noise seed.
    pub seed: u64,
}

impl Default for CameraModel {
    fn default() -> Self {
        CameraModel {
            filmic: Some(0.4),
            black: 1e-3,
            read_noise: 2e-4,
            shot_noise: 4e-3,
            bits: 8,
            seed: 7,
        }
    }
}

impl CameraModel {
    /// A linear (raw-like) camera with the default noise.
    pub fn linear() -> CameraModel {
        CameraModel {
            filmic: None,
            black: 0.0,
            ..CameraModel::default()
        }
    }

    /// The true response: exposure → normalised pixel value before clipping.
    pub fn response(&self, x: f32) -> f32 {
        let b = self.black.clamp(0.0, 0.5);
        let x = ((x - b) / (1.0 - b)).max(0.0);
        match self.filmic {
            None => x,
            Some(a) => {
                let p = x.powf(1.0 / 2.2);
                (1.0 + a) * p / (p + a)
            }
        }
    }

    /// The inverse of [`CameraModel::response`] for a value in [0, 1]:
    /// the exposure that produces it.
    pub fn inverse_response(&self, v: f32) -> f32 {
        let v = v.clamp(0.0, 1.0);
        let b = self.black.clamp(0.0, 0.5);
        let x = match self.filmic {
            None => v,
            Some(a) => {
                // v (p + a) = (1 + a) p  →  p = a v / (1 + a − v)
                let p = a * v / (1.0 + a - v);
                p.powf(2.2)
            }
        };
        b + (1.0 - b) * x
    }

    fn max_level(&self) -> f32 {
        ((1u64 << self.bits.clamp(1, 16)) - 1) as f32
    }

    /// Pixel levels of one noisy exposure of radiance `l` for `t` seconds.
    fn expose(&self, l: [f32; 3], t: f32, rng: &mut Rng) -> [u32; 3] {
        let m = self.max_level();
        let mut out = [0u32; 3];
        for c in 0..3 {
            let x = l[c] * t;
            let (n1, n2) = gaussian_pair(rng);
            let noisy = x + self.read_noise * n1 + self.shot_noise * x.max(0.0).sqrt() * n2;
            let v = self.response(noisy).clamp(0.0, 1.0);
            out[c] = (v * m).round() as u32;
        }
        out
    }
}

fn gaussian_pair(rng: &mut Rng) -> (f32, f32) {
    let u1 = rng.next_f32().max(1e-7);
    let u2 = rng.next_f32();
    let r = (-2.0 * u1.ln()).sqrt();
    (r * (2.0 * PI * u2).cos(), r * (2.0 * PI * u2).sin())
}

/// A linear radiance image the simulated camera photographs.
pub trait RadianceImage: Sync {
    /// Width and height in pixels.
    fn size(&self) -> (usize, usize);
    /// Linear RGB radiance of pixel `(x, y)` (row 0 at the top).
    fn radiance(&self, x: usize, y: usize) -> [f32; 3];
}

impl RadianceImage for SyntheticScene {
    fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }
    fn radiance(&self, x: usize, y: usize) -> [f32; 3] {
        SyntheticScene::radiance(self, x, y)
    }
}

/// A dark interior, the hard case for alignment: textured walls, floor, a
/// picture and a sofa at about 2·10⁻⁴ to 3·10⁻³ (black or noise in the
/// shorter exposures, never clipped), brightened around a window by up to
/// 60× (clipped in the longest exposures). With `window`, the window shows
/// a dark cross frame against a sky of 10 to 40 and trees of 1 to 6
/// (clipped in all but the shortest exposures); without it, the wall goes
/// on and the room is lit only by a faint glow (4× at most), so that in the
/// paper's exposures the four shortest are almost all black and noise.
/// Every region has edges in both directions. No sun or dark discs.
#[derive(Debug, Clone, Copy)]
pub struct DarkRoom {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Whether the bright window is there.
    pub window: bool,
}

impl DarkRoom {
    /// The room with its window, at the given size.
    pub fn new(width: usize, height: usize) -> DarkRoom {
        DarkRoom {
            width,
            height,
            window: true,
        }
    }

    /// The room without its window: dark everywhere.
    pub fn windowless(width: usize, height: usize) -> DarkRoom {
        DarkRoom {
            window: false,
            ..DarkRoom::new(width, height)
        }
    }
}

impl RadianceImage for DarkRoom {
    fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    fn radiance(&self, x: usize, y: usize) -> [f32; 3] {
        let u = (x as f32 + 0.5) / self.width as f32;
        let v = (y as f32 + 0.5) / self.height as f32;
        let aspect = self.width as f32 / self.height as f32;
        let square = |t: f32| if t.sin() >= 0.0 { 1.0 } else { -1.0 };
        let (u0, u1, v0, v1) = (0.58, 0.86, 0.16, 0.62);
        let (l, tint) = if self.window && (u0..u1).contains(&u) && (v0..v1).contains(&v) {
            let fu = (u - u0) / (u1 - u0);
            let fv = (v - v0) / (v1 - v0);
            let bar = |f: f32, at: f32| (f - at).abs() < 0.035;
            if bar(fu, 0.5)
                || bar(fv, 0.42)
                || !(0.04..=0.96).contains(&fu)
                || !(0.05..=0.95).contains(&fv)
            {
                // The frame, lit a little from outside.
                (0.06 * (1.0 + 0.3 * fv), [1.0, 0.9, 0.8])
            } else if fv < 0.6 + 0.08 * (2.0 * PI * 3.0 * fu).sin() {
                // Sky with clouds.
                let clouds = 0.5
                    + 0.5 * (2.0 * PI * (2.5 * fu + 0.7 * fv)).sin() * (2.0 * PI * 3.5 * fv).cos();
                (10.0 + 30.0 * fv * clouds, [0.8, 0.9, 1.1])
            } else {
                // Trees.
                let leaves = 1.0 + 0.5 * square(2.0 * PI * 9.0 * fu) * square(2.0 * PI * 7.0 * fv);
                (1.2 + 3.0 * (1.0 - fv) * leaves, [0.6, 1.0, 0.5])
            }
        } else {
            // Light around the window (or a faint glow), falling off.
            let (du, dv) = ((u - 0.72) * aspect, v - 0.39);
            let (base, glow, spread) = if self.window {
                (0.003, 60.0, 0.08)
            } else {
                (0.002, 3.0, 0.02)
            };
            let spill = 1.0 + glow * (-(du * du + dv * dv) / spread).exp();
            let (l, tint) = if (0.08..0.42).contains(&u) && (0.55..0.82).contains(&v) {
                // A dark sofa with cushions.
                let c = if ((u - 0.08) / 0.085) as i32 % 2 == 0 {
                    1.0
                } else {
                    0.6
                };
                (0.067 * c, [0.9, 0.6, 0.5])
            } else if v > 0.8 {
                // Floor boards.
                let board = 1.0 + 0.35 * square(2.0 * PI * 11.0 * v * v);
                let joint = if (u * 7.0 + 0.5 * ((v * 20.0) as i32 % 2) as f32).fract() < 0.04 {
                    0.4
                } else {
                    1.0
                };
                (0.4 * board * joint, [1.0, 0.8, 0.6])
            } else if (0.14..0.34).contains(&u) && (0.14..0.42).contains(&v) {
                // A picture on the wall.
                let p = 1.0
                    + 0.6 * (2.0 * PI * 4.0 * u).sin() * (2.0 * PI * 6.0 * v).cos()
                    + 0.3 * square(2.0 * PI * 15.0 * (u + v));
                (0.67 * p.max(0.1), [1.0, 0.8, 0.9])
            } else {
                // Striped wallpaper.
                let stripes = 1.0
                    + 0.4 * square(2.0 * PI * 16.0 * u) * (0.6 + 0.4 * (2.0 * PI * 5.0 * v).cos());
                (stripes, [0.95, 0.9, 0.8])
            };
            (base * l * spill, tint)
        };
        [l * tint[0], l * tint[1], l * tint[2]]
    }
}

/// Exposure times chosen from an image's dynamic range by
/// [`auto_exposures`].
#[derive(Debug, Clone, PartialEq)]
pub struct ExposurePlan {
    /// Exposure times in seconds, shortest first.
    pub times: Vec<f64>,
    /// The radiance the shortest exposure keeps below clipping: the largest
    /// channel, ignoring the brightest [`AUTO_IGNORED_BRIGHT`] of the pixels
    /// (relative units, as the image's).
    pub brightest: f32,
    /// The radiance the longest exposure puts at mid-range: the largest
    /// channel at the [`AUTO_DARK_QUANTILE`] of the pixels that are not
    /// black.
    pub darkest: f32,
    /// Stops between neighbouring exposures.
    pub step_stops: f64,
}

/// Fraction of the pixels [`auto_exposures`] lets clip (path-tracing
/// fireflies, specks): 10⁻⁵, five pixels of a 1024×512 panorama.
pub const AUTO_IGNORED_BRIGHT: f64 = 1e-5;
/// Quantile of the non-black pixels that [`auto_exposures`] exposes to
/// mid-range in its longest exposure.
pub const AUTO_DARK_QUANTILE: f64 = 0.01;
/// Largest step between neighbouring exposures of [`auto_exposures`], in
/// stops (unless [`AUTO_MAX_BRACKETS`] forces a larger one).
pub const AUTO_MAX_STEP_STOPS: f64 = 2.0;
/// Most exposures [`auto_exposures`] chooses.
pub const AUTO_MAX_BRACKETS: usize = 16;
/// Fewest exposures [`auto_exposures`] chooses (a response curve needs
/// several).
pub const AUTO_MIN_BRACKETS: usize = 3;
/// Normalised pixel value of the brightest radiance in the shortest
/// exposure (a margin below clipping for noise).
pub const AUTO_HIGH_VALUE: f32 = 0.95;
/// Normalised pixel value of the darkest radiance in the longest exposure.
pub const AUTO_LOW_VALUE: f32 = 0.5;

/// Exposure times that record `image` through `camera` from its brightest
/// to its darkest parts: the shortest puts the brightest radiance at
/// [`AUTO_HIGH_VALUE`] (just below clipping, which is at radiance × time =
/// 1 through the response), the longest puts the darkest at
/// [`AUTO_LOW_VALUE`], and the times between are evenly spaced in stops,
/// at most [`AUTO_MAX_STEP_STOPS`] apart, [`AUTO_MIN_BRACKETS`] to
/// [`AUTO_MAX_BRACKETS`] of them. A narrow range is widened evenly on
/// both sides to the smallest stack. Pixels that are black (0), not
/// finite, or among the brightest [`AUTO_IGNORED_BRIGHT`] are ignored. An
/// error names the fault when no pixel has light.
pub fn auto_exposures<S: RadianceImage + ?Sized>(
    image: &S,
    camera: &CameraModel,
) -> std::result::Result<ExposurePlan, NoExposurePlan> {
    let (w, h) = image.size();
    let mut peaks: Vec<f32> = (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            (0..w).map(move |x| {
                let c = image.radiance(x, y);
                c[0].max(c[1]).max(c[2])
            })
        })
        .filter(|m| m.is_finite() && *m > 0.0)
        .collect();
    let n = peaks.len();
    if n == 0 {
        return Err(NoExposurePlan::NoLight);
    }
    let bright_rank = n - 1 - ((n as f64 * AUTO_IGNORED_BRIGHT) as usize).min(n - 1);
    let (_, &mut brightest, _) = peaks.select_nth_unstable_by(bright_rank, f32::total_cmp);
    let dark_rank = ((n as f64 * AUTO_DARK_QUANTILE) as usize).min(bright_rank);
    let (_, &mut darkest, _) =
        peaks[..=bright_rank].select_nth_unstable_by(dark_rank, f32::total_cmp);
    let shortest = camera.inverse_response(AUTO_HIGH_VALUE) as f64 / brightest as f64;
    let longest = camera.inverse_response(AUTO_LOW_VALUE) as f64 / darkest as f64;
    // Span in stops, widened evenly to the smallest stack.
    let min_span = (AUTO_MIN_BRACKETS - 1) as f64 * AUTO_MAX_STEP_STOPS;
    let mut span = (longest / shortest).log2();
    let mut first = shortest;
    if span < min_span {
        first = shortest / 2f64.powf(0.5 * (min_span - span));
        span = min_span;
    }
    let count = ((span / AUTO_MAX_STEP_STOPS - 1e-9).ceil() as usize + 1)
        .clamp(AUTO_MIN_BRACKETS, AUTO_MAX_BRACKETS);
    let step = span / (count - 1) as f64;
    Ok(ExposurePlan {
        times: (0..count)
            .map(|i| first * 2f64.powf(step * i as f64))
            .collect(),
        brightest,
        darkest,
        step_stops: step,
    })
}

/// Options for [`write_brackets`].
#[derive(Debug, Clone)]
pub struct BracketOptions {
    /// File extension (format), e.g. `"tif"`, `"png"`, `"jpg"`.
    pub extension: String,
    /// Write ExposureTime / FNumber / ISO into the EXIF metadata.
    pub exif: bool,
    /// f-number written to EXIF (and used in the simulation as a factor
    /// `(f_ref / N)²` with `f_ref` the first value), one per bracket or empty.
    pub f_numbers: Vec<f64>,
    /// ISO written to EXIF (simulation factor `ISO / ISO_first`), one per
    /// bracket or empty.
    pub isos: Vec<f64>,
    /// Extra header attributes (e.g. `("compression", "none")`).
    pub attributes: Vec<Attribute>,
    /// Camera shake: bracket `i` shows the scene moved by `shifts[i]`
    /// pixels (its pixel `(x, y)` sees the scene at `(x − dx, y − dy)`,
    /// clamped at the borders); none if empty.
    pub shifts: Vec<(i32, i32)>,
}

impl Default for BracketOptions {
    fn default() -> Self {
        BracketOptions {
            extension: "tif".into(),
            exif: true,
            f_numbers: Vec::new(),
            isos: Vec::new(),
            attributes: Vec::new(),
            shifts: Vec::new(),
        }
    }
}

/// Rows simulated per band when writing brackets (bounded memory).
const BAND: usize = 64;

/// Simulates one photo per exposure time `times[i]` (seconds) of `scene`
/// through `camera` and writes them as `dir/bracket_NN.<ext>` (8- or 16-bit
/// by `camera.bits`), streaming rows, in parallel over rows. Returns the
/// paths in the order of `times`.
pub fn write_brackets<S: RadianceImage + ?Sized>(
    scene: &S,
    camera: &CameraModel,
    times: &[f64],
    dir: &Path,
    options: &BracketOptions,
) -> Result<Vec<PathBuf>> {
    let mut paths = Vec::new();
    let (w, height) = scene.size();
    for (i, &t) in times.iter().enumerate() {
        let path = dir.join(format!("bracket_{i:02}.{}", options.extension));
        let n = options.f_numbers.get(i).copied();
        let iso = options.isos.get(i).copied();
        let mut factor = 1.0;
        if let (Some(n), Some(n0)) = (n, options.f_numbers.first()) {
            factor *= (n0 / n).powi(2);
        }
        if let (Some(iso), Some(iso0)) = (iso, options.isos.first()) {
            factor *= iso / iso0;
        }
        let mut attrs = options.attributes.clone();
        if options.exif {
            attrs.push(("ExposureTime".into(), AttrValue::Float(t as f32)));
            attrs.push(("FNumber".into(), AttrValue::Float(n.unwrap_or(8.0) as f32)));
            attrs.push((
                "Exif:ISOSpeedRatings".into(),
                AttrValue::Int(iso.unwrap_or(100.0) as i32),
            ));
        }
        let stored = if camera.bits > 8 {
            PixelType::U16
        } else {
            PixelType::U8
        };
        let mut writer = ImageWriter::create(&path, w, height, 3, stored, &attrs)?;
        let te = (t * factor) as f32;
        let seed = mix64(camera.seed ^ mix64(i as u64 + 1));
        let (dx, dy) = options.shifts.get(i).copied().unwrap_or((0, 0));
        let (wi, hi) = (w as i64, height as i64);
        let at = |x: usize, y: usize| {
            let sx = (x as i64 - dx as i64).clamp(0, wi - 1) as usize;
            let sy = (y as i64 - dy as i64).clamp(0, hi - 1) as usize;
            scene.radiance(sx, sy)
        };
        let mut y0 = 0;
        while y0 < height {
            let y1 = (y0 + BAND).min(height);
            let mut levels = vec![0u32; (y1 - y0) * w * 3];
            levels
                .par_chunks_mut(w * 3)
                .enumerate()
                .for_each(|(r, row)| {
                    let y = y0 + r;
                    let mut rng = Rng::new(seed, y as u64);
                    for x in 0..w {
                        let z = camera.expose(at(x, y), te, &mut rng);
                        row[x * 3..x * 3 + 3].copy_from_slice(&z);
                    }
                });
            if stored == PixelType::U16 {
                let v: Vec<u16> = levels.iter().map(|z| *z as u16).collect();
                writer.write_rows(y0, y1, &v)?;
            } else {
                let v: Vec<u8> = levels.iter().map(|z| *z as u8).collect();
                writer.write_rows(y0, y1, &v)?;
            }
            y0 = y1;
        }
        writer.finish()?;
        paths.push(path);
    }
    Ok(paths)
}

/// Accuracy of a merged image against the synthetic truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Accuracy {
    /// RMS of `ln(merged) − ln(truth)` after removing the best global
    /// offset (the best global scale), over the recoverable pixels and
    /// all channels.
    pub log_rmse: f64,
    /// The best global scale `merged ≈ scale · truth`.
    pub scale: f64,
    /// Number of channel values compared.
    pub count: u64,
    /// Values that were not finite or not positive among all pixels.
    pub bad_values: u64,
}

/// Whether a true radiance value is recoverable from `times` through
/// `camera`: some exposure puts it well inside the camera's range (between
/// 2 and 253 levels of 255, noise-free).
pub fn recoverable(camera: &CameraModel, l: f32, times: &[f64]) -> bool {
    times.iter().any(|&t| {
        let v = camera.response(l * t as f32);
        (2.0 / 255.0..=253.0 / 255.0).contains(&v)
    })
}

/// Compares the image at `path` (read through OpenImageIO, streamed by
/// rows; first three channels) with the scene's truth over the pixels
/// recoverable with `times` (see [`recoverable`]).
pub fn accuracy<S: RadianceImage + ?Sized>(
    path: &Path,
    scene: &S,
    camera: &CameraModel,
    times: &[f64],
) -> Result<Accuracy> {
    let mut r = ImageReader::open(path)?;
    let info = r.info().clone();
    let (width, height) = scene.size();
    // A merge cropped to the brackets' common area says where it lies in
    // the frame (`plsr:crop`, "x0 y0 x1 y1 of WxH").
    let (ox, oy, width, height) = match r.string_attribute("plsr:crop") {
        None => (0, 0, width, height),
        Some(c) => {
            let v: Vec<usize> = c
                .split_whitespace()
                .take(4)
                .filter_map(|t| t.parse().ok())
                .collect();
            match v[..] {
                [x0, y0, x1, y1] if x0 < x1 && y0 < y1 && x1 <= width && y1 <= height => {
                    (x0, y0, x1 - x0, y1 - y0)
                }
                _ => {
                    return Err(Error::input(
                        path,
                        "plsr:crop",
                        format!("`{c}` is not a window of the {width}×{height} frame"),
                    ))
                }
            }
        }
    };
    if info.width != width || info.height != height || info.channels < 3 {
        return Err(Error::input(
            path,
            "",
            format!(
                "expected {}×{} RGB, found {}×{}×{}",
                width, height, info.width, info.height, info.channels
            ),
        ));
    }
    let (w, ch) = (info.width, info.channels);
    let (mut s1, mut s2, mut n, mut bad) = (0f64, 0f64, 0u64, 0u64);
    let mut y0 = 0;
    while y0 < info.height {
        let y1 = (y0 + BAND).min(info.height);
        let mut buf = vec![0f32; (y1 - y0) * w * ch];
        r.read_rows(y0, y1, &mut buf)?;
        let parts: Vec<(f64, f64, u64, u64)> = buf
            .par_chunks(w * ch)
            .enumerate()
            .map(|(k, row)| {
                let y = y0 + k;
                let (mut a, mut b, mut m, mut bd) = (0f64, 0f64, 0u64, 0u64);
                for x in 0..w {
                    let truth = scene.radiance(x + ox, y + oy);
                    for c in 0..3 {
                        let v = row[x * ch + c];
                        if !(v.is_finite() && v > 0.0) {
                            bd += 1;
                            continue;
                        }
                        if !recoverable(camera, truth[c], times) {
                            continue;
                        }
                        let d = (v as f64).ln() - (truth[c] as f64).ln();
                        a += d;
                        b += d * d;
                        m += 1;
                    }
                }
                (a, b, m, bd)
            })
            .collect();
        for (a, b, m, bd) in parts {
            s1 += a;
            s2 += b;
            n += m;
            bad += bd;
        }
        y0 = y1;
    }
    if n == 0 {
        return Err(Error::input(path, "", "no recoverable pixels to compare"));
    }
    let mean = s1 / n as f64;
    Ok(Accuracy {
        log_rmse: (s2 / n as f64 - mean * mean).max(0.0).sqrt(),
        scale: mean.exp(),
        count: n,
        bad_values: bad,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An image given by a function of the pixel.
    struct Image<F: Fn(usize, usize) -> f32 + Sync>(usize, usize, F);

    impl<F: Fn(usize, usize) -> f32 + Sync> RadianceImage for Image<F> {
        fn size(&self) -> (usize, usize) {
            (self.0, self.1)
        }
        fn radiance(&self, x: usize, y: usize) -> [f32; 3] {
            let l = (self.2)(x, y);
            [l, 0.5 * l, 0.25 * l]
        }
    }

    #[test]
    fn auto_exposures_cover_the_scene_from_its_suns_to_its_shadows() {
        let scene = SyntheticScene::textured(256, 128);
        let camera = CameraModel::default();
        let plan = auto_exposures(&scene, &camera).unwrap();
        let t = &plan.times;
        // The suns (0.2 % of the pixels, far above 10⁻⁵) are the brightest.
        assert_eq!(plan.brightest, SUN_RADIANCE);
        // Nothing clips in the shortest exposure: the brightest pixel lands
        // at AUTO_HIGH_VALUE.
        let v = camera.response(plan.brightest * t[0] as f32);
        assert!((v - AUTO_HIGH_VALUE).abs() < 1e-4, "{v}");
        // The darkest lands at mid-range in the longest.
        let v = camera.response(plan.darkest * *t.last().unwrap() as f32);
        assert!((v - AUTO_LOW_VALUE).abs() < 1e-4, "{v}");
        // Evenly spaced, at most two stops apart.
        assert!((AUTO_MIN_BRACKETS..=AUTO_MAX_BRACKETS).contains(&t.len()));
        for pair in t.windows(2) {
            let stops = (pair[1] / pair[0]).log2();
            assert!((stops - plan.step_stops).abs() < 1e-9);
            assert!(stops <= AUTO_MAX_STEP_STOPS + 1e-9, "{stops}");
        }
        // Every channel of 98 % of the pixels is recorded well inside the
        // camera's range by some exposure; with the paper's times, whose
        // shortest clips at radiance 30, the suns are not.
        let recorded = |times: &[f64]| {
            let mut ok = 0;
            for y in 0..scene.height {
                for x in 0..scene.width {
                    let c = scene.radiance(x, y);
                    ok += c.iter().all(|&l| recoverable(&camera, l, times)) as usize;
                }
            }
            ok as f64 / (scene.width * scene.height) as f64
        };
        assert!(recorded(t) > 0.98, "{}", recorded(t));
        assert!(!recoverable(&camera, SUN_RADIANCE, &PAPER_EXPOSURES));
        assert!(recoverable(&camera, SUN_RADIANCE, t));
    }

    #[test]
    fn auto_exposures_ignore_specks_and_widen_narrow_ranges() {
        let camera = CameraModel::linear();
        // Flat grey: the smallest stack, two stops apart, centred on it.
        let flat = Image(64, 32, |_, _| 0.3);
        let plan = auto_exposures(&flat, &camera).unwrap();
        assert_eq!(plan.times.len(), AUTO_MIN_BRACKETS);
        assert!((plan.step_stops - AUTO_MAX_STEP_STOPS).abs() < 1e-9);
        let (lo, hi): (f64, f64) = (0.95 / 0.3, 0.5 / 0.3);
        let centre = (plan.times[0] * plan.times[2]).sqrt();
        assert!((centre / (lo * hi).sqrt() - 1.0).abs() < 1e-6);
        // One firefly in 10⁶ pixels does not set the shortest exposure.
        let speck = Image(1000, 1000, |x, y| {
            if (x, y) == (5, 7) {
                1e6
            } else {
                1.0 + (x % 7) as f32
            }
        });
        let plan = auto_exposures(&speck, &camera).unwrap();
        assert_eq!(plan.brightest, 7.0);
        // Forty decades: capped at the most brackets, with larger steps.
        let huge = Image(100, 100, |x, _| 10f32.powf(-18.0 + 0.36 * x as f32));
        let plan = auto_exposures(&huge, &camera).unwrap();
        assert_eq!(plan.times.len(), AUTO_MAX_BRACKETS);
        assert!(plan.step_stops > AUTO_MAX_STEP_STOPS);
        // Black (and not-finite) pixels only: an error.
        let black = Image(8, 8, |x, _| if x == 0 { f32::NAN } else { 0.0 });
        let e = auto_exposures(&black, &camera).unwrap_err();
        assert!(e.to_string().contains("no light"), "{e}");
    }
}
