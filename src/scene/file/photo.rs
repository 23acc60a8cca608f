//! `[photo]`: the photograph virtual objects are composited into.

use super::Builder;
use crate::error::Result;
use crate::scene::photo::{PhotoResponse, PhotoSpec};
use serde::Deserialize;
use std::path::PathBuf;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PhotoSection {
    pub(super) file: PathBuf,
    pub(super) response: Option<String>,
    pub(super) exposure: Option<toml::Value>,
}

impl Builder<'_> {
    /// The `[photo]`: its file, response (`srgb`, the default; `linear`; or
    /// a curve CSV) and exposure (a positive factor, or `"auto"`, the
    /// default).
    pub(super) fn photo(&self, p: &PhotoSection) -> Result<PhotoSpec> {
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
            None => None,
            Some(toml::Value::String(s)) if s == "auto" => None,
            Some(v) => {
                let k = v.as_float().or_else(|| v.as_integer().map(|i| i as f64));
                match k {
                    Some(k) if k.is_finite() && k > 0.0 && k <= f32::MAX as f64 => Some(k as f32),
                    _ => {
                        return Err(self.err(
                            "photo.exposure",
                            format!("must be a positive number or \"auto\", got {v}"),
                        ))
                    }
                }
            }
        };
        Ok(PhotoSpec {
            file,
            response,
            exposure,
        })
    }
}
