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
    /// The factor `k` with `photo ≈ k · render` in linear radiance; `None`:
    /// fit it (`exposure = "auto"`).
    pub exposure: Option<f32>,
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
