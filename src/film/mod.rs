//! The film: per-pixel radiance and auxiliary layers (AOVs), and their output
//! as OpenEXR (all layers, linear float) and PNG (tone-mapped 8-bit sRGB).
//!
//! Layers, all `width × height`, row-major from the top-left pixel:
//! - `color`: mean radiance of the pixel's samples (linear RGB);
//! - `variance`: estimated variance *of that mean* per channel (sample
//!   variance / spp), for statistical comparisons of renders;
//! - `alpha`: fraction of camera samples that hit geometry (coverage);
//! - `object_id`: object (scene-file shape index) seen by the pixel's first
//!   sample, −1 where it saw nothing;
//! - `depth`: mean camera-space depth (distance along the view axis) of the
//!   samples that hit, 0 where none did;
//! - `normal`: mean world-space shading normal at the first hit (facing the camera);
//! - `albedo`: mean albedo at the first hit;
//! - `noisy`: only in a denoised film ([`denoise`]): the colour before
//!   denoising (`color` then holds the denoised one).
//!
//! EXR channel names: `R G B A`, `variance.R/G/B`, `albedo.R/G/B`,
//! `normal.X/Y/Z`, `Z` (depth), `object_id` and, when denoised,
//! `noisy.R/G/B`.
//!
//! **Film settings** ([`FilmSettings`], the scene file's `[film]` table):
//! the pixel reconstruction filter ([`crate::filter`]), exposure and white
//! balance. Exposure and white balance model the camera's sensor response:
//! they are applied to every camera sample's radiance before it is
//! accumulated, so they reach the EXR's colour layer (and, consistently, its
//! variance layer) and hence the PNG, as a photo's settings reach both its raw
//! and its JPEG. The response is `L' = s · W · L`:
//!
//! - `W`: the white balance matrix of [`crate::color::white_balance_matrix`]
//!   (identity when no white balance is set);
//! - `s = 2^exposure_ev · (t · S / (100 · N²))`, with the bracket only when a
//!   shutter time `t` (seconds), ISO `S` and f-number `N` are given. It is
//!   `2^−EV100` with the standard exposure value at ISO 100,
//!   `EV100 = log2(100 · N² / (t · S))`, and calibration constant `k = 1`:
//!   1 s at f/1 and ISO 100 leaves radiance unchanged, each stop halves or
//!   doubles it. (A photometric camera model would add `k = 1/1.2`, the
//!   ISO 12232 saturation constant; fold it into `exposure_ev` if wanted.)
//!
//! The settings are stored in the EXR header: `plsrFilter` (text),
//! `plsrFilterSigma`, `plsrFilterRadius` (pixels), `plsrExposureEv`,
//! `plsrExposureScale` (`s`), `plsrWhiteBalance` (kelvin, when set), and
//! OpenEXR's standard `expTime` (s), `aperture` (f-number) and `isoSpeed`
//! when a shutter time is given. The header's attributes are written in name
//! order, so the same film always gives the same file, byte for byte.

use crate::atomic_write::{check_extension, OutputSet};
use plsr_base::Vocabulary;
use std::fs::File;
use std::io::BufWriter;
pub mod denoise;
mod exact_sums;
pub mod part;
pub mod radiance;
mod sums;

pub use sums::{FilmSums, PixelSums, Tile};

use crate::color::white_balance_matrix;
use crate::error::{Error, Result};
use crate::filter::{GaussianFilter, PixelFilter, TentFilter};
use exr::prelude::{self as exrp, AnyChannel, AnyChannels, FlatSamples, WritableImage};
use glam::{Mat3, Vec3};
use std::path::Path;

/// Name of the EXR layer attribute holding the samples per pixel.
pub const SPP_ATTRIBUTE: &str = "plsrSpp";

/// Photographic exposure settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraExposure {
    /// Exposure time, seconds.
    pub shutter_s: f32,
    /// ISO sensitivity (100 = base).
    pub iso: f32,
    /// Aperture f-number `N` (focal length / aperture diameter).
    pub f_number: f32,
}

impl CameraExposure {
    /// `EV100 = log2(100 · N² / (t · S))`.
    pub fn ev100(&self) -> f64 {
        (100.0 * (self.f_number as f64).powi(2) / (self.shutter_s as f64 * self.iso as f64)).log2()
    }
}

/// How the film records light: reconstruction filter, exposure and white
/// balance (see the module docs for the formula).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FilmSettings {
    /// Pixel reconstruction filter.
    pub filter: PixelFilter,
    /// Exposure compensation in stops: radiance is multiplied by `2^exposure_ev`.
    pub exposure_ev: f32,
    /// Shutter, ISO and f-number, multiplying radiance by `t·S/(100·N²)`.
    pub camera_exposure: Option<CameraExposure>,
    /// White balance, kelvin (the colour temperature made neutral).
    pub white_balance_k: Option<f32>,
    /// The window of the camera's image that is rendered and developed
    /// (Mitsuba's `crop_*`): the film is this window's size, its pixels
    /// those of the whole image; `None` for the whole image.
    pub crop: Option<Crop>,
}

/// A window of the camera's image, pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Crop {
    /// Left column.
    pub x0: u32,
    /// Top row.
    pub y0: u32,
    /// Width (≥ 1).
    pub width: u32,
    /// Height (≥ 1).
    pub height: u32,
}

impl FilmSettings {
    /// The linear exposure scale `s` (see the module docs).
    pub fn exposure_scale(&self) -> f32 {
        let mut s = (self.exposure_ev as f64).exp2();
        if let Some(c) = &self.camera_exposure {
            s *= c.shutter_s as f64 * c.iso as f64 / (100.0 * (c.f_number as f64).powi(2));
        }
        s as f32
    }

    /// The sensor response these settings describe.
    pub fn response(&self) -> SensorResponse {
        SensorResponse {
            white_balance: self.white_balance_k.map(white_balance_matrix),
            scale: self.exposure_scale(),
        }
    }
}

/// The per-sample map from radiance to recorded value, `L' = s · W · L`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorResponse {
    /// White balance matrix `W` on linear Rec.709 (`None`: identity).
    pub white_balance: Option<Mat3>,
    /// Exposure scale `s`.
    pub scale: f32,
}

impl SensorResponse {
    /// Applies the response to one sample's radiance.
    #[inline]
    pub fn apply(&self, l: Vec3) -> Vec3 {
        let l = match &self.white_balance {
            Some(m) => *m * l,
            None => l,
        };
        if self.scale == 1.0 {
            l
        } else {
            l * self.scale
        }
    }
}

/// A rendered image with its auxiliary layers.
#[derive(Debug, Clone, PartialEq)]
pub struct Film {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel that went into it.
    pub spp: u32,
    /// Mean radiance per pixel (linear RGB).
    pub color: Vec<Vec3>,
    /// Variance of the mean radiance per pixel and channel.
    pub variance: Vec<Vec3>,
    /// Coverage in `[0, 1]`.
    pub alpha: Vec<f32>,
    /// Object id of the first sample's hit, −1 for none.
    pub object_id: Vec<f32>,
    /// Mean camera-space depth of hits (scene units), 0 for none.
    pub depth: Vec<f32>,
    /// Mean world-space normal at first hits.
    pub normal: Vec<Vec3>,
    /// Mean albedo at first hits.
    pub albedo: Vec<Vec3>,
    /// The colour before denoising, when `color` was denoised
    /// ([`Film::denoise`]).
    pub noisy: Option<Vec<Vec3>>,
    /// The filter, exposure and white balance it was recorded with.
    pub settings: FilmSettings,
}

/// Stages a float OpenEXR of named single-channel `layers` (each
/// `width × height` values, row-major), with text header `attributes`, into
/// `outputs`. For images that are not a [`Film`] (a composite).
pub fn stage_exr_layers(
    outputs: &mut OutputSet,
    path: &Path,
    width: u32,
    height: u32,
    layers: &[(String, Vec<f32>)],
    attributes: &[(String, String)],
) -> Result<()> {
    let fail = |message: String| Error::output(path.to_path_buf(), message);
    let mut list: exrp::SmallVec<[AnyChannel<FlatSamples>; 4]> = exrp::SmallVec::new();
    for (name, values) in layers {
        if values.len() != (width * height) as usize {
            return Err(fail(format!(
                "layer {name} has {} values for {width}×{height} pixels",
                values.len()
            )));
        }
        list.push(AnyChannel::new(
            name.as_str(),
            FlatSamples::F32(values.clone()),
        ));
    }
    let attributes = exrp::LayerAttributes {
        software_name: Some(exrp::Text::from(
            format!("plsr {}", env!("CARGO_PKG_VERSION")).as_str(),
        )),
        other: attributes
            .iter()
            .map(|(k, v)| {
                (
                    exrp::Text::from(k.as_str()),
                    exrp::AttributeValue::Text(exrp::Text::from(v.as_str())),
                )
            })
            .collect(),
        ..Default::default()
    };
    let layer = exrp::Layer::new(
        (width as usize, height as usize),
        attributes,
        exrp::Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    let image = exrp::Image::from_layer(layer);
    outputs.stage(path, |w| {
        image
            .write()
            .to_buffered(&mut *w)
            .map_err(|e| fail(format!("cannot write EXR: {e}")))?;
        std::io::Write::flush(w)
            .and_then(|()| plsr_base::exr_header::sort_attributes(w.get_mut()))
            .map_err(|e| fail(format!("cannot finish the EXR header: {e}")))
    })
}

/// The first layer of the OpenEXR file `path`, every channel read flat
/// (an unreadable or truncated file is an error naming it).
fn read_flat_layer(path: &Path) -> Result<exrp::Layer<AnyChannels<FlatSamples>>> {
    check_exr_header(path)?;
    exrp::read_first_flat_layer_from_file(path)
        .map(|image| image.layer_data)
        .map_err(|e| Error::input(path, "", format!("cannot read EXR: {e}")))
}

/// Refuses an EXR whose data window is inverted or too large, which the
/// `exr` crate would read as an image of another size, or claims more
/// samples than the file can hold ([`plsr_base::exr_header::header_fault`]).
pub fn check_exr_header(path: &Path) -> Result<()> {
    match plsr_base::exr_header::header_fault(path) {
        Ok(Some(fault)) => Err(Error::input(path, "dataWindow", fault)),
        Ok(None) => Ok(()),
        Err(source) => Err(Error::io(path.to_path_buf(), source)),
    }
}

/// How radiance becomes display values in [`Film::write_png`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToneMap {
    /// Exposure compensation in stops: values are multiplied by `2^exposure`.
    pub exposure: f32,
    /// Filmic curve (ACES fit of Narkowicz 2015) instead of a plain clamp.
    pub filmic: bool,
}

/// The largest exposure compensation, in stops, anywhere plsr takes one
/// (`[film] exposure_ev`, `--exposure`, the C ABI): 2^64 is far beyond any
/// real exposure.
pub const MAX_EXPOSURE_STOPS: f32 = 64.0;

/// An exposure compensation (stops) that is not finite or beyond
/// ±[`MAX_EXPOSURE_STOPS`]. Its text does not name the option or field.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("must be between -{MAX_EXPOSURE_STOPS} and {MAX_EXPOSURE_STOPS} stops, got {0}")]
pub struct ExposureOutOfRange(pub f32);

/// Checks an exposure compensation in stops: finite and within
/// ±[`MAX_EXPOSURE_STOPS`].
pub fn check_exposure_stops(stops: f32) -> std::result::Result<f32, ExposureOutOfRange> {
    if stops.is_finite() && stops.abs() <= MAX_EXPOSURE_STOPS {
        Ok(stops)
    } else {
        Err(ExposureOutOfRange(stops))
    }
}

/// The exposure compensation, in stops, that `--exposure auto` applies:
/// the image's key — the log-average luminance `L̄ = exp(mean(ln Y))` of
/// its lit pixels (Reinhard et al. 2002) — maps to middle grey (0.18), but
/// the exposure is lowered, by at most 2 stops, until no more than 2 % of
/// the lit pixels have a channel above 1 (where a plain clamp clips). An
/// image with no lit pixel gets 0.
pub fn auto_exposure_stops(color: &[Vec3]) -> f32 {
    let lit: Vec<(f32, f32)> = color
        .iter()
        .map(|c| (0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z, c.max_element()))
        .filter(|(y, m)| y.is_finite() && m.is_finite() && *y > 0.0)
        .collect();
    if lit.is_empty() {
        return 0.0;
    }
    let log_mean = lit.iter().map(|(y, _)| (*y as f64).ln()).sum::<f64>() / lit.len() as f64;
    let key_stops = (0.18f64.ln() - log_mean) / std::f64::consts::LN_2;
    let mut peaks: Vec<f32> = lit.iter().map(|(_, m)| *m).collect();
    let at = ((peaks.len() as f64 * 0.98) as usize).min(peaks.len() - 1);
    let (_, p98, _) = peaks.select_nth_unstable_by(at, |a, b| a.total_cmp(b));
    let highlight_stops = -(*p98 as f64).log2();
    let stops = key_stops.min(highlight_stops).max(key_stops - 2.0);
    (stops as f32).clamp(-MAX_EXPOSURE_STOPS, MAX_EXPOSURE_STOPS)
}

impl Default for ToneMap {
    fn default() -> Self {
        ToneMap {
            exposure: 0.0,
            filmic: false,
        }
    }
}

pub use crate::color::srgb_encode;

/// ACES filmic curve fit (Narkowicz 2015), mapping `[0, ∞)` to `[0, 1)`.
#[inline]
pub fn aces_filmic(x: f32) -> f32 {
    let (a, b, c, d, e) = (2.51, 0.03, 2.43, 0.59, 0.14);
    ((x * (a * x + b)) / (x * (c * x + d) + e)).clamp(0.0, 1.0)
}

impl Film {
    /// Whether `other` has the same size and every layer the same bit
    /// patterns (unlike `==`, which takes −0 for +0 and no NaN for itself).
    pub fn bitwise_eq(&self, other: &Film) -> bool {
        let v3 = |a: &[Vec3], b: &[Vec3]| {
            a.len() == b.len()
                && a.iter()
                    .zip(b)
                    .all(|(x, y)| x.to_array().map(f32::to_bits) == y.to_array().map(f32::to_bits))
        };
        let v1 = |a: &[f32], b: &[f32]| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
        };
        (self.width, self.height, self.spp) == (other.width, other.height, other.spp)
            && v3(&self.color, &other.color)
            && v3(&self.variance, &other.variance)
            && v3(&self.normal, &other.normal)
            && v3(&self.albedo, &other.albedo)
            && v1(&self.alpha, &other.alpha)
            && v1(&self.depth, &other.depth)
            && v1(&self.object_id, &other.object_id)
    }

    /// An empty (black) film.
    pub fn new(width: u32, height: u32) -> Film {
        let n = (width as usize) * (height as usize);
        Film {
            width,
            height,
            spp: 0,
            color: vec![Vec3::ZERO; n],
            variance: vec![Vec3::ZERO; n],
            alpha: vec![0.0; n],
            object_id: vec![-1.0; n],
            depth: vec![0.0; n],
            normal: vec![Vec3::ZERO; n],
            albedo: vec![Vec3::ZERO; n],
            noisy: None,
            settings: FilmSettings::default(),
        }
    }

    /// Index of pixel `(x, y)`.
    #[inline]
    pub fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    /// Mean of the colour layer over the image, per channel.
    pub fn mean_color(&self) -> Vec3 {
        let sum: glam::DVec3 = self.color.iter().map(|c| c.as_dvec3()).sum();
        (sum / self.color.len().max(1) as f64).as_vec3()
    }

    /// Writes all layers to an OpenEXR file (32-bit float, ZIP compression),
    /// atomically.
    pub fn write_exr(&self, path: &Path) -> Result<()> {
        let mut outputs = OutputSet::new();
        self.stage_exr(&mut outputs, path)?;
        Ok(outputs.commit()?)
    }

    /// Writes the OpenEXR file into `outputs`, to be committed with the
    /// command's other outputs.
    pub fn stage_exr(&self, outputs: &mut OutputSet, path: &Path) -> Result<()> {
        self.stage_exr_with(
            outputs,
            path,
            Vec::new(),
            Vec::new(),
            exrp::Encoding::SMALL_LOSSLESS,
        )
    }

    /// [`Film::stage_exr`] with `extra` channels and header `attributes`
    /// (a render's part, see [`part`]), compressed as `encoding` says.
    pub(crate) fn stage_exr_with(
        &self,
        outputs: &mut OutputSet,
        path: &Path,
        extra: Vec<AnyChannel<FlatSamples>>,
        attributes: Vec<(exrp::Text, exrp::AttributeValue)>,
        encoding: exrp::Encoding,
    ) -> Result<()> {
        check_extension(path, "exr", "OpenEXR")
            .map_err(|wrong| Error::output(path, wrong.to_string()))?;
        outputs.stage(path, |w| {
            self.encode_exr(path, w, extra, attributes, encoding)
        })
    }

    /// Encodes all layers as OpenEXR into `w` (a new file, to be `path`),
    /// with `extra` channels and header `attributes`.
    fn encode_exr(
        &self,
        path: &Path,
        w: &mut BufWriter<File>,
        extra: Vec<AnyChannel<FlatSamples>>,
        attributes: Vec<(exrp::Text, exrp::AttributeValue)>,
        encoding: exrp::Encoding,
    ) -> Result<()> {
        let split3 = |v: &[Vec3], i: usize| -> FlatSamples {
            FlatSamples::F32(v.iter().map(|c| c[i]).collect())
        };
        let mut list: exrp::SmallVec<[AnyChannel<FlatSamples>; 4]> = exrp::SmallVec::new();
        for (i, n) in ["R", "G", "B"].iter().enumerate() {
            list.push(AnyChannel::new(*n, split3(&self.color, i)));
            list.push(AnyChannel::new(
                format!("variance.{n}").as_str(),
                split3(&self.variance, i),
            ));
            list.push(AnyChannel::new(
                format!("albedo.{n}").as_str(),
                split3(&self.albedo, i),
            ));
        }
        for (i, n) in ["X", "Y", "Z"].iter().enumerate() {
            list.push(AnyChannel::new(
                format!("normal.{n}").as_str(),
                split3(&self.normal, i),
            ));
        }
        if let Some(noisy) = &self.noisy {
            for (i, n) in ["R", "G", "B"].iter().enumerate() {
                list.push(AnyChannel::new(
                    format!("noisy.{n}").as_str(),
                    split3(noisy, i),
                ));
            }
        }
        list.push(AnyChannel::new("A", FlatSamples::F32(self.alpha.clone())));
        list.push(AnyChannel::new("Z", FlatSamples::F32(self.depth.clone())));
        list.push(AnyChannel::new(
            "object_id",
            FlatSamples::F32(self.object_id.clone()),
        ));
        list.extend(extra);
        let attributes = exrp::LayerAttributes {
            software_name: Some(exrp::Text::from(
                format!("plsr {} ({} spp)", env!("CARGO_PKG_VERSION"), self.spp).as_str(),
            )),
            other: self
                .header_attributes()
                .into_iter()
                .chain(attributes)
                .collect(),
            exposure: self.settings.camera_exposure.map(|c| c.shutter_s),
            aperture: self.settings.camera_exposure.map(|c| c.f_number),
            iso_speed: self.settings.camera_exposure.map(|c| c.iso),
            ..Default::default()
        };
        let layer = exrp::Layer::new(
            (self.width as usize, self.height as usize),
            attributes,
            encoding,
            AnyChannels::sort(list),
        );
        let image = exrp::Image::from_layer(layer);
        {
            let fail = |message: String| Error::output(path.to_path_buf(), message);
            image
                .write()
                .to_buffered(&mut *w)
                .map_err(|e| fail(format!("cannot write EXR: {e}")))?;
            std::io::Write::flush(w)
                .and_then(|()| plsr_base::exr_header::sort_attributes(w.get_mut()))
                .map_err(|e| fail(format!("cannot finish the EXR header: {e}")))
        }
    }

    /// Reads an EXR written by [`Film::write_exr`] (missing layers stay at
    /// their defaults; `R G B` are required).
    pub fn read_exr(path: &Path) -> Result<Film> {
        let layer = read_flat_layer(path)?;
        let (w, h) = (layer.size.0 as u32, layer.size.1 as u32);
        let mut film = Film::new(w, h);
        let attrs = &layer.attributes.other;
        if let Some(exrp::AttributeValue::I32(spp)) = attrs.get(&exrp::Text::from(SPP_ATTRIBUTE)) {
            film.spp = (*spp).max(0) as u32;
        }
        film.settings = settings_from_header(&layer.attributes);
        let channel = |name: &str| -> Option<Vec<f32>> {
            layer
                .channel_data
                .list
                .iter()
                .find(|c| c.name.to_string() == name)
                .map(|c| c.sample_data.values_as_f32().collect())
        };
        let set3 = |names: [&str; 3], dst: &mut Vec<Vec3>, required: bool| -> Result<()> {
            for (i, n) in names.iter().enumerate() {
                match channel(n) {
                    Some(v) => {
                        for (d, x) in dst.iter_mut().zip(v) {
                            d[i] = x;
                        }
                    }
                    None if required => {
                        return Err(Error::input(path, *n, "channel missing from the EXR file"))
                    }
                    None => {}
                }
            }
            Ok(())
        };
        set3(["R", "G", "B"], &mut film.color, true)?;
        set3(
            ["variance.R", "variance.G", "variance.B"],
            &mut film.variance,
            false,
        )?;
        set3(
            ["albedo.R", "albedo.G", "albedo.B"],
            &mut film.albedo,
            false,
        )?;
        set3(
            ["normal.X", "normal.Y", "normal.Z"],
            &mut film.normal,
            false,
        )?;
        if channel("noisy.R").is_some() {
            let mut noisy = vec![Vec3::ZERO; film.color.len()];
            set3(["noisy.R", "noisy.G", "noisy.B"], &mut noisy, true)?;
            film.noisy = Some(noisy);
        }
        if let Some(v) = channel("A") {
            film.alpha = v;
        }
        if let Some(v) = channel("Z") {
            film.depth = v;
        }
        if let Some(v) = channel("object_id") {
            film.object_id = v;
        }
        Ok(film)
    }

    /// The EXR header attributes of the samples per pixel and the settings.
    fn header_attributes(&self) -> Vec<(exrp::Text, exrp::AttributeValue)> {
        use exrp::AttributeValue::{Text as T, F32, I32};
        let t = |s: &str| exrp::Text::from(s);
        let s = &self.settings;
        let mut out = vec![
            (t(SPP_ATTRIBUTE), I32(self.spp.min(i32::MAX as u32) as i32)),
            (t("plsrFilter"), T(t(s.filter.name()))),
            (t("plsrExposureEv"), F32(s.exposure_ev)),
            (t("plsrExposureScale"), F32(s.exposure_scale())),
        ];
        if let PixelFilter::Gaussian(g) = &s.filter {
            out.push((t("plsrFilterSigma"), F32(g.sigma)));
            out.push((t("plsrFilterRadius"), F32(g.radius)));
        }
        if let PixelFilter::Tent(f) = &s.filter {
            out.push((t("plsrFilterRadius"), F32(f.radius)));
        }
        if !matches!(s.filter, PixelFilter::Box) && s.filter.clips_at_border() {
            out.push((t("plsrFilterBorder"), T(t("clip"))));
        }
        if let Some(k) = s.white_balance_k {
            out.push((t("plsrWhiteBalance"), F32(k)));
        }
        if let Some(c) = s.crop {
            let crop = format!("{} {} {} {}", c.x0, c.y0, c.width, c.height);
            out.push((t("plsrCrop"), T(t(&crop))));
        }
        out
    }

    /// 8-bit sRGB pixels after exposure and tone mapping, row-major RGB.
    pub fn to_srgb8(&self, tone: ToneMap) -> Vec<u8> {
        let scale = tone.exposure.exp2();
        let mut out = Vec::with_capacity(self.color.len() * 3);
        for c in &self.color {
            for x in c.to_array() {
                let v = (x * scale).max(0.0);
                let v = if tone.filmic {
                    aces_filmic(v)
                } else {
                    v.min(1.0)
                };
                let v = if v.is_finite() { v } else { 0.0 };
                out.push((srgb_encode(v) * 255.0 + 0.5) as u8);
            }
        }
        out
    }

    /// Writes a tone-mapped 8-bit sRGB PNG, atomically.
    pub fn write_png(&self, path: &Path, tone: ToneMap) -> Result<()> {
        let mut outputs = OutputSet::new();
        self.stage_png(&mut outputs, path, tone)?;
        Ok(outputs.commit()?)
    }

    /// Writes the PNG into `outputs`, to be committed with the command's
    /// other outputs.
    pub fn stage_png(&self, outputs: &mut OutputSet, path: &Path, tone: ToneMap) -> Result<()> {
        check_extension(path, "png", "PNG")
            .map_err(|wrong| Error::output(path, wrong.to_string()))?;
        outputs.stage(path, |w| self.encode_png(path, tone, w))
    }

    /// Encodes the tone-mapped 8-bit sRGB PNG into `w` (a new file, to be
    /// `path`).
    fn encode_png(&self, path: &Path, tone: ToneMap, w: &mut BufWriter<File>) -> Result<()> {
        let pixels = self.to_srgb8(tone);
        image::write_buffer_with_format(
            w,
            &pixels,
            self.width,
            self.height,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| Error::output(path.to_path_buf(), format!("cannot write PNG: {e}")))
    }
}

/// Film settings from EXR header attributes written by [`Film::write_exr`]
/// (defaults for whatever is missing).
fn settings_from_header(layer: &exrp::LayerAttributes) -> FilmSettings {
    let attrs = &layer.other;
    let f32_of = |name: &str| match attrs.get(&exrp::Text::from(name)) {
        Some(exrp::AttributeValue::F32(v)) => Some(*v),
        _ => None,
    };
    let mut s = FilmSettings::default();
    let clip = matches!(
        attrs.get(&exrp::Text::from("plsrFilterBorder")),
        Some(exrp::AttributeValue::Text(b)) if b == "clip"
    );
    if let Some(exrp::AttributeValue::Text(name)) = attrs.get(&exrp::Text::from("plsrFilter")) {
        if name == "gaussian" {
            if let (Some(sigma), Some(radius)) =
                (f32_of("plsrFilterSigma"), f32_of("plsrFilterRadius"))
            {
                if let Ok(g) = GaussianFilter::new(sigma, radius) {
                    s.filter = PixelFilter::Gaussian(g.clipped_at_border(clip));
                }
            }
        } else if name == "tent" {
            if let Some(Ok(f)) = f32_of("plsrFilterRadius").map(TentFilter::new) {
                s.filter = PixelFilter::Tent(f.clipped_at_border(clip));
            }
        }
    }
    s.exposure_ev = f32_of("plsrExposureEv").unwrap_or(0.0);
    if let Some(exrp::AttributeValue::Text(c)) = attrs.get(&exrp::Text::from("plsrCrop")) {
        let v: Vec<u32> = c
            .to_string()
            .split(' ')
            .filter_map(|x| x.parse().ok())
            .collect();
        if let [x0, y0, width, height] = v[..] {
            if width > 0 && height > 0 {
                s.crop = Some(Crop {
                    x0,
                    y0,
                    width,
                    height,
                });
            }
        }
    }
    s.white_balance_k = f32_of("plsrWhiteBalance");
    if let (Some(shutter_s), Some(f_number), Some(iso)) =
        (layer.exposure, layer.aperture, layer.iso_speed)
    {
        s.camera_exposure = Some(CameraExposure {
            shutter_s,
            iso,
            f_number,
        });
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_encoding_hits_known_values() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_encode(0.18) - 0.4614).abs() < 1e-3);
    }

    #[test]
    fn exr_round_trip_keeps_every_layer() {
        let mut film = Film::new(5, 3);
        film.spp = 7;
        film.settings = FilmSettings {
            filter: PixelFilter::Gaussian(GaussianFilter::new(0.4, 1.2).unwrap()),
            exposure_ev: -1.5,
            camera_exposure: Some(CameraExposure {
                shutter_s: 0.25,
                iso: 400.0,
                f_number: 4.0,
            }),
            white_balance_k: Some(4400.0),
            // The crop of a larger image this film is (read back as given).
            crop: Some(Crop {
                x0: 3,
                y0: 1,
                width: 5,
                height: 3,
            }),
        };
        for i in 0..15 {
            let f = i as f32;
            film.color[i] = Vec3::new(f, f * 0.5, 1e-3 * f);
            film.variance[i] = Vec3::splat(f * 1e-4);
            film.alpha[i] = f / 15.0;
            film.object_id[i] = (i % 3) as f32 - 1.0;
            film.depth[i] = 10.0 + f;
            film.normal[i] = Vec3::new(0.0, 1.0, -f);
            film.albedo[i] = Vec3::new(0.1, 0.2, f * 0.01);
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.exr");
        film.write_exr(&path).unwrap();
        let back = Film::read_exr(&path).unwrap();
        assert_eq!(back.spp, 7);
        assert_eq!(back.color, film.color);
        assert_eq!(back.variance, film.variance);
        assert_eq!(back.alpha, film.alpha);
        assert_eq!(back.object_id, film.object_id);
        assert_eq!(back.depth, film.depth);
        assert_eq!(back.normal, film.normal);
        assert_eq!(back.albedo, film.albedo);
        assert_eq!(back.settings, film.settings);
        // Nothing but the output is left in the folder.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);

        // The same film gives the same file, byte for byte: the header's
        // attributes (seven of plsr's here) come out in name order, not in
        // the order of the writer's hash map, which differs from map to map.
        let first = std::fs::read(&path).unwrap();
        for k in 0..6 {
            let again = dir.path().join(format!("again{k}.exr"));
            film.write_exr(&again).unwrap();
            assert!(std::fs::read(&again).unwrap() == first, "write {k} differs");
            assert!(Film::read_exr(&again).unwrap().bitwise_eq(&film));
        }
        // OpenEXR's own library (through OpenImageIO) reads the reordered
        // header too.
        let oiio = plsr_hdr::oiio::ImageReader::open(&path).unwrap();
        assert_eq!((oiio.info().width, oiio.info().height), (5, 3));
        assert_eq!(oiio.info().channels, 15);
        assert_eq!(
            oiio.string_attribute("plsrFilter").as_deref(),
            Some("gaussian")
        );
        assert_eq!(oiio.float_attribute("plsrExposureEv"), Some(-1.5));
    }

    #[test]
    fn exposure_scale_follows_ev100() {
        let mut s = FilmSettings {
            exposure_ev: 1.0,
            ..Default::default()
        };
        assert_eq!(s.exposure_scale(), 2.0);
        assert_eq!(
            s.response().apply(Vec3::new(0.3, 0.1, 7.0)),
            Vec3::new(0.6, 0.2, 14.0)
        );
        s.exposure_ev = 0.0;
        let c = CameraExposure {
            shutter_s: 0.25,
            iso: 400.0,
            f_number: 1.0,
        };
        assert_eq!(c.ev100(), 0.0);
        s.camera_exposure = Some(c);
        assert_eq!(s.exposure_scale(), 1.0);
        s.camera_exposure = Some(CameraExposure { f_number: 2.0, ..c });
        assert_eq!(s.exposure_scale(), 0.25);
        assert_eq!(
            FilmSettings::default().response().apply(Vec3::ONE),
            Vec3::ONE
        );
    }

    #[test]
    fn png_exposure_doubles_per_stop() {
        let mut film = Film::new(1, 1);
        film.color[0] = Vec3::splat(0.1);
        let a = film.to_srgb8(ToneMap::default());
        let b = film.to_srgb8(ToneMap {
            exposure: 1.0,
            filmic: false,
        });
        assert_eq!(a[0], (srgb_encode(0.1) * 255.0 + 0.5) as u8);
        assert_eq!(b[0], (srgb_encode(0.2) * 255.0 + 0.5) as u8);
    }
}
