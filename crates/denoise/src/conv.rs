//! The network's one kind of layer: a 3×3 convolution (stride 1, zero
//! padding of 1, so the size is kept) with a bias, followed by a ReLU.
//!
//! It runs as a matrix product: the 3×3 neighbourhoods of a band of rows
//! become the columns of a patch matrix (one row per input channel and
//! kernel tap), which the weights (one row per output channel) multiply.
//! Bands run in parallel and each is computed alone, so the result does not
//! depend on the thread count. The input may be several feature maps, read
//! as one concatenated along the channels (the U-Net's skip connections).

use crate::planes::Planes;
use rayon::prelude::*;

/// Output pixels per band: the patch matrix of a band stays within a few
/// MiB (at most 160 input channels × 9 taps × 4 bytes each).
const BAND_PIXELS: usize = 2048;

/// A 3×3 convolution with its ReLU.
#[derive(Debug, Clone)]
pub struct Conv3x3 {
    /// Output channels.
    pub outputs: usize,
    /// Input channels (all inputs together).
    pub inputs: usize,
    /// `outputs × (inputs · 9)`, row-major: output, input, ky, kx (OIDN's
    /// `oihw`, PyTorch's layout: a cross-correlation).
    weight: Vec<f32>,
    /// One per output channel.
    bias: Vec<f32>,
}

impl Conv3x3 {
    /// A convolution of these weights (`outputs × inputs × 3 × 3`) and
    /// biases; `None` if their sizes disagree.
    pub fn new(outputs: usize, inputs: usize, weight: Vec<f32>, bias: Vec<f32>) -> Option<Conv3x3> {
        (weight.len() == outputs * inputs * 9 && bias.len() == outputs).then_some(Conv3x3 {
            outputs,
            inputs,
            weight,
            bias,
        })
    }

    /// The convolution of `parts` concatenated along the channels (all of
    /// one size), with the ReLU.
    pub fn forward(&self, parts: &[&Planes]) -> Planes {
        let (h, w) = (parts[0].height, parts[0].width);
        debug_assert!(parts.iter().all(|p| p.height == h && p.width == w));
        debug_assert_eq!(parts.iter().map(|p| p.channels).sum::<usize>(), self.inputs);
        let k = self.inputs * 9;
        let rows_per_band = (BAND_PIXELS / w).max(1);
        let mut out = Planes::zeros(self.outputs, h, w);
        let bands: Vec<(usize, Vec<f32>)> = (0..h)
            .step_by(rows_per_band)
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|y0| {
                let y1 = (y0 + rows_per_band).min(h);
                let n = (y1 - y0) * w;
                let patches = patches(parts, y0, y1);
                let mut band = vec![0.0f32; self.outputs * n];
                for (o, row) in band.chunks_exact_mut(n).enumerate() {
                    row.fill(self.bias[o]);
                }
                // SAFETY: the pointers and strides describe three row-major
                // matrices held by live vectors: the weights (outputs × k),
                // the patches (k × n) and the band (outputs × n), each of
                // exactly that many elements.
                unsafe {
                    matrixmultiply::sgemm(
                        self.outputs,
                        k,
                        n,
                        1.0,
                        self.weight.as_ptr(),
                        k as isize,
                        1,
                        patches.as_ptr(),
                        n as isize,
                        1,
                        1.0,
                        band.as_mut_ptr(),
                        n as isize,
                        1,
                    );
                }
                for v in &mut band {
                    *v = v.max(0.0);
                }
                (y0, band)
            })
            .collect();
        for (y0, band) in bands {
            let n = band.len() / self.outputs;
            for o in 0..self.outputs {
                out.plane_mut(o)[y0 * w..y0 * w + n].copy_from_slice(&band[o * n..(o + 1) * n]);
            }
        }
        out
    }
}

/// The patch matrix of rows `y0..y1`: row `(c·3 + ky)·3 + kx` holds, for
/// each output pixel of the band, input channel `c` at offset
/// `(ky − 1, kx − 1)`, zero outside the image.
fn patches(parts: &[&Planes], y0: usize, y1: usize) -> Vec<f32> {
    let (h, w) = (parts[0].height, parts[0].width);
    let channels: usize = parts.iter().map(|p| p.channels).sum();
    let n = (y1 - y0) * w;
    let mut m = vec![0.0f32; channels * 9 * n];
    let mut c = 0;
    for part in parts {
        for pc in 0..part.channels {
            let plane = part.plane(pc);
            for ky in 0..3 {
                for kx in 0..3 {
                    let row = &mut m[((c * 3 + ky) * 3 + kx) * n..][..n];
                    for (j, y) in (y0..y1).enumerate() {
                        let sy = y as isize + ky as isize - 1;
                        if sy < 0 || sy >= h as isize {
                            continue;
                        }
                        let src = &plane[sy as usize * w..(sy as usize + 1) * w];
                        let dst = &mut row[j * w..(j + 1) * w];
                        match kx {
                            0 => dst[1..].copy_from_slice(&src[..w - 1]),
                            1 => dst.copy_from_slice(src),
                            _ => dst[..w - 1].copy_from_slice(&src[1..]),
                        }
                    }
                }
            }
            c += 1;
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The convolution written as its definition, one output at a time.
    fn direct(conv: &Conv3x3, x: &Planes) -> Planes {
        let mut out = Planes::zeros(conv.outputs, x.height, x.width);
        for o in 0..conv.outputs {
            for y in 0..x.height as isize {
                for xx in 0..x.width as isize {
                    let mut sum = conv.bias[o];
                    for i in 0..conv.inputs {
                        for ky in 0..3isize {
                            for kx in 0..3isize {
                                let (sy, sx) = (y + ky - 1, xx + kx - 1);
                                if sy < 0
                                    || sx < 0
                                    || sy >= x.height as isize
                                    || sx >= x.width as isize
                                {
                                    continue;
                                }
                                let wgt = conv.weight
                                    [((o * conv.inputs + i) * 3 + ky as usize) * 3 + kx as usize];
                                sum += wgt * x.plane(i)[sy as usize * x.width + sx as usize];
                            }
                        }
                    }
                    out.plane_mut(o)[y as usize * x.width + xx as usize] = sum.max(0.0);
                }
            }
        }
        out
    }

    fn ramp(n: usize, seed: u32) -> Vec<f32> {
        (0..n)
            .map(|i| (((i as u32).wrapping_mul(2_654_435_761) ^ seed) % 1000) as f32 / 500.0 - 1.0)
            .collect()
    }

    #[test]
    fn the_matrix_product_is_the_convolution() {
        // Two inputs concatenated, a width of 1 and bands cut mid-image.
        for (h, w) in [(7, 5), (3, 1), (70, 40)] {
            let a = Planes {
                channels: 2,
                height: h,
                width: w,
                data: ramp(2 * h * w, 1),
            };
            let b = Planes {
                channels: 3,
                height: h,
                width: w,
                data: ramp(3 * h * w, 2),
            };
            let conv = Conv3x3::new(4, 5, ramp(4 * 5 * 9, 3), ramp(4, 4)).unwrap();
            let got = conv.forward(&[&a, &b]);
            let mut joined = a.data.clone();
            joined.extend_from_slice(&b.data);
            let want = direct(
                &conv,
                &Planes {
                    channels: 5,
                    height: h,
                    width: w,
                    data: joined,
                },
            );
            for (g, e) in got.data.iter().zip(&want.data) {
                assert!(
                    (g - e).abs() <= 1e-5 * (1.0 + e.abs()),
                    "{h}×{w}: {g} vs {e}"
                );
            }
        }
        assert!(Conv3x3::new(2, 2, vec![0.0; 35], vec![0.0; 2]).is_none());
    }
}
