//! Compositing virtual objects into a photograph, with the shadows and
//! reflected light they cast on the real surfaces (differential rendering,
//! Debevec 1998).
//!
//! The scene holds a proxy of the real room (its geometry, with materials
//! that stand in for the real surfaces) and the virtual objects
//! (`virtual = true`). It is rendered twice on one Embree scene, with the
//! same seed: with the virtual objects (`W`) and without them (`O`, ray
//! masks hide them). With the photo `P` in linear radiance, the exposure
//! `k` (`P ≈ k·O` where nothing virtual is) and the virtual objects'
//! coverage `α` of each pixel (the matte, from the camera samples):
//!
//! - `differential` (the default): `C = α·k·W + (1 − α)·B` with, per
//!   channel, `B = P·W/O` where the objects darken the surface (`W < O`:
//!   shadows) and `B = P + k·(W − O)` where they brighten it (light they
//!   reflect). A shadow scales the photo's own colour, so its hue stays the
//!   photo's, whatever the proxy's albedo got wrong;
//! - `additive`: `B = max(P + k·(W − O), 0)`, Debevec's original. Where the
//!   proxy is brighter than the photo, a shadow subtracts more than the
//!   photo has in some channel, and the clamp shifts the hue (cyan or black
//!   specks in contact shadows);
//! - `superimpose`: `C = α·k·W + (1 − α)·P`: the paper's plain cut-out.
//!
//! Where no path of a pixel meets a virtual object, `W` and `O` are equal
//! bit for bit (same samples, same paths), so `C = P` exactly.

use crate::error::{Error, Result};
use glam::Vec3;
use plsr::film::FilmSums;
use plsr::scene::photo::{PhotoExposure, PhotoResponse, PhotoSpec};
use plsr_base::atomic_write::OutputSet;
use plsr_base::Vocabulary;
use plsr_hdr::oiio::{ImageReader, PixelType};
use plsr_hdr::response::ResponseCurve;
use std::path::Path;

/// How the rendered objects join the photo.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// The objects, and what they change about the real surfaces: shadows
    /// scale the photo by `with / without`, reflected light adds
    /// `k·(with − without)`, outside the matte.
    Differential,
    /// Debevec's additive differential: `photo + k·(with − without)`,
    /// clamped at 0, outside the matte.
    Additive,
    /// The objects pasted over the photo (the paper's cut-out).
    Superimpose,
}

/// A compositing mode's name that is not one of plsr's.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown mode `{0}` (known: differential, additive, superimpose)")]
pub struct UnknownMode(pub String);

impl std::fmt::Display for Mode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Mode::Differential => "differential",
            Mode::Additive => "additive",
            Mode::Superimpose => "superimpose",
        })
    }
}

impl std::str::FromStr for Mode {
    type Err = UnknownMode;
    fn from_str(s: &str) -> std::result::Result<Mode, UnknownMode> {
        match s {
            "differential" => Ok(Mode::Differential),
            "additive" => Ok(Mode::Additive),
            "superimpose" => Ok(Mode::Superimpose),
            other => Err(UnknownMode(other.into())),
        }
    }
}

/// How pixel values of the photo map to linear radiance and back.
#[derive(Debug, Clone)]
pub enum Transfer {
    /// sRGB.
    Srgb,
    /// Proportional.
    Linear,
    /// A recovered curve: the linear value of each level, per channel.
    Curve(ResponseCurve),
}

impl Transfer {
    /// The transfer of a `[photo]` response (reading its curve file).
    pub fn of(response: &PhotoResponse) -> Result<Transfer> {
        Ok(match response {
            PhotoResponse::Srgb => Transfer::Srgb,
            PhotoResponse::Linear => Transfer::Linear,
            PhotoResponse::Curve(path) => Transfer::Curve(ResponseCurve::read_csv(path)?),
        })
    }

    /// Linear value of level `level` of `levels` in channel `c`.
    fn decode(&self, c: usize, level: u32, levels: u32) -> f32 {
        let v = level as f32 / (levels - 1) as f32;
        match self {
            Transfer::Srgb => plsr_hdr::response::srgb_to_linear(v),
            Transfer::Linear => v,
            Transfer::Curve(curve) => curve.inverse[c.min(curve.channels() - 1)][level as usize],
        }
    }

    /// The 8-bit value whose linear value is nearest `x` in channel `c`
    /// (the inverse of `decode` on 256 levels).
    fn encode8(&self, c: usize, x: f32) -> u8 {
        let x = if x.is_finite() { x.max(0.0) } else { 0.0 };
        match self {
            Transfer::Srgb => (plsr::film::srgb_encode(x.min(1.0)) * 255.0).round() as u8,
            Transfer::Linear => (x.min(1.0) * 255.0).round() as u8,
            Transfer::Curve(curve) => {
                let table = &curve.inverse[c.min(curve.channels() - 1)];
                let levels = table.len();
                // The nearest level of a non-decreasing table, rescaled to
                // 8 bits when the curve has more levels.
                let i = table.partition_point(|&t| t < x).min(levels - 1);
                let best = if i > 0 && (x - table[i - 1]).abs() <= (table[i] - x).abs() {
                    i - 1
                } else {
                    i
                };
                ((best as f32 / (levels - 1) as f32) * 255.0).round() as u8
            }
        }
    }
}

/// A photograph in linear radiance, with the transfer that made it so.
#[derive(Debug, Clone)]
pub struct Photo {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear radiance per pixel (the transfer's units), row-major from
    /// the top.
    pub radiance: Vec<Vec3>,
    /// How the photo's values map to linear radiance and back.
    pub transfer: Transfer,
    /// The radiance of the top code per channel, where the camera clips
    /// (integer images); `None` for float images, which do not clip.
    pub clip: Option<Vec3>,
    /// The exposure `k` (photo ≈ k · render) the scene gives, as a number
    /// or through the photo's EXIF; `None`: fit it.
    pub exposure: Option<f32>,
    /// Where a given exposure comes from, for summaries (`exposure =
    /// "exif"`: the EXIF settings it was worked out from).
    pub exposure_source: Option<String>,
}

impl Photo {
    /// Reads the photo of a `[photo]` table: 8- or 16-bit images through
    /// their response; float images must have the `linear` response.
    pub fn load(spec: &PhotoSpec) -> Result<Photo> {
        let transfer = Transfer::of(&spec.response)?;
        let path = &spec.file;
        let mut reader = ImageReader::open(path)?;
        let (exposure, exposure_source) = match &spec.exposure {
            PhotoExposure::Auto => (None, None),
            PhotoExposure::Factor(k) => (Some(*k), None),
            PhotoExposure::Exif(units) => {
                let e = crate::exif_exposure::exif_exposure(path, &reader.exif(), units)?;
                (Some(e.k), Some(e.description))
            }
        };
        let info = reader.info().clone();
        let (w, h, ch) = (info.width, info.height, info.channels);
        let levels = match info.format {
            PixelType::U8 => 256u32,
            PixelType::U16 => 65536,
            _ => 0,
        };
        if let Transfer::Curve(curve) = &transfer {
            if levels == 0 || curve.levels() != levels as usize {
                return Err(Error::input(
                    path,
                    "photo.response",
                    format!(
                        "the curve has {} levels but the photo's pixels have {}",
                        curve.levels(),
                        if levels == 0 {
                            "float values".to_string()
                        } else {
                            format!("{levels}")
                        }
                    ),
                ));
            }
        }
        let colour = |values: &[f32], i: usize| -> Vec3 {
            let p = &values[i * ch..(i + 1) * ch];
            if ch >= 3 {
                Vec3::new(p[0], p[1], p[2])
            } else {
                Vec3::splat(p[0])
            }
        };
        let radiance: Vec<Vec3> = match info.format {
            PixelType::U8 | PixelType::U16 => {
                let codes: Vec<u32> = if info.format == PixelType::U8 {
                    reader
                        .read_all::<u8>()?
                        .into_iter()
                        .map(u32::from)
                        .collect()
                } else {
                    reader
                        .read_all::<u16>()?
                        .into_iter()
                        .map(u32::from)
                        .collect()
                };
                (0..w * h)
                    .map(|i| {
                        let code = |c: usize| codes[i * ch + c.min(ch - 1)];
                        Vec3::new(
                            transfer.decode(0, code(0), levels),
                            transfer.decode(1, code(1), levels),
                            transfer.decode(2, code(2), levels),
                        )
                    })
                    .collect()
            }
            _ => {
                if !matches!(transfer, Transfer::Linear) {
                    return Err(Error::input(
                        path,
                        "photo.response",
                        "a float image holds linear values: give response = \"linear\"",
                    ));
                }
                let values = reader.read_all::<f32>()?;
                (0..w * h).map(|i| colour(&values, i)).collect()
            }
        };
        if let Some(i) = radiance
            .iter()
            .position(|v| !v.is_finite() || v.min_element() < 0.0)
        {
            return Err(Error::input(
                path,
                "",
                format!(
                    "pixel ({}, {}) is not a finite, non-negative value",
                    i % w,
                    i / w
                ),
            ));
        }
        let clip = (levels > 0).then(|| {
            Vec3::new(
                transfer.decode(0, levels - 1, levels),
                transfer.decode(1, levels - 1, levels),
                transfer.decode(2, levels - 1, levels),
            )
        });
        Ok(Photo {
            width: w as u32,
            height: h as u32,
            radiance,
            transfer,
            clip,
            exposure,
            exposure_source,
        })
    }
}

impl Photo {
    /// A photo from interleaved 8-bit RGB values (`width × height × 3`,
    /// row-major from the top), through `transfer` (a curve must have 256
    /// levels): a camera frame handed over by a host program.
    pub fn from_rgb8(width: u32, height: u32, rgb: &[u8], transfer: Transfer) -> Result<Photo> {
        let n = width as usize * height as usize;
        if n == 0 || rgb.len() != n * 3 {
            return Err(Error::invalid_argument(format!(
                "a {width}×{height} RGB photo has {} bytes, got {}",
                n * 3,
                rgb.len()
            )));
        }
        if let Transfer::Curve(curve) = &transfer {
            if curve.levels() != 256 {
                return Err(Error::invalid_argument(format!(
                    "the curve has {} levels, an 8-bit photo 256",
                    curve.levels()
                )));
            }
        }
        let radiance = rgb
            .chunks_exact(3)
            .map(|p| {
                Vec3::new(
                    transfer.decode(0, p[0] as u32, 256),
                    transfer.decode(1, p[1] as u32, 256),
                    transfer.decode(2, p[2] as u32, 256),
                )
            })
            .collect();
        let clip = Some(Vec3::new(
            transfer.decode(0, 255, 256),
            transfer.decode(1, 255, 256),
            transfer.decode(2, 255, 256),
        ));
        Ok(Photo {
            width,
            height,
            radiance,
            transfer,
            clip,
            exposure: None,
            exposure_source: None,
        })
    }
}

/// The fitted exposure `k` of `photo ≈ k · render`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExposureFit {
    /// The factor.
    pub k: f32,
    /// Root-mean-square residual `photo − k·render` over the pixels used,
    /// relative to their mean photo value.
    pub relative_rms: f32,
    /// Pixels used after rejecting those the proxy does not model.
    pub used: usize,
    /// Pixels considered (outside every virtual object, lit in the render).
    pub considered: usize,
}

/// Fits `k` in `photo ≈ k·without` by least squares over the pixels no
/// virtual object covers (`matte == 0`), on luminance, robustly: three
/// rounds that drop pixels whose residual exceeds three robust standard
/// deviations (1.4826 × the median absolute residual) — pixels the proxy
/// does not model (a real object missing from it, a light it lacks).
pub fn fit_exposure(photo: &[Vec3], without: &[Vec3], matte: &[f32]) -> Option<ExposureFit> {
    let lum = plsr_base::color::luminance;
    let pairs: Vec<(f64, f64)> = (0..photo.len())
        .filter(|&i| matte[i] == 0.0 && lum(without[i]) > 0.0)
        .map(|i| (lum(photo[i]) as f64, lum(without[i]) as f64))
        .collect();
    let considered = pairs.len();
    let solve = |set: &[(f64, f64)]| -> Option<f64> {
        let (pr, rr) = set
            .iter()
            .fold((0.0, 0.0), |(a, b), (p, r)| (a + p * r, b + r * r));
        (rr > 0.0).then(|| pr / rr)
    };
    let mut used = pairs.clone();
    let mut k = solve(&used)?;
    for _ in 0..3 {
        let mut residuals: Vec<f64> = used.iter().map(|(p, r)| (p - k * r).abs()).collect();
        residuals.sort_by(|a, b| a.total_cmp(b));
        let sigma = 1.4826 * residuals[residuals.len() / 2];
        if sigma == 0.0 {
            break;
        }
        let kept: Vec<(f64, f64)> = pairs
            .iter()
            .copied()
            .filter(|(p, r)| (p - k * r).abs() <= 3.0 * sigma)
            .collect();
        if kept.len() < 2 {
            break;
        }
        used = kept;
        k = solve(&used)?;
    }
    let n = used.len() as f64;
    let rms = (used.iter().map(|(p, r)| (p - k * r).powi(2)).sum::<f64>() / n).sqrt();
    let mean = used.iter().map(|(p, _)| p).sum::<f64>() / n;
    Some(ExposureFit {
        k: k as f32,
        relative_rms: if mean > 0.0 { (rms / mean) as f32 } else { 0.0 },
        used: used.len(),
        considered,
    })
}

/// A composite and the layers it was made of.
#[derive(Debug, Clone)]
pub struct Composite {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The composite in the photo's linear radiance.
    pub color: Vec<Vec3>,
    /// The virtual objects' coverage of each pixel, in [0, 1].
    pub matte: Vec<f32>,
    /// What the virtual objects change about the real scene, `k·(W − O)`
    /// (negative in shadows), in the photo's linear radiance.
    pub difference: Vec<Vec3>,
    /// The exposure used.
    pub k: f32,
}

/// The matte of a render with the virtual objects: the share of each
/// pixel's camera samples whose first hit is virtual.
pub fn matte(with: &FilmSums) -> Vec<f32> {
    let (w, h) = (with.width(), with.height());
    let mut out = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let p = with.pixel(x, y);
            out.push(if p.samples == 0 {
                0.0
            } else {
                p.virtual_hits as f32 / p.samples as f32
            });
        }
    }
    out
}

/// The differential background of one pixel, per channel: the photo
/// scaled by `with / without` where the objects darken it, `photo + d`
/// (`d = k·(with − without)`) where they brighten it.
#[inline]
fn shadowed(photo: Vec3, with: Vec3, without: Vec3, d: Vec3) -> Vec3 {
    let mut out = Vec3::ZERO;
    for c in 0..3 {
        out[c] = if d[c] >= 0.0 {
            photo[c] + d[c]
        } else if without[c] > 0.0 {
            photo[c] * (with[c] / without[c]).clamp(0.0, 1.0)
        } else {
            (photo[c] + d[c]).max(0.0)
        };
    }
    out
}

/// Composites: `with` and `without` are the developed renders' colours,
/// `matte` the coverage, `k` the exposure (see the module docs).
pub fn composite(
    photo: &Photo,
    with: &[Vec3],
    without: &[Vec3],
    matte: &[f32],
    k: f32,
    mode: Mode,
) -> Composite {
    let n = photo.radiance.len();
    let mut color = Vec::with_capacity(n);
    let mut difference = Vec::with_capacity(n);
    for i in 0..n {
        let p = photo.radiance[i];
        let a = matte[i];
        let d = (with[i] - without[i]) * k;
        let background = match mode {
            Mode::Differential => shadowed(p, with[i], without[i], d),
            Mode::Additive => (p + d).max(Vec3::ZERO),
            Mode::Superimpose => p,
        };
        // Exactly the photo where nothing virtual is: no rounding from
        // blending with a zero coverage.
        color.push(if a == 0.0 {
            background
        } else {
            with[i] * (k * a) + background * (1.0 - a)
        });
        difference.push(d);
    }
    Composite {
        width: photo.width,
        height: photo.height,
        color,
        matte: matte.to_vec(),
        difference,
        k,
    }
}

impl Composite {
    /// Stages the linear OpenEXR: `R`, `G`, `B` the composite, `A` the
    /// matte, `difference.R/G/B` the shadow and reflection layer.
    pub fn stage_exr(&self, outputs: &mut OutputSet, path: &Path) -> Result<()> {
        plsr_base::atomic_write::check_extension(path, "exr", "OpenEXR")
            .map_err(|message| Error::output(path.to_path_buf(), message.to_string()))?;
        let split = |v: &[Vec3], c: usize| -> Vec<f32> { v.iter().map(|x| x[c]).collect() };
        let mut layers: Vec<(String, Vec<f32>)> = Vec::new();
        for (c, name) in ["R", "G", "B"].iter().enumerate() {
            layers.push((name.to_string(), split(&self.color, c)));
            layers.push((format!("difference.{name}"), split(&self.difference, c)));
        }
        layers.push(("A".into(), self.matte.clone()));
        Ok(plsr::film::stage_exr_layers(
            outputs,
            path,
            self.width,
            self.height,
            &layers,
            &[("plsr:exposure_k".into(), format!("{}", self.k))],
        )?)
    }

    /// Stages an 8-bit PNG encoded through the photo's transfer, so that
    /// it equals the photo wherever nothing virtual changed it.
    pub fn stage_png(
        &self,
        outputs: &mut OutputSet,
        path: &Path,
        transfer: &Transfer,
    ) -> Result<()> {
        plsr_base::atomic_write::check_extension(path, "png", "PNG")
            .map_err(|message| Error::output(path.to_path_buf(), message.to_string()))?;
        let mut img = image::RgbImage::new(self.width, self.height);
        for (i, px) in img.pixels_mut().enumerate() {
            let c = self.color[i];
            *px = image::Rgb([
                transfer.encode8(0, c.x),
                transfer.encode8(1, c.y),
                transfer.encode8(2, c.z),
            ]);
        }
        outputs.stage(path, |w| {
            img.write_to(w, image::ImageFormat::Png)
                .map_err(|e| Error::output(path.to_path_buf(), e.to_string()))
        })
    }
}

impl Composite {
    /// Stages the matte as an 8-bit grey PNG (the virtual objects' coverage,
    /// 255 where they cover the whole pixel): a mask for `plsr compare`.
    pub fn stage_matte_png(&self, outputs: &mut OutputSet, path: &Path) -> Result<()> {
        plsr_base::atomic_write::check_extension(path, "png", "PNG")
            .map_err(|message| Error::output(path.to_path_buf(), message.to_string()))?;
        let mut img = image::GrayImage::new(self.width, self.height);
        for (px, &a) in img.pixels_mut().zip(&self.matte) {
            *px = image::Luma([(a.clamp(0.0, 1.0) * 255.0).round() as u8]);
        }
        outputs.stage(path, |w| {
            img.write_to(w, image::ImageFormat::Png)
                .map_err(|e| Error::output(path.to_path_buf(), e.to_string()))
        })
    }
}

/// The start of the error of an exposure that cannot be fitted.
const FIT_FAILED: &str = "cannot fit the exposure";

/// How to run `plsr composite` (what to composite is the scene file).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompositeOptions {
    /// Differential (default) or superimpose.
    pub mode: Mode,
    /// Samples per pixel of each of the two renders (default: the scene's).
    pub spp: Option<u32>,
    /// Random seed (default: the scene's); both renders share it.
    pub seed: Option<u64>,
    /// How to run the renders.
    pub render: plsr::render::RenderOptions,
    /// Denoise both renders (with and without the virtual objects), both
    /// guided by the layers of the render with the objects and at its input
    /// scale, before the difference is taken; `None`: unbiased.
    pub denoise: Option<plsr::film::denoise::DenoiseSettings>,
    /// How the render without the virtual objects is made (the images are
    /// the same either way).
    pub retrace: Retrace,
}

impl Default for CompositeOptions {
    fn default() -> Self {
        CompositeOptions {
            mode: Mode::Differential,
            spp: None,
            seed: None,
            render: Default::default(),
            denoise: None,
            retrace: Retrace::Touched,
        }
    }
}

/// How a composite makes its render without the virtual objects; both
/// give the same sums, bit for bit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Retrace {
    /// Alongside the render with them: each path traced once until it
    /// meets a virtual object, then forked
    /// ([`plsr::render::render_pair_sums`]); about 1.2× the cost of one
    /// render where the objects are small in the view.
    Touched,
    /// As a second whole render (2× the cost of one).
    All,
}

/// What a composite did.
#[derive(Debug, Clone)]
pub struct CompositeReport {
    /// The exposure fit, when the scene asked for `auto`.
    pub fit: Option<ExposureFit>,
    /// Wall-clock seconds of both renders.
    pub render_seconds: f64,
    /// Camera samples of both renders.
    pub samples: u64,
    /// Wall-clock seconds of denoising both renders (0 when not asked).
    pub denoise_seconds: f64,
    /// Rays of both renders; with [`Retrace::Touched`], how many paths
    /// forked and what their render without the objects traced.
    pub rays: plsr::integrator::RayStats,
    /// Where a given exposure came from (`exposure = "exif"`: the EXIF
    /// settings); `None` for a number or a fit.
    pub exposure_source: Option<String>,
}

/// Composites the virtual objects of a scene file into its `[photo]`:
/// renders with and without them (same seed, one Embree scene), fits or
/// takes the exposure, and blends (see the module docs). `progress(done,
/// total)` counts the tiles (of both renders, when they are made apart);
/// returning `false` cancels.
pub fn composite_scene(
    scene_file: &Path,
    contents: plsr::scene::file::SceneFileContents,
    options: &CompositeOptions,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<(Composite, Transfer, CompositeReport)> {
    let spec = contents.photo.ok_or_else(|| {
        Error::input(
            scene_file,
            "photo",
            "required for compositing: a [photo] table naming the photograph (file, response, exposure)",
        )
    })?;
    if !contents.description.meshes.iter().any(|m| m.is_virtual) {
        return Err(Error::input(
            scene_file,
            "shapes",
            "no shape is virtual: mark the objects to insert with `virtual = true`",
        ));
    }
    let photo = Photo::load(&spec)?;
    let scene = plsr::scene::Scene::build(contents.description)?;
    if scene.film().crop.is_some() {
        return Err(Error::invalid_argument(
            "film.crop: a composite covers the whole photo (remove the crop)",
        ));
    }
    let (cw, ch) = (scene.camera().width(), scene.camera().height());
    if (photo.width, photo.height) != (cw, ch) {
        return Err(Error::input(
            scene_file,
            "photo.file",
            format!(
                "{} is {}×{} pixels but the camera renders {cw}×{ch}: set camera.resolution to the photo's size",
                spec.file.display(),
                photo.width,
                photo.height
            ),
        ));
    }
    let (result, mut report) = composite_built(&scene, &photo, photo.exposure, options, progress)
        .map_err(|e| match e {
        // The fit's failure is about the scene's `photo.exposure`.
        Error::Base(plsr_base::Error::InvalidArgument(m)) if m.starts_with(FIT_FAILED) => {
            Error::input(scene_file, "photo.exposure", m)
        }
        other => other,
    })?;
    report.exposure_source = photo.exposure_source;
    Ok((result, photo.transfer, report))
}

/// Composites the virtual meshes of a built `scene` into `photo` (see
/// [`composite_scene`]): `exposure` is `k`, or `None` to fit it. The
/// photo's size must be the camera's.
pub fn composite_built(
    scene: &plsr::scene::Scene,
    photo: &Photo,
    exposure: Option<f32>,
    options: &CompositeOptions,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<(Composite, CompositeReport)> {
    if !scene.meshes().iter().any(|m| m.is_virtual) {
        return Err(Error::invalid_argument(
            "no shape is virtual: mark the objects to insert with `virtual = true`",
        ));
    }
    if scene.film().crop.is_some() {
        return Err(Error::invalid_argument(
            "film.crop: a composite covers the whole photo (remove the crop)",
        ));
    }
    let (cw, ch) = (scene.camera().width(), scene.camera().height());
    if (photo.width, photo.height) != (cw, ch) {
        return Err(Error::invalid_argument(format!(
            "the photo is {}×{} pixels but the camera renders {cw}×{ch}",
            photo.width, photo.height
        )));
    }
    if let Some(k) = exposure {
        if !(k.is_finite() && k > 0.0) {
            return Err(Error::invalid_argument(format!(
                "exposure {k}: must be a positive number"
            )));
        }
    }
    let mut job = scene.default_job();
    if let Some(spp) = options.spp {
        job.spp = spp;
    }
    if let Some(seed) = options.seed {
        job.seed = seed;
    }
    job.validate()
        .map_err(|e| Error::invalid_argument(format!("render: {e}")))?;
    // With the virtual objects, then without: the same samples.
    let jobs = [false, true].map(|hide_virtual| plsr::job::RenderJob {
        hide_virtual,
        ..job
    });
    let mut sums = Vec::new();
    let mut report = CompositeReport {
        fit: None,
        render_seconds: 0.0,
        samples: 0,
        denoise_seconds: 0.0,
        rays: Default::default(),
        exposure_source: None,
    };
    match options.retrace {
        Retrace::Touched => {
            let (with, without, stats) =
                plsr::render::render_pair_sums(scene, &jobs[0], &options.render, progress)?;
            report.render_seconds = stats.seconds;
            report.samples = stats.samples;
            report.rays = stats.rays;
            sums = vec![with, without];
        }
        Retrace::All => {
            for (i, job) in jobs.iter().enumerate() {
                let step = |done: usize, total: usize| progress(i * total + done, 2 * total);
                let (s, stats) = plsr::render::render_sums(scene, job, &options.render, &step)?;
                report.render_seconds += stats.seconds;
                report.samples += stats.samples;
                report.rays.add(&stats.rays);
                sums.push(s);
            }
        }
    }
    let matte = matte(&sums[0]);
    let [mut with, mut without] = [&sums[0], &sums[1]].map(|s| s.develop(job.spp));
    if let Some(settings) = &options.denoise {
        // Both renders, not their difference (the network takes no
        // negative values), each from the same guides: those of the render
        // with the virtual objects. The renders share their samples, so
        // where the scenes agree the denoiser sees the same input twice
        // and the difference stays 0; where they differ (shadows,
        // reflections) it sees the same surfaces, lit otherwise.
        plsr::integrator::guides::see_through_glass(scene, &jobs[0], &mut with);
        without.albedo.clone_from(&with.albedo);
        without.normal.clone_from(&with.normal);
        without.alpha.clone_from(&with.alpha);
        // One input scale for both (that of the render with the objects):
        // the network must see equal pixels where the renders agree.
        let settings = plsr::film::denoise::DenoiseSettings {
            input_scale: Some(
                settings
                    .input_scale
                    .unwrap_or_else(|| plsr::film::denoise::input_scale(&with)),
            ),
            ..*settings
        };
        for film in [&mut with, &mut without] {
            report.denoise_seconds += film.denoise(&settings)?.seconds;
        }
    }
    let (with, without) = (with.color, without.color);
    let k = match exposure {
        Some(k) => k,
        None => {
            let fit = fit_exposure(&photo.radiance, &without, &matte).ok_or_else(|| {
                Error::invalid_argument(format!(
                    "{FIT_FAILED}: no pixel outside the virtual objects is lit in the render; give the exposure"
                ))
            })?;
            report.fit = Some(fit);
            fit.k
        }
    };
    let result = composite(photo, &with, &without, &matte, k, options.mode);
    Ok((result, report))
}
