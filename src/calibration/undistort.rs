//! Undistortion: a photo resampled into the image an ideal pinhole with the
//! same focal lengths, principal point and skew would have taken, as
//! OpenCV's `undistort` (and `fisheye::undistortImage` with `Knew = K`)
//! makes it. Each output pixel `(u, v)` looks up the photo at
//! `K·distort(K⁻¹·(u, v, 1))` by bilinear interpolation; where that falls
//! outside the photo (or beyond the lens model's valid radius) it is 0.

use super::CameraModel;
use glam::{DVec2, DVec3};
use rayon::prelude::*;

/// The photo position (OpenCV's pixel convention) each pixel of the
/// undistorted image samples, row by row; `None` where the lens model has
/// no image of that pixel's direction.
pub fn source_positions(model: &CameraModel) -> Vec<Option<DVec2>> {
    let (w, h) = (model.width as usize, model.height as usize);
    let mut out = vec![None; w * h];
    out.par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            for (x, slot) in row.iter_mut().enumerate() {
                *slot = source_position(model, DVec2::new(x as f64, y as f64));
            }
        });
    out
}

/// The photo position sampled for pixel `p` of the undistorted image.
#[inline]
pub fn source_position(model: &CameraModel, p: DVec2) -> Option<DVec2> {
    let k = &model.intrinsics;
    let ideal = k.from_pixel(p);
    let d = model
        .distortion
        .distort(DVec3::new(ideal.x, ideal.y, 1.0))?;
    Some(k.to_pixel(d))
}

/// Undistorts an image of `channels` interleaved floats per pixel, of the
/// calibration's size, into an image of the same size.
///
/// # Panics
/// If `pixels` does not hold `width × height × channels` values.
pub fn undistort(model: &CameraModel, pixels: &[f32], channels: usize) -> Vec<f32> {
    let (w, h) = (model.width as usize, model.height as usize);
    assert_eq!(pixels.len(), w * h * channels, "image size");
    let mut out = vec![0.0f32; pixels.len()];
    if channels == 0 {
        return out;
    }
    out.par_chunks_mut(w * channels)
        .enumerate()
        .for_each(|(y, row)| {
            for x in 0..w {
                let Some(src) = source_position(model, DVec2::new(x as f64, y as f64)) else {
                    continue;
                };
                bilinear(
                    pixels,
                    w,
                    h,
                    channels,
                    src,
                    &mut row[x * channels..(x + 1) * channels],
                );
            }
        });
    out
}

/// Bilinear lookup at `p` (pixel centres at whole numbers); texels outside
/// the image count as 0, as OpenCV's constant border does.
fn bilinear(pixels: &[f32], w: usize, h: usize, channels: usize, p: DVec2, out: &mut [f32]) {
    if !(p.x > -1.0 && p.y > -1.0 && p.x < w as f64 && p.y < h as f64) {
        return;
    }
    let (x0, y0) = (p.x.floor(), p.y.floor());
    let (fx, fy) = ((p.x - x0) as f32, (p.y - y0) as f32);
    let (x0, y0) = (x0 as i64, y0 as i64);
    for (dy, wy) in [(0, 1.0 - fy), (1, fy)] {
        for (dx, wx) in [(0, 1.0 - fx), (1, fx)] {
            let (x, y) = (x0 + dx, y0 + dy);
            if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 || wx * wy == 0.0 {
                continue;
            }
            let i = (y as usize * w + x as usize) * channels;
            for (c, o) in out.iter_mut().enumerate() {
                *o += wx * wy * pixels[i + c];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrated_camera::Intrinsics;
    use crate::lens_distortion::LensDistortion;

    #[test]
    fn without_distortion_the_image_is_unchanged() {
        let model = CameraModel {
            width: 7,
            height: 5,
            intrinsics: Intrinsics {
                fx: 10.0,
                fy: 11.0,
                cx: 3.2,
                cy: 1.9,
                skew: 0.4,
            },
            distortion: LensDistortion::None,
        };
        let pixels: Vec<f32> = (0..7 * 5 * 2).map(|i| i as f32 * 0.5).collect();
        let out = undistort(&model, &pixels, 2);
        for (a, b) in out.iter().zip(&pixels) {
            assert!((a - b).abs() < 1e-4, "{a} {b}");
        }
    }
}
