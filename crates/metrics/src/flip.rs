//! FLIP: NVIDIA's perceptual difference evaluator for rendered images
//! (Andersson et al., "FLIP: A Difference Evaluator for Alternating
//! Images", HPG 2020; "Visualizing Errors in Rendered High Dynamic Range
//! Images", Eurographics 2021), LDR-FLIP and HDR-FLIP, computed as the
//! reference implementation (the `flip-evaluator` 1.7 package, NVlabs'
//! `FLIP.h`) computes them: in `f32`, with the same constants and steps, so
//! the mean FLIP agrees with it within 1e-4 (`crates/cli/tests/it/metrics.rs`).
//!
//! **LDR-FLIP** compares two images of linear RGB in [0, 1] (sRGB-encoded
//! display values are first decoded with the sRGB transfer function).
//! Both go to the opponent space YCxCz (linear RGB → CIE XYZ under D65 →
//! Y = 116·y − 16, Cx = 500·(x − y), Cz = 200·(y − z), x, y, z relative
//! to the D65 white) and are blurred by the contrast sensitivity
//! functions of the human eye at the viewing distance given as pixels per
//! degree of visual angle (default 67.02 ppd: a 0.7 m wide 3840-pixel
//! monitor seen from 0.7 m). The filters are Gaussians in the spatial
//! domain (one for Y and one for Cx, a sum of two for Cz), of radius
//! ⌈3·√(0.04 / 2π²)·ppd⌉ pixels (10 at 67 ppd), applied separably with
//! coordinates clamped at the image border. The blurred images go back to
//! linear RGB, are clamped to [0, 1], and go to CIELAB (L\* 0–100); the
//! Hunt effect scales a\* and b\* by 0.01·L\*; the colour difference is
//! HyAB (|ΔL\*| + √(Δa\*² + Δb\*²)), raised to q_c = 0.7 and mapped to
//! [0, 1] by the largest difference (green against blue, c_max): values
//! below p_c·c_max (p_c = 0.4) map linearly to [0, p_t] (p_t = 0.95), the
//! rest to [p_t, 1]. This is ΔE_c.
//!
//! The feature difference ΔE_f compares edges and points of the
//! achromatic channel ((Y + 16)/116, 0–1): first and second derivatives
//! of a Gaussian of σ = ½·0.082·ppd pixels (radius ⌈3σ⌉), normalised so
//! that the Gaussian sums to 1 and the positive and negative lobes of the
//! derivatives to ±1, give an edge magnitude |∇| and a point magnitude
//! |∇²| per pixel; ΔE_f = (max(Δedge, Δpoint)/√2)^q_f with q_f = 0.5. The
//! FLIP value of a pixel is ΔE_c^(1 − ΔE_f), between 0 (no visible
//! difference) and 1; the score is the mean over the pixels.
//!
//! **HDR-FLIP** compares linear radiance (any non-negative values). Both
//! images are exposed by 2^e for a range of exposures e (stops), tone
//! mapped (ACES by default: per channel (a·x² + b·x + c)/(d·x² + e·x + f)
//! with FLIP's coefficients, which fold in a 0.6 pre-exposure; Hable and
//! Reinhard also offered), clamped to [0, 1], and compared by LDR-FLIP;
//! each pixel keeps its largest value over the exposures. By default the
//! range comes from the reference's luminance L = 0.2126·R + 0.7152·G +
//! 0.0722·B: with x_max the radiance the tone mapper maps to 0.85, the
//! start exposure is log₂(x_max / L_max) and the stop exposure
//! log₂(x_max / L_median) (the median is the element at n/2 of the sorted
//! luminances), and there are max(2, ⌈stop − start⌉) exposures, evenly
//! spaced from start to stop inclusive. Each of the three can be given
//! instead ([`FlipOptions`]).

use crate::error::{Error, Result};
use crate::MetricImage;
use plsr_base::Vocabulary;
use rayon::prelude::*;

/// π (`FLIP.h`'s 3.14159265358979 rounds to the same `f32`).
const PI: f32 = std::f32::consts::PI;

/// Colour-difference exponent q_c.
const QC: f32 = 0.7;
/// Colour-difference breakpoint p_c (fraction of c_max).
const PC: f32 = 0.4;
/// Value the breakpoint maps to, p_t.
const PT: f32 = 0.95;
/// Feature filter width w (degrees): σ = ½·w·ppd pixels.
const GW: f32 = 0.082;
/// Feature-difference exponent q_f.
const QF: f32 = 0.5;

/// The D65 white point in XYZ (Y = 1) and its inverse, as FLIP uses them.
const WHITE: [f32; 3] = [0.950_428_55, 1.0, 1.088_900_3];
const INV_WHITE: [f32; 3] = [1.052_156_9, 1.0, 0.918_357_7];

/// The contrast sensitivity filters' Gaussians (a, b) per channel: Y and
/// Cx one each, Cz two (FLIP paper, Table 1).
const CSF_Y: (f32, f32) = (1.0, 0.0047);
const CSF_CX: (f32, f32) = (1.0, 0.0053);
const CSF_CZ1: (f32, f32) = (34.1, 0.04);
const CSF_CZ2: (f32, f32) = (13.5, 0.025);
/// The largest scale parameter b of all the Gaussians (it sets the radius).
const CSF_MAX_B: f32 = 0.04;

/// Pixels per degree of visual angle of a display `width_px` pixels and
/// `width_m` metres wide seen from `distance_m` metres, as FLIP computes it.
pub fn pixels_per_degree(distance_m: f64, width_px: f64, width_m: f64) -> f64 {
    let (d, r, w) = (distance_m as f32, width_px as f32, width_m as f32);
    (d * (r / w) * (PI / 180.0)) as f64
}

/// The tone mapper HDR-FLIP assumes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ToneMapper {
    /// ACES filmic (Narkowicz's fit, FLIP's coefficients), the default.
    #[default]
    Aces,
    /// Hable (Uncharted 2).
    Hable,
    /// Reinhard on luminance: `rgb / (1 + L)`.
    Reinhard,
}

impl ToneMapper {
    /// The rational function's coefficients (a, b, c, d, e, f):
    /// `(a·x² + b·x + c) / (d·x² + e·x + f)` (for Reinhard only used to
    /// find the exposure range, as FLIP does).
    fn coefficients(self) -> [f32; 6] {
        match self {
            ToneMapper::Reinhard => [0.0, 1.0, 0.0, 0.0, 1.0, 1.0],
            ToneMapper::Aces => [
                0.6 * 0.6 * 2.51,
                0.6 * 0.03,
                0.0,
                0.6 * 0.6 * 2.43,
                0.6 * 0.59,
                0.14,
            ],
            ToneMapper::Hable => [0.231683, 0.013791, 0.0, 0.18, 0.3, 0.018],
        }
    }

    /// The tone mapper's name ("aces", "hable", "reinhard").
    pub fn name(self) -> &'static str {
        match self {
            ToneMapper::Aces => "aces",
            ToneMapper::Hable => "hable",
            ToneMapper::Reinhard => "reinhard",
        }
    }

    /// Maps one linear RGB pixel.
    fn map(self, c: [f32; 3]) -> [f32; 3] {
        match self {
            ToneMapper::Reinhard => {
                let l = luminance(c);
                let k = 1.0 / (1.0 + l);
                c.map(|v| v * k)
            }
            _ => {
                let t = self.coefficients();
                c.map(|v| (v * v * t[0] + v * t[1] + t[2]) / (v * v * t[3] + v * t[4] + t[5]))
            }
        }
    }
}

/// FLIP's settings; the defaults are the reference's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlipOptions {
    /// Pixels per degree of visual angle (default 67.0206, FLIP's 0.7 m
    /// wide 3840-pixel display at 0.7 m; see [`pixels_per_degree`]).
    pub pixels_per_degree: f64,
    /// HDR-FLIP's tone mapper (default ACES).
    pub tone_mapper: ToneMapper,
    /// HDR-FLIP's first exposure, stops; `None`: from the reference's
    /// largest luminance.
    pub start_exposure: Option<f64>,
    /// HDR-FLIP's last exposure, stops; `None`: from the reference's
    /// median luminance.
    pub stop_exposure: Option<f64>,
    /// HDR-FLIP's number of exposures; `None`: max(2, ⌈stop − start⌉).
    /// With 1, only the start exposure is used (the reference divides by
    /// zero there).
    pub exposures: Option<usize>,
}

impl Default for FlipOptions {
    fn default() -> FlipOptions {
        FlipOptions {
            pixels_per_degree: pixels_per_degree(0.7, 3840.0, 0.7),
            tone_mapper: ToneMapper::Aces,
            start_exposure: None,
            stop_exposure: None,
            exposures: None,
        }
    }
}

/// The exposures HDR-FLIP used.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlipExposures {
    /// First exposure, stops.
    pub start: f64,
    /// Last exposure, stops.
    pub stop: f64,
    /// Number of exposures, evenly spaced from `start` to `stop`.
    pub count: usize,
}

/// A FLIP error map.
#[derive(Debug, Clone, PartialEq)]
pub struct FlipMap {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// FLIP per pixel, 0–1, row-major.
    pub v: Vec<f32>,
    /// The mean of `v`.
    pub mean: f64,
    /// HDR-FLIP's exposures (`None` for LDR-FLIP).
    pub exposures: Option<FlipExposures>,
}

impl FlipMap {
    /// The map in the magma colour map, as FLIP's tool writes it (entry
    /// ⌊255·v + ½⌋ of the 256-entry table, 8-bit sRGB).
    pub fn magma(&self) -> image::RgbImage {
        let mut img = image::RgbImage::new(self.width as u32, self.height as u32);
        for (px, &v) in img.pixels_mut().zip(&self.v) {
            let i = (v * 255.0 + 0.5) as usize % MAGMA.len();
            *px = image::Rgb(MAGMA[i]);
        }
        img
    }
}

/// LDR-FLIP of `test` against `reference`, on their display values
/// ([`MetricImage::display`]: sRGB-encoded, 0–1), decoded to linear RGB
/// with the sRGB transfer function.
pub fn ldr_flip(reference: &MetricImage, test: &MetricImage, o: &FlipOptions) -> Result<FlipMap> {
    let ppd = check(reference, test, o)?;
    let decode = |img: &MetricImage| -> Vec<[f32; 3]> {
        img.display()
            .chunks_exact(3)
            .map(|p| [p[0], p[1], p[2]].map(|v| srgb_to_linear(v).clamp(0.0, 1.0)))
            .collect()
    };
    let (r, t) = (decode(reference), decode(test));
    let filters = Filters::new(ppd);
    let v = ldr_flip_linear(reference.width, reference.height, &r, &t, &filters);
    Ok(finish(reference.width, reference.height, v, None))
}

/// HDR-FLIP of `test` against `reference`, on their linear values
/// ([`MetricImage::rgb`]: radiance for float files).
pub fn hdr_flip(reference: &MetricImage, test: &MetricImage, o: &FlipOptions) -> Result<FlipMap> {
    let ppd = check(reference, test, o)?;
    for img in [reference, test] {
        if let Some(i) = img.rgb.iter().position(|v| !v.is_finite()) {
            return Err(Error::invalid_argument(format!(
                "FLIP: {} has a value that is not a finite number at pixel ({}, {})",
                img.path.display(),
                (i / 3) % img.width,
                (i / 3) / img.width
            )));
        }
    }
    let pixels = |img: &MetricImage| -> Vec<[f32; 3]> {
        img.rgb
            .chunks_exact(3)
            .map(|p| [p[0], p[1], p[2]])
            .collect()
    };
    let (r, t) = (pixels(reference), pixels(test));
    let tm = o.tone_mapper;
    let (mut start, mut stop) = (
        o.start_exposure.map(|v| v as f32),
        o.stop_exposure.map(|v| v as f32),
    );
    if start.is_none() || stop.is_none() {
        let (s0, s1) = automatic_exposures(&r, tm);
        start = start.or(Some(s0));
        stop = stop.or(Some(s1));
    }
    let (start, stop) = (start.unwrap_or(0.0), stop.unwrap_or(0.0));
    if !start.is_finite() || !stop.is_finite() {
        return Err(Error::invalid_argument(format!(
            "HDR-FLIP: the exposure range of {} is not finite (start {start}, stop {stop}): \
             its largest or median luminance is 0; give the start and stop exposures",
            reference.path.display()
        )));
    }
    if start > stop {
        return Err(Error::invalid_argument(format!(
            "HDR-FLIP: the start exposure ({start}) must not exceed the stop exposure ({stop})"
        )));
    }
    let count = match o.exposures {
        Some(0) => {
            return Err(Error::invalid_argument(
                "HDR-FLIP: the number of exposures must be at least 1",
            ))
        }
        Some(n) => n,
        None => (stop - start).ceil().max(2.0) as usize,
    };
    let step = if count > 1 {
        (stop - start) / (count - 1) as f32
    } else {
        0.0
    };
    let filters = Filters::new(ppd);
    let (w, h) = (reference.width, reference.height);
    let mut best = vec![0.0f32; w * h];
    for i in 0..count {
        let exposure = start + i as f32 * step;
        let m = 2.0f32.powf(exposure);
        let expose = |img: &[[f32; 3]]| -> Vec<[f32; 3]> {
            img.par_iter()
                .map(|&c| tm.map(c.map(|v| v * m)).map(|v| v.clamp(0.0, 1.0)))
                .collect()
        };
        let v = ldr_flip_linear(w, h, &expose(&r), &expose(&t), &filters);
        best.par_iter_mut().zip(&v).for_each(|(b, &x)| {
            if x > *b {
                *b = x;
            }
        });
    }
    let exposures = FlipExposures {
        start: start as f64,
        stop: stop as f64,
        count,
    };
    Ok(finish(w, h, best, Some(exposures)))
}

/// Checks the images' sizes and the options; the pixels per degree.
fn check(reference: &MetricImage, test: &MetricImage, o: &FlipOptions) -> Result<f32> {
    super::same_size("FLIP: ", reference, test)?;
    if reference.width == 0 || reference.height == 0 {
        return Err(Error::invalid_argument(format!(
            "FLIP: {} has no pixels",
            reference.path.display()
        )));
    }
    for img in [reference, test] {
        if img.rgb.len() != img.width * img.height * 3 {
            return Err(Error::invalid_argument(format!(
                "FLIP: {} holds {} values, not 3 per pixel of its {}×{}",
                img.path.display(),
                img.rgb.len(),
                img.width,
                img.height
            )));
        }
    }
    let ppd = o.pixels_per_degree;
    if !(ppd.is_finite() && ppd > 0.0) {
        return Err(Error::invalid_argument(format!(
            "FLIP: the pixels per degree must be a positive number, not {ppd}"
        )));
    }
    for (name, v) in [("start", o.start_exposure), ("stop", o.stop_exposure)] {
        if v.is_some_and(|v| !v.is_finite()) {
            return Err(Error::invalid_argument(format!(
                "HDR-FLIP: the {name} exposure must be a finite number"
            )));
        }
    }
    Ok(ppd as f32)
}

/// The map and its mean (summed per row in `f64`, then the rows in order:
/// the same for any number of threads).
fn finish(w: usize, h: usize, v: Vec<f32>, exposures: Option<FlipExposures>) -> FlipMap {
    let rows: Vec<f64> = v
        .par_chunks(w)
        .map(|row| row.iter().map(|&x| x as f64).sum())
        .collect();
    let mean = rows.iter().sum::<f64>() / (w * h) as f64;
    FlipMap {
        width: w,
        height: h,
        v,
        mean,
        exposures,
    }
}

/// HDR-FLIP's automatic exposure range from the reference's luminance.
fn automatic_exposures(reference: &[[f32; 3]], tm: ToneMapper) -> (f32, f32) {
    // The radiance the tone mapper maps to 0.85: the larger root of
    // (a − t·d)·x² + (b − t·e)·x + (c − t·f) = 0.
    let k = tm.coefficients();
    let t = 0.85f32;
    let (a, b, c) = (k[0] - t * k[3], k[1] - t * k[4], k[2] - t * k[5]);
    let x_max = if a == 0.0 {
        -c / b
    } else {
        let d1 = -0.5 * (b / a);
        let d2 = ((d1 * d1) - (c / a)).sqrt();
        d1 + d2
    };
    let mut lum: Vec<f32> = reference.iter().map(|&p| luminance(p)).collect();
    let y_max = lum.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let mid = lum.len() / 2;
    let (_, &mut y_median, _) = lum.select_nth_unstable_by(mid, f32::total_cmp);
    let log2 = |x: f32| (x as f64).log2() as f32;
    (log2(x_max / y_max), log2(x_max / y_median))
}

/// Luminance of linear sRGB.
fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// The sRGB transfer function's inverse (display value to linear).
fn srgb_to_linear(s: f32) -> f32 {
    if s <= 0.04045 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear sRGB to CIE XYZ (D65).
fn rgb_to_xyz(c: [f32; 3]) -> [f32; 3] {
    const M: [[f32; 3]; 3] = [
        [
            10135552.0 / 24577794.0,
            8788810.0 / 24577794.0,
            4435075.0 / 24577794.0,
        ],
        [
            2613072.0 / 12288897.0,
            8788810.0 / 12288897.0,
            887015.0 / 12288897.0,
        ],
        [
            1425312.0 / 73733382.0,
            8788810.0 / 73733382.0,
            70074185.0 / 73733382.0,
        ],
    ];
    M.map(|r| r[0] * c[0] + r[1] * c[1] + r[2] * c[2])
}

/// CIE XYZ (D65) to linear sRGB.
fn xyz_to_rgb(c: [f32; 3]) -> [f32; 3] {
    const M: [[f32; 3]; 3] = [
        [3.241_003_3, -1.537_398_9, -0.498_615_86],
        [-0.969_224_33, 1.875_930_1, 0.041_554_224],
        [0.055_639_423, -0.204_011_2, 1.057_148_9],
    ];
    M.map(|r| r[0] * c[0] + r[1] * c[1] + r[2] * c[2])
}

/// CIE XYZ to YCxCz (relative to D65).
fn xyz_to_ycxcz(c: [f32; 3]) -> [f32; 3] {
    let [x, y, z] = [
        c[0] * INV_WHITE[0],
        c[1] * INV_WHITE[1],
        c[2] * INV_WHITE[2],
    ];
    [116.0 * y - 16.0, 500.0 * (x - y), 200.0 * (y - z)]
}

/// YCxCz to CIE XYZ (D65).
fn ycxcz_to_xyz(c: [f32; 3]) -> [f32; 3] {
    let y = (c[0] + 16.0) / 116.0;
    let cx = c[1] / 500.0;
    let cz = c[2] / 200.0;
    [(y + cx) * WHITE[0], y * WHITE[1], (y - cz) * WHITE[2]]
}

/// CIE XYZ to CIELAB (D65 white).
fn xyz_to_lab(c: [f32; 3]) -> [f32; 3] {
    let delta = 6.0f32 / 29.0;
    let delta_square = delta * delta;
    let delta_cube = delta * delta_square;
    let factor = 1.0 / (3.0 * delta_square);
    let term = 4.0f32 / 29.0;
    let f = |v: f32| {
        if v > delta_cube {
            v.powf(1.0 / 3.0)
        } else {
            factor * v + term
        }
    };
    let [x, y, z] = [
        f(c[0] * INV_WHITE[0]),
        f(c[1] * INV_WHITE[1]),
        f(c[2] * INV_WHITE[2]),
    ];
    [116.0 * y - 16.0, 500.0 * (x - y), 200.0 * (y - z)]
}

/// CIELAB with the Hunt adjustment (a\*, b\* scaled by 0.01·L\*).
fn hunt(lab: [f32; 3]) -> [f32; 3] {
    [lab[0], 0.01 * lab[0] * lab[1], 0.01 * lab[0] * lab[2]]
}

/// The HyAB distance: |ΔL| + √(Δa² + Δb²).
fn hyab(p: [f32; 3], q: [f32; 3]) -> f32 {
    let (da, db) = (p[1] - q[1], p[2] - q[2]);
    (p[0] - q[0]).abs() + (da * da + db * db).sqrt()
}

/// c_max: the HyAB distance, raised to q_c, of green and blue.
fn max_colour_distance() -> f32 {
    let lab = |c| hunt(xyz_to_lab(rgb_to_xyz(c)));
    hyab(lab([0.0, 1.0, 0.0]), lab([0.0, 0.0, 1.0])).powf(QC)
}

/// The 1D filters for a number of pixels per degree.
struct Filters {
    /// CSF weights for Y and Cx.
    ycx: Vec<[f32; 2]>,
    /// CSF weights of Cz's two Gaussians (separated: each the square root
    /// of its 2D Gaussian, normalised together).
    cz: Vec<[f32; 2]>,
    /// Feature detection: Gaussian, its first and second derivatives.
    feature: Vec<[f32; 3]>,
}

impl Filters {
    fn new(ppd: f32) -> Filters {
        let pi_sq = PI * PI;
        // a·√(π/b)·exp(−π²x²/b), and its square root's amplitude for the
        // separated sum of two Gaussians.
        let gauss = |x2: f32, (a, b): (f32, f32)| a * (PI / b).sqrt() * (-pi_sq * x2 / b).exp();
        let gauss_sqrt =
            |x2: f32, (a, b): (f32, f32)| (a * (PI / b).sqrt()).sqrt() * (-pi_sq * x2 / b).exp();
        let radius = (3.0 * (CSF_MAX_B / (2.0 * pi_sq)).sqrt() * ppd).ceil() as i32;
        let dx = 1.0 / ppd;
        let mut ycx = Vec::new();
        let mut cz = Vec::new();
        let (mut sum_ycx, mut sum_cz) = ([0.0f32; 2], [0.0f32; 2]);
        for i in -radius..=radius {
            let x = i as f32 * dx;
            let x2 = x * x;
            let a = [gauss(x2, CSF_Y), gauss(x2, CSF_CX)];
            let b = [gauss_sqrt(x2, CSF_CZ1), gauss_sqrt(x2, CSF_CZ2)];
            for k in 0..2 {
                sum_ycx[k] += a[k];
                sum_cz[k] += b[k];
            }
            ycx.push(a);
            cz.push(b);
        }
        let norm_ycx = [1.0 / sum_ycx[0], 1.0 / sum_ycx[1]];
        let norm_cz = 1.0 / (sum_cz[0] * sum_cz[0] + sum_cz[1] * sum_cz[1]).sqrt();
        for w in &mut ycx {
            *w = [w[0] * norm_ycx[0], w[1] * norm_ycx[1]];
        }
        for w in &mut cz {
            *w = w.map(|v| v * norm_cz);
        }

        let sd = 0.5 * GW * ppd;
        let r = (3.0 * sd).ceil() as i32;
        let mut feature = Vec::new();
        let (mut g_sum, mut dg_pos, mut dg_neg, mut ddg_pos, mut ddg_neg) =
            (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
        for i in -r..=r {
            let x = i as f32;
            let g = (-(x * x) / (2.0 * sd * sd)).exp();
            g_sum += g;
            let dg = -x * g;
            if dg > 0.0 {
                dg_pos += dg;
            } else {
                dg_neg -= dg;
            }
            let ddg = (x * x / (sd * sd) - 1.0) * g;
            if ddg > 0.0 {
                ddg_pos += ddg;
            } else {
                ddg_neg -= ddg;
            }
            feature.push([g, dg, ddg]);
        }
        for w in &mut feature {
            *w = [
                w[0] / g_sum,
                w[1] / if w[1] > 0.0 { dg_pos } else { dg_neg },
                w[2] / if w[2] > 0.0 { ddg_pos } else { ddg_neg },
            ];
        }
        Filters { ycx, cz, feature }
    }
}

/// A separable filter's first pass: along each row, coordinates clamped
/// to the row; `tap(acc, k, pixel)` adds tap `k`'s contribution.
fn along_rows<S, A, F>(w: usize, h: usize, src: &[S], taps: usize, tap: F) -> Vec<A>
where
    S: Copy + Sync,
    A: Copy + Default + Send,
    F: Fn(&mut A, usize, S) + Sync,
{
    let r = (taps / 2) as isize;
    let mut out = vec![A::default(); w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let line = &src[y * w..(y + 1) * w];
        for (x, o) in row.iter_mut().enumerate() {
            let mut acc = A::default();
            for k in 0..taps {
                let xx = (x as isize + k as isize - r).clamp(0, w as isize - 1) as usize;
                tap(&mut acc, k, line[xx]);
            }
            *o = acc;
        }
    });
    out
}

/// A separable filter's second pass for row `y`: down each column,
/// coordinates clamped to the column, taps added in order.
fn down_columns<S, A, F>(w: usize, h: usize, y: usize, src: &[S], taps: usize, tap: F) -> Vec<A>
where
    S: Copy,
    A: Copy + Default,
    F: Fn(&mut A, usize, S),
{
    let r = (taps / 2) as isize;
    let mut acc = vec![A::default(); w];
    for k in 0..taps {
        let yy = (y as isize + k as isize - r).clamp(0, h as isize - 1) as usize;
        for (a, &s) in acc.iter_mut().zip(&src[yy * w..(yy + 1) * w]) {
            tap(a, k, s);
        }
    }
    acc
}

/// LDR-FLIP of two linear RGB images (values in [0, 1]), per pixel.
fn ldr_flip_linear(
    w: usize,
    h: usize,
    reference: &[[f32; 3]],
    test: &[[f32; 3]],
    f: &Filters,
) -> Vec<f32> {
    let to_ycxcz = |img: &[[f32; 3]]| -> Vec<[f32; 3]> {
        img.par_iter()
            .map(|&c| xyz_to_ycxcz(rgb_to_xyz(c)))
            .collect()
    };
    let (r, t) = (to_ycxcz(reference), to_ycxcz(test));

    // Colour: the CSF filters, first along the rows (Y, Cx, and Cz by each
    // of its two Gaussians).
    let n = f.ycx.len();
    let csf_rows = |img: &[[f32; 3]]| {
        along_rows(w, h, img, n, |a: &mut [f32; 4], k, c: [f32; 3]| {
            let (p, q) = (f.ycx[k], f.cz[k]);
            a[0] += p[0] * c[0];
            a[1] += p[1] * c[1];
            a[2] += q[0] * c[2];
            a[3] += q[1] * c[2];
        })
    };
    let (r_rows, t_rows) = (csf_rows(&r), csf_rows(&t));

    // Features: the Y channel normalised to [0, 1], first along the rows
    // (first and second derivative and the Gaussian).
    let m = f.feature.len();
    let feature_rows = |img: &[[f32; 3]]| {
        along_rows(w, h, img, m, |a: &mut [f32; 3], k, c: [f32; 3]| {
            let g = f.feature[k];
            let v = c[0] * (1.0 / 116.0) + 16.0 / 116.0;
            a[0] += g[1] * v;
            a[1] += g[2] * v;
            a[2] += g[0] * v;
        })
    };
    let (rf_rows, tf_rows) = (feature_rows(&r), feature_rows(&t));

    let c_max = max_colour_distance();
    let pc_max = PC * c_max;
    let mut out = vec![0.0f32; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let csf_cols = |src: &[[f32; 4]]| {
            down_columns(w, h, y, src, n, |a: &mut [f32; 4], k, c: [f32; 4]| {
                let (p, q) = (f.ycx[k], f.cz[k]);
                a[0] += p[0] * c[0];
                a[1] += p[1] * c[1];
                a[2] += q[0] * c[2];
                a[3] += q[1] * c[3];
            })
        };
        let feature_cols = |src: &[[f32; 3]]| {
            down_columns(w, h, y, src, m, |a: &mut [f32; 4], k, c: [f32; 3]| {
                let g = f.feature[k];
                a[0] += g[0] * c[0]; // dx
                a[1] += g[0] * c[1]; // ddx
                a[2] += g[1] * c[2]; // dy
                a[3] += g[2] * c[2]; // ddy
            })
        };
        let (rc, tc) = (csf_cols(&r_rows), csf_cols(&t_rows));
        let (rf, tf) = (feature_cols(&rf_rows), feature_cols(&tf_rows));
        for x in 0..w {
            let lab = |a: [f32; 4]| {
                let rgb =
                    xyz_to_rgb(ycxcz_to_xyz([a[0], a[1], a[2] + a[3]])).map(|v| v.clamp(0.0, 1.0));
                hunt(xyz_to_lab(rgb_to_xyz(rgb)))
            };
            let mut de_c = hyab(lab(rc[x]), lab(tc[x])).powf(QC);
            de_c = if de_c < pc_max {
                de_c * (PT / pc_max)
            } else {
                PT + ((de_c - pc_max) / (c_max - pc_max)) * (1.0 - PT)
            };
            let (a, b) = (rf[x], tf[x]);
            let edge = |d: [f32; 4]| (d[0] * d[0] + d[2] * d[2]).sqrt();
            let point = |d: [f32; 4]| (d[1] * d[1] + d[3] * d[3]).sqrt();
            let d_edge = (edge(a) - edge(b)).abs();
            let d_point = (point(a) - point(b)).abs();
            let de_f = ((1.0 / 2.0f32.sqrt()) * d_edge.max(d_point)).powf(QF);
            row[x] = de_c.powf(1.0 - de_f);
        }
    });
    out
}

/// The magma colour map (matplotlib's, as FLIP tabulates it), 8-bit sRGB.
const MAGMA: [[u8; 3]; 256] = [
    [0, 0, 4],
    [1, 0, 5],
    [1, 1, 6],
    [1, 1, 8],
    [2, 1, 9],
    [2, 2, 11],
    [2, 2, 13],
    [3, 3, 15],
    [3, 3, 18],
    [4, 4, 20],
    [5, 4, 22],
    [6, 5, 24],
    [6, 5, 26],
    [7, 6, 28],
    [8, 7, 30],
    [9, 7, 32],
    [10, 8, 34],
    [11, 9, 36],
    [12, 9, 38],
    [13, 10, 41],
    [14, 11, 43],
    [16, 11, 45],
    [17, 12, 47],
    [18, 13, 49],
    [19, 13, 52],
    [20, 14, 54],
    [21, 14, 56],
    [22, 15, 59],
    [24, 15, 61],
    [25, 16, 63],
    [26, 16, 66],
    [28, 16, 68],
    [29, 17, 71],
    [30, 17, 73],
    [32, 17, 75],
    [33, 17, 78],
    [34, 17, 80],
    [36, 18, 83],
    [37, 18, 85],
    [39, 18, 88],
    [41, 17, 90],
    [42, 17, 92],
    [44, 17, 95],
    [45, 17, 97],
    [47, 17, 99],
    [49, 17, 101],
    [51, 16, 103],
    [52, 16, 105],
    [54, 16, 107],
    [56, 16, 108],
    [57, 15, 110],
    [59, 15, 112],
    [61, 15, 113],
    [63, 15, 114],
    [64, 15, 116],
    [66, 15, 117],
    [68, 15, 118],
    [69, 16, 119],
    [71, 16, 120],
    [73, 16, 120],
    [74, 16, 121],
    [76, 17, 122],
    [78, 17, 123],
    [79, 18, 123],
    [81, 18, 124],
    [82, 19, 124],
    [84, 19, 125],
    [86, 20, 125],
    [87, 21, 126],
    [89, 21, 126],
    [90, 22, 126],
    [92, 22, 127],
    [93, 23, 127],
    [95, 24, 127],
    [96, 24, 128],
    [98, 25, 128],
    [100, 26, 128],
    [101, 26, 128],
    [103, 27, 128],
    [104, 28, 129],
    [106, 28, 129],
    [107, 29, 129],
    [109, 29, 129],
    [110, 30, 129],
    [112, 31, 129],
    [114, 31, 129],
    [115, 32, 129],
    [117, 33, 129],
    [118, 33, 129],
    [120, 34, 129],
    [121, 34, 130],
    [123, 35, 130],
    [124, 35, 130],
    [126, 36, 130],
    [128, 37, 130],
    [129, 37, 129],
    [131, 38, 129],
    [132, 38, 129],
    [134, 39, 129],
    [136, 39, 129],
    [137, 40, 129],
    [139, 41, 129],
    [140, 41, 129],
    [142, 42, 129],
    [144, 42, 129],
    [145, 43, 129],
    [147, 43, 128],
    [148, 44, 128],
    [150, 44, 128],
    [152, 45, 128],
    [153, 45, 128],
    [155, 46, 127],
    [156, 46, 127],
    [158, 47, 127],
    [160, 47, 127],
    [161, 48, 126],
    [163, 48, 126],
    [165, 49, 126],
    [166, 49, 125],
    [168, 50, 125],
    [170, 51, 125],
    [171, 51, 124],
    [173, 52, 124],
    [174, 52, 123],
    [176, 53, 123],
    [178, 53, 123],
    [179, 54, 122],
    [181, 54, 122],
    [183, 55, 121],
    [184, 55, 121],
    [186, 56, 120],
    [188, 57, 120],
    [189, 57, 119],
    [191, 58, 119],
    [192, 58, 118],
    [194, 59, 117],
    [196, 60, 117],
    [197, 60, 116],
    [199, 61, 115],
    [200, 62, 115],
    [202, 62, 114],
    [204, 63, 113],
    [205, 64, 113],
    [207, 64, 112],
    [208, 65, 111],
    [210, 66, 111],
    [211, 67, 110],
    [213, 68, 109],
    [214, 69, 108],
    [216, 69, 108],
    [217, 70, 107],
    [219, 71, 106],
    [220, 72, 105],
    [222, 73, 104],
    [223, 74, 104],
    [224, 76, 103],
    [226, 77, 102],
    [227, 78, 101],
    [228, 79, 100],
    [229, 80, 100],
    [231, 82, 99],
    [232, 83, 98],
    [233, 84, 98],
    [234, 86, 97],
    [235, 87, 96],
    [236, 88, 96],
    [237, 90, 95],
    [238, 91, 94],
    [239, 93, 94],
    [240, 95, 94],
    [241, 96, 93],
    [242, 98, 93],
    [242, 100, 92],
    [243, 101, 92],
    [244, 103, 92],
    [244, 105, 92],
    [245, 107, 92],
    [246, 108, 92],
    [246, 110, 92],
    [247, 112, 92],
    [247, 114, 92],
    [248, 116, 92],
    [248, 118, 92],
    [249, 120, 93],
    [249, 121, 93],
    [249, 123, 93],
    [250, 125, 94],
    [250, 127, 94],
    [250, 129, 95],
    [251, 131, 95],
    [251, 133, 96],
    [251, 135, 97],
    [252, 137, 97],
    [252, 138, 98],
    [252, 140, 99],
    [252, 142, 100],
    [252, 144, 101],
    [253, 146, 102],
    [253, 148, 103],
    [253, 150, 104],
    [253, 152, 105],
    [253, 154, 106],
    [253, 155, 107],
    [254, 157, 108],
    [254, 159, 109],
    [254, 161, 110],
    [254, 163, 111],
    [254, 165, 113],
    [254, 167, 114],
    [254, 169, 115],
    [254, 170, 116],
    [254, 172, 118],
    [254, 174, 119],
    [254, 176, 120],
    [254, 178, 122],
    [254, 180, 123],
    [254, 182, 124],
    [254, 183, 126],
    [254, 185, 127],
    [254, 187, 129],
    [254, 189, 130],
    [254, 191, 132],
    [254, 193, 133],
    [254, 194, 135],
    [254, 196, 136],
    [254, 198, 138],
    [254, 200, 140],
    [254, 202, 141],
    [254, 204, 143],
    [254, 205, 144],
    [254, 207, 146],
    [254, 209, 148],
    [254, 211, 149],
    [254, 213, 151],
    [254, 215, 153],
    [254, 216, 154],
    [253, 218, 156],
    [253, 220, 158],
    [253, 222, 160],
    [253, 224, 161],
    [253, 226, 163],
    [253, 227, 165],
    [253, 229, 167],
    [253, 231, 169],
    [253, 233, 170],
    [253, 235, 172],
    [252, 236, 174],
    [252, 238, 176],
    [252, 240, 178],
    [252, 242, 180],
    [252, 244, 182],
    [252, 246, 184],
    [252, 247, 185],
    [252, 249, 187],
    [252, 251, 189],
    [252, 253, 191],
];

#[cfg(test)]
mod tests {
    use super::*;

    fn uniform(w: usize, h: usize, v: f32, hdr: bool) -> MetricImage {
        let mut img = MetricImage::from_display(w, h, vec![v; w * h * 3]);
        img.hdr = hdr;
        img
    }

    #[test]
    fn the_default_viewing_condition_is_the_references() {
        // flip-evaluator 1.7 reports ppd 67.02064514160156.
        let o = FlipOptions::default();
        assert_eq!(o.pixels_per_degree, 67.020_645_141_601_56);
        assert_eq!(o.tone_mapper, ToneMapper::Aces);
        let f = Filters::new(o.pixels_per_degree as f32);
        assert_eq!((f.ycx.len(), f.feature.len()), (21, 19));
    }

    #[test]
    fn identical_images_give_zero_everywhere() {
        let w = 23;
        let h = 17;
        let rgb: Vec<f32> = (0..w * h * 3)
            .map(|i| (i * 37 % 101) as f32 / 100.0)
            .collect();
        let a = MetricImage::from_display(w, h, rgb.clone());
        let m = ldr_flip(&a, &a, &FlipOptions::default()).unwrap();
        assert!(m.v.iter().all(|&v| v == 0.0));
        assert_eq!(m.mean, 0.0);
        let mut b = MetricImage::from_display(w, h, rgb.iter().map(|v| v * 5.0).collect());
        b.hdr = true;
        let m = hdr_flip(&b, &b, &FlipOptions::default()).unwrap();
        assert!(m.v.iter().all(|&v| v == 0.0));
        assert!(m.exposures.is_some());
    }

    #[test]
    fn black_against_white_matches_the_reference() {
        // flip_evaluator 1.7: evaluate(zeros, ones, "LDR") on 32×32 gives
        // 0.9673883318901062 at every pixel (its own mean, summed in f32,
        // says 0.9673951268196106).
        let m = ldr_flip(
            &uniform(32, 32, 0.0, false),
            &uniform(32, 32, 1.0, false),
            &FlipOptions::default(),
        )
        .unwrap();
        assert!(m.v.iter().all(|&v| v == 0.967_388_33), "{:?}", &m.v[..4]);
        assert!(
            (m.mean - 0.967_388_331_890_106_2).abs() < 1e-7,
            "{}",
            m.mean
        );
    }

    #[test]
    fn hdr_uniform_images_match_the_reference() {
        // flip_evaluator 1.7: evaluate(0.5, 2.0, "HDR") on 32×32 gives
        // 0.19163233041763306 at every pixel (its own mean, summed in f32:
        // 0.19163411855697632), exposures 2.0832972526550293 to the same, 2
        // of them.
        let m = hdr_flip(
            &uniform(32, 32, 0.5, true),
            &uniform(32, 32, 2.0, true),
            &FlipOptions::default(),
        )
        .unwrap();
        assert!(
            (m.mean - 0.191_632_330_417_633_06).abs() < 1e-7,
            "{}",
            m.mean
        );
        let e = m.exposures.unwrap();
        assert!((e.start - 2.083_297_252_655_029_3).abs() < 1e-6);
        assert_eq!((e.start, e.count), (e.stop, 2));
    }

    #[test]
    fn different_sizes_and_bad_options_are_errors() {
        let e = ldr_flip(
            &uniform(4, 4, 0.0, false),
            &uniform(5, 4, 0.0, false),
            &FlipOptions::default(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("must have the same size"), "{e}");
        let o = FlipOptions {
            start_exposure: Some(2.0),
            stop_exposure: Some(1.0),
            ..FlipOptions::default()
        };
        let a = uniform(4, 4, 1.0, true);
        let e = hdr_flip(&a, &a, &o).unwrap_err();
        assert!(e.to_string().contains("must not exceed"), "{e}");
        let black = uniform(4, 4, 0.0, true);
        let e = hdr_flip(&black, &black, &FlipOptions::default()).unwrap_err();
        assert!(e.to_string().contains("not finite"), "{e}");
    }

    #[test]
    fn the_magma_map_spans_dark_purple_to_light_yellow() {
        let m = FlipMap {
            width: 2,
            height: 1,
            v: vec![0.0, 1.0],
            mean: 0.5,
            exposures: None,
        };
        let img = m.magma();
        assert_eq!(img.get_pixel(0, 0).0, [0, 0, 4]);
        assert_eq!(img.get_pixel(1, 0).0, [252, 253, 191]);
    }
}
