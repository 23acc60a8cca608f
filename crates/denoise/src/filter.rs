//! The RT filter: a noisy colour image (with, optionally, the albedo and
//! normal of the first non-specular hit) in, the clean image out, as Intel
//! Open Image Denoise's "RT" filter computes it with its base networks.
//!
//! 1. Images with NaN or infinite values are refused. The colour is
//!    scaled (HDR: [`crate::autoexposure`]; LDR: by 1), clamped to [0, ∞) (HDR) or [0, 1] (LDR) and encoded
//!    ([`crate::transfer`]); the albedo is clamped to [0, 1]; the normal
//!    to [−1, 1] and mapped to [0, 1].
//! 2. The channels (colour, albedo, normal) go into the network's input,
//!    padded with zeros at the bottom and right to multiples of 16.
//! 3. The network's first three output channels, clamped at 0, decoded
//!    and divided by the scale, are the result.

use crate::planes::Planes;
use crate::transfer::Transfer;
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

impl<'a> Image<'a> {
    /// The image of `pixels`, `width × height`, from the top row.
    pub fn new(pixels: &'a [[f32; 3]], width: usize, height: usize) -> Image<'a> {
        Image {
            pixels,
            width,
            height,
        }
    }
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
    /// Pixels that are NaN or infinite: the network would spread them (OIDN
    /// reads NaN as 0 and infinity as the largest float; plsr refuses).
    #[error("{what}: {count} pixels are NaN or infinite")]
    NonFinite {
        /// Which image.
        what: &'static str,
        /// How many pixels have a value that is not finite.
        count: usize,
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
            check_finite(what, image.pixels)?;
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
    let scale = match options.input_scale {
        Some(s) => s,
        None if options.hdr => crate::autoexposure::input_scale(color.pixels, w, h),
        None => 1.0,
    };
    let encoding = Encoding {
        main: Main::Color { hdr: options.hdr },
        transfer: weights::color_transfer(options.hdr),
        scale,
    };
    run(set, &encoding, &[Some(color), albedo, normal], w, h)
}

/// Which auxiliary layer a prefilter cleans.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Aux {
    /// An albedo layer (values in [0, 1]).
    Albedo,
    /// A normal layer (values in [−1, 1], any length).
    Normal,
}

/// Cleans a noisy auxiliary layer (OIDN's albedo and normal prefilters),
/// so that the colour can then be denoised with `clean_aux`: a render's
/// layers are noisy where the first hit varies within a pixel (motion,
/// depth of field, glossy or rough transmission).
pub fn prefilter(aux: Image, kind: Aux) -> Result<Vec<[f32; 3]>, FilterError> {
    let (w, h) = (aux.width, aux.height);
    if aux.pixels.len() != w * h {
        return Err(FilterError::Size {
            what: match kind {
                Aux::Albedo => "albedo",
                Aux::Normal => "normal",
            },
            got: aux.pixels.len(),
            width: w,
            height: h,
        });
    }
    check_finite(
        match kind {
            Aux::Albedo => "albedo",
            Aux::Normal => "normal",
        },
        aux.pixels,
    )?;
    let (set, encoding) = match kind {
        Aux::Albedo => (
            weights::albedo_prefilter(),
            Encoding {
                main: Main::Albedo,
                transfer: Transfer::Srgb,
                scale: 1.0,
            },
        ),
        Aux::Normal => (
            weights::normal_prefilter(),
            Encoding {
                main: Main::Normal,
                transfer: Transfer::Linear,
                scale: 1.0,
            },
        ),
    };
    run(set, &encoding, &[Some(aux), None, None], w, h)
}

/// [`denoise`] after the albedo and normal are cleaned by [`prefilter`],
/// with the weights for clean guides (`clean_aux` is implied): three
/// networks instead of one.
pub fn denoise_prefiltered(
    color: Image,
    albedo: Option<Image>,
    normal: Option<Image>,
    options: &Options,
) -> Result<Vec<[f32; 3]>, FilterError> {
    if normal.is_some() && albedo.is_none() {
        return Err(FilterError::NormalWithoutAlbedo);
    }
    let albedo = albedo
        .map(|a| prefilter(a, Aux::Albedo).map(|p| (p, a.width, a.height)))
        .transpose()?;
    let normal = normal
        .map(|n| prefilter(n, Aux::Normal).map(|p| (p, n.width, n.height)))
        .transpose()?;
    fn image((pixels, width, height): &(Vec<[f32; 3]>, usize, usize)) -> Image<'_> {
        Image {
            pixels,
            width: *width,
            height: *height,
        }
    }
    denoise(
        color,
        albedo.as_ref().map(image),
        normal.as_ref().map(image),
        &Options {
            clean_aux: true,
            ..*options
        },
    )
}

/// Refuses `pixels` if any value is NaN or infinite.
fn check_finite(what: &'static str, pixels: &[[f32; 3]]) -> Result<(), FilterError> {
    let count = pixels
        .iter()
        .filter(|p| !p.iter().all(|v| v.is_finite()))
        .count();
    if count == 0 {
        Ok(())
    } else {
        Err(FilterError::NonFinite { what, count })
    }
}

/// Runs the network of `set` over `images` (`w × h`), tile by tile.
fn run(
    set: weights::WeightSet,
    encoding: &Encoding,
    images: &[Option<Image>; 3],
    w: usize,
    h: usize,
) -> Result<Vec<[f32; 3]>, FilterError> {
    let net = UNet::load(set.bytes).map_err(|source| FilterError::Weights {
        set: set.name,
        source,
    })?;
    let mut out = vec![[0.0f32; 3]; w * h];
    for tile in tiles(w, h, MAX_TILE_CORE, ONE_TILE_PIXELS) {
        let input = encoding.input(images, &tile, net.input_channels());
        let output = net.forward(&input);
        drop(input);
        encoding.output(&output, &tile, &mut out, w);
    }
    Ok(out)
}

/// The largest image (padded, in pixels) run as one tile: a 1920×1080
/// frame, whose feature maps peak at about 1.3 GiB (the 73 input channels
/// of `dec_conv1a`, its 64 outputs at full resolution, and the skips).
/// Tiles cost the work of their overlaps (30 % more for 1080p in four).
const ONE_TILE_PIXELS: usize = 1920 * 1088;

/// The largest side of a tile's core, in pixels, for larger images: a
/// 1024² core with its overlap peaks at about 0.9 GiB, whatever the image's
/// size.
const MAX_TILE_CORE: usize = 1024;

/// How far each tile reaches past its core on every side that has a
/// neighbour, in pixels: past the network's receptive radius (87 pixels),
/// and a multiple of 16 so that tiles keep the pooling grid of the whole
/// image. With it, tiles give exactly what the whole image would.
const OVERLAP: usize = 96;

/// A tile: the network runs over `x0..x1 × y0..y1` (a multiple of 16 each
/// way, zeros beyond the image) and keeps `core_x0..core_x1 ×
/// core_y0..core_y1`.
#[derive(Debug, Clone, PartialEq)]
struct Tile {
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
    core_x0: usize,
    core_x1: usize,
    core_y0: usize,
    core_y1: usize,
}

/// The tiles of a `w × h` image: one if it has at most `one_tile`
/// pixels once padded, else cores of at most `max_core` (multiples of 16)
/// reaching [`OVERLAP`] past on the sides they share.
fn tiles(w: usize, h: usize, max_core: usize, one_tile: usize) -> Vec<Tile> {
    let whole = w.next_multiple_of(16) * h.next_multiple_of(16) <= one_tile;
    let spans = |n: usize| -> Vec<(usize, usize, usize, usize)> {
        let padded = n.next_multiple_of(16);
        let count = if whole {
            1
        } else {
            padded.div_ceil(max_core).max(1)
        };
        let core = padded.div_ceil(count).next_multiple_of(16);
        (0..count)
            .map(|i| {
                let (c0, c1) = (i * core, ((i + 1) * core).min(padded));
                let lo = c0.saturating_sub(OVERLAP);
                let hi = (c1 + OVERLAP).min(padded);
                (lo, hi, c0, c1.min(n))
            })
            .filter(|s| s.2 < s.3)
            .collect()
    };
    let (columns, rows) = (spans(w), spans(h));
    let mut out = Vec::new();
    for &(y0, y1, core_y0, core_y1) in &rows {
        for &(x0, x1, core_x0, core_x1) in &columns {
            out.push(Tile {
                x0,
                x1,
                y0,
                y1,
                core_x0,
                core_x1,
                core_y0,
                core_y1,
            });
        }
    }
    out
}

/// What the network's first three channels hold.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Main {
    /// Colour, HDR or LDR.
    Color {
        /// Unbounded rather than in [0, 1].
        hdr: bool,
    },
    /// An albedo layer to prefilter, in [0, 1].
    Albedo,
    /// A normal layer to prefilter, in [−1, 1].
    Normal,
}

/// How values go into the network and come out of it.
struct Encoding {
    main: Main,
    transfer: Transfer,
    scale: f32,
}

impl Encoding {
    /// The network's input over `tile`: colour, then albedo and normal
    /// where given, encoded; zeros beyond the image.
    fn input(&self, images: &[Option<Image>; 3], tile: &Tile, channels: usize) -> Planes {
        let (tw, th) = (tile.x1 - tile.x0, tile.y1 - tile.y0);
        let mut planes = Planes::zeros(channels, th, tw);
        let [color, albedo, normal] = images;
        // Colour, then albedo and normal where given, each encoded by a
        // function of its own (generic, so that it inlines per pixel).
        let mut first = 0;
        if let Some(color) = color {
            let t = self.transfer;
            match self.main {
                Main::Color { hdr } => {
                    let top = if hdr { f32::MAX } else { 1.0 };
                    encode_into(&mut planes, first, color, tile, |v| {
                        t.forward(sanitise(v * self.scale, 0.0, top))
                    })
                }
                Main::Albedo => encode_into(&mut planes, first, color, tile, |v| {
                    t.forward(sanitise(v, 0.0, 1.0))
                }),
                Main::Normal => encode_into(&mut planes, first, color, tile, |v| {
                    t.forward(sanitise(v, -1.0, 1.0) * 0.5 + 0.5)
                }),
            }
            first += 3;
        }
        if let Some(albedo) = albedo {
            encode_into(&mut planes, first, albedo, tile, |v| sanitise(v, 0.0, 1.0));
            first += 3;
        }
        if let Some(normal) = normal {
            encode_into(&mut planes, first, normal, tile, |v| {
                sanitise(v, -1.0, 1.0) * 0.5 + 0.5
            });
        }
        planes
    }

    /// Writes the core of `tile` from the network's `output` into `out` (an
    /// image `width` pixels wide): decoded, clamped at 0, scaled back.
    fn output(&self, output: &Planes, tile: &Tile, out: &mut [[f32; 3]], width: usize) {
        let tw = tile.x1 - tile.x0;
        let unscale = if self.scale == 0.0 {
            0.0
        } else {
            1.0 / self.scale
        };
        for c in 0..3 {
            let plane = output.plane(c);
            for y in tile.core_y0..tile.core_y1 {
                let row = &mut out[y * width + tile.core_x0..y * width + tile.core_x1];
                let src = &plane[(y - tile.y0) * tw + tile.core_x0 - tile.x0..][..row.len()];
                for (pixel, &v) in row.iter_mut().zip(src) {
                    let v = self.transfer.inverse(sanitise(v, 0.0, f32::MAX));
                    let v = match self.main {
                        Main::Color { hdr: true } => v,
                        Main::Color { hdr: false } | Main::Albedo => v.min(1.0),
                        Main::Normal => (2.0 * v - 1.0).clamp(-1.0, 1.0),
                    };
                    pixel[c] = v * unscale;
                }
            }
        }
    }
}

/// Writes `image`'s three channels over `tile`, mapped by `encode`, into
/// planes `first..first + 3`; what lies beyond the image stays 0.
fn encode_into(
    planes: &mut Planes,
    first: usize,
    image: &Image,
    tile: &Tile,
    encode: impl Fn(f32) -> f32,
) {
    let tw = tile.x1 - tile.x0;
    for c in 0..3 {
        let plane = planes.plane_mut(first + c);
        for y in tile.y0..tile.y1.min(image.height) {
            let row = &image.pixels[y * image.width..(y + 1) * image.width];
            let x1 = tile.x1.min(image.width);
            let dst = &mut plane[(y - tile.y0) * tw..][..x1 - tile.x0];
            for (d, pixel) in dst.iter_mut().zip(&row[tile.x0..x1]) {
                *d = encode(pixel[c]);
            }
        }
    }
}

/// NaN as 0, then clamped to `[lo, hi]`.
fn sanitise(v: f32, lo: f32, hi: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_cover_the_image_once_on_the_pooling_grid() {
        for (w, h, core) in [
            (37, 29, 1024),
            (1000, 300, 256),
            (517, 389, 128),
            (16, 700, 64),
        ] {
            let tiles = tiles(w, h, core, 0);
            let mut covered = vec![0u8; w * h];
            for t in &tiles {
                assert!(t.x0 % 16 == 0 && t.y0 % 16 == 0, "{t:?}");
                assert!((t.x1 - t.x0) % 16 == 0 && (t.y1 - t.y0) % 16 == 0, "{t:?}");
                assert!(t.core_x0 - t.x0 >= OVERLAP.min(t.core_x0), "{t:?}");
                for y in t.core_y0..t.core_y1 {
                    for x in t.core_x0..t.core_x1 {
                        covered[y * w + x] += 1;
                    }
                }
            }
            assert!(
                covered.iter().all(|&c| c == 1),
                "{w}×{h} in cores of {core}"
            );
        }
        assert_eq!(tiles(37, 29, 1024, 0).len(), 1);
        assert_eq!(tiles(1920, 1080, 1024, ONE_TILE_PIXELS).len(), 1);
        assert_eq!(tiles(1920, 1080, 1024, 0).len(), 4);
    }

    #[test]
    fn tiled_filtering_is_the_whole_images() {
        // A 300×200 image cut into cores of 64: the overlap keeps every
        // pixel's receptive field, so the result is the same.
        let (w, h) = (300, 200);
        let color: Vec<[f32; 3]> = (0..w * h)
            .map(|i| {
                let v = ((i as u32).wrapping_mul(2_654_435_761) >> 8) as f32 / (1u32 << 24) as f32;
                [v * 2.0, v, 0.5 * (i % w) as f32 / w as f32]
            })
            .collect();
        let image = Image {
            pixels: &color,
            width: w,
            height: h,
        };
        let options = Options {
            hdr: true,
            clean_aux: false,
            input_scale: None,
        };
        let whole = denoise(image, None, None, &options).unwrap();
        let net = UNet::load(weights::for_color(true, Guides::None).bytes).unwrap();
        let encode = Encoding {
            main: Main::Color { hdr: true },
            transfer: Transfer::Pu,
            scale: crate::autoexposure::input_scale(&color, w, h),
        };
        let mut tiled = vec![[0.0f32; 3]; w * h];
        let tiles = tiles(w, h, 64, 0);
        assert!(tiles.len() > 6);
        for tile in tiles {
            let input = encode.input(&[Some(image), None, None], &tile, 3);
            encode.output(&net.forward(&input), &tile, &mut tiled, w);
        }
        for (a, b) in whole.iter().zip(&tiled) {
            for c in 0..3 {
                assert!(
                    (a[c] - b[c]).abs() <= 1e-6 * (1.0 + a[c].abs()),
                    "{a:?} vs {b:?}"
                );
            }
        }
    }

    type Pixels = Vec<[f32; 3]>;

    /// A noisy test image of `w × h` pixels, with its albedo and normal.
    fn noisy(w: usize, h: usize) -> (Pixels, Pixels, Pixels) {
        let mut state = 0x2545_f491u32;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        let color = (0..w * h).map(|_| [next() * 2.0, next(), next()]).collect();
        let albedo = (0..w * h)
            .map(|i| if i % w < w / 2 { [0.2; 3] } else { [0.8; 3] })
            .collect();
        let normal = vec![[0.0, 0.0, 1.0]; w * h];
        (color, albedo, normal)
    }

    fn image(pixels: &[[f32; 3]], width: usize, height: usize) -> Image<'_> {
        Image {
            pixels,
            width,
            height,
        }
    }

    const HDR: Options = Options {
        hdr: true,
        clean_aux: false,
        input_scale: None,
    };

    #[test]
    fn the_output_is_the_same_for_any_thread_count() {
        // Wide enough for several bands per layer.
        let (w, h) = (150, 40);
        let (c, a, n) = noisy(w, h);
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    denoise(
                        image(&c, w, h),
                        Some(image(&a, w, h)),
                        Some(image(&n, w, h)),
                        &HDR,
                    )
                    .unwrap()
                })
        };
        let one = run(1);
        assert_eq!(one, run(2));
        assert_eq!(one, run(5));
    }

    #[test]
    fn images_smaller_than_the_network_are_padded() {
        for (w, h) in [(1, 1), (2, 3), (17, 1), (1, 33)] {
            let (c, a, n) = noisy(w, h);
            let out = denoise(
                image(&c, w, h),
                Some(image(&a, w, h)),
                Some(image(&n, w, h)),
                &HDR,
            )
            .unwrap();
            assert_eq!(out.len(), w * h);
            assert!(out.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
        }
    }

    #[test]
    fn nan_and_infinite_pixels_are_refused_with_their_count() {
        let (w, h) = (8, 4);
        let (mut c, mut a, n) = noisy(w, h);
        c[3][1] = f32::NAN;
        c[9] = [f32::INFINITY, 0.0, f32::NAN];
        c[10][2] = f32::NEG_INFINITY;
        let got = denoise(image(&c, w, h), None, None, &HDR);
        assert_eq!(
            got,
            Err(FilterError::NonFinite {
                what: "color",
                count: 3
            })
        );
        assert_eq!(
            got.unwrap_err().to_string(),
            "color: 3 pixels are NaN or infinite"
        );
        let (c, _, _) = noisy(w, h);
        a[0][0] = f32::NAN;
        let got = denoise(
            image(&c, w, h),
            Some(image(&a, w, h)),
            Some(image(&n, w, h)),
            &HDR,
        );
        assert_eq!(
            got,
            Err(FilterError::NonFinite {
                what: "albedo",
                count: 1
            })
        );
        assert_eq!(
            prefilter(image(&a, w, h), Aux::Albedo),
            Err(FilterError::NonFinite {
                what: "albedo",
                count: 1
            })
        );
    }

    #[test]
    fn prefiltered_denoising_is_the_prefilters_then_the_clean_guide_weights() {
        let (w, h) = (24, 18);
        let (c, a, n) = noisy(w, h);
        let got = denoise_prefiltered(
            image(&c, w, h),
            Some(image(&a, w, h)),
            Some(image(&n, w, h)),
            &HDR,
        )
        .unwrap();
        let a2 = prefilter(image(&a, w, h), Aux::Albedo).unwrap();
        let n2 = prefilter(image(&n, w, h), Aux::Normal).unwrap();
        let clean = Options {
            clean_aux: true,
            ..HDR
        };
        let want = denoise(
            image(&c, w, h),
            Some(image(&a2, w, h)),
            Some(image(&n2, w, h)),
            &clean,
        )
        .unwrap();
        assert_eq!(got, want);
        assert_eq!(
            denoise_prefiltered(image(&c, w, h), None, Some(image(&n, w, h)), &HDR),
            Err(FilterError::NormalWithoutAlbedo)
        );
    }
}
