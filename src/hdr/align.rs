//! Translation alignment of brackets by median threshold bitmaps (Ward 2003).
//!
//! Each bracket is reduced to an 8-bit grey image; at every level of an
//! image pyramid the bitmap "brighter than the median" is compared with the
//! reference's, ignoring pixels within ±4 grey levels of the median, over the
//! nine shifts around the doubled shift of the coarser level. Median
//! thresholds do not depend on the exposure, so brackets of very different
//! exposure align. Only whole-pixel translations are found.

use super::oiio::ImageReader;
use crate::error::Result;

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

/// Threshold bitmap (above the `p`-quantile, the median for 0.5) and
/// exclusion bitmap (farther than `tolerance` from that threshold).
fn bitmaps(g: &Grey, p: f64, tolerance: u8) -> (Vec<bool>, Vec<bool>) {
    let hist = histogram(g);
    let rank = ((g.data.len() as f64 * p) as usize).min(g.data.len().saturating_sub(1));
    let mut acc = 0;
    let mut median = 0u8;
    for (v, n) in hist.iter().enumerate() {
        acc += n;
        if acc > rank {
            median = v as u8;
            break;
        }
    }
    let tb = g.data.iter().map(|&v| v > median).collect();
    let eb = g
        .data
        .iter()
        .map(|&v| v.abs_diff(median) > tolerance)
        .collect();
    (tb, eb)
}

/// Threshold and exclusion bitmaps of one image.
struct Bitmaps {
    threshold: Vec<bool>,
    include: Vec<bool>,
}

/// Number of disagreeing, non-excluded pixels of `w`×`h` bitmaps when `b`
/// is shifted by `(dx, dy)` (pixel `(x, y)` of the shifted bitmap is
/// `b(x − dx, y − dy)`).
fn error(w: usize, h: usize, a: &Bitmaps, b: &Bitmaps, dx: i32, dy: i32) -> u64 {
    let (ta, ea, tb, eb) = (&a.threshold, &a.include, &b.threshold, &b.include);
    let mut err = 0u64;
    for y in 0..h as i32 {
        let sy = y - dy;
        if sy < 0 || sy >= h as i32 {
            continue;
        }
        for x in 0..w as i32 {
            let sx = x - dx;
            if sx < 0 || sx >= w as i32 {
                continue;
            }
            let i = y as usize * w + x as usize;
            let j = sy as usize * w + sx as usize;
            if (ta[i] != tb[j]) && ea[i] && eb[j] {
                err += 1;
            }
        }
    }
    err
}

/// The quantile to threshold a pair at: the median, unless clipping in
/// either image (levels ≤ 4 or ≥ 251) would put the median into a clipped
/// band; then the middle of the range of quantiles unclipped in both (Ward
/// 2003 suggests other percentiles for over- and under-exposed images).
fn pair_quantile(a: &Grey, b: &Grey) -> f64 {
    let fractions = |g: &Grey| {
        let hist = histogram(g);
        let n = g.data.len().max(1) as f64;
        let low = hist[..=4].iter().sum::<usize>() as f64 / n;
        let high = hist[251..].iter().sum::<usize>() as f64 / n;
        (low, 1.0 - high)
    };
    let (la, ha) = fractions(a);
    let (lb, hb) = fractions(b);
    let (lo, hi) = (la.max(lb), ha.min(hb));
    if hi > lo {
        0.5 * (lo + hi)
    } else {
        0.5
    }
}

/// The translation `(dx, dy)` in pixels that aligns `image` with
/// `reference` (pixel `(x, y)` of the reference matches `image(x − dx,
/// y − dy)`), searched up to `2^levels − 1` pixels each way. Images of
/// different sizes give `(0, 0)`.
pub fn mtb_shift(reference: &Grey, image: &Grey, levels: u32) -> (i32, i32) {
    if reference.width != image.width || reference.height != image.height {
        return (0, 0);
    }
    let p = pair_quantile(reference, image);
    fn rec(a: &Grey, b: &Grey, p: f64, level: u32) -> (i32, i32) {
        let (cx, cy) = if level > 0 && a.width >= 32 && a.height >= 32 {
            let (x, y) = rec(&shrink(a), &shrink(b), p, level - 1);
            (2 * x, 2 * y)
        } else {
            (0, 0)
        };
        let (threshold, include) = bitmaps(a, p, 4);
        let ba = Bitmaps { threshold, include };
        let (threshold, include) = bitmaps(b, p, 4);
        let bb = Bitmaps { threshold, include };
        let mut best = (u64::MAX, (cx, cy));
        for j in -1..=1 {
            for i in -1..=1 {
                let (dx, dy) = (cx + i, cy + j);
                let e = error(a.width, a.height, &ba, &bb, dx, dy);
                if e < best.0 {
                    best = (e, (dx, dy));
                }
            }
        }
        best.1
    }
    rec(reference, image, p, levels)
}

/// Pyramid depth for an image: up to 6 levels (±63 pixels), keeping the
/// coarsest level at least 16 pixels on its short side.
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
        let make = |dx: i32, dy: i32, gain: f32| Grey {
            width: w,
            height: h,
            data: (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as i32, (i / w) as i32);
                    (scene(x - dx, y - dy) * gain * 255.0).clamp(0.0, 255.0) as u8
                })
                .collect(),
        };
        let reference = make(0, 0, 1.0);
        let moved = make(-5, 3, 0.5);
        // moved(x, y) = scene(x + 5, y − 3): reference(x, y) = moved(x − 5, y + 3).
        assert_eq!(mtb_shift(&reference, &moved, default_levels(w, h)), (5, -3));
        assert_eq!(mtb_shift(&reference, &make(0, 0, 1.7), 3), (0, 0));
    }
}
