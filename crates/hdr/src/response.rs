//! Camera response curves: recovery from bracketed samples and presets.
//!
//! A [`ResponseCurve`] is stored as the *inverse* response per channel: for
//! each pixel level `z` of its domain (256 levels for 8-bit input, a binned
//! domain of [`BINNED_LEVELS`] levels for 16-bit and float input) the
//! relative linear exposure `I(z)` (irradiance × time, arbitrary units) that
//! produces it. Pixel values are handled normalised, `v = z / (levels − 1)`
//! in [0, 1], so one curve serves any bit depth; between levels the curve is
//! interpolated linearly.
//!
//! Methods:
//! - Debevec & Malik 1997: least squares for `g = ln I` with a smoothness
//!   term weighted by λ and hat weights, solved per channel (dense normal
//!   equations, the per-sample unknowns eliminated by a Schur complement,
//!   Cholesky in f64);
//! - Robertson, Borman & Stevenson 2003: alternating estimates of the
//!   irradiances and of `I(z)` until the curve stops changing;
//! - `linear` (raw data: `I(v) = v`) and `srgb` (the sRGB transfer function).
//!
//! Recovered curves are normalised so that the middle level maps to the
//! exposure a linear curve gives it (≈ 0.5), per channel: a mid-grey pixel
//! stays neutral.

use crate::error::{Error, Result, UnknownResponseMethod};
use crate::levels::SignalRange;
use plsr_base::Vocabulary;
use rayon::prelude::*;
use std::fmt;
use std::io::Write;
use std::path::Path;
use std::str::FromStr;

/// Levels of the binned domain used to recover curves for 16-bit and float
/// inputs.
pub const BINNED_LEVELS: usize = 1024;

/// Default smoothness weight λ of Debevec–Malik (for weights on the 8-bit
/// scale, 0–127.5).
pub const DEFAULT_LAMBDA: f64 = 20.0;

/// How the camera response is obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResponseMethod {
    /// Debevec & Malik 1997 least squares.
    Debevec,
    /// Robertson et al. 2003 iterative estimate.
    Robertson,
    /// Linear (raw or already linear data).
    Linear,
    /// The sRGB transfer function.
    Srgb,
    /// A curve read from a file (`--response-curve`): one camera's
    /// calibration reused for its later stacks.
    Given,
}

impl ResponseMethod {
    /// Whether the curve is recovered from the images (rather than a preset).
    pub fn is_recovered(self) -> bool {
        matches!(self, ResponseMethod::Debevec | ResponseMethod::Robertson)
    }
}

impl fmt::Display for ResponseMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ResponseMethod::Debevec => "debevec",
            ResponseMethod::Robertson => "robertson",
            ResponseMethod::Linear => "linear",
            ResponseMethod::Srgb => "srgb",
            ResponseMethod::Given => "given",
        })
    }
}

impl FromStr for ResponseMethod {
    type Err = UnknownResponseMethod;
    fn from_str(s: &str) -> std::result::Result<Self, UnknownResponseMethod> {
        match s.to_ascii_lowercase().as_str() {
            "debevec" => Ok(ResponseMethod::Debevec),
            "robertson" => Ok(ResponseMethod::Robertson),
            "linear" => Ok(ResponseMethod::Linear),
            "srgb" => Ok(ResponseMethod::Srgb),
            _ => Err(UnknownResponseMethod(s.into())),
        }
    }
}

/// The hat weight of a normalised pixel value `v` ∈ [0, 1]: `1 − |2v − 1|`,
/// zero at both clip limits (and outside [0, 1]), one at mid-range.
#[inline]
pub fn hat(v: f32) -> f32 {
    if v.is_finite() {
        (1.0 - (2.0 * v - 1.0).abs()).max(0.0)
    } else {
        0.0
    }
}

/// The sRGB decoding function (encoded value in [0, 1] → linear).
#[inline]
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// An inverse camera response per channel.
#[derive(Debug, Clone, PartialEq)]
pub struct ResponseCurve {
    /// How it was obtained.
    pub method: ResponseMethod,
    /// Per channel, the relative linear exposure `I` of each level (all
    /// channels have the same number of levels, at least 2); non-decreasing
    /// and positive except possibly at level 0.
    pub inverse: Vec<Vec<f32>>,
}

impl ResponseCurve {
    /// The linear preset on `levels` levels: `I(v) = v`.
    pub fn linear(levels: usize, channels: usize) -> ResponseCurve {
        let l = levels.max(2);
        let c: Vec<f32> = (0..l).map(|z| z as f32 / (l - 1) as f32).collect();
        ResponseCurve {
            method: ResponseMethod::Linear,
            inverse: vec![c; channels.max(1)],
        }
    }

    /// The sRGB preset on `levels` levels.
    pub fn srgb(levels: usize, channels: usize) -> ResponseCurve {
        let l = levels.max(2);
        let c: Vec<f32> = (0..l)
            .map(|z| srgb_to_linear(z as f32 / (l - 1) as f32))
            .collect();
        ResponseCurve {
            method: ResponseMethod::Srgb,
            inverse: vec![c; channels.max(1)],
        }
    }

    /// Number of levels of the domain.
    pub fn levels(&self) -> usize {
        self.inverse.first().map_or(0, Vec::len)
    }

    /// Number of channels.
    pub fn channels(&self) -> usize {
        self.inverse.len()
    }

    /// The relative exposure for normalised pixel value `v` ∈ [0, 1] in
    /// channel `c` (clamped to the domain), exact for the presets and
    /// linearly interpolated between levels for recovered curves.
    #[inline]
    pub fn eval(&self, c: usize, v: f32) -> f32 {
        let v = if v.is_finite() {
            v.clamp(0.0, 1.0)
        } else {
            0.0
        };
        match self.method {
            ResponseMethod::Linear => v,
            ResponseMethod::Srgb => srgb_to_linear(v),
            _ => {
                let t = &self.inverse[c.min(self.inverse.len() - 1)];
                let x = v * (t.len() - 1) as f32;
                let i = (x as usize).min(t.len() - 2);
                let f = x - i as f32;
                t[i] * (1.0 - f) + t[i + 1] * f
            }
        }
    }

    /// The curve as a compact header string: one line per channel of
    /// space-separated exposures, level 0 first.
    pub fn to_header_string(&self) -> String {
        self.inverse
            .iter()
            .map(|c| {
                c.iter()
                    .map(|v| format!("{v:.6e}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            })
            .collect::<Vec<_>>()
            .join("\n")
    }

    /// Reads a curve written by [`ResponseCurve::write_csv`] (`plsr hdr
    /// merge --curve`): comment lines starting with `#`, the header
    /// `level,pixel_value,<channels>`, then one row per level from 0, with
    /// finite, non-negative, non-decreasing exposures. A file without that
    /// header whose rows are three numbers is read as OpenCV's
    /// `CalibrateDebevec`/`CalibrateRobertson` response saved as a 256×3
    /// CSV (`numpy.savetxt(f, response.reshape(-1, 3), delimiter=",")`): one
    /// row per level, in OpenCV's channel order, blue, green, red, made
    /// non-decreasing where OpenCV's solution dips. Errors
    /// name the file and the line. The curve's method is
    /// [`ResponseMethod::Given`].
    pub fn read_csv(path: &Path) -> Result<ResponseCurve> {
        plsr_base::input::check_input_file(path)?;
        let text = std::fs::read_to_string(path)
            .map_err(|source| Error::io(path.to_path_buf(), source))?;
        let fail = |line: usize, m: String| Error::input(path, "", format!("line {line}: {m}"));
        let mut rows = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
        let (header_line, header) = rows
            .next()
            .ok_or_else(|| Error::input(path, "", "empty: no header `level,pixel_value,…`"))?;
        let names: Vec<&str> = header.split(',').map(str::trim).collect();
        if names.len() == 3 && names.iter().all(|n| n.parse::<f64>().is_ok()) {
            return read_opencv_rows(path, &text);
        }
        if names.len() < 3 || names[0] != "level" || names[1] != "pixel_value" {
            return Err(fail(
                header_line + 1,
                format!("expected the header `level,pixel_value,r,g,b`, got `{header}`"),
            ));
        }
        let channels = names.len() - 2;
        let mut inverse = vec![Vec::new(); channels];
        for (n, row) in rows {
            let cells: Vec<&str> = row.split(',').map(str::trim).collect();
            if cells.len() != names.len() {
                return Err(fail(
                    n + 1,
                    format!("{} values, the header has {}", cells.len(), names.len()),
                ));
            }
            let level = inverse[0].len();
            if cells[0].parse::<usize>().ok() != Some(level) {
                return Err(fail(
                    n + 1,
                    format!("level `{}` where level {level} belongs", cells[0]),
                ));
            }
            for (c, cell) in cells[2..].iter().enumerate() {
                let v: f32 = cell
                    .parse()
                    .map_err(|_| fail(n + 1, format!("`{cell}` is not a number")))?;
                let previous = inverse[c].last().copied().unwrap_or(0.0);
                if !(v.is_finite() && v >= previous) {
                    return Err(fail(
                        n + 1,
                        format!(
                            "exposure {v} of channel {} must be finite and not below the level before ({previous})",
                            names[c + 2]
                        ),
                    ));
                }
                inverse[c].push(v);
            }
        }
        if inverse[0].len() < 2 {
            return Err(Error::input(path, "", "a curve needs at least two levels"));
        }
        Ok(ResponseCurve {
            method: ResponseMethod::Given,
            inverse,
        })
    }

    /// Writes the curve as CSV: `level,pixel_value,<channel 0>,…`, where
    /// `pixel_value` is the normalised value in [0, 1] and the channel
    /// columns (`r,g,b` for three channels) are relative linear exposures.
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        let mut outputs = plsr_base::atomic_write::OutputSet::new();
        self.stage_csv(&mut outputs, path)?;
        Ok(outputs.commit()?)
    }

    /// [`ResponseCurve::write_csv`] into `outputs`, to be committed with
    /// the command's other outputs.
    pub fn stage_csv(
        &self,
        outputs: &mut plsr_base::atomic_write::OutputSet,
        path: &Path,
    ) -> Result<()> {
        let names: Vec<String> = match self.channels() {
            3 => vec!["r".into(), "g".into(), "b".into()],
            1 => vec!["y".into()],
            n => (0..n).map(|c| format!("c{c}")).collect(),
        };
        outputs.stage(path, |w| {
            let io = |source| Error::io(path.to_path_buf(), source);
            writeln!(
                w,
                "# plsr camera response ({}): relative linear exposure per pixel level",
                self.method
            )
            .map_err(io)?;
            writeln!(w, "level,pixel_value,{}", names.join(",")).map_err(io)?;
            let l = self.levels();
            for z in 0..l {
                let vals: Vec<String> = self
                    .inverse
                    .iter()
                    .map(|c| format!("{:.8e}", c[z]))
                    .collect();
                writeln!(w, "{z},{:.6},{}", z as f64 / (l - 1) as f64, vals.join(","))
                    .map_err(io)?;
            }
            Ok(())
        })
    }

    /// Plots the curve to a PNG (`width`×`height` pixels): x is the
    /// normalised pixel value 0–1 (ticks every 0.1), y is log10 of the
    /// relative exposure (ticks every decade), one coloured line per channel
    /// (red, green, blue; grey for one channel).
    pub fn write_plot_png(&self, path: &Path, width: u32, height: u32) -> Result<()> {
        let mut outputs = plsr_base::atomic_write::OutputSet::new();
        self.stage_plot_png(&mut outputs, path, width, height)?;
        Ok(outputs.commit()?)
    }

    /// [`ResponseCurve::write_plot_png`] into `outputs`, to be committed
    /// with the command's other outputs.
    pub fn stage_plot_png(
        &self,
        outputs: &mut plsr_base::atomic_write::OutputSet,
        path: &Path,
        width: u32,
        height: u32,
    ) -> Result<()> {
        Ok(outputs.stage_png(path, &self.plot(width.max(64), height.max(48)))?)
    }

    fn plot(&self, width: u32, height: u32) -> image::RgbImage {
        use plsr_base::text::{draw_text, draw_text_up, line, text_width, GLYPH_HEIGHT};
        let mut img = image::RgbImage::from_pixel(width, height, image::Rgb([255, 255, 255]));
        // Room for the title above, tick labels and axis titles left and below.
        let (l, r, t, b) = (62i32, width as i32 - 14, 34i32, height as i32 - 44);
        // y range: log10 of the positive exposures, whole decades.
        let logs = self
            .inverse
            .iter()
            .flatten()
            .filter(|v| **v > 0.0 && v.is_finite())
            .map(|v| v.log10());
        let (mut lo, mut hi) = logs.fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
        if !lo.is_finite() || !hi.is_finite() {
            lo = -3.0;
            hi = 0.0;
        }
        lo = lo.max(hi - 8.0).floor();
        hi = hi.ceil().max(lo + 1.0);
        let px = |v: f32| l as f32 + v * (r - l) as f32;
        let py = |y: f32| b as f32 - (y - lo) / (hi - lo) * (b - t) as f32;
        let grey = image::Rgb([200, 200, 200]);
        let black = image::Rgb([0, 0, 0]);
        let gh = GLYPH_HEIGHT as i32;
        // Grid, ticks and their labels: pixel value along x, every tenth
        // (labelled every fifth); exposure along y, every decade.
        for k in 0..=10 {
            let x = px(k as f32 / 10.0) as i32;
            line(&mut img, x, t, x, b, grey);
            line(&mut img, x, b, x, b + 6, black);
            if k % 2 == 0 {
                let label = format!("{:.1}", k as f32 / 10.0);
                let lw = text_width(&label, 1) as i32;
                draw_text(&mut img, x - lw / 2, b + 9, &label, 1, black);
            }
        }
        let mut d = lo;
        while d <= hi + 1e-3 {
            let y = py(d) as i32;
            line(&mut img, l, y, r, y, grey);
            line(&mut img, l - 6, y, l, y, black);
            let label = format!("1e{}", d.round() as i32);
            let lw = text_width(&label, 1) as i32;
            draw_text(&mut img, l - 9 - lw, y - gh / 2, &label, 1, black);
            d += 1.0;
        }
        // Title and axis titles.
        let title = format!("camera response ({})", self.method);
        let tw = text_width(&title, 2) as i32;
        draw_text(&mut img, (l + r - tw) / 2, 8, &title, 2, black);
        let xt = "pixel value (0 black, 1 white)";
        let xw = text_width(xt, 1) as i32;
        draw_text(&mut img, (l + r - xw) / 2, b + 24, xt, 1, black);
        let yt = "relative exposure (log scale)";
        let yw = text_width(yt, 1) as i32;
        draw_text_up(&mut img, 6, (t + b + yw) / 2, yt, 1, black);
        // Axes.
        line(&mut img, l, b, r, b, black);
        line(&mut img, l, t, l, b, black);
        let colours = match self.channels() {
            1 => vec![image::Rgb([80, 80, 80])],
            _ => vec![
                image::Rgb([220, 30, 30]),
                image::Rgb([30, 160, 30]),
                image::Rgb([30, 60, 220]),
            ],
        };
        // Legend, top left inside the plot: a swatch and the channel.
        let names: &[&str] = if self.channels() == 1 {
            &["grey"]
        } else {
            &["R", "G", "B"]
        };
        for (c, name) in names.iter().enumerate().take(self.channels()) {
            let y = t + 8 + c as i32 * (gh + 5);
            let colour = colours[c % colours.len()];
            for dy in 0..3 {
                line(
                    &mut img,
                    l + 8,
                    y + gh / 2 - 1 + dy,
                    l + 26,
                    y + gh / 2 - 1 + dy,
                    colour,
                );
            }
            draw_text(&mut img, l + 32, y, name, 1, black);
        }
        let n = self.levels();
        for (c, curve) in self.inverse.iter().enumerate() {
            let colour = colours[c % colours.len()];
            let mut prev: Option<(i32, i32)> = None;
            for (z, &v) in curve.iter().enumerate() {
                if v.is_nan() || v <= 0.0 || !v.is_finite() {
                    prev = None;
                    continue;
                }
                let p = (
                    px(z as f32 / (n - 1) as f32) as i32,
                    py(v.log10().max(lo)) as i32,
                );
                if let Some(q) = prev {
                    line(&mut img, q.0, q.1, p.0, p.1, colour);
                    line(&mut img, q.0, q.1 + 1, p.0, p.1 + 1, colour);
                }
                prev = Some(p);
            }
        }
        img
    }
}

/// The rows of an OpenCV response saved as CSV: per level, the blue, green
/// and red exposures; returned as red, green, blue.
fn read_opencv_rows(path: &Path, text: &str) -> Result<ResponseCurve> {
    let mut inverse = vec![Vec::new(); 3];
    for (n, row) in text.lines().enumerate() {
        if row.trim().is_empty() || row.trim_start().starts_with('#') {
            continue;
        }
        let fail = |m: String| Error::input(path, "", format!("line {}: {m}", n + 1));
        let cells: Vec<&str> = row.split(',').map(str::trim).collect();
        if cells.len() != 3 {
            return Err(fail(format!(
                "{} values where an OpenCV response has 3 (blue, green, red)",
                cells.len()
            )));
        }
        for (cell, c) in cells.iter().zip([2usize, 1, 0]) {
            let v: f32 = cell
                .parse()
                .map_err(|_| fail(format!("`{cell}` is not a number")))?;
            if !(v.is_finite() && v >= 0.0) {
                return Err(fail(format!("exposure {v} must be finite and ≥ 0")));
            }
            inverse[c].push(v);
        }
    }
    // OpenCV's least squares may dip at the ends of the range; made
    // non-decreasing, as plsr's recovered curves are.
    for c in inverse.iter_mut() {
        for z in 1..c.len() {
            c[z] = c[z].max(c[z - 1]);
        }
    }
    let levels = inverse[0].len();
    if levels != 256 && levels != BINNED_LEVELS {
        return Err(Error::input(
            path,
            "",
            format!("{levels} rows: an OpenCV response has 256 (one per 8-bit level)"),
        ));
    }
    Ok(ResponseCurve {
        method: ResponseMethod::Given,
        inverse,
    })
}

/// Pixel samples for response recovery: `values[(s · brackets + i) ·
/// channels + c]` is the level (0..levels) of sample `s` in bracket `i`,
/// channel `c`. Brackets are in the order of the exposures passed with it.
#[derive(Debug, Clone, Default)]
pub struct SampleSet {
    /// Number of levels of the domain (256 for 8-bit).
    pub levels: usize,
    /// Number of brackets.
    pub brackets: usize,
    /// Number of channels.
    pub channels: usize,
    /// The levels, sample-major, then bracket, then channel.
    pub values: Vec<u16>,
}

impl SampleSet {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.values
            .len()
            .checked_div(self.brackets * self.channels)
            .unwrap_or(0)
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    #[inline]
    fn get(&self, s: usize, i: usize, c: usize) -> usize {
        self.values[(s * self.brackets + i) * self.channels + c] as usize
    }
}

/// Hat weight on the 8-bit scale (0–127.5) for level `z` of `levels`
/// within the channel's signal `range`.
#[inline]
fn level_weight(z: usize, levels: usize, range: &SignalRange) -> f64 {
    range.weight(z as f32 / (levels - 1) as f32) as f64 * 127.5
}

/// The signal range of channel `c` (the last one for extra channels; the
/// full range if none is given).
fn range_of(ranges: &[SignalRange], c: usize) -> SignalRange {
    ranges
        .get(c)
        .or(ranges.last())
        .copied()
        .unwrap_or(SignalRange::FULL)
}

fn check_samples(samples: &SampleSet, exposures: &[f64]) -> Result<()> {
    if samples.levels < 2 || samples.levels > 65536 {
        return Err(Error::invalid_argument(format!(
            "response recovery needs 2–65536 levels, got {}",
            samples.levels
        )));
    }
    if exposures.len() != samples.brackets || samples.brackets < 2 {
        return Err(Error::invalid_argument(format!(
            "response recovery needs at least 2 brackets and one exposure each ({} brackets, {} exposures)",
            samples.brackets,
            exposures.len()
        )));
    }
    if exposures
        .iter()
        .any(|t| t.is_nan() || *t <= 0.0 || !t.is_finite())
    {
        return Err(Error::invalid_argument(
            "exposures must be positive and finite",
        ));
    }
    if samples.is_empty() {
        return Err(Error::invalid_argument(
            "response recovery got no sample pixels",
        ));
    }
    if samples.values.iter().any(|&z| z as usize >= samples.levels) {
        return Err(Error::invalid_argument(
            "a sample level is outside the curve's domain",
        ));
    }
    Ok(())
}

/// Scales each channel so the middle level maps to the exposure a linear
/// curve gives it, and makes the curve non-decreasing and positive.
fn normalise(inverse: &mut [Vec<f32>]) {
    for c in inverse.iter_mut() {
        let l = c.len();
        // Fill non-finite entries from their neighbours first.
        for z in 1..l {
            if !c[z].is_finite() || c[z] <= 0.0 {
                c[z] = c[z - 1];
            }
        }
        for z in 1..l {
            c[z] = c[z].max(c[z - 1]);
        }
        let mid = (l - 1) / 2;
        let target = mid as f32 / (l - 1) as f32;
        let s = if c[mid] > 0.0 && c[mid].is_finite() {
            target / c[mid]
        } else {
            1.0
        };
        for v in c.iter_mut() {
            *v = (*v * s).max(0.0);
        }
    }
}

/// Debevec–Malik recovery per channel with smoothness weight `lambda` (on
/// the 8-bit weight scale; scaled internally for other domains so the
/// smoothing is the same per unit of normalised pixel value).
/// `exposures[i]` is the relative exposure of bracket `i` (seconds, or
/// t/N²·ISO when those differ); `ranges` the signal range of each channel
/// (hat weights between its black and white levels).
pub fn debevec(
    samples: &SampleSet,
    exposures: &[f64],
    lambda: f64,
    ranges: &[SignalRange],
) -> Result<ResponseCurve> {
    check_samples(samples, exposures)?;
    let l = samples.levels;
    let ln_t: Vec<f64> = exposures.iter().map(|t| t.ln()).collect();
    let lam = lambda.max(0.0) * ((l - 1) as f64 / 255.0).powi(2);
    // The channels are independent systems, solved in parallel.
    let channel = |c: usize| -> Result<Vec<f32>> {
        let range = range_of(ranges, c);
        // Normal equations over g (l unknowns) with the per-sample ln E
        // eliminated: G g = r with
        // G = A_gᵀA_g − Σ_j b_j b_jᵀ / D_j,  r = A_gᵀy − Σ_j b_j (e_j / D_j).
        let mut g = vec![0f64; l * l];
        let mut rhs = vec![0f64; l];
        let mut idx: Vec<(usize, f64)> = Vec::with_capacity(samples.brackets);
        for s in 0..samples.len() {
            idx.clear();
            let mut d = 0.0;
            let mut e = 0.0;
            for (i, lt) in ln_t.iter().enumerate() {
                let z = samples.get(s, i, c);
                let w = level_weight(z, l, &range);
                if w <= 0.0 {
                    continue;
                }
                let w2 = w * w;
                // Row: w·g(z) − w·lnE_j = w·ln t_i.
                g[z * l + z] += w2;
                rhs[z] += w2 * lt;
                d += w2;
                e += -w2 * lt; // the ln E_j entry of Aᵀy
                match idx.iter_mut().find(|(zz, _)| *zz == z) {
                    Some(p) => p.1 += -w2,
                    None => idx.push((z, -w2)),
                }
            }
            if d <= 0.0 {
                continue;
            }
            for &(za, ba) in &idx {
                rhs[za] -= ba * e / d;
                for &(zb, bb) in &idx {
                    g[za * l + zb] -= ba * bb / d;
                }
            }
        }
        // Fix the scale: g(mid) = 0.
        let mid = (l - 1) / 2;
        g[mid * l + mid] += 1.0;
        // Smoothness: λ w(z) (g(z−1) − 2g(z) + g(z+1)) = 0.
        for z in 1..l - 1 {
            let w = lam * level_weight(z, l, &range);
            let coef = [(z - 1, w), (z, -2.0 * w), (z + 1, w)];
            for &(a, ca) in &coef {
                for &(b, cb) in &coef {
                    g[a * l + b] += ca * cb;
                }
            }
        }
        // A tiny ridge keeps levels no equation reaches solvable.
        let trace: f64 = (0..l).map(|z| g[z * l + z]).sum::<f64>() / l as f64;
        for z in 0..l {
            g[z * l + z] += 1e-10 * trace.max(1.0);
        }
        let sol = cholesky_solve(&mut g, &mut rhs, l).ok_or_else(|| {
            Error::invalid_argument(
                "Debevec response recovery: the least-squares system is singular (too few usable samples?)",
            )
        })?;
        let mut sol = sol;
        extend_beyond_range(&mut sol, |z| level_weight(z, l, &range) > 0.0);
        Ok(sol.iter().map(|g| (g.exp()) as f32).collect())
    };
    let mut inverse = (0..samples.channels)
        .into_par_iter()
        .map(channel)
        .collect::<Result<Vec<_>>>()?;
    normalise(&mut inverse);
    Ok(ResponseCurve {
        method: ResponseMethod::Debevec,
        inverse,
    })
}

/// Holds `g` constant below and above the levels its equations reach:
/// those the `weighted` predicate accepts, and one level either side (which
/// their smoothness rows tie in). Below the black level the solution is
/// otherwise only the ridge's `g = 0`, which would lift the whole dark end
/// when the curve is made non-decreasing.
fn extend_beyond_range(g: &mut [f64], weighted: impl Fn(usize) -> bool) {
    let l = g.len();
    let (Some(first), Some(last)) = (
        (0..l).find(|&z| weighted(z)),
        (0..l).rfind(|&z| weighted(z)),
    ) else {
        return;
    };
    let (lo, hi) = (first.saturating_sub(1), (last + 1).min(l - 1));
    let (g_lo, g_hi) = (g[lo], g[hi]);
    g[..lo].fill(g_lo);
    g[hi + 1..].fill(g_hi);
}

/// Solves the symmetric positive definite `a x = b` (`a` n×n row-major,
/// overwritten by its Cholesky factor); `None` if not positive definite.
fn cholesky_solve(a: &mut [f64], b: &mut [f64], n: usize) -> Option<Vec<f64>> {
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        if d.is_nan() || d <= 0.0 || !d.is_finite() {
            return None;
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            let (ri, rj) = (i * n, j * n);
            for k in 0..j {
                s -= a[ri + k] * a[rj + k];
            }
            a[i * n + j] = s / d;
        }
    }
    // Forward: L y = b.
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= a[i * n + k] * b[k];
        }
        b[i] = s / a[i * n + i];
    }
    // Backward: Lᵀ x = y.
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= a[k * n + i] * b[k];
        }
        b[i] = s / a[i * n + i];
    }
    b.iter().all(|v| v.is_finite()).then(|| b.to_vec())
}

/// Robertson et al. 2003 recovery per channel: starting from a linear
/// curve, alternately estimate each sample's irradiance (hat-weighted
/// maximum likelihood) and each level's exposure (mean of `t·E` over the
/// samples at that level), until the largest relative change of the curve is
/// below `tolerance` or after `max_iterations`. `ranges` as for
/// [`debevec`].
pub fn robertson(
    samples: &SampleSet,
    exposures: &[f64],
    max_iterations: usize,
    tolerance: f64,
    ranges: &[SignalRange],
) -> Result<ResponseCurve> {
    check_samples(samples, exposures)?;
    let l = samples.levels;
    let n = samples.len();
    let mut inverse = Vec::with_capacity(samples.channels);
    for c in 0..samples.channels {
        let range = range_of(ranges, c);
        let weights: Vec<f64> = (0..l).map(|z| level_weight(z, l, &range) / 127.5).collect();
        let mut curve: Vec<f64> = (0..l).map(|z| (z as f64 + 0.5) / l as f64).collect();
        let mut e = vec![0f64; n];
        let mut sum = vec![0f64; l];
        let mut count = vec![0u32; l];
        for _ in 0..max_iterations.max(1) {
            for (s, es) in e.iter_mut().enumerate() {
                let (mut num, mut den) = (0.0, 0.0);
                for (i, t) in exposures.iter().enumerate() {
                    let z = samples.get(s, i, c);
                    let w = weights[z];
                    num += w * t * curve[z];
                    den += w * t * t;
                }
                *es = if den > 0.0 { num / den } else { f64::NAN };
            }
            sum.fill(0.0);
            count.fill(0);
            for (s, es) in e.iter().enumerate() {
                if !es.is_finite() {
                    continue;
                }
                for (i, t) in exposures.iter().enumerate() {
                    let z = samples.get(s, i, c);
                    sum[z] += t * es;
                    count[z] += 1;
                }
            }
            let mut next: Vec<f64> = (0..l)
                .map(|z| {
                    if count[z] > 0 {
                        sum[z] / count[z] as f64
                    } else {
                        f64::NAN
                    }
                })
                .collect();
            fill_gaps(&mut next);
            let mid = (l - 1) / 2;
            let s = if next[mid] > 0.0 {
                1.0 / next[mid]
            } else {
                1.0
            };
            next.iter_mut().for_each(|v| *v *= s);
            let change = next
                .iter()
                .zip(&curve)
                .map(|(a, b)| ((a - b) / b.abs().max(1e-12)).abs())
                .fold(0.0, f64::max);
            curve = next;
            if change < tolerance {
                break;
            }
        }
        // The top level holds clipped values, whose average exposure says
        // nothing about where clipping starts: extrapolate it from below.
        if l >= 3 {
            curve[l - 1] = curve[l - 2] + (curve[l - 2] - curve[l - 3]).max(0.0);
        }
        inverse.push(curve.iter().map(|v| *v as f32).collect());
    }
    normalise(&mut inverse);
    Ok(ResponseCurve {
        method: ResponseMethod::Robertson,
        inverse,
    })
}

/// Replaces NaN entries by linear interpolation between the nearest known
/// neighbours (constant beyond the ends); all-NaN becomes linear.
fn fill_gaps(c: &mut [f64]) {
    let known: Vec<usize> = (0..c.len()).filter(|&z| c[z].is_finite()).collect();
    if known.is_empty() {
        let n = c.len();
        for (z, v) in c.iter_mut().enumerate() {
            *v = (z as f64 + 0.5) / n as f64;
        }
        return;
    }
    let (first, last) = (known[0], *known.last().unwrap_or(&known[0]));
    for z in 0..first {
        c[z] = c[first] * (z as f64 + 0.5) / (first as f64 + 0.5);
    }
    for z in last + 1..c.len() {
        c[z] = c[last];
    }
    for w in known.windows(2) {
        let (a, b) = (w[0], w[1]);
        for z in a + 1..b {
            let f = (z - a) as f64 / (b - a) as f64;
            c[z] = c[a] * (1.0 - f) + c[b] * f;
        }
    }
}

#[cfg(test)]
mod tests {

    /// The plot has a title, tick labels on both axes, axis titles and a
    /// legend with each channel's colour.
    #[test]
    fn the_curve_plot_is_labelled() {
        let (w, h) = (640u32, 480u32);
        let img = ResponseCurve::srgb(256, 3).plot(w, h);
        let (l, r, t, b) = (62u32, w - 14, 34u32, h - 44);
        let dark = |x0: u32, y0: u32, x1: u32, y1: u32| {
            (y0..y1)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .filter(|&(x, y)| img.get_pixel(x, y).0 == [0, 0, 0])
                .count()
        };
        assert!(dark(l, 0, r, t - 4) > 100, "no title");
        assert!(dark(l - 10, b + 9, r + 10, b + 17) > 60, "no x tick labels");
        assert!(dark(l, b + 24, r, b + 32) > 60, "no x axis title");
        assert!(dark(0, t, 14, b) > 60, "no y axis title");
        assert!(dark(14, t - 4, l - 8, b + 4) > 20, "no y tick labels");
        for (c, colour) in [[220u8, 30, 30], [30, 160, 30], [30, 60, 220]]
            .iter()
            .enumerate()
        {
            let y = t + 8 + c as u32 * 12 + 3;
            assert_eq!(img.get_pixel(l + 15, y).0, *colour, "legend swatch {c}");
        }
        assert!(dark(l + 32, t + 8, l + 40, t + 44) > 30, "no legend names");
    }

    use super::*;

    /// Samples of a known curve f(x) = x^(1/2.2) on 8 bits, noiseless.
    fn synthetic(levels: usize, n: usize, exposures: Vec<f64>) -> (SampleSet, Vec<f64>) {
        let mut values = Vec::new();
        let mut rng = plsr_base::rng::Rng::new(3, 4);
        for _ in 0..n {
            // Log-uniform irradiances over four decades.
            let e = 10f64.powf(-2.0 + 4.0 * rng.next_f32() as f64);
            for t in &exposures {
                let v = (e * t).min(1.0).powf(1.0 / 2.2);
                let z = (v * (levels - 1) as f64).round() as u16;
                values.push(z);
            }
        }
        (
            SampleSet {
                levels,
                brackets: exposures.len(),
                channels: 1,
                values,
            },
            exposures,
        )
    }

    fn check_gamma(curve: &ResponseCurve, tol: f64) {
        let l = curve.levels();
        // Compare ln I with 2.2 ln v up to a constant over the well-exposed range.
        let zs: Vec<usize> = (l / 20..l * 19 / 20).collect();
        let d: Vec<f64> = zs
            .iter()
            .map(|&z| {
                let v = z as f64 / (l - 1) as f64;
                (curve.inverse[0][z] as f64).ln() - 2.2 * v.ln()
            })
            .collect();
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        let rms = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / d.len() as f64).sqrt();
        assert!(rms < tol, "{:?} log-RMS error {rms}", curve.method);
    }

    #[test]
    fn debevec_recovers_a_gamma_curve() {
        // Debevec needs few samples (about 100 for 8 bits).
        let (s, t) = synthetic(256, 120, vec![0.01, 0.04, 0.16, 0.64, 2.56]);
        check_gamma(&debevec(&s, &t, DEFAULT_LAMBDA, &[]).unwrap(), 0.03);
        let (s, t) = synthetic(BINNED_LEVELS, 240, vec![0.01, 0.04, 0.16, 0.64, 2.56]);
        check_gamma(&debevec(&s, &t, DEFAULT_LAMBDA, &[]).unwrap(), 0.03);
    }

    #[test]
    fn robertson_recovers_a_gamma_curve() {
        // Robertson estimates each level from the samples that land on it,
        // so it takes many (the merge gives it the whole pixel lattice); from
        // its linear start it converges well with brackets one stop apart
        // (as the paper's), slowly with wider spacing.
        let (s, t) = synthetic(256, 5000, (0..10).map(|k| 0.01 * 2f64.powi(k)).collect());
        check_gamma(&robertson(&s, &t, 50, 1e-5, &[]).unwrap(), 0.05);
    }

    #[test]
    fn presets_and_hat() {
        let c = ResponseCurve::srgb(256, 3);
        assert!((c.eval(1, 1.0) - 1.0).abs() < 1e-6);
        assert!((c.eval(0, 0.5) - 0.214).abs() < 1e-3);
        assert_eq!(ResponseCurve::linear(256, 1).eval(0, 0.25), 0.25);
        assert_eq!(hat(0.0), 0.0);
        assert_eq!(hat(1.0), 0.0);
        assert_eq!(hat(0.5), 1.0);
        assert_eq!(hat(f32::NAN), 0.0);
    }

    #[test]
    fn curves_are_read_back_and_opencv_responses_are_read_in_its_order() {
        let dir = tempfile::tempdir().unwrap();
        let mut c = ResponseCurve::srgb(256, 3);
        c.method = ResponseMethod::Debevec;
        c.inverse[0][200] *= 1.0001; // break the channels' symmetry
        c.write_csv(&dir.path().join("c.csv")).unwrap();
        let back = ResponseCurve::read_csv(&dir.path().join("c.csv")).unwrap();
        assert_eq!(back.inverse, c.inverse);
        assert_eq!(back.method, ResponseMethod::Given);
        // OpenCV: blue, green, red per row, no header.
        let rows: Vec<String> = (0..256)
            .map(|z| format!("{},{},{}", 3.0 * z as f32, 2.0 * z as f32, z as f32))
            .collect();
        std::fs::write(dir.path().join("cv.csv"), rows.join("\n")).unwrap();
        let cv = ResponseCurve::read_csv(&dir.path().join("cv.csv")).unwrap();
        assert_eq!(cv.inverse[0][10], 10.0, "red is the last column");
        assert_eq!(cv.inverse[2][10], 30.0, "blue is the first column");
        std::fs::write(dir.path().join("short.csv"), "1,2,3\n4,5,6\n").unwrap();
        let e = ResponseCurve::read_csv(&dir.path().join("short.csv"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("short.csv") && e.contains("256"), "{e}");
    }

    #[test]
    fn csv_and_plot_are_written() {
        let dir = std::env::temp_dir().join(format!("plsr-resp-unit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let c = ResponseCurve::srgb(256, 3);
        c.write_csv(&dir.join("c.csv")).unwrap();
        c.write_plot_png(&dir.join("c.png"), 320, 240).unwrap();
        let text = std::fs::read_to_string(dir.join("c.csv")).unwrap();
        assert_eq!(text.lines().count(), 2 + 256);
        assert!(text
            .lines()
            .nth(1)
            .unwrap()
            .starts_with("level,pixel_value,r,g,b"));
        let img = image::open(dir.join("c.png")).unwrap();
        assert_eq!(img.width(), 320);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
