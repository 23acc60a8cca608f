//! Reading the linear images plsr writes, whatever their format: OpenEXR
//! (renders, merges, composites), Radiance HDR and 32-bit float TIFF
//! (`plsr hdr merge -o pano.hdr|pano.tif`), for `tonemap` and `info`.

use crate::error::{Error, Result};
use plsr::film::Film;
use plsr_base::Vocabulary;
use std::path::Path;

/// The formats [`read_linear`] reads, by extension.
pub const LINEAR_FORMATS: &str = "OpenEXR (.exr), Radiance HDR (.hdr) or float TIFF (.tif)";

/// The lowercase extension of `path`.
fn extension(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// Reads `path` as linear RGB into a film's colour layer (every pixel
/// covered): an OpenEXR as [`Film::read_exr`] reads it (with its layers
/// and film settings), a Radiance HDR or a TIFF (its first three channels,
/// or one grey channel) with the others empty.
pub fn read_linear(path: &Path) -> Result<Film> {
    match extension(path).as_str() {
        "exr" => Ok(Film::read_exr(path)?),
        "hdr" => {
            let (w, h, color) = plsr::film::radiance::read_radiance_hdr(path)?;
            Ok(film_of(w, h, color))
        }
        "tif" | "tiff" => {
            let (info, data) = plsr_hdr::oiio::read_image_f32(path)?;
            let ch = info.channels;
            if !(ch == 1 || ch >= 3) {
                return Err(Error::input(
                    path,
                    "",
                    format!("{ch} channels: a linear image has 3 (RGB, RGBA) or 1 (grey)"),
                ));
            }
            let color = data
                .chunks_exact(ch)
                .map(|p| {
                    if ch == 1 {
                        glam::Vec3::splat(p[0])
                    } else {
                        glam::Vec3::new(p[0], p[1], p[2])
                    }
                })
                .collect();
            Ok(film_of(info.width as u32, info.height as u32, color))
        }
        _ => Err(Error::input(
            path,
            "",
            format!("not a linear image plsr reads: give {LINEAR_FORMATS}"),
        )),
    }
}

fn film_of(width: u32, height: u32, color: Vec<glam::Vec3>) -> Film {
    let mut film = Film::new(width, height);
    film.color = color;
    film.alpha.fill(1.0);
    film
}
