//! `[photo]`: the photograph virtual objects are composited into.

use super::Builder;
use crate::error::Result;
use crate::scene::photo::{ExifUnits, PhotoExposure, PhotoResponse, PhotoSpec, ScaleReference};
use serde::Deserialize;
use std::path::PathBuf;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PhotoSection {
    pub(super) file: PathBuf,
    pub(super) response: Option<String>,
    pub(super) exposure: Option<toml::Value>,
    /// The merged panorama whose units the render is in, for `exposure =
    /// "exif"` (default: the scene's `[environment] file`).
    pub(super) panorama: Option<PathBuf>,
    pub(super) reference: Option<ReferenceSection>,
}

/// `[photo] reference`: a grey card (`shape`, `reflectance`) or a light
/// (`light`) of known brightness.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ReferenceSection {
    shape: Option<String>,
    reflectance: Option<f32>,
    light: Option<String>,
}

impl Builder<'_> {
    /// The `[photo]`: its file, response (`srgb`, the default; `linear`; or
    /// a curve CSV) and exposure (a positive factor, `"auto"`, the default,
    /// or `"exif"`). `environment` is the scene's environment map and
    /// scale, where `"exif"` finds the render's units unless `panorama`
    /// names them.
    pub(super) fn photo(
        &self,
        p: &PhotoSection,
        environment: Option<(PathBuf, f32)>,
    ) -> Result<PhotoSpec> {
        let file = self.base.join(&p.file);
        self.read_input(&file);
        let response = match p.response.as_deref().unwrap_or("srgb") {
            "srgb" => PhotoResponse::Srgb,
            "linear" => PhotoResponse::Linear,
            csv if csv.to_ascii_lowercase().ends_with(".csv") => {
                let path = self.base.join(csv);
                self.read_input(&path);
                PhotoResponse::Curve(path)
            }
            other => {
                return Err(self.err(
                    "photo.response",
                    format!(
                        "`{other}` is not a response: `srgb`, `linear`, or a curve CSV \
                         (`plsr hdr merge --curve`)"
                    ),
                ))
            }
        };
        let exposure = match &p.exposure {
            None => PhotoExposure::Auto,
            Some(toml::Value::String(s)) if s == "auto" => PhotoExposure::Auto,
            Some(toml::Value::String(s)) if s == "exif" => {
                let units = match (&p.panorama, environment) {
                    (Some(pano), _) => ExifUnits {
                        panorama: self.base.join(pano),
                        scale: 1.0,
                    },
                    (None, Some((map, scale))) => ExifUnits {
                        panorama: map,
                        scale,
                    },
                    (None, None) => {
                        return Err(self.err(
                            "photo.exposure",
                            "is \"exif\", which needs the units the render is in: name the \
                             panorama `plsr hdr merge` wrote (`panorama = \"merged.exr\"`), or light \
                             the scene with it (`[environment] file`)",
                        ))
                    }
                };
                if !(units.scale.is_finite() && units.scale > 0.0) {
                    return Err(self.err(
                        "photo.exposure",
                        format!(
                            "is \"exif\", but the environment's scale is {}: it must be positive",
                            units.scale
                        ),
                    ));
                }
                self.read_input(&units.panorama);
                PhotoExposure::Exif(units)
            }
            Some(v) => {
                let k = v.as_float().or_else(|| v.as_integer().map(|i| i as f64));
                match k {
                    Some(k) if k.is_finite() && k > 0.0 && k <= f32::MAX as f64 => {
                        PhotoExposure::Factor(k as f32)
                    }
                    _ => {
                        return Err(self.err(
                            "photo.exposure",
                            format!("must be a positive number, \"auto\" or \"exif\", got {v}"),
                        ))
                    }
                }
            }
        };
        if p.panorama.is_some() && !matches!(exposure, PhotoExposure::Exif(_)) {
            return Err(self.err("photo.panorama", "is only read with exposure = \"exif\""));
        }
        let reference = match &p.reference {
            None => None,
            Some(r) => Some(match (&r.shape, &r.light) {
                (Some(shape), None) => ScaleReference::Card {
                    shape: shape.clone(),
                    reflectance: match r.reflectance {
                        None => None,
                        Some(x) if x > 0.0 && x <= 1.0 => Some(x),
                        Some(x) => {
                            return Err(self.err(
                                "photo.reference.reflectance",
                                format!("must be in (0, 1], got {x}"),
                            ))
                        }
                    },
                },
                (None, Some(name)) if r.reflectance.is_none() => {
                    ScaleReference::Light { name: name.clone() }
                }
                (None, Some(_)) => {
                    return Err(self.err(
                        "photo.reference.reflectance",
                        "is for a card (`shape`), not a light",
                    ))
                }
                _ => {
                    return Err(self.err(
                        "photo.reference",
                        "give either `shape` (a grey card, with its `reflectance`) or `light` \
                         (a light of measured brightness seen in the photo)",
                    ))
                }
            }),
        };
        Ok(PhotoSpec {
            file,
            response,
            exposure,
            reference,
        })
    }
}
