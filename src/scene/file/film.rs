//! `[film]`: pixel filter, exposure, white balance and crop window.

use super::Builder;
use crate::camera::CameraPreset;
use crate::color::{MAX_TEMPERATURE_K, MIN_TEMPERATURE_K};
use crate::error::Result;
use crate::film::{CameraExposure, Crop, FilmSettings};
use crate::filter::{
    GaussianFilter, PixelFilter, TentFilter, DEFAULT_GAUSSIAN_RADIUS, DEFAULT_GAUSSIAN_SIGMA,
    DEFAULT_TENT_RADIUS,
};
use serde::Deserialize;

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct FilmSection {
    pub(super) filter: Option<String>,
    pub(super) filter_sigma: Option<f32>,
    pub(super) filter_radius: Option<f32>,
    /// `"extend"` (default) or `"clip"`: keep samples on the film.
    pub(super) filter_border: Option<String>,
    pub(super) exposure_ev: Option<f32>,
    pub(super) shutter: Option<f32>,
    pub(super) iso: Option<f32>,
    pub(super) f_number: Option<f32>,
    pub(super) white_balance: Option<f32>,
    /// `[x0, y0, x1, y1]`: the window of the image rendered.
    pub(super) crop: Option<[i64; 4]>,
}

impl Builder<'_> {
    /// Pixel filter, exposure and white balance; a camera preset supplies
    /// the defaults of `shutter`, `iso` and `white_balance`.
    pub(super) fn film(
        &self,
        f: &FilmSection,
        preset: Option<&CameraPreset>,
        (width, height): (u32, u32),
    ) -> Result<FilmSettings> {
        let filter = self.pixel_filter(f)?;
        let exposure_ev = self.finite("film.exposure_ev", f.exposure_ev.unwrap_or(0.0))?;
        let exposure_ev = crate::film::check_exposure_stops(exposure_ev)
            .map_err(|m| self.err("film.exposure_ev", m.to_string()))?;
        let camera_exposure = match f.f_number {
            Some(n) => {
                let n = self.positive("film.f_number", n)?;
                let from_preset = |name: &str, v: Option<f32>, p: Option<f32>| -> Result<f32> {
                    let v = v.or(p).ok_or_else(|| {
                        self.err(
                            format!("film.{name}"),
                            "required with f_number (shutter in seconds, iso)",
                        )
                    })?;
                    self.positive(&format!("film.{name}"), v)
                };
                Some(CameraExposure {
                    shutter_s: from_preset("shutter", f.shutter, preset.map(|p| p.shutter_s))?,
                    iso: from_preset("iso", f.iso, preset.map(|p| p.iso))?,
                    f_number: n,
                })
            }
            None => {
                if f.shutter.is_some() || f.iso.is_some() {
                    return Err(self.err(
                        "film.f_number",
                        "required with shutter and iso (the exposure is t·S/(100·N²))",
                    ));
                }
                None
            }
        };
        let white_balance_k = match f.white_balance.or(preset.map(|p| p.white_balance_k)) {
            Some(k) => {
                let k = self.finite("film.white_balance", k)?;
                if !(MIN_TEMPERATURE_K..=MAX_TEMPERATURE_K).contains(&k) {
                    return Err(self.err(
                        "film.white_balance",
                        format!(
                            "must be between {MIN_TEMPERATURE_K} and {MAX_TEMPERATURE_K} K, got {k}"
                        ),
                    ));
                }
                Some(k)
            }
            None => None,
        };
        let crop = match f.crop {
            None => None,
            Some([x0, y0, x1, y1]) => {
                if !(0 <= x0
                    && x0 < x1
                    && x1 <= width as i64
                    && 0 <= y0
                    && y0 < y1
                    && y1 <= height as i64)
                {
                    return Err(self.err(
                        "film.crop",
                        format!(
                            "[{x0}, {y0}, {x1}, {y1}] is not a window [x0, y0, x1, y1] of the \
                             {width}×{height} image (0 ≤ x0 < x1 ≤ width, 0 ≤ y0 < y1 ≤ height)"
                        ),
                    ));
                }
                Some(Crop {
                    x0: x0 as u32,
                    y0: y0 as u32,
                    width: (x1 - x0) as u32,
                    height: (y1 - y0) as u32,
                })
            }
        };
        Ok(FilmSettings {
            filter,
            exposure_ev,
            camera_exposure,
            white_balance_k,
            crop,
        })
    }

    /// `filter` and its keys: `filter_sigma` (Gaussian), `filter_radius`
    /// (Gaussian, tent) and `filter_border` (both).
    fn pixel_filter(&self, f: &FilmSection) -> Result<PixelFilter> {
        let kind = f.filter.as_deref().unwrap_or("box");
        let allowed: &[&str] = match kind {
            "box" => &[],
            "gaussian" => &["filter_sigma", "filter_radius", "filter_border"],
            "tent" => &["filter_radius", "filter_border"],
            other => {
                return Err(self.err(
                    "film.filter",
                    format!("unknown filter `{other}` (known: box, gaussian, tent)"),
                ))
            }
        };
        for (name, present) in [
            ("filter_sigma", f.filter_sigma.is_some()),
            ("filter_radius", f.filter_radius.is_some()),
            ("filter_border", f.filter_border.is_some()),
        ] {
            if present && !allowed.contains(&name) {
                let users = match name {
                    "filter_sigma" => "filter = \"gaussian\"",
                    _ => "filter = \"gaussian\" or \"tent\"",
                };
                return Err(self.err(format!("film.{name}"), format!("only used with {users}")));
            }
        }
        let clip = match f.filter_border.as_deref() {
            None | Some("extend") => false,
            Some("clip") => true,
            Some(other) => {
                return Err(self.err(
                    "film.filter_border",
                    format!("unknown border `{other}` (known: extend, clip)"),
                ))
            }
        };
        Ok(match kind {
            "gaussian" => {
                let sigma = self.positive(
                    "film.filter_sigma",
                    f.filter_sigma.unwrap_or(DEFAULT_GAUSSIAN_SIGMA),
                )?;
                let radius = self.positive(
                    "film.filter_radius",
                    f.filter_radius.unwrap_or(DEFAULT_GAUSSIAN_RADIUS),
                )?;
                let g = GaussianFilter::new(sigma, radius)
                    .map_err(|e| self.err("film.filter_radius", e.to_string()))?;
                PixelFilter::Gaussian(g.clipped_at_border(clip))
            }
            "tent" => {
                let radius = self.positive(
                    "film.filter_radius",
                    f.filter_radius.unwrap_or(DEFAULT_TENT_RADIUS),
                )?;
                let t = TentFilter::new(radius)
                    .map_err(|e| self.err("film.filter_radius", e.to_string()))?;
                PixelFilter::Tent(t.clipped_at_border(clip))
            }
            _ => PixelFilter::Box,
        })
    }
}
