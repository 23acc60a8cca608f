//! The input scale of an HDR image (OIDN's autoexposure): the networks were
//! trained on images exposed so that their geometric-mean luminance is
//! 0.18, so an image is scaled to that before it is encoded and scaled
//! back after.
//!
//! The image is cut into blocks of about 16×16 pixels (⌈h/16⌉ × ⌈w/16⌉
//! blocks, their edges at ⌊i·h/rows⌋); each block's mean luminance (Rec.
//! 709 weights, each pixel's channels first clamped to [0, ∞), NaN as 0)
//! counts if it is above 1e-8, and the scale is 0.18 over 2 to the mean of
//! their log2. An image with no such block gets 1.

/// Luminance weights of linear Rec. 709 / sRGB primaries.
const LUMINANCE: [f32; 3] = [0.212_671, 0.715_160, 0.072_169];

/// The side of the blocks, in pixels.
const BLOCK: usize = 16;

/// The key value the networks expect: the geometric-mean luminance after
/// scaling.
const KEY: f64 = 0.18;

/// The scale that exposes `rgb` (row-major, `width × height` pixels of three
/// channels) for the network.
pub fn input_scale(rgb: &[[f32; 3]], width: usize, height: usize) -> f32 {
    assert_eq!(
        rgb.len(),
        width * height,
        "the image is width × height pixels"
    );
    if width == 0 || height == 0 {
        return 1.0;
    }
    let (rows, cols) = (height.div_ceil(BLOCK), width.div_ceil(BLOCK));
    let mut log_sum = 0.0f64;
    let mut counted = 0usize;
    for i in 0..rows {
        let (y0, y1) = (i * height / rows, (i + 1) * height / rows);
        for j in 0..cols {
            let (x0, x1) = (j * width / cols, (j + 1) * width / cols);
            let mut sum = 0.0f64;
            for y in y0..y1 {
                for p in &rgb[y * width + x0..y * width + x1] {
                    let l: f32 = p
                        .iter()
                        .zip(LUMINANCE)
                        .map(|(&c, w)| if c.is_nan() { 0.0 } else { c.clamp(0.0, f32::MAX) } * w)
                        .sum();
                    sum += f64::from(l);
                }
            }
            let mean = sum / ((y1 - y0) * (x1 - x0)) as f64;
            if mean > 1e-8 {
                log_sum += mean.log2();
                counted += 1;
            }
        }
    }
    if counted == 0 {
        return 1.0;
    }
    (KEY / (log_sum / counted as f64).exp2()) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grey_image_is_scaled_to_the_key() {
        let image = vec![[2.0f32, 2.0, 2.0]; 40 * 23];
        let s = input_scale(&image, 40, 23);
        assert!((s - 0.09).abs() < 1e-6, "{s}");
    }

    #[test]
    fn the_scale_is_the_geometric_mean_over_lit_blocks() {
        // Two 16×16 blocks: luminance 1 and 4; a black one is left out.
        let (w, h) = (48, 16);
        let image: Vec<[f32; 3]> = (0..w * h)
            .map(|i| match (i % w) / 16 {
                0 => [1.0, 1.0, 1.0],
                1 => [4.0, 4.0, 4.0],
                _ => [0.0, 0.0, 0.0],
            })
            .collect();
        let s = input_scale(&image, w, h);
        assert!((s - 0.09).abs() < 1e-6, "geometric mean 2: {s}");
        // NaN and negative values count as 0; a black image gets 1.
        let dark = vec![[f32::NAN, -1.0, 0.0]; 20 * 20];
        assert_eq!(input_scale(&dark, 20, 20), 1.0);
        // Infinity is clamped to the largest float, not propagated.
        let mut hot = vec![[1.0f32; 3]; 16 * 16];
        hot[0] = [f32::INFINITY; 3];
        assert!(input_scale(&hot, 16, 16).is_finite());
    }
}
