//! CW-SSIM, the complex wavelet structural similarity of Wang and
//! Simoncelli (2005) as Sampat et al. (2009) define it and as their MATLAB
//! `cwssim_index` computes it — the score the paper reports (Tables 4, 5).
//!
//! Both grey images are decomposed by a complex steerable pyramid built in
//! the Fourier domain (Portilla and Simoncelli's `buildSCFpyr`: raised-
//! cosine radial masks one octave wide, `or` analytic orientation masks
//! `cos^(or−1)` of one lobe). Only the bands of level `level` are used. Per
//! orientation, with `c1`, `c2` the two images' coefficients:
//!
//! `cssim = (2·|Σ_w c1·c2*| + K) / (Σ_w |c1|² + Σ_w |c2|² + K)`
//!
//! over 7×7 local windows `w` (a box, "valid" positions only), and the
//! band's score is the map's mean weighted by a Gaussian of standard
//! deviation a quarter of the band's height centred on the band; the
//! score is the mean over orientations. With `K = 0` the score does not
//! depend on the images' scale.

use super::GreyImage;
use crate::error::{Error, Result};
use plsr_base::Vocabulary;
use rustfft::num_complex::Complex64;
use rustfft::FftPlanner;
use std::f64::consts::PI;

/// CW-SSIM's settings; the defaults are `cwssim_index`'s usual ones.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CwSsimOptions {
    /// Pyramid levels; the bands of the last (coarsest) level are compared.
    pub level: u32,
    /// Orientations per level.
    pub orientations: u32,
    /// Border, in pixels of the full image, left out of each band
    /// (divided by `2^(level−1)`).
    pub guard: u32,
    /// Stabilising constant `K` (0: scale invariant).
    pub k: f64,
}

impl Default for CwSsimOptions {
    fn default() -> Self {
        CwSsimOptions {
            level: 4,
            orientations: 8,
            guard: 0,
            k: 0.0,
        }
    }
}

/// Side of the local windows.
const WINDOW: usize = 7;

/// A complex image, row-major.
struct Spectrum {
    w: usize,
    h: usize,
    v: Vec<Complex64>,
}

/// The CW-SSIM of two grey images of the same size (1 when identical).
pub fn cwssim(a: &GreyImage, b: &GreyImage, options: &CwSsimOptions) -> Result<f64> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(Error::invalid_argument(format!(
            "CW-SSIM: the images differ in size ({}×{} and {}×{})",
            a.width, a.height, b.width, b.height
        )));
    }
    if options.orientations == 0 || options.level == 0 {
        return Err(Error::invalid_argument(
            "CW-SSIM: level and orientations must be at least 1",
        ));
    }
    let smallest = a.width.min(a.height);
    let most = (smallest.max(1) as f64).log2().floor() as i64 - 2;
    if options.level as i64 > most {
        return Err(Error::invalid_argument(format!(
            "CW-SSIM: a {}×{} image holds at most {} pyramid level{}, {} asked for \
             (crop less tightly, lower --cwssim-level, or leave CW-SSIM out with --metric)",
            a.width,
            a.height,
            most.max(0),
            if most == 1 { "" } else { "s" },
            options.level
        )));
    }
    // The two pyramids are independent: build them side by side.
    let (pa, pb) = rayon::join(|| bands(a, options), || bands(b, options));
    let (bw, bh) = (pa[0].w, pa[0].h);
    let gb = (options.guard >> (options.level - 1)) as usize;
    if bw < 2 * gb + WINDOW || bh < 2 * gb + WINDOW {
        return Err(Error::invalid_argument(format!(
            "CW-SSIM: the level-{} bands ({bw}×{bh}) are too small for 7×7 windows{}",
            options.level,
            if gb > 0 {
                " inside the guard border"
            } else {
                ""
            }
        )));
    }
    let (cw, ch) = (bw - 2 * gb, bh - 2 * gb);
    let (mw, mh) = (cw - WINDOW + 1, ch - WINDOW + 1);
    // The Gaussian weights (MATLAB's fspecial('gaussian', size, σ) with
    // σ = the band's height / 4), normalised to sum 1.
    let sigma = bh as f64 / 4.0;
    let mut weights = vec![0.0; mw * mh];
    for y in 0..mh {
        for x in 0..mw {
            let dy = y as f64 - (mh as f64 - 1.0) / 2.0;
            let dx = x as f64 - (mw as f64 - 1.0) / 2.0;
            weights[y * mw + x] = (-(dx * dx + dy * dy) / (2.0 * sigma * sigma)).exp();
        }
    }
    let peak = weights.iter().copied().fold(0.0, f64::max);
    for v in &mut weights {
        if *v < f64::EPSILON * peak {
            *v = 0.0;
        }
    }
    let total: f64 = weights.iter().sum();
    weights.iter_mut().for_each(|v| *v /= total);
    let mut score = 0.0;
    for (s1, s2) in pa.iter().zip(&pb) {
        let mut corr = vec![Complex64::default(); cw * ch];
        let mut var = vec![0.0; cw * ch];
        for y in 0..ch {
            for x in 0..cw {
                let i = (y + gb) * bw + x + gb;
                let (c1, c2) = (s1.v[i], s2.v[i]);
                corr[y * cw + x] = c1 * c2.conj();
                var[y * cw + x] = c1.norm_sqr() + c2.norm_sqr();
            }
        }
        let corr = box_valid(&corr, cw, ch);
        let var = box_valid(&var, cw, ch);
        let mut band = 0.0;
        for i in 0..mw * mh {
            let map = (2.0 * corr[i].norm() + options.k) / (var[i] + options.k);
            band += map * weights[i];
        }
        score += band;
    }
    Ok(score / options.orientations as f64)
}

/// The mean of each 7×7 window lying wholly inside a `w`×`h` image
/// (MATLAB's `filter2(ones(7)/49, x, 'valid')`).
fn box_valid<T>(x: &[T], w: usize, h: usize) -> Vec<T>
where
    T: Copy + Default + std::ops::Add<Output = T> + std::ops::Sub<Output = T> + Scale,
{
    let (mw, mh) = (w - WINDOW + 1, h - WINDOW + 1);
    // Sums along rows, then along columns (running sums).
    let mut rows = vec![T::default(); mw * h];
    for y in 0..h {
        let r = &x[y * w..(y + 1) * w];
        let mut s = T::default();
        for v in &r[..WINDOW] {
            s = s + *v;
        }
        rows[y * mw] = s;
        for k in 1..mw {
            s = s + r[k + WINDOW - 1] - r[k - 1];
            rows[y * mw + k] = s;
        }
    }
    let mut out = vec![T::default(); mw * mh];
    for k in 0..mw {
        let mut s = T::default();
        for y in 0..WINDOW {
            s = s + rows[y * mw + k];
        }
        out[k] = s.scale(1.0 / (WINDOW * WINDOW) as f64);
        for y in 1..mh {
            s = s + rows[(y + WINDOW - 1) * mw + k] - rows[(y - 1) * mw + k];
            out[y * mw + k] = s.scale(1.0 / (WINDOW * WINDOW) as f64);
        }
    }
    out
}

/// Multiplication by a real number.
trait Scale {
    fn scale(self, k: f64) -> Self;
}
impl Scale for f64 {
    fn scale(self, k: f64) -> f64 {
        self * k
    }
}
impl Scale for Complex64 {
    fn scale(self, k: f64) -> Complex64 {
        self * k
    }
}

/// MATLAB's `pointOp`: linear interpolation in the table `lut` sampled at
/// `origin + k·step`, the end segments extended.
fn point_op(v: f64, lut: &[f64], origin: f64, step: f64) -> f64 {
    let pos = (v - origin) / step;
    let k = (pos as i64).clamp(0, lut.len() as i64 - 2) as usize;
    lut[k] + (lut[k + 1] - lut[k]) * (pos - k as f64)
}

/// The raised-cosine transition of `buildSCFpyr` (`rcosFn(1, −½, [0, 1])`):
/// its abscissae' origin and step, and its square root (the high-pass
/// side) and complement (the low-pass side).
struct Transition {
    origin: f64,
    step: f64,
    high: Vec<f64>,
    low: Vec<f64>,
}

impl Transition {
    fn new() -> Transition {
        let sz = 256i64;
        let xs: Vec<f64> = (-sz - 1..=1)
            .map(|k| PI * k as f64 / (2.0 * sz as f64))
            .collect();
        let mut y: Vec<f64> = xs.iter().map(|x| x.cos().powi(2)).collect();
        let n = y.len();
        y[0] = y[1];
        y[n - 1] = y[n - 2];
        let x0 = -0.5 + (2.0 / PI) * (xs[0] + PI / 4.0);
        let x1 = -0.5 + (2.0 / PI) * (xs[1] + PI / 4.0);
        let high: Vec<f64> = y.iter().map(|v| v.sqrt()).collect();
        let low = high.iter().map(|v| (1.0 - v * v).sqrt().abs()).collect();
        Transition {
            origin: x0,
            step: x1 - x0,
            high,
            low,
        }
    }
}

/// The `or` complex bands of level `level` of the image's steerable
/// pyramid.
fn bands(img: &GreyImage, options: &CwSsimOptions) -> Vec<Spectrum> {
    let (w, h) = (img.width, img.height);
    let mut planner = FftPlanner::<f64>::new();
    // The centred spectrum (fftshift(fft2(im))).
    let mut s = Spectrum {
        w,
        h,
        v: img.v.iter().map(|&g| Complex64::new(g, 0.0)).collect(),
    };
    fft2(&mut planner, &mut s, false);
    let mut s = shift(&s, false);
    // Polar frequency coordinates of each (shifted) position: log₂ radius
    // and angle, with MATLAB's centre and its patched zero frequency.
    let (cx, cy) = (w / 2, h / 2);
    let mut log_rad = vec![0.0; w * h];
    let mut angle = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let xr = (x as f64 - cx as f64) / (w as f64 / 2.0);
            let yr = (y as f64 - cy as f64) / (h as f64 / 2.0);
            angle[y * w + x] = yr.atan2(xr);
            log_rad[y * w + x] = (xr * xr + yr * yr).sqrt();
        }
    }
    log_rad[cy * w + cx] = log_rad[cy * w + cx.saturating_sub(1)];
    for r in &mut log_rad {
        *r = r.log2();
    }
    let t = Transition::new();
    // lo0: the low-pass residual of the first split.
    for (c, r) in s.v.iter_mut().zip(&log_rad) {
        *c *= point_op(*r, &t.low, t.origin, t.step);
    }
    let nbands = options.orientations as usize;
    let order = nbands - 1;
    // Angular masks: 2·√const·cos^order of one lobe (analytic bands).
    let lutsize = 1024i64;
    let xcosn: Vec<f64> = (-(2 * lutsize + 1)..=lutsize + 1)
        .map(|k| PI * k as f64 / lutsize as f64)
        .collect();
    let factorial = |n: usize| (1..=n).map(|k| k as f64).product::<f64>();
    let constant = 2f64.powi(2 * order as i32) * factorial(order).powi(2)
        / (nbands as f64 * factorial(2 * order));
    let ycosn: Vec<f64> = xcosn
        .iter()
        .map(|&x| {
            let alfa = (PI + x).rem_euclid(2.0 * PI) - PI;
            if alfa.abs() < PI / 2.0 {
                2.0 * constant.sqrt() * x.cos().powi(order as i32)
            } else {
                0.0
            }
        })
        .collect();
    let cstep = xcosn[1] - xcosn[0];
    // (−i)^(nbands−1)
    let phase = (0..order).fold(Complex64::new(1.0, 0.0), |p, _| {
        p * Complex64::new(0.0, -1.0)
    });
    let mut origin = t.origin;
    for level in 1..=options.level {
        origin -= 1.0;
        if level == options.level {
            let mut out = Vec::with_capacity(nbands);
            for b in 0..nbands {
                let aorigin = xcosn[0] + PI * b as f64 / nbands as f64;
                let mut band = Spectrum {
                    w: s.w,
                    h: s.h,
                    v: Vec::with_capacity(s.v.len()),
                };
                for i in 0..s.v.len() {
                    let am = point_op(angle[i], &ycosn, aorigin, cstep);
                    let hm = point_op(log_rad[i], &t.high, origin, t.step);
                    band.v.push(phase * s.v[i] * (am * hm));
                }
                let mut band = shift(&band, true);
                fft2(&mut planner, &mut band, true);
                out.push(band);
            }
            return out;
        }
        // Down one octave: keep the centre half of the spectrum, low-pass.
        let (lw, lh) = (s.w.div_ceil(2), s.h.div_ceil(2));
        let start = |d: usize, l: usize| -> usize {
            let ctr = (2 * d + 1).div_ceil(4); // ceil((d + 0.5) / 2)
            let loctr = (2 * l + 1).div_ceil(4);
            ctr - loctr
        };
        let (sx, sy) = (start(s.w, lw), start(s.h, lh));
        let mut v = Vec::with_capacity(lw * lh);
        let mut r2 = Vec::with_capacity(lw * lh);
        let mut a2 = Vec::with_capacity(lw * lh);
        for y in sy..sy + lh {
            for x in sx..sx + lw {
                let i = y * s.w + x;
                v.push(s.v[i] * point_op(log_rad[i], &t.low, origin, t.step));
                r2.push(log_rad[i]);
                a2.push(angle[i]);
            }
        }
        s = Spectrum { w: lw, h: lh, v };
        log_rad = r2;
        angle = a2;
    }
    unreachable!("the loop returns at the last level")
}

/// MATLAB's `fftshift` (`inverse`: `ifftshift`) of a 2-D array.
fn shift(s: &Spectrum, inverse: bool) -> Spectrum {
    let (w, h) = (s.w, s.h);
    let (ox, oy) = if inverse {
        (w.div_ceil(2), h.div_ceil(2))
    } else {
        (w / 2, h / 2)
    };
    let mut v = vec![Complex64::default(); w * h];
    for y in 0..h {
        for x in 0..w {
            v[((y + oy) % h) * w + (x + ox) % w] = s.v[y * w + x];
        }
    }
    Spectrum { w, h, v }
}

/// The 2-D DFT in place (`inverse`: divided by the number of samples, as
/// MATLAB's `ifft2`).
fn fft2(planner: &mut FftPlanner<f64>, s: &mut Spectrum, inverse: bool) {
    let (w, h) = (s.w, s.h);
    let row = if inverse {
        planner.plan_fft_inverse(w)
    } else {
        planner.plan_fft_forward(w)
    };
    row.process(&mut s.v);
    let col = if inverse {
        planner.plan_fft_inverse(h)
    } else {
        planner.plan_fft_forward(h)
    };
    let mut column = vec![Complex64::default(); h];
    for x in 0..w {
        for (y, c) in column.iter_mut().enumerate() {
            *c = s.v[y * w + x];
        }
        col.process(&mut column);
        for (y, c) in column.iter().enumerate() {
            s.v[y * w + x] = *c;
        }
    }
    if inverse {
        let k = 1.0 / (w * h) as f64;
        s.v.iter_mut().for_each(|c| *c *= k);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noise(w: usize, h: usize, seed: u64) -> GreyImage {
        let mut state = seed;
        let v = (0..w * h)
            .map(|_| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((state >> 33) % 256) as f64
            })
            .collect();
        GreyImage {
            width: w,
            height: h,
            v,
        }
    }

    #[test]
    fn identical_images_score_one_and_scaling_both_changes_nothing() {
        let a = noise(96, 80, 1);
        let o = CwSsimOptions::default();
        assert!((cwssim(&a, &a, &o).unwrap() - 1.0).abs() < 1e-12);
        let b = noise(96, 80, 2);
        let s = cwssim(&a, &b, &o).unwrap();
        assert!(s < 0.9, "{s}");
        let half = |g: &GreyImage| GreyImage {
            v: g.v.iter().map(|v| 0.5 * v).collect(),
            ..g.clone()
        };
        assert!((cwssim(&half(&a), &half(&b), &o).unwrap() - s).abs() < 1e-9);
    }

    #[test]
    fn the_pyramid_band_is_analytic_and_oriented() {
        // A vertical grating: its energy lands in the horizontal-frequency
        // band (b = 0) and not in the one at 90°.
        let (w, h) = (64, 64);
        let v = (0..w * h)
            .map(|i| (2.0 * PI * (i % w) as f64 / 8.0).cos())
            .collect();
        let img = GreyImage {
            width: w,
            height: h,
            v,
        };
        let o = CwSsimOptions {
            level: 2,
            orientations: 4,
            ..CwSsimOptions::default()
        };
        let b = bands(&img, &o);
        let energy: Vec<f64> = b
            .iter()
            .map(|s| s.v.iter().map(|c| c.norm_sqr()).sum())
            .collect();
        assert!(energy[0] > 1e3 * energy[2], "{energy:?}");
    }

    #[test]
    fn too_small_images_are_a_clear_error() {
        let a = noise(20, 20, 1);
        let e = cwssim(&a, &a, &CwSsimOptions::default()).unwrap_err();
        assert!(e.to_string().contains("at most 2 pyramid levels"), "{e}");
    }
}
