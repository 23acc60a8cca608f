//! Translation alignment of brackets by median threshold bitmaps (Ward 2003).
//!
//! Each bracket is reduced to an 8-bit grey image. Brackets are aligned in
//! a chain, each to its neighbour in exposure, outward from the middle
//! bracket, and the shifts are summed: neighbours (a stop or two apart)
//! show the same parts of the scene unclipped, which the shortest and the
//! longest exposure and the middle one need not. A pair is compared through
//! threshold bitmaps ("brighter than the threshold") at nine thresholds
//! taken at the same quantiles of both images, spread over the quantiles
//! that are neither black nor clipped in either: the same quantile is the
//! same scene radiance in both, whatever their exposures. Pixels within a
//! tolerance of a threshold (±4 levels, more where the image is noisier)
//! are excluded. The search runs on an image pyramid, coarse to fine, over
//! the shifts within ±2 of the doubled coarser shift, minimising the
//! fraction of disagreeing pixels among those compared. A pair with too
//! little common detail, or whose best shift is not clearly better than
//! none, keeps the shift (0, 0). Only whole-pixel translations are found.

use super::oiio::ImageReader;
use crate::error::Result;
use rayon::prelude::*;

/// An 8-bit grey image.
#[derive(Debug, Clone)]
pub struct Grey {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Row-major grey levels.
    pub data: Vec<u8>,
}

/// Rows read per band when building a grey image.
const BAND: usize = 64;

/// Reads `reader`'s image as 8-bit grey (Ward's weights 54/183/19 of 256 on
/// the first three channels; the first channel for fewer), band by band.
pub fn read_grey(reader: &mut ImageReader) -> Result<Grey> {
    let info = reader.info().clone();
    let (w, h, ch) = (info.width, info.height, info.channels);
    let mut data = vec![0u8; w * h];
    let mut buf = Vec::new();
    let mut y0 = 0;
    while y0 < h {
        let y1 = (y0 + BAND).min(h);
        buf.resize((y1 - y0) * w * ch, 0u8);
        reader.read_rows(y0, y1, &mut buf)?;
        for (k, px) in buf.chunks_exact(ch).enumerate() {
            data[y0 * w + k] = if ch >= 3 {
                ((54 * px[0] as u32 + 183 * px[1] as u32 + 19 * px[2] as u32) >> 8) as u8
            } else {
                px[0]
            };
        }
        y0 = y1;
    }
    Ok(Grey {
        width: w,
        height: h,
        data,
    })
}

fn shrink(g: &Grey) -> Grey {
    let (w, h) = ((g.width / 2).max(1), (g.height / 2).max(1));
    let mut data = vec![0u8; w * h];
    for y in 0..h {
        for x in 0..w {
            let at = |xx: usize, yy: usize| {
                g.data[yy.min(g.height - 1) * g.width + xx.min(g.width - 1)] as u32
            };
            let s = at(2 * x, 2 * y)
                + at(2 * x + 1, 2 * y)
                + at(2 * x, 2 * y + 1)
                + at(2 * x + 1, 2 * y + 1);
            data[y * w + x] = ((s + 2) / 4) as u8;
        }
    }
    Grey {
        width: w,
        height: h,
        data,
    }
}

fn histogram(g: &Grey) -> [usize; 256] {
    let mut hist = [0usize; 256];
    for &v in &g.data {
        hist[v as usize] += 1;
    }
    hist
}

/// Levels at or below this are black (or crushed noise).
const BLACK: usize = 4;
/// Levels at or above this are clipped.
const CLIPPED: usize = 251;
/// Thresholds (bitmaps) compared per pair.
const THRESHOLDS: usize = 9;
/// A pair whose quantiles unclipped in both images span less than this
/// fraction of the pixels is not aligned.
const MIN_COMMON: f64 = 0.05;
/// Shifts searched around the doubled coarser shift, each way.
const RADIUS: i32 = 2;
/// Smallest exclusion tolerance, in grey levels (Ward's and OpenCV's 4).
const MIN_TOLERANCE: u32 = 4;
/// Tolerance in noise standard deviations.
const NOISE_TOLERANCE: f64 = 2.0;
/// Levels around a threshold whose pixels estimate the noise there.
const NOISE_BAND: i32 = 16;
/// A non-zero shift must lower the disagreements of (0, 0) by this many
/// standard deviations (binomial) to be kept.
const SIGNIFICANCE: f64 = 4.0;

/// The grey level at quantile `p` of an image of `n` pixels.
fn quantile_level(hist: &[usize; 256], n: usize, p: f64) -> u8 {
    let rank = ((n as f64 * p) as usize).min(n.saturating_sub(1));
    let mut acc = 0;
    for (v, count) in hist.iter().enumerate() {
        acc += count;
        if acc > rank {
            return v as u8;
        }
    }
    255
}

/// Absolute second differences along rows (capped at 255) per level of
/// the centre pixel: row `c` of this 256×256 table counts them for the
/// pixels of level `c`.
fn second_differences(g: &Grey) -> Vec<u32> {
    let w = g.width;
    let add = |mut table: Vec<u32>, row: &[u8]| {
        for x in 1..w.saturating_sub(1) {
            let c = row[x] as i32;
            let d = (row[x - 1] as i32 + row[x + 1] as i32 - 2 * c).unsigned_abs();
            table[(c as usize) << 8 | d.min(255) as usize] += 1;
        }
        table
    };
    g.data
        .par_chunks(w.max(1))
        .fold(|| vec![0u32; 256 * 256], add)
        .reduce(
            || vec![0u32; 256 * 256],
            |mut a, b| {
                a.iter_mut().zip(&b).for_each(|(a, b)| *a += b);
                a
            },
        )
}

/// Exclusion tolerance around threshold `t`: `NOISE_TOLERANCE` times the
/// noise of the pixels within `NOISE_BAND` levels of it, estimated from the
/// median absolute second difference along rows (`table`, see
/// [`second_differences`]; it ignores smooth gradients, and for white
/// noise of deviation σ it is 1.652 σ), at least `MIN_TOLERANCE`.
fn tolerance(table: &[u32], t: u8) -> u32 {
    let lo = (t as i32 - NOISE_BAND).max(0) as usize;
    let hi = (t as i32 + NOISE_BAND).min(255) as usize;
    let mut hist = [0u64; 256];
    for c in lo..=hi {
        for (h, &n) in hist.iter_mut().zip(&table[c << 8..(c + 1) << 8]) {
            *h += n as u64;
        }
    }
    let count: u64 = hist.iter().sum();
    if count < 64 {
        return MIN_TOLERANCE;
    }
    let mut acc = 0;
    let mut median = 0;
    for (d, n) in hist.iter().enumerate() {
        acc += n;
        if 2 * acc > count {
            median = d;
            break;
        }
    }
    let sigma = median as f64 / 1.652;
    ((NOISE_TOLERANCE * sigma).ceil() as u32).max(MIN_TOLERANCE)
}

/// A bitmap of `w`×`h` pixels packed 64 to a word, row by row (bit `x % 64`
/// of word `x / 64` of its row); bits past the width are 0.
struct Plane {
    words: usize,
    bits: Vec<u64>,
}

impl Plane {
    fn row(&self, y: usize) -> &[u64] {
        &self.bits[y * self.words..(y + 1) * self.words]
    }
}

/// Threshold and inclusion bitmaps of one image at one threshold.
struct Bitmaps {
    above: Plane,
    include: Plane,
}

/// The bitmaps of `g` at the levels of quantiles `ps`: above the threshold,
/// and farther from it than its tolerance.
fn bitmaps(g: &Grey, ps: &[f64]) -> Vec<Bitmaps> {
    let hist = histogram(g);
    let table = second_differences(g);
    let (w, h) = (g.width, g.height);
    let words = w.div_ceil(64);
    ps.iter()
        .map(|&p| {
            let t = quantile_level(&hist, g.data.len(), p);
            let tol = tolerance(&table, t);
            let mut above = vec![0u64; words * h];
            let mut include = vec![0u64; words * h];
            above
                .par_chunks_mut(words.max(1))
                .zip(include.par_chunks_mut(words.max(1)))
                .zip(g.data.par_chunks(w.max(1)))
                .for_each(|((above, include), row)| {
                    for ((a, e), px) in above.iter_mut().zip(include.iter_mut()).zip(row.chunks(64))
                    {
                        let (mut wa, mut we) = (0u64, 0u64);
                        for (k, &v) in px.iter().enumerate() {
                            wa |= ((v > t) as u64) << k;
                            we |= ((v.abs_diff(t) as u32 > tol) as u64) << k;
                        }
                        (*a, *e) = (wa, we);
                    }
                });
            Bitmaps {
                above: Plane { words, bits: above },
                include: Plane {
                    words,
                    bits: include,
                },
            }
        })
        .collect()
}

/// `out` = row `src` moved right by `dx` pixels (bit `x` of `out` is bit
/// `x − dx` of `src`, 0 outside it).
fn shift_row(src: &[u64], dx: i32, out: &mut [u64]) {
    let n = src.len() as i64;
    let (q, r) = (dx.div_euclid(64) as i64, dx.rem_euclid(64));
    let at = |k: i64| {
        if (0..n).contains(&k) {
            src[k as usize]
        } else {
            0
        }
    };
    if r == 0 {
        for (k, o) in out.iter_mut().enumerate() {
            *o = at(k as i64 - q);
        }
    } else {
        for (k, o) in out.iter_mut().enumerate() {
            let k = k as i64 - q;
            *o = (at(k) << r) | (at(k - 1) >> (64 - r));
        }
    }
}

/// Disagreeing and compared pixels (summed over the thresholds) of `w`×`h`
/// bitmaps when `b` is shifted by `(dx, dy)` (pixel `(x, y)` of the shifted
/// bitmap is `b(x − dx, y − dy)`; pixels shifted in from outside are not
/// compared).
fn error(w: usize, h: usize, a: &[Bitmaps], b: &[Bitmaps], dx: i32, dy: i32) -> (u64, u64) {
    let words = w.div_ceil(64);
    let (mut above, mut include) = (vec![0u64; words], vec![0u64; words]);
    let (mut bad, mut compared) = (0u64, 0u64);
    for (ma, mb) in a.iter().zip(b) {
        for y in 0..h as i32 {
            let sy = y - dy;
            if sy < 0 || sy >= h as i32 {
                continue;
            }
            shift_row(mb.above.row(sy as usize), dx, &mut above);
            shift_row(mb.include.row(sy as usize), dx, &mut include);
            let (ta, ea) = (ma.above.row(y as usize), ma.include.row(y as usize));
            for k in 0..words {
                let both = ea[k] & include[k];
                bad += ((ta[k] ^ above[k]) & both).count_ones() as u64;
                compared += both.count_ones() as u64;
            }
        }
    }
    (bad, compared)
}

/// Whether `x` = (disagreeing, compared) has a lower disagreement rate than
/// `y`; nothing compared is worst.
fn lower_rate(x: (u64, u64), y: (u64, u64)) -> bool {
    if x.1 == 0 {
        return false;
    }
    if y.1 == 0 {
        return true;
    }
    (x.0 as u128) * (y.1 as u128) < (y.0 as u128) * (x.1 as u128)
}

/// The quantiles to threshold a pair at: `THRESHOLDS` of them spread evenly
/// over the quantiles that are neither black (levels ≤ 4) nor clipped
/// (≥ 251) in either image, so that each threshold is the same scene
/// radiance in both and lies where both images show detail (Ward 2003
/// suggests percentiles other than the median for under- and over-exposed
/// images). `None` when that range holds less than `MIN_COMMON` of the
/// pixels: too little in common to align.
fn pair_quantiles(a: &Grey, b: &Grey) -> Option<Vec<f64>> {
    let range = |g: &Grey| {
        let hist = histogram(g);
        let n = g.data.len().max(1) as f64;
        let black = hist[..=BLACK].iter().sum::<usize>() as f64 / n;
        let clipped = hist[CLIPPED..].iter().sum::<usize>() as f64 / n;
        (black, 1.0 - clipped)
    };
    let (la, ha) = range(a);
    let (lb, hb) = range(b);
    let (lo, hi) = (la.max(lb), ha.min(hb));
    if hi - lo < MIN_COMMON {
        return None;
    }
    Some(
        (0..THRESHOLDS)
            .map(|k| lo + (hi - lo) * (k as f64 + 0.5) / THRESHOLDS as f64)
            .collect(),
    )
}

/// The translation `(dx, dy)` in pixels that aligns `image` with
/// `reference` (pixel `(x, y)` of the reference matches `image(x − dx,
/// y − dy)`), searched on `levels` pyramid levels below the full size (up
/// to `2^(levels + 2) − 2` pixels each way). `(0, 0)` for images of
/// different sizes, for a pair with too little detail in common, and when
/// the best shift found is not clearly better than none. Meant for images
/// of neighbouring exposures (see [`stack_shifts`]).
pub fn mtb_shift(reference: &Grey, image: &Grey, levels: u32) -> (i32, i32) {
    if reference.width != image.width || reference.height != image.height {
        return (0, 0);
    }
    let Some(ps) = pair_quantiles(reference, image) else {
        return (0, 0);
    };
    let (w, h) = (reference.width, reference.height);
    // Returns the shift and the level's bitmaps (kept for the final test).
    fn rec(a: &Grey, b: &Grey, ps: &[f64], level: u32) -> ((i32, i32), Vec<Bitmaps>, Vec<Bitmaps>) {
        let (cx, cy) = if level > 0 && a.width >= 32 && a.height >= 32 {
            let ((x, y), _, _) = rec(&shrink(a), &shrink(b), ps, level - 1);
            (2 * x, 2 * y)
        } else {
            (0, 0)
        };
        let (ba, bb) = (bitmaps(a, ps), bitmaps(b, ps));
        let candidates: Vec<(i32, i32)> = (-RADIUS..=RADIUS)
            .flat_map(|j| (-RADIUS..=RADIUS).map(move |i| (cx + i, cy + j)))
            .collect();
        let errors: Vec<(u64, u64)> = candidates
            .par_iter()
            .map(|&(dx, dy)| error(a.width, a.height, &ba, &bb, dx, dy))
            .collect();
        // The centre unless another is strictly better; ties go to the
        // first in row order, so the result does not depend on threads.
        let centre = candidates.iter().position(|&c| c == (cx, cy)).unwrap();
        let mut best = centre;
        for k in 0..candidates.len() {
            if lower_rate(errors[k], errors[best]) {
                best = k;
            }
        }
        (candidates[best], ba, bb)
    }
    let (shift, ba, bb) = rec(reference, image, &ps, levels);
    if shift == (0, 0) {
        return shift;
    }
    // Keep a shift only if it clearly beats no shift: fewer disagreements
    // (at the same number of compared pixels) by SIGNIFICANCE standard
    // deviations. Noise alone moves the minimum by about one.
    let (d0, n0) = error(w, h, &ba, &bb, 0, 0);
    let (ds, ns) = error(w, h, &ba, &bb, shift.0, shift.1);
    if n0 == 0 || ns == 0 {
        return (0, 0);
    }
    let (d0, ds) = (d0 as f64, ds as f64 * n0 as f64 / ns as f64);
    if d0 - ds > SIGNIFICANCE * (d0 + ds + 1.0).sqrt() {
        shift
    } else {
        (0, 0)
    }
}

/// Shifts that align `n` brackets, sorted by exposure, with the middle one
/// (index `n / 2`, shift `(0, 0)`): each bracket is aligned with its
/// neighbour towards the middle by [`mtb_shift`] and the shifts are summed
/// outward, so that every pair compared is a stop or two apart. `grey(i)`
/// gives bracket `i`'s grey image; it is called once per bracket (middle
/// first, then the shorter ones, then the longer ones), and at most two are
/// held at a time. The searches run in `pool` (rayon's current pool if
/// `None`); the result does not depend on it.
pub fn stack_shifts(
    n: usize,
    levels: u32,
    pool: Option<&rayon::ThreadPool>,
    mut grey: impl FnMut(usize) -> Result<Grey>,
) -> Result<Vec<(i32, i32)>> {
    let mut shifts = vec![(0, 0); n];
    if n == 0 {
        return Ok(shifts);
    }
    let mid = n / 2;
    let reference = grey(mid)?;
    for order in [
        (0..mid).rev().collect::<Vec<_>>(),
        (mid + 1..n).collect::<Vec<_>>(),
    ] {
        let mut previous = (mid, reference.clone());
        for b in order {
            let g = grey(b)?;
            let search = || mtb_shift(&previous.1, &g, levels);
            let (dx, dy) = match pool {
                Some(pool) => pool.install(search),
                None => search(),
            };
            let base = shifts[previous.0];
            shifts[b] = (base.0 + dx, base.1 + dy);
            previous = (b, g);
        }
    }
    Ok(shifts)
}

/// Pyramid depth for an image: up to 6 levels (shifts up to ±254 pixels),
/// keeping the coarsest level at least 16 pixels on its short side.
pub fn default_levels(width: usize, height: usize) -> u32 {
    let mut l = 0;
    let mut s = width.min(height);
    while l < 6 && s >= 32 {
        s /= 2;
        l += 1;
    }
    l
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic hash of a pixel, uniform in [0, 1).
    fn hash(x: i32, y: i32, seed: u32) -> f32 {
        let mut v = (x as u32).wrapping_mul(0x9E37_79B1)
            ^ (y as u32).wrapping_mul(0x85EB_CA77)
            ^ seed.wrapping_mul(0xC2B2_AE3D);
        v ^= v >> 15;
        v = v.wrapping_mul(0x2C1B_3C6D);
        v ^= v >> 12;
        v = v.wrapping_mul(0x297A_2D39);
        v ^= v >> 15;
        (v >> 8) as f32 / (1u32 << 24) as f32
    }

    fn grey(w: usize, h: usize, f: impl Fn(i32, i32) -> f32) -> Grey {
        Grey {
            width: w,
            height: h,
            data: (0..w * h)
                .map(|i| f((i % w) as i32, (i / w) as i32).round().clamp(0.0, 255.0) as u8)
                .collect(),
        }
    }

    #[test]
    fn finds_a_known_shift_between_exposures() {
        let (w, h) = (160, 96);
        let scene = |x: i32, y: i32| -> f32 {
            let (x, y) = (x as f32, y as f32);
            let checker = if ((x / 8.0).floor() + (y / 8.0).floor()) as i32 % 2 == 0 {
                0.1
            } else {
                -0.1
            };
            0.5 + 0.2 * (x * 0.21).sin() * (y * 0.13).cos()
                + 0.1 * ((x + 2.0 * y) * 0.05).sin()
                + checker
        };
        let make = |dx: i32, dy: i32, gain: f32| {
            grey(w, h, |x, y| (scene(x - dx, y - dy) * gain * 255.0).floor())
        };
        let reference = make(0, 0, 1.0);
        let moved = make(-5, 3, 0.5);
        // moved(x, y) = scene(x + 5, y − 3): reference(x, y) = moved(x − 5, y + 3).
        assert_eq!(mtb_shift(&reference, &moved, default_levels(w, h)), (5, -3));
        assert_eq!(mtb_shift(&reference, &make(0, 0, 1.7), 3), (0, 0));
    }

    #[test]
    fn shifted_rows_match_a_plain_shift() {
        for w in [1usize, 63, 64, 65, 150, 200] {
            let bits: Vec<bool> = (0..w).map(|x| hash(x as i32, 1, 2) < 0.5).collect();
            let words = w.div_ceil(64);
            let mut packed = vec![0u64; words];
            for (x, &b) in bits.iter().enumerate() {
                packed[x / 64] |= (b as u64) << (x % 64);
            }
            let plane = Plane {
                words,
                bits: packed,
            };
            let mut out = vec![0u64; plane.words];
            for dx in [-201, -130, -64, -63, -5, -1, 0, 1, 7, 63, 64, 65, 129, 201] {
                shift_row(plane.row(0), dx, &mut out);
                for x in 0..plane.words * 64 {
                    let got = out[x / 64] >> (x % 64) & 1 == 1;
                    let sx = x as i64 - dx as i64;
                    let want = (0..w as i64).contains(&sx) && bits[sx as usize];
                    assert_eq!(got, want, "w {w} dx {dx} x {x}");
                }
            }
        }
    }

    #[test]
    fn noise_or_black_gives_no_shift() {
        let (w, h) = (128, 96);
        let levels = default_levels(w, h);
        // Two independent noise images: nothing to align.
        let a = grey(w, h, |x, y| 255.0 * hash(x, y, 1));
        let b = grey(w, h, |x, y| 255.0 * hash(x, y, 2));
        assert_eq!(mtb_shift(&a, &b, levels), (0, 0));
        // Black with noise up to level 20 (a crushed noise floor), over
        // most of the image, in both.
        let c = grey(w, h, |x, y| {
            if hash(x, y, 3) < 0.6 {
                0.0
            } else {
                20.0 * hash(x, y, 4)
            }
        });
        let d = grey(w, h, |x, y| {
            if hash(x, y, 5) < 0.6 {
                0.0
            } else {
                20.0 * hash(x, y, 6)
            }
        });
        assert_eq!(mtb_shift(&c, &d, levels), (0, 0));
        // Detail in 2 % of the pixels only: too little in common.
        let spot = |x: i32, y: i32| {
            if x < 16 && y < 12 {
                100.0 + 100.0 * hash(x, y, 7)
            } else {
                0.0
            }
        };
        let e = grey(w, h, spot);
        let f = grey(w, h, |x, y| spot(x - 3, y));
        assert_eq!(mtb_shift(&e, &f, levels), (0, 0));
    }

    #[test]
    fn a_chain_of_neighbours_aligns_exposures_that_share_nothing() {
        // A scene spanning 16 stops left to right, with texture; seven
        // linear 8-bit exposures two stops apart, each shaken. The shortest
        // and the longest show nothing the middle one shows (unclipped
        // and above black), but each shares half its range with its
        // neighbours.
        let (w, h) = (192, 96);
        let radiance = |x: i32, y: i32| -> f32 {
            let x = x.clamp(0, w as i32 - 1);
            let y = y.clamp(0, h as i32 - 1);
            let ramp = 2f32.powf(16.0 * (x as f32 + 0.5) / w as f32 - 10.0);
            let checker = if (x / 6 + y / 6) % 2 == 0 { 1.0 } else { 0.55 };
            ramp * checker * (1.0 + 0.25 * (0.3 * y as f32).sin())
        };
        let shake = [(2, -1), (-3, 2), (1, 3), (-2, -2), (3, 1), (0, -3), (-1, 2)];
        let n = shake.len();
        let images: Vec<Grey> = (0..n)
            .map(|i| {
                let gain = 2f32.powi(2 * (i as i32 - 3));
                let (sx, sy) = shake[i];
                grey(w, h, |x, y| {
                    255.0 * gain * radiance(x - sx, y - sy) + hash(x, y, i as u32) - 0.5
                })
            })
            .collect();
        let mid = shake[n / 2];
        let want: Vec<(i32, i32)> = shake.iter().map(|s| (mid.0 - s.0, mid.1 - s.1)).collect();
        let mut order = Vec::new();
        let found = stack_shifts(n, default_levels(w, h), None, |i| {
            order.push(i);
            Ok(images[i].clone())
        })
        .unwrap();
        assert_eq!(found, want);
        assert_eq!(order, [3, 2, 1, 0, 4, 5, 6]);
        // Aligned to the middle one directly, the ends are not found.
        let levels = default_levels(w, h);
        assert_ne!(mtb_shift(&images[3], &images[0], levels), want[0]);
        assert_ne!(mtb_shift(&images[3], &images[6], levels), want[6]);
        // Deterministic, and the same in any thread pool.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let again = stack_shifts(n, levels, Some(&pool), |i| Ok(images[i].clone())).unwrap();
        assert_eq!(again, found);
    }
}
