//! How close a merged radiance map is to a reference map of the same
//! scene, such as a photographer's own merge of a real stack (the scale of
//! both is arbitrary).
//!
//! [`reference_errors`]: the log2 error of every channel value, less the
//! one offset (global scale) that best matches the two maps in the log
//! domain, as an RMSE over every pixel, the brightest 1 % (windows, lamps)
//! and the darkest 10 % (shadows) of the reference's luminance. Pixels the
//! reference holds as 0 in some channel are left out of all three.

/// log2-RMSE of a merge against a reference, in stops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceErrors {
    /// Over every pixel.
    pub all: f64,
    /// Over the brightest 1 % of the reference's luminance.
    pub brightest: f64,
    /// Over the darkest 10 %.
    pub darkest: f64,
    /// The global scale applied to the merge (reference ÷ merge).
    pub scale: f64,
}

/// Compares `merged` with `reference`, both interleaved RGB of the same
/// size (at least one pixel); values ≤ 0 or NaN in `merged` count as
/// 10⁻¹² (a gross error).
pub fn reference_errors(merged: &[f32], reference: &[f32]) -> ReferenceErrors {
    assert_eq!(merged.len(), reference.len(), "maps of different sizes");
    let n = reference.len() / 3;
    let lum: Vec<f64> = (0..n)
        .map(|p| {
            let r = &reference[3 * p..3 * p + 3];
            0.2126 * r[0] as f64 + 0.7152 * r[1] as f64 + 0.0722 * r[2] as f64
        })
        .collect();
    let mut sorted = lum.clone();
    sorted.sort_by(f64::total_cmp);
    let quantile = |q: f64| sorted[((n.max(1) - 1) as f64 * q).round() as usize];
    let (hi, lo) = (quantile(0.99), quantile(0.10));
    let valid: Vec<bool> = (0..n)
        .map(|p| reference[3 * p..3 * p + 3].iter().all(|&v| v > 0.0))
        .collect();
    let log2 = |v: f32| {
        if v > 0.0 {
            (v as f64).log2()
        } else {
            1e-12f64.log2()
        }
    };
    let d: Vec<f64> = merged
        .iter()
        .zip(reference)
        .map(|(&m, &r)| log2(m) - log2(r))
        .collect();
    let (mut sum, mut count) = (0.0, 0usize);
    for p in (0..n).filter(|&p| valid[p]) {
        sum += d[3 * p..3 * p + 3].iter().sum::<f64>();
        count += 3;
    }
    let offset = sum / count.max(1) as f64;
    let rmse = |keep: &dyn Fn(usize) -> bool| {
        let (mut s, mut c) = (0.0, 0usize);
        for p in (0..n).filter(|&p| valid[p] && keep(p)) {
            for v in &d[3 * p..3 * p + 3] {
                s += (v - offset).powi(2);
                c += 1;
            }
        }
        (s / c.max(1) as f64).sqrt()
    };
    ReferenceErrors {
        all: rmse(&|_| true),
        brightest: rmse(&|p| lum[p] >= hi),
        darkest: rmse(&|p| lum[p] <= lo),
        scale: (-offset).exp2(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scaled_copy_has_no_error_and_an_offset_shows_where_it_is() {
        // 100 pixels of rising grey.
        let reference: Vec<f32> = (0..300).map(|i| 0.01 * (1 + i / 3) as f32).collect();
        let scaled: Vec<f32> = reference.iter().map(|v| 4.0 * v).collect();
        let e = reference_errors(&scaled, &reference);
        assert!(e.all < 1e-6 && e.brightest < 1e-6 && e.darkest < 1e-6);
        assert!((e.scale - 0.25).abs() < 1e-6);
        // The darkest 10 pixels one stop too bright: the darkest tenth's
        // error is about a stop, the brightest percent's a tenth of one
        // (the offset the others absorb).
        let mut off = reference.clone();
        off[..30].iter_mut().for_each(|v| *v *= 2.0);
        let e = reference_errors(&off, &reference);
        assert!((e.darkest - 0.9).abs() < 0.05, "{e:?}");
        assert!((e.brightest - 0.1).abs() < 0.01, "{e:?}");
    }
}
