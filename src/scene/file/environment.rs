//! `[environment]`: an HDR panorama or a constant sky at infinity.

use super::Builder;
use crate::error::FormatError;
use crate::error::{Error, Result};
use crate::light::EnvironmentLight;
use glam::Vec3;
use plsr_base::Vocabulary;
use serde::Deserialize;
use std::path::{Path, PathBuf};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct EnvironmentSection {
    pub(super) file: Option<PathBuf>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) radiance: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) up: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) forward: Option<[f32; 3]>,
    pub(super) scale: Option<f32>,
    /// `"nearest"` (default) or `"bilinear"`.
    pub(super) filter: Option<String>,
    /// `"centres"` (default: row `y` covers `[y, y+1)/height`) or
    /// `"poles"` (Mitsuba's `envmap`: the first and last rows' centres are
    /// the zenith and nadir; needs `filter = "bilinear"`).
    pub(super) rows: Option<String>,
}

impl Builder<'_> {
    /// The `[environment]`: an equirectangular image (`file`, EXR or
    /// Radiance HDR) oriented by `up` and `forward`, or a constant
    /// `radiance`; times `scale`.
    pub(super) fn environment(&self, e: &EnvironmentSection) -> Result<EnvironmentLight> {
        let scale = self.finite("environment.scale", e.scale.unwrap_or(1.0))?;
        let bilinear = match e.filter.as_deref() {
            None | Some("nearest") => false,
            Some("bilinear") => true,
            Some(other) => {
                return Err(self.err(
                    "environment.filter",
                    format!("unknown filter `{other}` (known: nearest, bilinear)"),
                ))
            }
        };
        if bilinear && e.file.is_none() {
            return Err(self.err("environment.filter", "only used with an image file"));
        }
        let rows_at_poles = match e.rows.as_deref() {
            None | Some("centres") => false,
            Some("poles") => true,
            Some(other) => {
                return Err(self.err(
                    "environment.rows",
                    format!("unknown row layout `{other}` (known: centres, poles)"),
                ))
            }
        };
        if e.rows.is_some() && e.file.is_none() {
            return Err(self.err("environment.rows", "only used with an image file"));
        }
        if rows_at_poles && !bilinear {
            return Err(self.err(
                "environment.rows",
                "`poles` needs filter = \"bilinear\" (rows at the poles are interpolated)",
            ));
        }
        if scale < 0.0 {
            return Err(self.err(
                "environment.scale",
                format!("must not be negative, got {scale}"),
            ));
        }
        match (&e.file, e.radiance) {
            (Some(_), Some(_)) => Err(self.err(
                "environment.radiance",
                "give either file or radiance, not both",
            )),
            (None, None) => Err(self.err(
                "environment.file",
                "give an image file or a constant radiance",
            )),
            (None, Some(r)) => {
                for (k, present) in [("up", e.up.is_some()), ("forward", e.forward.is_some())] {
                    if present {
                        return Err(
                            self.err(format!("environment.{k}"), "only used with an image file")
                        );
                    }
                }
                Ok(EnvironmentLight::constant(
                    self.colour("environment.radiance", r, None)? * scale,
                ))
            }
            (Some(rel), None) => {
                let up = e.up.ok_or_else(|| {
                    self.err(
                        "environment.up",
                        "required with an image file: the world direction of its top row",
                    )
                })?;
                let forward = e.forward.ok_or_else(|| {
                    self.err(
                        "environment.forward",
                        "required with an image file: the world direction of its centre column",
                    )
                })?;
                let up = self.vec3("environment.up", up)?;
                let forward = self.vec3("environment.forward", forward)?;
                // Each vector is blamed for its own fault: a zero `up` is
                // not `forward`'s.
                if up.length_squared() == 0.0 {
                    return Err(self.err("environment.up", "must not be the zero vector"));
                }
                if forward.length_squared() == 0.0 {
                    return Err(self.err("environment.forward", "must not be the zero vector"));
                }
                let frame = crate::equirect::SphereFrame::new(up, forward).ok_or_else(|| {
                    self.err(
                        "environment.forward",
                        format!("{forward} is parallel to up {up}: the frame is undefined"),
                    )
                })?;
                let path = self.base.join(rel);
                self.read_input(&path);
                checked_environment(&path, frame, scale)
                    .map(|env| {
                        env.with_bilinear(bilinear)
                            .with_rows_at_poles(rows_at_poles)
                    })
                    .map_err(|m| self.err("environment.file", m.to_string()))
            }
        }
    }
}

/// Loads an equirectangular environment image (`.exr` or `.hdr`, linear
/// radiance, finite and ≥ 0) oriented by `frame`, times `scale`; errors name
/// the file.
pub fn load_environment(
    path: &Path,
    frame: crate::equirect::SphereFrame,
    scale: f32,
) -> Result<EnvironmentLight> {
    checked_environment(path, frame, scale).map_err(|m| Error::input(path, "", m.to_string()))
}

pub(super) fn checked_environment(
    path: &Path,
    frame: crate::equirect::SphereFrame,
    scale: f32,
) -> std::result::Result<EnvironmentLight, FormatError> {
    let (w, h, texels) = load_environment_image(path)?;
    if let Some(i) = texels
        .iter()
        .position(|t| !t.is_finite() || t.min_element() < 0.0)
    {
        return Err(format!(
            "{}: texel ({}, {}) is {}: radiance must be finite and not negative",
            path.display(),
            i % w as usize,
            i / w as usize,
            texels[i]
        )
        .into());
    }
    Ok(EnvironmentLight::from_image(w, h, texels, scale, frame))
}

/// Reads an equirectangular image of linear radiance: OpenEXR (`.exr`, its
/// R, G, B channels) or Radiance HDR (`.hdr`). Returns width, height and
/// texels row-major from the top row.
pub(super) fn load_environment_image(
    path: &Path,
) -> std::result::Result<(u32, u32, Vec<Vec3>), FormatError> {
    crate::input::check_regular_file(path).map_err(|m| {
        format!(
            "{}: environment image {m} (paths are relative to the scene file)",
            path.display()
        )
    })?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("exr") => {
            let film = crate::film::Film::read_exr(path)
                .map_err(|e| format!("{}: {e}", path.display()))?;
            Ok((film.width, film.height, film.color))
        }
        Some("hdr") => {
            crate::film::radiance::read_radiance_hdr(path).map_err(|e| e.to_string().into())
        }
        _ => Err(format!(
            "{}: unsupported environment image (use .exr or .hdr)",
            path.display()
        )
        .into()),
    }
}
