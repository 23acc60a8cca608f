//! Pixel-wise metrics: RMSE and PSNR, over every channel of the pixels a
//! mask keeps (all pixels without one).

/// Root-mean-square difference of two interleaved RGB buffers.
pub fn rmse(a: &[f32], b: &[f32], inside: Option<&[bool]>) -> f64 {
    mean_squared(a, b, inside).sqrt()
}

/// Peak signal-to-noise ratio of two display-value buffers (peak 1), dB;
/// infinite for identical images.
pub fn psnr(a: &[f32], b: &[f32], inside: Option<&[bool]>) -> f64 {
    -10.0 * mean_squared(a, b, inside).log10()
}

fn mean_squared(a: &[f32], b: &[f32], inside: Option<&[bool]>) -> f64 {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (i, (p, q)) in a.chunks_exact(3).zip(b.chunks_exact(3)).enumerate() {
        if inside.is_some_and(|m| !m[i]) {
            continue;
        }
        for c in 0..3 {
            let d = p[c] as f64 - q[c] as f64;
            sum += d * d;
        }
        n += 3;
    }
    if n == 0 {
        0.0
    } else {
        sum / n as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_values() {
        let a = [0.5f32; 6];
        let b = [0.5f32, 0.5, 0.5, 0.6, 0.6, 0.6];
        // One pixel of two differs by 0.1 in each channel.
        assert!((rmse(&a, &b, None) - (0.005f64).sqrt()).abs() < 1e-6);
        assert!((psnr(&a, &b, None) - 10.0 * (1.0 / 0.005f64).log10()).abs() < 1e-4);
        assert_eq!(rmse(&a, &b, Some(&[true, false])), 0.0);
        assert!(psnr(&a, &a, None).is_infinite());
    }
}
