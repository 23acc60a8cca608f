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
use std::cell::RefCell;

/// Output pixels per band: the patch matrix of a band stays within a few
/// MiB (at most 160 input channels × 9 taps × 4 bytes each).
pub(crate) const BAND_PIXELS: usize = 2048;

thread_local! {
    /// Each thread's patch matrix and product, reused from band to band so
    /// that no band pays for fresh memory.
    static SCRATCH: RefCell<(Vec<f32>, Vec<f32>)> = const { RefCell::new((Vec::new(), Vec::new())) };
}

/// Runs `f` with this thread's two scratch buffers, grown to `a` and `b`
/// values (their contents are whatever the last band left).
pub(crate) fn with_scratch<R>(
    a: usize,
    b: usize,
    f: impl FnOnce(&mut [f32], &mut [f32]) -> R,
) -> R {
    SCRATCH.with(|cell| {
        let mut guard = cell.borrow_mut();
        let (x, y) = &mut *guard;
        if x.len() < a {
            x.resize(a, 0.0);
        }
        if y.len() < b {
            y.resize(b, 0.0);
        }
        f(&mut x[..a], &mut y[..b])
    })
}

/// `c = a · b` for row-major `a` (`m × k`), `b` (`k × n`) and `c` (`m × n`),
/// single-threaded (the bands are the parallelism).
pub(crate) fn matmul(m: usize, k: usize, n: usize, a: &[f32], b: &[f32], c: &mut [f32]) {
    assert!(a.len() >= m * k && b.len() >= k * n && c.len() >= m * n);
    // SAFETY: the asserts above show the three row-major matrices lie
    // within their slices; `c` is borrowed mutably, so nothing aliases it.
    unsafe {
        matrixmultiply::sgemm(
            m,
            k,
            n,
            1.0,
            a.as_ptr(),
            k as isize,
            1,
            b.as_ptr(),
            n as isize,
            1,
            0.0,
            c.as_mut_ptr(),
            n as isize,
            1,
        );
    }
}

/// A 3×3 convolution with its ReLU.
#[derive(Debug, Clone)]
pub struct Conv3x3 {
    /// Output channels.
    pub outputs: usize,
    /// Input channels (all inputs together).
    pub inputs: usize,
    /// `outputs × (inputs · 9)`, row-major: output, input, ky, kx (OIDN's
    /// `oihw`, PyTorch's layout: a cross-correlation).
    pub(crate) weight: Vec<f32>,
    /// One per output channel.
    pub(crate) bias: Vec<f32>,
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
        Bands::of(&mut out, rows_per_band).for_each(|y0, y1, write| {
            let n = (y1 - y0) * w;
            with_scratch(k * n, self.outputs * n, |patch, product| {
                patches(parts, y0, y1, patch);
                matmul(self.outputs, k, n, &self.weight, patch, product);
                for (o, row) in product.chunks_exact_mut(n).enumerate() {
                    let b = self.bias[o];
                    row.iter_mut().for_each(|v| *v = (*v + b).max(0.0));
                    write(o, y0 * w, 1, row);
                }
            })
        });
        out
    }
}

/// Feature maps cut into bands of rows that threads fill at once, each
/// band by one thread and each by itself, so the result does not depend on
/// the thread count.
pub(crate) struct Bands<'a> {
    data: *mut f32,
    len: usize,
    height: usize,
    width: usize,
    rows: usize,
    _out: std::marker::PhantomData<&'a mut Planes>,
}

// SAFETY: `Bands` hands each band's writer only the rows of its own band
// (checked in `for_each`), so threads never write the same value; the
// planes are borrowed mutably for `'a`, so nothing else reads them
// meanwhile; and `for_each` consumes the `Bands`, so it runs once.
unsafe impl Sync for Bands<'_> {}

impl<'a> Bands<'a> {
    /// `out` in bands of `rows` rows.
    pub(crate) fn of(out: &'a mut Planes, rows: usize) -> Bands<'a> {
        Bands {
            data: out.data.as_mut_ptr(),
            len: out.data.len(),
            height: out.height,
            width: out.width,
            rows,
            _out: std::marker::PhantomData,
        }
    }

    /// Calls `f(y0, y1, write)` for each band of rows `y0..y1`, in
    /// parallel; `write(channel, offset, stride, values)` stores
    /// `values[i]` at pixel `offset + i·stride` (a pixel index is
    /// row · width + column) of plane `channel`; every such pixel must lie
    /// within the band's rows.
    pub(crate) fn for_each<F>(self, f: F)
    where
        F: Fn(usize, usize, &dyn Fn(usize, usize, usize, &[f32])) + Sync,
    {
        // The closure borrows the whole `Bands` (which is `Sync`), not its
        // raw pointer alone.
        let this = &self;
        let plane = self.height * self.width;
        (0..self.height.div_ceil(self.rows))
            .into_par_iter()
            .for_each(|band| {
                let y0 = band * this.rows;
                let y1 = (y0 + this.rows).min(this.height);
                let (lo, hi) = (y0 * this.width, y1 * this.width);
                let write = |channel: usize, offset: usize, stride: usize, values: &[f32]| {
                    if values.is_empty() {
                        return;
                    }
                    let last = (values.len() - 1)
                        .checked_mul(stride)
                        .and_then(|span| span.checked_add(offset))
                        .filter(|&last| stride > 0 && offset >= lo && last < hi)
                        .expect("a band writes only its own rows");
                    assert!(channel * plane + last < this.len);
                    let base = channel * plane + offset;
                    for (i, v) in values.iter().enumerate() {
                        // SAFETY: every index from `base` to `channel · plane
                        // + last` lies in this band's rows of plane `channel`
                        // (asserted above), which no other band writes, and
                        // within the planes' values.
                        unsafe { *this.data.add(base + i * stride) = *v };
                    }
                };
                f(y0, y1, &write)
            });
    }
}

/// `dst[x] = src[x + dx]` for `dx` in −1..=1 (slices of one length), 0
/// where that falls outside `src`: a row of a 3×3 window's column.
pub(crate) fn copy_shifted(dst: &mut [f32], src: &[f32], dx: isize) {
    let w = dst.len();
    match dx {
        -1 => {
            dst[0] = 0.0;
            dst[1..].copy_from_slice(&src[..w - 1]);
        }
        0 => dst.copy_from_slice(src),
        _ => {
            dst[..w - 1].copy_from_slice(&src[1..]);
            dst[w - 1] = 0.0;
        }
    }
}

/// Writes into `m` the patch matrix of rows `y0..y1`: row
/// `(c·3 + ky)·3 + kx` holds, for each output pixel of the band, input
/// channel `c` at offset `(ky − 1, kx − 1)`, zero outside the image. Every
/// value of `m` is written.
fn patches(parts: &[&Planes], y0: usize, y1: usize, m: &mut [f32]) {
    let (h, w) = (parts[0].height, parts[0].width);
    let n = (y1 - y0) * w;
    let mut c = 0;
    for part in parts {
        for pc in 0..part.channels {
            let plane = part.plane(pc);
            for ky in 0..3 {
                for kx in 0..3 {
                    let row = &mut m[((c * 3 + ky) * 3 + kx) * n..][..n];
                    for (j, y) in (y0..y1).enumerate() {
                        let dst = &mut row[j * w..(j + 1) * w];
                        let sy = y as isize + ky as isize - 1;
                        if sy < 0 || sy >= h as isize {
                            dst.fill(0.0);
                            continue;
                        }
                        let src = &plane[sy as usize * w..(sy as usize + 1) * w];
                        copy_shifted(dst, src, kx as isize - 1);
                    }
                }
            }
            c += 1;
        }
    }
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
