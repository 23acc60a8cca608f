//! The RT filter: a noisy colour image (with, optionally, the albedo and
//! normal of the first non-specular hit) in, the clean image out, as Intel
//! Open Image Denoise's "RT" filter computes it with its base networks.
//!
//! 1. The colour is scaled (HDR: [`crate::autoexposure`]; LDR: by 1),
//!    NaN set to 0, clamped to [0, ∞) (HDR) or [0, 1] (LDR) and encoded
//!    ([`crate::transfer`]); the albedo is clamped to [0, 1]; the normal
//!    to [−1, 1] and mapped to [0, 1].
//! 2. The channels (colour, albedo, normal) go into the network's input,
//!    padded with zeros at the bottom and right to multiples of 16.
//! 3. The network's first three output channels, clamped at 0, decoded
//!    and divided by the scale, are the result.

use crate::planes::Planes;
use crate::unet::{UNet, WeightsError};
use crate::weights::{self, Guides};

/// An image: row-major RGB pixels.
#[derive(Debug, Clone, Copy)]
pub struct Image<'a> {
    /// The pixels, `width × height`, from the top row.
    pub pixels: &'a [[f32; 3]],
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
}

/// How to filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// The colour is HDR (linear radiance, unbounded) rather than LDR in
    /// [0, 1].
    pub hdr: bool,
    /// The albedo and normal are clean (noise-free or prefiltered).
    pub clean_aux: bool,
    /// The colour's scale for the network; `None`: automatic (HDR) or 1.
    pub input_scale: Option<f32>,
}

/// Why the filter cannot run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FilterError {
    /// An image's pixels are not its width × height, or the auxiliary
    /// images are not the colour's size.
    #[error("{what}: {got} pixels, where {width}×{height} needs {}", width * height)]
    Size {
        /// Which image.
        what: &'static str,
        /// Its pixel count.
        got: usize,
        /// The colour's width.
        width: usize,
        /// The colour's height.
        height: usize,
    },
    /// A normal without an albedo (OIDN's networks take none).
    #[error("a normal image needs an albedo image too")]
    NormalWithoutAlbedo,
    /// The built-in weights did not load (a damaged build).
    #[error("the denoiser's weights {set}: {source}")]
    Weights {
        /// The weight set.
        set: &'static str,
        /// Why.
        source: WeightsError,
    },
}

/// Denoises `color` guided by `albedo` and `normal` (same size).
pub fn denoise(
    color: Image,
    albedo: Option<Image>,
    normal: Option<Image>,
    options: &Options,
) -> Result<Vec<[f32; 3]>, FilterError> {
    let (w, h) = (color.width, color.height);
    for (what, image) in [
        ("color", Some(color)),
        ("albedo", albedo),
        ("normal", normal),
    ] {
        if let Some(image) = image {
            if image.pixels.len() != w * h || image.width != w || image.height != h {
                return Err(FilterError::Size {
                    what,
                    got: image.pixels.len(),
                    width: w,
                    height: h,
                });
            }
        }
    }
    let guides = match (albedo, normal) {
        (None, None) => Guides::None,
        (Some(_), None) => Guides::Albedo,
        (Some(_), Some(_)) => Guides::AlbedoNormal {
            clean: options.clean_aux,
        },
        (None, Some(_)) => return Err(FilterError::NormalWithoutAlbedo),
    };
    let set = weights::for_color(options.hdr, guides);
    let net = UNet::load(set.bytes).map_err(|source| FilterError::Weights {
        set: set.name,
        source,
    })?;
    let transfer = weights::color_transfer(options.hdr);
    let scale = match options.input_scale {
        Some(s) => s,
        None if options.hdr => crate::autoexposure::input_scale(color.pixels, w, h),
        None => 1.0,
    };
    let (ph, pw) = (h.next_multiple_of(16), w.next_multiple_of(16));
    let mut input = Planes::zeros(net.input_channels(), ph, pw);
    let top = if options.hdr { f32::MAX } else { 1.0 };
    fill(&mut input, 0, color, |v| {
        transfer.forward(sanitise(v * scale, 0.0, top))
    });
    if let Some(albedo) = albedo {
        fill(&mut input, 3, albedo, |v| sanitise(v, 0.0, 1.0));
    }
    if let Some(normal) = normal {
        fill(&mut input, 6, normal, |v| {
            sanitise(v, -1.0, 1.0) * 0.5 + 0.5
        });
    }
    let output = net.forward(&input);
    drop(input);
    let unscale = if scale == 0.0 { 0.0 } else { 1.0 / scale };
    let mut out = vec![[0.0f32; 3]; w * h];
    for (c, plane) in (0..3).map(|c| (c, output.plane(c))) {
        for y in 0..h {
            for x in 0..w {
                let v = transfer.inverse(sanitise(plane[y * pw + x], 0.0, f32::MAX));
                let v = if options.hdr { v } else { v.min(1.0) };
                out[y * w + x][c] = v * unscale;
            }
        }
    }
    Ok(out)
}

/// NaN as 0, then clamped to `[lo, hi]`.
fn sanitise(v: f32, lo: f32, hi: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(lo, hi)
    }
}

/// Writes `image`'s three channels, mapped by `f`, into planes `first..first + 3`.
fn fill(planes: &mut Planes, first: usize, image: Image, f: impl Fn(f32) -> f32) {
    let pw = planes.width;
    for c in 0..3 {
        let plane = planes.plane_mut(first + c);
        for y in 0..image.height {
            for x in 0..image.width {
                plane[y * pw + x] = f(image.pixels[y * image.width + x][c]);
            }
        }
    }
}
