//! Image quality metrics: how close a render (or a composite) is to a
//! photo, scored as the paper scores it (CW-SSIM, Tables 4 and 5) and by
//! the usual pixel metrics.
//!
//! Images come through OpenImageIO. 8- and 16-bit files hold display values
//! (sRGB-encoded, 0–1) and are used as they are; float files (EXR, HDR)
//! hold linear radiance and are brought to display values for the metrics
//! made for displayed images by one fixed operator: clamp to [0, 1], then
//! the sRGB transfer function (no exposure change) — see
//! [`MetricImage::display`]. The structural metrics work on grey values as
//! MATLAB's `rgb2gray` makes them, on the 0–255 scale.
//!
//! - [`error`]: the metrics' error enum.
//! - [`cwssim`]: CW-SSIM (complex steerable pyramid, one band level).
//! - [`lpips`]: LPIPS (AlexNet, v0.1; the weights ship inside plsr).
//! - [`ssim`]: SSIM (Wang et al. 2004, Gaussian 11×11 windows).
//! - [`pixel`]: RMSE (on the files' own values) and PSNR (display values).
//! - [`flip`]: FLIP (NVIDIA's, LDR-FLIP on display values; HDR-FLIP when
//!   both files are float files).

pub mod cwssim;
pub mod error;
pub mod flip;
pub mod lpips;
pub mod pixel;
pub mod ssim;

pub use error::{Error, Result};

use plsr_base::Vocabulary;
use std::path::{Path, PathBuf};

/// A grey image on MATLAB's 0–255 scale, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct GreyImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Grey values, 0–255 for displayable values.
    pub v: Vec<f64>,
}

/// An RGB image read for comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct MetricImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Interleaved RGB: display values 0–1 (LDR files) or linear radiance
    /// (float files).
    pub rgb: Vec<f32>,
    /// Whether the values are linear radiance from a float file.
    pub hdr: bool,
    /// The file it came from (for messages).
    pub path: PathBuf,
}

/// A window of an image, in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Crop {
    /// Left column.
    pub x: usize,
    /// Top row.
    pub y: usize,
    /// Width.
    pub w: usize,
    /// Height.
    pub h: usize,
}

impl MetricImage {
    /// Reads an image file: grey files become RGB, alpha and further
    /// channels are dropped.
    pub fn load(path: &Path) -> Result<MetricImage> {
        let (info, data) = plsr_hdr::oiio::read_image_f32(path)?;
        let c = info.channels;
        if c == 0 {
            return Err(Error::input(path, "", "has no channels"));
        }
        let mut rgb = Vec::with_capacity(info.width * info.height * 3);
        for p in data.chunks_exact(c) {
            if c < 3 {
                rgb.extend([p[0]; 3]);
            } else {
                rgb.extend(&p[..3]);
            }
        }
        if let Some(i) = rgb.iter().position(|v| !v.is_finite()) {
            let px = i / 3;
            return Err(Error::input(
                path,
                "",
                format!(
                    "pixel ({}, {}) is not a finite number ({})",
                    px % info.width,
                    px / info.width,
                    rgb[i]
                ),
            ));
        }
        Ok(MetricImage {
            width: info.width,
            height: info.height,
            rgb,
            hdr: !info.format.is_integer(),
            path: path.to_path_buf(),
        })
    }

    /// An image of in-memory display values (0–1, interleaved RGB).
    pub fn from_display(width: usize, height: usize, rgb: Vec<f32>) -> MetricImage {
        MetricImage {
            width,
            height,
            rgb,
            hdr: false,
            path: PathBuf::from("<memory>"),
        }
    }

    /// The display values (0–1): as read for LDR files; for HDR ones the
    /// fixed operator `srgb(clamp(x, 0, 1))`.
    pub fn display(&self) -> Vec<f32> {
        if self.hdr {
            self.rgb
                .iter()
                .map(|&x| plsr_base::color::srgb_encode(x.clamp(0.0, 1.0)))
                .collect()
        } else {
            self.rgb.iter().map(|&x| x.clamp(0.0, 1.0)).collect()
        }
    }

    /// The window `c` of the image.
    pub fn crop(&self, c: Crop) -> MetricImage {
        let mut rgb = Vec::with_capacity(c.w * c.h * 3);
        for y in c.y..c.y + c.h {
            let row = (y * self.width + c.x) * 3;
            rgb.extend_from_slice(&self.rgb[row..row + c.w * 3]);
        }
        MetricImage {
            width: c.w,
            height: c.h,
            rgb,
            hdr: self.hdr,
            path: self.path.clone(),
        }
    }

    /// The grey image of the display values, as MATLAB's `rgb2gray` makes
    /// it from the 8-bit image: `0.2989·R + 0.5870·G + 0.1140·B` of the
    /// values on 0–255 rounded to integers, rounded.
    pub fn grey(&self) -> GreyImage {
        GreyImage {
            width: self.width,
            height: self.height,
            v: grey_of(&self.display()),
        }
    }
}

/// `rgb2gray`'s weights (the luma of ITU-R BT.601 as MATLAB rounds them).
const GREY_WEIGHTS: [f64; 3] = [0.298936021293775, 0.587043074451121, 0.114020904255103];

/// Grey values (0–255, rounded to integers as `rgb2gray` rounds an 8-bit
/// image's) of interleaved display RGB (0–1).
pub fn grey_of(display: &[f32]) -> Vec<f64> {
    display
        .chunks_exact(3)
        .map(|p| {
            let [r, g, b] = [p[0], p[1], p[2]].map(|v| (v as f64 * 255.0).round());
            (GREY_WEIGHTS[0] * r + GREY_WEIGHTS[1] * g + GREY_WEIGHTS[2] * b).round()
        })
        .collect()
}

/// A mask read from an image file: a pixel is in where its chosen channel
/// exceeds one half.
#[derive(Debug, Clone, PartialEq)]
pub struct Mask {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Whether each pixel is in, row-major.
    pub inside: Vec<bool>,
}

/// A mask file and the channel to read from it (`matte.png`,
/// `composite.exr:A`).
#[derive(Debug, Clone, PartialEq)]
pub struct MaskSource {
    /// The image file.
    pub path: std::path::PathBuf,
    /// The channel's name (an OpenEXR channel such as `A` or `mask.Y`; for
    /// other formats `R`, `G`, `B` or `A`), or `None` for a grey mask.
    pub channel: Option<String>,
}

impl MaskSource {
    /// Reads `PATH[:CHANNEL]`: a file that exists is taken whole; otherwise
    /// the text after the last `:` names the channel.
    pub fn parse(text: &str) -> MaskSource {
        let whole = Path::new(text);
        match text.rsplit_once(':') {
            Some((path, channel))
                if !whole.exists()
                    && !path.is_empty()
                    && !channel.is_empty()
                    && !channel.contains('/') =>
            {
                MaskSource {
                    path: path.into(),
                    channel: Some(channel.into()),
                }
            }
            _ => MaskSource {
                path: whole.to_path_buf(),
                channel: None,
            },
        }
    }
}

impl Mask {
    /// Reads a grey mask image (any format OpenImageIO reads; colour
    /// channels must be equal, so that an image with a matte in one channel
    /// is not read by another).
    pub fn load(path: &Path) -> Result<Mask> {
        Mask::load_source(&MaskSource {
            path: path.to_path_buf(),
            channel: None,
        })
    }

    /// Reads the mask `source` names.
    pub fn load_source(source: &MaskSource) -> Result<Mask> {
        let path = source.path.as_path();
        let is_exr = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        let (width, height, values) = match (&source.channel, is_exr) {
            (Some(name), true) => exr_channel(path, name)?,
            (channel, _) => {
                let (info, data) = plsr_hdr::oiio::read_image_f32(path)?;
                let c = info.channels.max(1);
                let index = match channel.as_deref() {
                    None => {
                        let colour = c.min(3);
                        if colour > 1
                            && data
                                .chunks_exact(c)
                                .any(|p| p[..colour].iter().any(|&v| v != p[0]))
                        {
                            return Err(Error::input(
                                path,
                                "",
                                format!(
                                    "{c} channels that differ: name the mask's channel \
                                     (`{}:A` for a composite's matte)",
                                    path.display()
                                ),
                            ));
                        }
                        0
                    }
                    Some(name) => {
                        let index = ["R", "G", "B", "A"]
                            .iter()
                            .position(|n| n.eq_ignore_ascii_case(name))
                            .filter(|&i| i < c)
                            .ok_or_else(|| {
                                Error::input(
                                    path,
                                    name,
                                    format!(
                                        "no such channel: the image has {}",
                                        ["R", "G", "B", "A"][..c.min(4)].join(", ")
                                    ),
                                )
                            })?;
                        if c == 1 {
                            0
                        } else {
                            index
                        }
                    }
                };
                let values = data.chunks_exact(c).map(|p| p[index]).collect();
                (info.width, info.height, values)
            }
        };
        let inside: Vec<bool> = values.iter().map(|&v| v > 0.5).collect();
        if !inside.iter().any(|&b| b) {
            return Err(Error::input(
                path,
                source.channel.as_deref().unwrap_or(""),
                "the mask is empty (no pixel above 0.5)",
            ));
        }
        Ok(Mask {
            width,
            height,
            inside,
        })
    }

    /// The mask's window `c`.
    pub fn crop(&self, c: Crop) -> Mask {
        let mut inside = Vec::with_capacity(c.w * c.h);
        for y in c.y..c.y + c.h {
            inside.extend_from_slice(&self.inside[y * self.width + c.x..][..c.w]);
        }
        Mask {
            width: c.w,
            height: c.h,
            inside,
        }
    }

    /// The bounding box of the mask's pixels grown by `margin` pixels on
    /// each side, then to at least `min_side` pixels a side where the
    /// image allows, clipped to the image.
    pub fn bounding_box(&self, margin: usize, min_side: usize) -> Crop {
        let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
        for (i, _) in self.inside.iter().enumerate().filter(|(_, &b)| b) {
            let (x, y) = (i % self.width, i / self.width);
            x0 = x0.min(x);
            y0 = y0.min(y);
            x1 = x1.max(x + 1);
            y1 = y1.max(y + 1);
        }
        let grow = |lo: usize, hi: usize, size: usize| -> (usize, usize) {
            let mut lo = lo.saturating_sub(margin);
            let mut hi = (hi + margin).min(size);
            while hi - lo < min_side.min(size) {
                lo = lo.saturating_sub(1);
                if hi - lo < min_side.min(size) && hi < size {
                    hi += 1;
                }
            }
            (lo, hi)
        };
        let (x0, x1) = grow(x0, x1, self.width);
        let (y0, y1) = grow(y0, y1, self.height);
        Crop {
            x: x0,
            y: y0,
            w: x1 - x0,
            h: y1 - y0,
        }
    }
}

/// The metrics `plsr compare` can compute.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Metric {
    /// CW-SSIM (higher is better, 1 for identical images).
    CwSsim,
    /// LPIPS, AlexNet v0.1 (lower is better, 0 for identical images).
    Lpips,
    /// SSIM (higher is better).
    Ssim,
    /// PSNR in dB over display values (higher is better).
    Psnr,
    /// RMSE over the files' own values (lower is better).
    Rmse,
    /// Mean FLIP (lower is better, 0 for identical images): HDR-FLIP when
    /// both images are HDR, LDR-FLIP of the display values otherwise.
    Flip,
}

impl Metric {
    /// Every metric, in the order reports list them.
    pub const ALL: [Metric; 6] = [
        Metric::CwSsim,
        Metric::Lpips,
        Metric::Ssim,
        Metric::Psnr,
        Metric::Rmse,
        Metric::Flip,
    ];

    /// The metric's name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Metric::CwSsim => "cwssim",
            Metric::Lpips => "lpips",
            Metric::Ssim => "ssim",
            Metric::Psnr => "psnr",
            Metric::Rmse => "rmse",
            Metric::Flip => "flip",
        }
    }

    /// The metric of a name (as [`Metric::name`] gives it).
    pub fn parse(name: &str) -> Option<Metric> {
        Metric::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// Settings of a comparison.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CompareOptions {
    /// The metrics to compute.
    pub metrics: Vec<Metric>,
    /// CW-SSIM's settings.
    pub cwssim: cwssim::CwSsimOptions,
    /// FLIP's settings.
    pub flip: flip::FlipOptions,
}

/// One metric's score.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Score {
    /// The metric.
    pub metric: Metric,
    /// Its value.
    pub value: f64,
}

/// An error unless `reference` and `test` have the same size; `metric`
/// (with its colon, or empty) starts the message.
fn same_size(metric: &str, reference: &MetricImage, test: &MetricImage) -> Result<()> {
    if (reference.width, reference.height) == (test.width, test.height) {
        return Ok(());
    }
    Err(Error::invalid_argument(format!(
        "{metric}{} is {}×{} but {} is {}×{}: the images must have the same size",
        reference.path.display(),
        reference.width,
        reference.height,
        test.path.display(),
        test.width,
        test.height
    )))
}

/// Scores `test` against `reference` (both already cropped; `mask`, of
/// the same size, restricts the pixel metrics).
pub fn compare(
    reference: &MetricImage,
    test: &MetricImage,
    mask: Option<&Mask>,
    options: &CompareOptions,
) -> Result<Vec<Score>> {
    same_size("", reference, test)?;
    let inside = mask.map(|m| m.inside.as_slice());
    let mut scores = Vec::new();
    let greys = options
        .metrics
        .iter()
        .any(|m| matches!(m, Metric::CwSsim | Metric::Ssim))
        .then(|| (reference.grey(), test.grey()));
    for &metric in &options.metrics {
        let value = match (metric, &greys) {
            (Metric::CwSsim, Some((a, b))) => cwssim::cwssim(a, b, &options.cwssim)?,
            (Metric::Ssim, Some((a, b))) => ssim::ssim(a, b)?,
            (Metric::Lpips, _) => lpips::lpips(reference, test)?,
            (Metric::CwSsim | Metric::Ssim, None) => unreachable!("greys made above"),
            (Metric::Psnr, _) => pixel::psnr(&reference.display(), &test.display(), inside),
            (Metric::Rmse, _) => pixel::rmse(&reference.rgb, &test.rgb, inside),
            (Metric::Flip, _) => flip_map(reference, test, &options.flip)?.mean,
        };
        scores.push(Score { metric, value });
    }
    Ok(scores)
}

/// Which part of the images a comparison looks at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CropSpec {
    /// The whole image.
    #[default]
    Whole,
    /// The mask's bounding box, grown by [`AUTO_MARGIN`] and to at least
    /// [`AUTO_MIN_SIDE`] pixels a side (the paper crops to the object).
    Auto,
    /// A window given in pixels.
    Window(Crop),
}

/// Margin of `--crop auto` around the mask's bounding box, pixels.
pub const AUTO_MARGIN: usize = 16;
/// Smallest side of an automatic crop, pixels (CW-SSIM's four pyramid
/// levels need 64).
pub const AUTO_MIN_SIDE: usize = 64;

/// The result of comparing two files.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// The window compared.
    pub crop: Crop,
    /// The mask's pixels inside the window (all of them without a mask).
    pub pixels: usize,
    /// One score per requested metric, in the order asked.
    pub scores: Vec<Score>,
    /// The reference's window.
    pub reference: MetricImage,
    /// The test image's window.
    pub test: MetricImage,
}

/// One channel of an OpenEXR file's first layer, by name.
fn exr_channel(path: &Path, name: &str) -> Result<(usize, usize, Vec<f32>)> {
    match plsr_base::exr_header::header_fault(path) {
        Ok(Some(fault)) => return Err(Error::input(path, "dataWindow", fault)),
        Ok(None) => {}
        Err(source) => return Err(Error::io(path.to_path_buf(), source)),
    }
    let image = exr::prelude::read_first_flat_layer_from_file(path)
        .map_err(|e| Error::input(path, "", format!("cannot read EXR: {e}")))?;
    let layer = image.layer_data;
    let size = layer.size;
    let channels = &layer.channel_data.list;
    let channel = channels
        .iter()
        .find(|c| c.name.to_string() == name)
        .ok_or_else(|| {
            let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
            Error::input(
                path,
                name,
                format!("no such channel: the image has {}", names.join(", ")),
            )
        })?;
    let values = channel.sample_data.values_as_f32().collect();
    Ok((size.width(), size.height(), values))
}

/// Reads `reference`, `test` and the optional `mask`, checks their sizes,
/// crops them and scores `test` against `reference`.
pub fn compare_files(
    reference: &Path,
    test: &Path,
    mask: Option<&MaskSource>,
    crop: CropSpec,
    options: &CompareOptions,
) -> Result<Report> {
    let a = MetricImage::load(reference)?;
    let b = MetricImage::load(test)?;
    if (a.width, a.height) != (b.width, b.height) {
        return Err(Error::input(
            test,
            "",
            format!(
                "is {}×{} but the reference {} is {}×{}: the images must have the same size",
                b.width,
                b.height,
                reference.display(),
                a.width,
                a.height
            ),
        ));
    }
    let mask = match mask {
        Some(source) => {
            let m = Mask::load_source(source)?;
            let p = &source.path;
            if (m.width, m.height) != (a.width, a.height) {
                return Err(Error::input(
                    p,
                    "",
                    format!(
                        "the mask is {}×{} but the images are {}×{}",
                        m.width, m.height, a.width, a.height
                    ),
                ));
            }
            Some(m)
        }
        None => None,
    };
    let window = match crop {
        CropSpec::Whole => Crop {
            x: 0,
            y: 0,
            w: a.width,
            h: a.height,
        },
        CropSpec::Auto => match &mask {
            Some(m) => m.bounding_box(AUTO_MARGIN, AUTO_MIN_SIDE),
            None => {
                return Err(Error::invalid_argument(
                    "--crop auto needs --mask (the crop is the mask's bounding box)",
                ))
            }
        },
        CropSpec::Window(c) => {
            if c.w == 0 || c.h == 0 || c.x + c.w > a.width || c.y + c.h > a.height {
                return Err(Error::invalid_argument(format!(
                    "--crop {},{},{},{} (corners) is not inside the {}×{} image",
                    c.x,
                    c.y,
                    c.x + c.w,
                    c.y + c.h,
                    a.width,
                    a.height
                )));
            }
            c
        }
    };
    let (ra, rb) = (a.crop(window), b.crop(window));
    let mask = mask.map(|m| m.crop(window));
    if let Some(m) = &mask {
        if !m.inside.iter().any(|&x| x) {
            return Err(Error::invalid_argument(format!(
                "the crop {},{},{},{} holds no pixel of the mask",
                window.x, window.y, window.w, window.h
            )));
        }
    }
    let scores = compare(&ra, &rb, mask.as_ref(), options)?;
    Ok(Report {
        crop: window,
        pixels: mask.as_ref().map_or(window.w * window.h, |m| {
            m.inside.iter().filter(|&&x| x).count()
        }),
        scores,
        reference: ra,
        test: rb,
    })
}

/// The FLIP error map of `test` against `reference`: HDR-FLIP when both
/// are HDR (float files), LDR-FLIP of their display values otherwise.
pub fn flip_map(
    reference: &MetricImage,
    test: &MetricImage,
    options: &flip::FlipOptions,
) -> Result<flip::FlipMap> {
    if reference.hdr && test.hdr {
        flip::hdr_flip(reference, test, options)
    } else {
        flip::ldr_flip(reference, test, options)
    }
}
