//! Feature maps, the values between the network's layers: `channels`
//! planes of `height × width` floats, one plane after another; and the
//! two resamplings of the U-Net, 2×2 max pooling and 2× nearest upsampling.

use rayon::prelude::*;

/// Feature maps, channel-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Planes {
    /// How many planes.
    pub channels: usize,
    /// Rows of each plane.
    pub height: usize,
    /// Columns of each plane.
    pub width: usize,
    /// The values: plane `c`, row `y`, column `x` at `(c·height + y)·width + x`.
    pub data: Vec<f32>,
}

impl Planes {
    /// Planes of zeros.
    pub fn zeros(channels: usize, height: usize, width: usize) -> Planes {
        Planes {
            channels,
            height,
            width,
            data: vec![0.0; channels * height * width],
        }
    }

    /// Plane `c`.
    pub fn plane(&self, c: usize) -> &[f32] {
        let n = self.height * self.width;
        &self.data[c * n..(c + 1) * n]
    }

    /// Plane `c`, to write.
    pub fn plane_mut(&mut self, c: usize) -> &mut [f32] {
        let n = self.height * self.width;
        &mut self.data[c * n..(c + 1) * n]
    }

    /// The largest of each 2×2 block (the size must be even).
    pub fn max_pool(&self) -> Planes {
        debug_assert!(self.height.is_multiple_of(2) && self.width.is_multiple_of(2));
        let (h, w) = (self.height / 2, self.width / 2);
        let mut out = Planes::zeros(self.channels, h, w);
        out.data
            .par_chunks_mut(h * w)
            .zip(self.data.par_chunks(self.height * self.width))
            .for_each(|(dst, src)| {
                for y in 0..h {
                    let (a, b) = (&src[2 * y * self.width..], &src[(2 * y + 1) * self.width..]);
                    for x in 0..w {
                        dst[y * w + x] = a[2 * x].max(a[2 * x + 1]).max(b[2 * x]).max(b[2 * x + 1]);
                    }
                }
            });
        out
    }

    /// Each value copied into a 2×2 block.
    pub fn upsample(&self) -> Planes {
        let (h, w) = (self.height * 2, self.width * 2);
        let mut out = Planes::zeros(self.channels, h, w);
        out.data
            .par_chunks_mut(h * w)
            .zip(self.data.par_chunks(self.height * self.width))
            .for_each(|(dst, src)| {
                for y in 0..h {
                    let row = &src[(y / 2) * self.width..(y / 2 + 1) * self.width];
                    for (x, d) in dst[y * w..(y + 1) * w].iter_mut().enumerate() {
                        *d = row[x / 2];
                    }
                }
            });
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pooling_takes_the_largest_and_upsampling_repeats() {
        let p = Planes {
            channels: 1,
            height: 2,
            width: 4,
            data: vec![1.0, 5.0, -1.0, -2.0, 3.0, 2.0, -3.0, -0.5],
        };
        assert_eq!(p.max_pool().data, [5.0, -0.5]);
        let up = p.max_pool().upsample();
        assert_eq!(up.data, [5.0, 5.0, -0.5, -0.5, 5.0, 5.0, -0.5, -0.5]);
        assert_eq!((up.height, up.width), (2, 4));
    }
}
