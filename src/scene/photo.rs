//! The photograph a scene's virtual objects are composited into: the
//! `[photo]` table of a scene file, read by `plsr composite`.

use std::path::PathBuf;

/// How a photograph's pixel values map to linear radiance.
#[derive(Debug, Clone, PartialEq)]
pub enum PhotoResponse {
    /// The sRGB transfer curve (most cameras' JPEG and PNG).
    Srgb,
    /// Values are proportional to radiance (raw or float images).
    Linear,
    /// A recovered response curve, as `plsr hdr merge --curve` writes it
    /// (CSV, one row per pixel level).
    Curve(PathBuf),
}

/// The photograph of a scene file's `[photo]` table.
#[derive(Debug, Clone, PartialEq)]
pub struct PhotoSpec {
    /// The image file (resolved against the scene file's folder).
    pub file: PathBuf,
    /// How its values map to linear radiance.
    pub response: PhotoResponse,
    /// The factor `k` with `photo ≈ k · render` in linear radiance, or how
    /// to find it.
    pub exposure: PhotoExposure,
    /// What in the photo has a known brightness, so that a fitted exposure
    /// cannot trade against fitted albedos or lights (`reference`).
    pub reference: Option<ScaleReference>,
}

/// How a photo's exposure `k` (`photo ≈ k · render`, linear) is found.
#[derive(Debug, Clone, PartialEq)]
pub enum PhotoExposure {
    /// Fitted to the photo (`exposure = "auto"`, the default).
    Auto,
    /// Given (`exposure = 0.25`).
    Factor(f32),
    /// From the photo's EXIF exposure time, f-number and ISO against the
    /// settings of the merged panorama the render's units come from
    /// (`exposure = "exif"`).
    Exif(ExifUnits),
}

impl PhotoExposure {
    /// The factor when it is given as a number.
    pub fn factor(&self) -> Option<f32> {
        match self {
            PhotoExposure::Factor(k) => Some(*k),
            _ => None,
        }
    }
}

/// Where a render's units come from for `exposure = "exif"`: a panorama
/// merged by `plsr hdr merge`, whose header keeps its brackets' exposure
/// times, f-numbers, ISO and any absolute calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct ExifUnits {
    /// The merged panorama (OpenEXR).
    pub panorama: PathBuf,
    /// How much brighter the render is than the panorama's units: the
    /// `[environment] scale` when the units come from the scene's
    /// environment map, else 1.
    pub scale: f32,
}

/// Something in a photo whose brightness is known: it pins the scale when
/// the exposure is fitted with albedos or lights (`plsr fit`).
#[derive(Debug, Clone, PartialEq)]
pub enum ScaleReference {
    /// A patch of known reflectance (a grey card): the shape of that name,
    /// whose material is diffuse and is not fitted.
    Card {
        /// The shape's name.
        shape: String,
        /// Its reflectance (0 to 1, the same in every channel); `None`: as
        /// the scene's material says.
        reflectance: Option<f32>,
    },
    /// A light of measured brightness seen in the photo: the emitting shape
    /// (or PLS light) of that name, not fitted.
    Light {
        /// The light's name.
        name: String,
    },
}

/// A `[[views]]` entry: another photo of the scene, with the camera that
/// took it (`plsr fit` fits against every view).
#[derive(Debug, Clone, PartialEq)]
pub struct ViewSpec {
    /// The camera.
    pub camera: crate::camera::Camera,
    /// The photo.
    pub photo: PhotoSpec,
}
