//! How a part (and a render kept for `--resume`) stores its seven `f64`
//! sums per pixel exactly and compactly: each as the difference from a
//! prediction made from the image layers beside it in the same file, the
//! difference's bit pattern cut into four 16-bit words (16-bit channels
//! `part.sum.R.r0` … `part.sum.R.r3`, least significant first).
//!
//! The image layers hold the same quantities rounded to `f32`: the colour
//! is `sum / samples`, the variance `(sum_sq − sum·mean) / (n(n−1))`, the
//! depth `depth / hits`. So the predictions
//!
//! - `sum ≈ mean · n` (the colour before denoising: `noisy.R` when the
//!   file has it, else `R`),
//! - `sum_sq ≈ variance · n(n−1) + sum · (sum / n)`,
//! - `depth ≈ Z · hits`
//!
//! agree with the sums in their top ~24 bits. The differences are small
//! numbers with few significant bits (a sum of `f32` samples has rarely
//! more than 35), so their low words are mostly zero, which the file's
//! ZIP compression removes: the sums take about 45 % less space than
//! their own words would. Reading computes the
//! same prediction in the same `f64` arithmetic from the same `f32`
//! values and adds the difference back.
//!
//! Exactness does not rest on the argument above: the writer checks every
//! value, `prediction + difference == sum` bit for bit, and where it does
//! not hold (a non-finite prediction, a layer that is not the mean) stores
//! the sum's own bits instead and sets that value's bit in the pixel's
//! `part.raw` mask (bit `k` for [`NAMES`]`[k]`).

use super::{Film, PixelSums};
use exr::prelude::{f16, AnyChannel, FlatSamples};

/// The `f64` sums, in the order they are predicted (`sum_sq` needs `sum`).
pub(super) const NAMES: [&str; 7] = [
    "sum.R", "sum.G", "sum.B", "sum_sq.R", "sum_sq.G", "sum_sq.B", "depth",
];

/// The image layers the predictions are made from, per pixel.
pub(super) struct Guide {
    /// The mean colour (before any denoising), per channel.
    pub mean: [Vec<f32>; 3],
    /// The variance of the mean, per channel.
    pub variance: [Vec<f32>; 3],
    /// The mean depth of hits.
    pub depth: Vec<f32>,
}

impl Guide {
    /// The layers of `film` as its EXR file holds them.
    pub fn of_film(film: &Film) -> Guide {
        let mean = film.noisy.as_ref().unwrap_or(&film.color);
        let split = |v: &[glam::Vec3], c: usize| v.iter().map(|x| x[c]).collect::<Vec<f32>>();
        Guide {
            mean: [0, 1, 2].map(|c| split(mean, c)),
            variance: [0, 1, 2].map(|c| split(&film.variance, c)),
            depth: film.depth.clone(),
        }
    }
}

/// Sum `k` of [`NAMES`] of a pixel.
fn get(p: &PixelSums, k: usize) -> f64 {
    match k {
        0..=2 => p.sum[k],
        3..=5 => p.sum_sq[k - 3],
        _ => p.depth,
    }
}

/// Sets sum `k` of [`NAMES`] of a pixel.
fn set(p: &mut PixelSums, k: usize, x: f64) {
    match k {
        0..=2 => p.sum[k] = x,
        3..=5 => p.sum_sq[k - 3] = x,
        _ => p.depth = x,
    }
}

/// The prediction of sum `k` of pixel `i`, from the guide and the pixel's
/// counts and earlier sums (`sum_sq` uses `sum`).
fn predict(k: usize, i: usize, guide: &Guide, p: &PixelSums) -> f64 {
    let n = p.samples as f64;
    match k {
        0..=2 => guide.mean[k][i] as f64 * n,
        3..=5 if p.samples > 0 => {
            let (c, s) = (k - 3, p.sum[k - 3]);
            let spread = if p.samples > 1 {
                guide.variance[c][i] as f64 * (n * (n - 1.0))
            } else {
                0.0
            };
            spread + s * (s / n)
        }
        3..=5 => 0.0,
        _ => guide.depth[i] as f64 * p.hits as f64,
    }
}

/// The channels that store `pixels`' `f64` sums against `guide`: four
/// word channels per sum and the `part.raw` mask.
pub(super) fn encode(pixels: &[PixelSums], guide: &Guide) -> Vec<AnyChannel<FlatSamples>> {
    let mut raw = vec![0u32; pixels.len()];
    let mut channels = Vec::new();
    for (k, name) in NAMES.iter().enumerate() {
        let stored: Vec<u64> = pixels
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let (x, guess) = (get(p, k), predict(k, i, guide, p));
                let difference = x - guess;
                if guess.is_finite() && (guess + difference).to_bits() == x.to_bits() {
                    difference.to_bits()
                } else {
                    raw[i] |= 1 << k;
                    x.to_bits()
                }
            })
            .collect();
        for word in 0..4 {
            channels.push(AnyChannel::new(
                format!("part.{name}.r{word}").as_str(),
                FlatSamples::F16(
                    stored
                        .iter()
                        .map(|b| f16::from_bits((b >> (16 * word)) as u16))
                        .collect(),
                ),
            ));
        }
    }
    channels.push(AnyChannel::new("part.raw", FlatSamples::U32(raw)));
    channels
}

/// Fills in `pixels`' `f64` sums (their counts already read) from the
/// stored words (`words[k][w]`: word `w` of sum `k` of every pixel), the
/// `part.raw` mask and `guide`.
pub(super) fn decode(
    pixels: &mut [PixelSums],
    guide: &Guide,
    words: &[[&Vec<f16>; 4]; 7],
    raw: &[u32],
) {
    for (i, p) in pixels.iter_mut().enumerate() {
        for (k, w) in words.iter().enumerate() {
            let bits = (0..4).fold(0u64, |b, word| {
                b | (w[word][i].to_bits() as u64) << (16 * word)
            });
            let stored = f64::from_bits(bits);
            let x = if raw[i] & (1 << k) != 0 {
                stored
            } else {
                predict(k, i, guide, p) + stored
            };
            set(p, k, x);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn pixel(sum: f64, sum_sq: f64, samples: u32) -> PixelSums {
        PixelSums {
            sum: DVec3::splat(sum),
            sum_sq: DVec3::splat(sum_sq),
            samples,
            hits: samples,
            depth: 3.25 * samples as f64,
            ..Default::default()
        }
    }

    fn round_trip(pixels: &[PixelSums], guide: &Guide) -> (Vec<PixelSums>, Vec<u32>) {
        let channels = encode(pixels, guide);
        let words: Vec<&Vec<f16>> = channels[..28]
            .iter()
            .map(|c| match &c.sample_data {
                FlatSamples::F16(v) => v,
                _ => panic!("not a word channel"),
            })
            .collect();
        let words: [[&Vec<f16>; 4]; 7] =
            std::array::from_fn(|k| std::array::from_fn(|w| words[4 * k + w]));
        let FlatSamples::U32(raw) = &channels[28].sample_data else {
            panic!("no mask")
        };
        let mut back: Vec<PixelSums> = pixels
            .iter()
            .map(|p| PixelSums {
                sum: DVec3::ZERO,
                sum_sq: DVec3::ZERO,
                depth: 0.0,
                ..*p
            })
            .collect();
        decode(&mut back, guide, &words, raw);
        (back, raw.clone())
    }

    fn bits(p: &PixelSums) -> Vec<u64> {
        (0..7).map(|k| get(p, k).to_bits()).collect()
    }

    #[test]
    fn sums_come_back_exactly_whether_the_guide_predicts_them_or_not() {
        let pixels = vec![
            pixel(12.345678912345, 20.5, 16),
            pixel(0.1 + 0.2, 0.09 + 0.04, 2),
            pixel(1e-300, 1e-310, 1),
            pixel(f64::MAX, f64::MAX, 7),
            pixel(0.0, 0.0, 0),
            pixel(-0.0, 5e-324, 3),
        ];
        // The guide the film gives: the rounded means, variances, depths.
        let film = crate::film::FilmSums::from_pixels(
            6,
            1,
            0,
            pixels.clone(),
            crate::film::FilmSettings::default(),
        )
        .develop(16);
        let good = Guide::of_film(&film);
        // A guide unrelated to the sums (another image's layers).
        let bad = Guide {
            mean: [vec![7.0; 6], vec![f32::NAN; 6], vec![f32::INFINITY; 6]],
            variance: [vec![-1.0; 6], vec![1e30; 6], vec![0.0; 6]],
            depth: vec![f32::MAX; 6],
        };
        for (what, guide) in [("the film's", &good), ("an unrelated", &bad)] {
            let (back, _) = round_trip(&pixels, guide);
            for (p, q) in pixels.iter().zip(&back) {
                assert_eq!(bits(p), bits(q), "{what} guide");
            }
        }
        // With the film's guide, the ordinary pixels' sums are predicted,
        // and what is stored is their tiny difference from the prediction.
        let (_, raw) = round_trip(&pixels, &good);
        assert_eq!(raw[..2], [0, 0]);
        assert_eq!(raw[3], 0b0011_1111, "the sums of f64::MAX are stored raw");
        let channels = encode(&pixels[..1], &good);
        for k in 0..7 {
            let stored = (0..4).fold(0u64, |b, w| match &channels[4 * k + w].sample_data {
                FlatSamples::F16(v) => b | (v[0].to_bits() as u64) << (16 * w),
                _ => panic!(),
            });
            let (d, x) = (f64::from_bits(stored), get(&pixels[0], k));
            assert!(d.abs() <= x.abs() * 1e-6, "{}: {d} of {x}", NAMES[k]);
        }
    }
}
