//! LPIPS, the learned perceptual image patch similarity of Zhang et al.
//! (2018), version 0.1 with AlexNet, run on the CPU.
//!
//! Both images (display values, 0–1) are mapped to [−1, 1] and scaled per
//! channel (`(x − shift) / scale`, LPIPS's `ScalingLayer`), then passed
//! through AlexNet's five convolution layers (11×11 stride 4, 5×5, 3×3,
//! 3×3, 3×3, each followed by a ReLU; 3×3 stride-2 max pooling after the
//! first two). At each layer's output, every pixel's feature vector is
//! divided by its length; the squared differences of the two images'
//! unit vectors are weighted per channel by the learned linear layer, summed
//! over channels and averaged over the pixels; the score is the sum over
//! the five layers (0 for identical images, larger for more different).
//!
//! The weights ship inside plsr (`assets/lpips/alex-v0.1.bin`, half floats,
//! converted once by `scripts/convert_lpips_weights.py`; BSD licensed, see
//! `assets/lpips/LICENSE`). Convolutions run as matrix products of image
//! patches (`matrixmultiply`), a band of output rows at a time on the
//! thread pool, so memory stays bounded on panoramas.

use super::MetricImage;
use crate::error::{BadWeights, Error, Result};
use plsr_base::Vocabulary;
use rayon::prelude::*;
use std::sync::OnceLock;

/// The weights file, embedded.
static WEIGHTS: &[u8] = include_bytes!("../../../assets/lpips/alex-v0.1.bin");

/// LPIPS's input scaling: `(x − SHIFT) / SCALE` per channel, on [−1, 1].
const SHIFT: [f32; 3] = [-0.030, -0.088, -0.188];
const SCALE: [f32; 3] = [0.458, 0.448, 0.450];

/// One convolution layer: kernels in OIHW order, a bias per output.
struct Conv {
    outputs: usize,
    inputs: usize,
    size: usize,
    stride: usize,
    pad: usize,
    weight: Vec<f32>,
    bias: Vec<f32>,
}

/// AlexNet's five convolutions and LPIPS's five linear layers.
struct Network {
    conv: Vec<Conv>,
    lin: Vec<Vec<f32>>,
}

/// A feature map: `channels` planes of `h × w`, channel-major.
struct Features {
    channels: usize,
    w: usize,
    h: usize,
    v: Vec<f32>,
}

fn network() -> Result<&'static Network> {
    static NET: OnceLock<std::result::Result<Network, BadWeights>> = OnceLock::new();
    NET.get_or_init(|| parse(WEIGHTS))
        .as_ref()
        .map_err(|m| Error::Weights(m.clone()))
}

/// Reads the weights file (see the conversion script for its layout).
fn parse(bytes: &[u8]) -> std::result::Result<Network, BadWeights> {
    let mut at = 0usize;
    let mut take = |n: usize| -> std::result::Result<&[u8], BadWeights> {
        let s = bytes.get(at..at + n).ok_or(BadWeights::Truncated)?;
        at += n;
        Ok(s)
    };
    if take(10)? != b"PLSRLPIPS1" {
        return Err(BadWeights::NotLpips);
    }
    let u32_at = |s: &[u8]| u32::from_le_bytes([s[0], s[1], s[2], s[3]]) as usize;
    let count = u32_at(take(4)?);
    let mut tensors = std::collections::HashMap::new();
    for _ in 0..count {
        let n = u32_at(take(4)?);
        let name = String::from_utf8(take(n)?.to_vec()).map_err(|_| BadWeights::NameNotUtf8)?;
        let rank = u32_at(take(4)?);
        let mut dims = Vec::with_capacity(rank);
        for _ in 0..rank {
            dims.push(u32_at(take(4)?));
        }
        let len: usize = dims.iter().product();
        let values = take(2 * len)?
            .chunks_exact(2)
            .map(|b| half::f16::from_le_bytes([b[0], b[1]]).to_f32())
            .collect::<Vec<f32>>();
        tensors.insert(name, (dims, values));
    }
    let mut get = |name: &str| {
        tensors
            .remove(name)
            .ok_or_else(|| BadWeights::Missing(name.into()))
    };
    let layout = [(11, 4, 2), (5, 1, 2), (3, 1, 1), (3, 1, 1), (3, 1, 1)];
    let mut conv = Vec::new();
    let mut lin = Vec::new();
    for (k, (size, stride, pad)) in layout.into_iter().enumerate() {
        let (dims, weight) = get(&format!("conv{}.weight", k + 1))?;
        let (_, bias) = get(&format!("conv{}.bias", k + 1))?;
        if dims.len() != 4 || dims[2] != size || dims[3] != size || bias.len() != dims[0] {
            return Err(BadWeights::ConvShape { layer: k + 1, dims });
        }
        let (_, w) = get(&format!("lin{}.weight", k + 1))?;
        if w.len() != dims[0] {
            return Err(BadWeights::LinearShape {
                layer: k + 1,
                weights: w.len(),
                channels: dims[0],
            });
        }
        conv.push(Conv {
            outputs: dims[0],
            inputs: dims[1],
            size,
            stride,
            pad,
            weight,
            bias,
        });
        lin.push(w);
    }
    Ok(Network { conv, lin })
}

/// Output pixels computed per task (whole rows, at least one): small
/// enough that a band's patch matrix (up to 3456 × 512 values) stays in
/// the cache between being written and being multiplied. Measured on the
/// 1680×840 pair of `plsr bench compare`: 512 pixels 0.80 s, 1024 0.88 s,
/// 4096 1.28 s, 16384 1.39 s.
const BAND_PIXELS: usize = 512;

impl Conv {
    /// The convolution of `x`, plus bias, through a ReLU.
    fn apply(&self, x: &Features) -> Features {
        let ow = (x.w + 2 * self.pad - self.size) / self.stride + 1;
        let oh = (x.h + 2 * self.pad - self.size) / self.stride + 1;
        let k = self.inputs * self.size * self.size;
        let rows_per_band = (BAND_PIXELS / ow).max(1);
        let bands: Vec<(usize, Vec<f32>)> = (0..oh)
            .step_by(rows_per_band)
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|r0| {
                let r1 = (r0 + rows_per_band).min(oh);
                let n = (r1 - r0) * ow;
                // Patches: one column per output pixel, rows (i, ky, kx).
                let mut cols = vec![0.0f32; k * n];
                for i in 0..self.inputs {
                    let plane = &x.v[i * x.w * x.h..(i + 1) * x.w * x.h];
                    for ky in 0..self.size {
                        for kx in 0..self.size {
                            let row = (i * self.size + ky) * self.size + kx;
                            let dst = &mut cols[row * n..(row + 1) * n];
                            for (j, oy) in (r0..r1).enumerate() {
                                let y = (oy * self.stride + ky) as isize - self.pad as isize;
                                if y < 0 || y >= x.h as isize {
                                    continue;
                                }
                                let src = &plane[y as usize * x.w..(y as usize + 1) * x.w];
                                for ox in 0..ow {
                                    let xx = (ox * self.stride + kx) as isize - self.pad as isize;
                                    if xx >= 0 && xx < x.w as isize {
                                        dst[j * ow + ox] = src[xx as usize];
                                    }
                                }
                            }
                        }
                    }
                }
                let mut out = vec![0.0f32; self.outputs * n];
                for (o, row) in out.chunks_exact_mut(n).enumerate() {
                    row.fill(self.bias[o]);
                }
                // SAFETY: the pointers and strides describe the three
                // row-major matrices allocated above (outputs × k weights,
                // k × n patches, outputs × n result), all in bounds.
                unsafe {
                    matrixmultiply::sgemm(
                        self.outputs,
                        k,
                        n,
                        1.0,
                        self.weight.as_ptr(),
                        k as isize,
                        1,
                        cols.as_ptr(),
                        n as isize,
                        1,
                        1.0,
                        out.as_mut_ptr(),
                        n as isize,
                        1,
                    );
                }
                for v in &mut out {
                    *v = v.max(0.0);
                }
                (r0, out)
            })
            .collect();
        let mut v = vec![0.0f32; self.outputs * ow * oh];
        for (r0, band) in bands {
            let n = band.len() / self.outputs;
            for o in 0..self.outputs {
                let dst = o * ow * oh + r0 * ow;
                v[dst..dst + n].copy_from_slice(&band[o * n..(o + 1) * n]);
            }
        }
        Features {
            channels: self.outputs,
            w: ow,
            h: oh,
            v,
        }
    }
}

/// 3×3 max pooling with stride 2 (no padding).
fn max_pool(x: &Features) -> Features {
    let ow = (x.w - 3) / 2 + 1;
    let oh = (x.h - 3) / 2 + 1;
    let mut v = vec![0.0f32; x.channels * ow * oh];
    v.par_chunks_mut(ow * oh).enumerate().for_each(|(c, out)| {
        let plane = &x.v[c * x.w * x.h..(c + 1) * x.w * x.h];
        for oy in 0..oh {
            for ox in 0..ow {
                let mut m = f32::NEG_INFINITY;
                for dy in 0..3 {
                    for dx in 0..3 {
                        m = m.max(plane[(2 * oy + dy) * x.w + 2 * ox + dx]);
                    }
                }
                out[oy * ow + ox] = m;
            }
        }
    });
    Features {
        channels: x.channels,
        w: ow,
        h: oh,
        v,
    }
}

/// The five layers' outputs for one image.
fn features(net: &Network, img: &MetricImage) -> Vec<Features> {
    let (w, h) = (img.width, img.height);
    let display = img.display();
    let mut v = vec![0.0f32; 3 * w * h];
    for c in 0..3 {
        for p in 0..w * h {
            v[c * w * h + p] = (display[3 * p + c] * 2.0 - 1.0 - SHIFT[c]) / SCALE[c];
        }
    }
    let input = Features {
        channels: 3,
        w,
        h,
        v,
    };
    let mut out: Vec<Features> = Vec::with_capacity(5);
    for (k, conv) in net.conv.iter().enumerate() {
        let x = out.last().unwrap_or(&input);
        let next = if k == 1 || k == 2 {
            conv.apply(&max_pool(x))
        } else {
            conv.apply(x)
        };
        out.push(next);
    }
    out
}

/// The smallest side LPIPS accepts, pixels (the last layer keeps a pixel).
pub const MIN_SIDE: usize = 32;

/// LPIPS of two images of the same size (0 when identical).
pub fn lpips(a: &MetricImage, b: &MetricImage) -> Result<f64> {
    super::same_size("LPIPS: ", a, b)?;
    if a.width.min(a.height) < MIN_SIDE {
        return Err(Error::invalid_argument(format!(
            "LPIPS: a {}×{} image is too small (at least {MIN_SIDE} pixels a side)",
            a.width, a.height
        )));
    }
    let net = network()?;
    let (fa, fb) = rayon::join(|| features(net, a), || features(net, b));
    let mut total = 0.0f64;
    for ((x, y), lin) in fa.iter().zip(&fb).zip(&net.lin) {
        let pixels = x.w * x.h;
        let sum: f64 = (0..pixels)
            .into_par_iter()
            .map(|p| {
                let (mut nx, mut ny) = (0.0f32, 0.0f32);
                for c in 0..x.channels {
                    nx += x.v[c * pixels + p].powi(2);
                    ny += y.v[c * pixels + p].powi(2);
                }
                let (nx, ny) = (nx.sqrt() + 1e-10, ny.sqrt() + 1e-10);
                let mut d = 0.0f32;
                for (c, w) in lin.iter().enumerate() {
                    let e = x.v[c * pixels + p] / nx - y.v[c * pixels + p] / ny;
                    d += w * e * e;
                }
                d as f64
            })
            .sum();
        total += sum / pixels as f64;
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_weights_load_with_alexnets_shapes() {
        let net = network().unwrap();
        let shapes: Vec<(usize, usize, usize)> = net
            .conv
            .iter()
            .map(|c| (c.outputs, c.inputs, c.size))
            .collect();
        assert_eq!(
            shapes,
            [
                (64, 3, 11),
                (192, 64, 5),
                (384, 192, 3),
                (256, 384, 3),
                (256, 256, 3)
            ]
        );
        // LPIPS's linear weights are non-negative.
        assert!(net.lin.iter().flatten().all(|&w| w >= 0.0));
    }

    #[test]
    fn a_convolution_equals_the_direct_sum() {
        // 2 inputs, 3 outputs, 3×3 kernel, stride 2, pad 1, on a 7×5 image.
        let conv = Conv {
            outputs: 3,
            inputs: 2,
            size: 3,
            stride: 2,
            pad: 1,
            weight: (0..3 * 2 * 9)
                .map(|i| ((i * 7) % 11) as f32 - 5.0)
                .collect(),
            bias: vec![0.5, -20.0, 1.0],
        };
        let x = Features {
            channels: 2,
            w: 7,
            h: 5,
            v: (0..2 * 35).map(|i| ((i * 5) % 13) as f32 - 6.0).collect(),
        };
        let y = conv.apply(&x);
        assert_eq!((y.w, y.h), (4, 3));
        for o in 0..3 {
            for oy in 0..3 {
                for ox in 0..4 {
                    let mut s = conv.bias[o];
                    for i in 0..2 {
                        for ky in 0..3 {
                            for kx in 0..3 {
                                let (yy, xx) = (2 * oy + ky, 2 * ox + kx);
                                if (1..=5).contains(&yy) && (1..=7).contains(&xx) {
                                    s += conv.weight[((o * 2 + i) * 3 + ky) * 3 + kx]
                                        * x.v[i * 35 + (yy - 1) * 7 + xx - 1];
                                }
                            }
                        }
                    }
                    assert_eq!(y.v[o * 12 + oy * 4 + ox], s.max(0.0), "o {o} ({ox}, {oy})");
                }
            }
        }
    }
}
