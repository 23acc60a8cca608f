//! Chunks of [`W`] lanes: components loaded from the lane arrays and stored
//! back.

use super::*;

/// Lanes per chunk of [`shade_lanes`]: one AVX-512 register of `f32`.
pub(super) const W: usize = 16;

/// A component of [`W`] lanes, copied out of a lane array (zero past its end).
#[inline(always)]
pub(super) fn load<T: Copy + Default>(src: &[T], start: usize) -> [T; W] {
    // A whole chunk is a fixed-size copy (register moves); only the last,
    // partial one needs a variable-length copy.
    if let Some(Ok(chunk)) = src.get(start..start + W).map(<[T; W]>::try_from) {
        return chunk;
    }
    let mut out = [T::default(); W];
    let m = (src.len() - start).min(W);
    out[..m].copy_from_slice(&src[start..start + m]);
    out
}

/// The fixed random streams of [`W`] lanes (see [`SoaLanes::sampler`]).
#[inline(always)]
pub(super) fn load_streams(streams: &[Vec<u32>; 3], start: usize) -> [SampleStream; W] {
    let parts = [
        load(&streams[0], start),
        load(&streams[1], start),
        load(&streams[2], start),
    ];
    std::array::from_fn(|k| SampleStream {
        reversed_sample: parts[0][k],
        pixel_lo: parts[1][k],
        pixel_hi: parts[2][k],
    })
}

/// [`load`] with `fill` past the end of the lane array.
#[inline(always)]
pub(super) fn load_or<T: Copy + Default>(src: &[T], start: usize, fill: T) -> [T; W] {
    let mut out = load(src, start);
    let m = (src.len() - start).min(W);
    out[m..].fill(fill);
    out
}

/// Copies a component of [`W`] lanes back (as far as the lane array goes).
#[inline(always)]
pub(super) fn store<T: Copy>(dst: &mut [T], start: usize, src: &[T; W]) {
    if let Some(chunk) = dst.get_mut(start..start + W) {
        chunk.copy_from_slice(src);
        return;
    }
    let m = (dst.len() - start).min(W);
    dst[start..start + m].copy_from_slice(&src[..m]);
}

/// [`store`] of the lanes `owned` marks (`all`: every lane), leaving the
/// others as they are.
#[inline(always)]
pub(super) fn store_owned<T: Copy + Default>(
    dst: &mut [T],
    start: usize,
    src: &[T; W],
    owned: &[bool; W],
    all: bool,
) {
    if all {
        return store(dst, start, src);
    }
    let old = load(dst, start);
    let merged = std::array::from_fn(|k| if owned[k] { src[k] } else { old[k] });
    store(dst, start, &merged);
}
