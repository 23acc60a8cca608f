//! SSIM, the structural similarity of Wang, Bovik, Sheikh and Simoncelli
//! (2004), as their MATLAB `ssim_index` computes it: grey values on the
//! 0–255 scale, an 11×11 Gaussian window of standard deviation 1.5 at every
//! position where it lies wholly inside the image, `K1 = 0.01`,
//! `K2 = 0.03`, `L = 255`, and the mean of the map. No downsampling.

use super::GreyImage;
use crate::error::{Error, Result};
use plsr_base::Vocabulary;

/// Side of the Gaussian window.
const SIDE: usize = 11;
/// Its standard deviation, pixels.
const SIGMA: f64 = 1.5;

/// The mean SSIM of two grey images of the same size (1 when identical).
pub fn ssim(a: &GreyImage, b: &GreyImage) -> Result<f64> {
    let map = ssim_map(a, b)?;
    Ok(map.iter().sum::<f64>() / map.len() as f64)
}

/// The SSIM map ("valid" positions: `(w − 10) × (h − 10)`, row-major).
pub fn ssim_map(a: &GreyImage, b: &GreyImage) -> Result<Vec<f64>> {
    let (w, h) = (a.width, a.height);
    if (w, h) != (b.width, b.height) {
        return Err(Error::invalid_argument(format!(
            "SSIM: the images differ in size ({w}×{h} and {}×{})",
            b.width, b.height
        )));
    }
    if w < SIDE || h < SIDE {
        return Err(Error::invalid_argument(format!(
            "SSIM: a {w}×{h} image is smaller than its 11×11 window"
        )));
    }
    let g: Vec<f64> = (0..SIDE)
        .map(|i| {
            let d = i as f64 - (SIDE as f64 - 1.0) / 2.0;
            (-d * d / (2.0 * SIGMA * SIGMA)).exp()
        })
        .collect();
    let total: f64 = g.iter().sum();
    let g: Vec<f64> = g.iter().map(|v| v / total).collect();
    // The Gaussian is separable: filter rows, then columns.
    let filter = |x: &[f64]| -> Vec<f64> {
        let mw = w - SIDE + 1;
        let mh = h - SIDE + 1;
        let mut rows = vec![0.0; mw * h];
        for y in 0..h {
            for k in 0..mw {
                rows[y * mw + k] = (0..SIDE).map(|j| g[j] * x[y * w + k + j]).sum();
            }
        }
        let mut out = vec![0.0; mw * mh];
        for y in 0..mh {
            for k in 0..mw {
                out[y * mw + k] = (0..SIDE).map(|j| g[j] * rows[(y + j) * mw + k]).sum();
            }
        }
        out
    };
    let product =
        |p: &[f64], q: &[f64]| -> Vec<f64> { p.iter().zip(q).map(|(x, y)| x * y).collect() };
    let (mu1, mu2) = (filter(&a.v), filter(&b.v));
    let s11 = filter(&product(&a.v, &a.v));
    let s22 = filter(&product(&b.v, &b.v));
    let s12 = filter(&product(&a.v, &b.v));
    let (c1, c2) = ((0.01f64 * 255.0).powi(2), (0.03f64 * 255.0).powi(2));
    Ok((0..mu1.len())
        .map(|i| {
            let (m1, m2) = (mu1[i], mu2[i]);
            let v1 = s11[i] - m1 * m1;
            let v2 = s22[i] - m2 * m2;
            let c = s12[i] - m1 * m2;
            ((2.0 * m1 * m2 + c1) * (2.0 * c + c2)) / ((m1 * m1 + m2 * m2 + c1) * (v1 + v2 + c2))
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_images_score_one_and_a_shift_in_mean_lowers_it_as_the_formula_says() {
        let w = 32;
        let v: Vec<f64> = (0..w * w).map(|i| ((i * 37) % 101) as f64).collect();
        let a = GreyImage {
            width: w,
            height: w,
            v: v.clone(),
        };
        assert!((ssim(&a, &a).unwrap() - 1.0).abs() < 1e-12);
        // A constant offset d changes only the luminance term:
        // (2·μ(μ + d) + C1) / (μ² + (μ + d)² + C1) at each window.
        let flat = GreyImage {
            width: w,
            height: w,
            v: vec![100.0; w * w],
        };
        let lifted = GreyImage {
            width: w,
            height: w,
            v: vec![120.0; w * w],
        };
        let c1 = (0.01f64 * 255.0).powi(2);
        let want = (2.0 * 100.0 * 120.0 + c1) / (100f64 * 100.0 + 120.0 * 120.0 + c1);
        assert!((ssim(&flat, &lifted).unwrap() - want).abs() < 1e-12);
    }
}
