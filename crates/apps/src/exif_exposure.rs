//! `exposure = "exif"`: a photo's exposure `k` (photo ≈ k · render, linear)
//! from the exposure time, f-number and ISO in its EXIF, against the
//! settings of the merged panorama the render's units come from.
//!
//! `plsr hdr merge` divides each bracket by its relative exposure
//! `t · (N₀/N)² · (S/S₀)`, where `N₀` and `S₀` are the f-number and ISO of
//! the bracket of least exposure, and multiplies by `plsr:radiance_scale`
//! when it calibrates to absolute units. A photo from the same camera,
//! read through the same response, taken at `t`, `N` and `S`, therefore
//! records the render's radiance times
//!
//! `k = t · (N₀/N)² · (S/S₀) / (radiance_scale · environment scale)`.
//!
//! Where the photo or the panorama lacks the f-number (or the ISO), both
//! are taken as equal, as the merge does, and the result says so.

use crate::error::{Error, Result};
use plsr::scene::photo::ExifUnits;
use plsr_base::Vocabulary;
use plsr_hdr::oiio::{Exif, ImageReader};
use std::path::Path;

/// A photo's exposure worked out from its EXIF.
#[derive(Debug, Clone, PartialEq)]
pub struct ExifExposure {
    /// `k` with photo ≈ k · render.
    pub k: f32,
    /// How it was found, for the summary line (`1/60 s at f/4, ISO 200
    /// against f/8, ISO 100 of pano.exr`).
    pub description: String,
}

/// The reference settings a merged panorama's units are at.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PanoramaUnits {
    /// f-number of the reference bracket, if the brackets had one.
    f_number: Option<f64>,
    /// ISO of the reference bracket, if the brackets had one.
    iso: Option<f64>,
    /// Factor to absolute units (1: relative units).
    radiance_scale: f64,
}

/// Reads the units of a panorama `plsr hdr merge` wrote from its header.
fn panorama_units(path: &Path) -> Result<PanoramaUnits> {
    let reader = ImageReader::open(path)?;
    if reader.string_attribute("plsr:relative_exposures").is_none() {
        return Err(Error::input(
            path,
            "plsr:relative_exposures",
            "is missing: this image was not merged by `plsr hdr merge`, so the exposure its units \
             are at is unknown; give the photo's exposure as a number or \"auto\"",
        ));
    }
    // The reference bracket comes first (the merge sorts by exposure).
    let first = |name: &str| -> Result<Option<f64>> {
        let Some(text) = reader.string_attribute(name) else {
            return Ok(None);
        };
        match text.split_whitespace().next().map(str::parse::<f64>) {
            Some(Ok(v)) if v.is_finite() && v > 0.0 => Ok(Some(v)),
            _ => Err(Error::input(
                path,
                name,
                format!("`{text}` does not start with a positive number"),
            )),
        }
    };
    let radiance_scale = match reader.float_attribute("plsr:radiance_scale") {
        None => 1.0,
        Some(s) if s.is_finite() && s > 0.0 => s,
        Some(s) => {
            return Err(Error::input(
                path,
                "plsr:radiance_scale",
                format!("must be positive, got {s}"),
            ))
        }
    };
    Ok(PanoramaUnits {
        f_number: first("plsr:f_numbers")?,
        iso: first("plsr:iso")?,
        radiance_scale,
    })
}

/// The exposure of the photo `photo` (whose EXIF is `exif`) in the units
/// of `units`; see the module docs.
pub fn exif_exposure(photo: &Path, exif: &Exif, units: &ExifUnits) -> Result<ExifExposure> {
    let reference = panorama_units(&units.panorama)?;
    exposure_from(photo, exif, &reference, units)
}

fn exposure_from(
    photo: &Path,
    exif: &Exif,
    reference: &PanoramaUnits,
    units: &ExifUnits,
) -> Result<ExifExposure> {
    let t = exif.exposure_time.ok_or_else(|| {
        Error::input(
            photo,
            "ExposureTime",
            "is not in the photo's EXIF, which `exposure = \"exif\"` reads: give the exposure \
             as a number or \"auto\"",
        )
    })?;
    let mut k = t;
    let mut settings = vec![format!("{} s", seconds(t))];
    let mut against = Vec::new();
    let mut assumed = Vec::new();
    match (exif.f_number, reference.f_number) {
        (Some(n), Some(n0)) => {
            k *= (n0 / n).powi(2);
            settings.push(format!("f/{}", n as f32));
            against.push(format!("f/{}", n0 as f32));
        }
        _ => assumed.push("the f-number"),
    }
    match (exif.iso, reference.iso) {
        (Some(s), Some(s0)) => {
            k *= s / s0;
            settings.push(format!("ISO {}", s as f32));
            against.push(format!("ISO {}", s0 as f32));
        }
        _ => assumed.push("the ISO"),
    }
    k /= reference.radiance_scale * f64::from(units.scale);
    let k = k as f32;
    if !(k.is_finite() && k > 0.0) {
        return Err(Error::input(
            photo,
            "ExposureTime",
            format!("gives the exposure {k}, which is not a positive number"),
        ));
    }
    let name = units
        .panorama
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut description = format!("EXIF {}", settings.join(", "));
    if !against.is_empty() {
        description += &format!(" against {} of {name}", against.join(", "));
    } else {
        description += &format!(" in the units of {name}");
    }
    if !assumed.is_empty() {
        description += &format!(
            "; {} taken as the panorama's (not in both files)",
            assumed.join(" and ")
        );
    }
    Ok(ExifExposure { k, description })
}

/// An exposure time as a photographer writes it: `1/60` below a second.
fn seconds(t: f64) -> String {
    let inverse = 1.0 / t;
    if t < 1.0 && (inverse - inverse.round()).abs() < 1e-6 * inverse {
        format!("1/{}", inverse.round())
    } else {
        // EXIF stores single precision: print no more digits than it has.
        format!("{}", t as f32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn units(scale: f32) -> ExifUnits {
        ExifUnits {
            panorama: PathBuf::from("pano.exr"),
            scale,
        }
    }

    /// A photo at 1/8 s, f/4, ISO 200 against a panorama whose reference
    /// bracket was f/2, ISO 100: `k = 0.125 · (2/4)² · 2 = 0.0625`.
    #[test]
    fn the_factor_follows_time_aperture_and_iso() {
        let exif = Exif {
            exposure_time: Some(0.125),
            f_number: Some(4.0),
            iso: Some(200.0),
        };
        let reference = PanoramaUnits {
            f_number: Some(2.0),
            iso: Some(100.0),
            radiance_scale: 1.0,
        };
        let e = exposure_from(Path::new("p.jpg"), &exif, &reference, &units(1.0)).unwrap();
        assert_eq!(e.k, 0.0625);
        assert_eq!(
            e.description,
            "EXIF 1/8 s, f/4, ISO 200 against f/2, ISO 100 of pano.exr"
        );
        // Absolute units and a brighter environment divide it.
        let absolute = PanoramaUnits {
            radiance_scale: 5.0,
            ..reference
        };
        let e = exposure_from(Path::new("p.jpg"), &exif, &absolute, &units(2.0)).unwrap();
        assert_eq!(e.k, 0.00625);
    }

    #[test]
    fn missing_settings_are_taken_as_equal_and_said() {
        let exif = Exif {
            exposure_time: Some(0.5),
            f_number: None,
            iso: Some(400.0),
        };
        let reference = PanoramaUnits {
            f_number: Some(8.0),
            iso: None,
            radiance_scale: 1.0,
        };
        let e = exposure_from(Path::new("p.jpg"), &exif, &reference, &units(1.0)).unwrap();
        assert_eq!(e.k, 0.5);
        assert!(
            e.description.ends_with(
                "; the f-number and the ISO taken as the panorama's (not in both files)"
            ),
            "{}",
            e.description
        );
    }

    #[test]
    fn a_photo_without_an_exposure_time_is_refused() {
        let reference = PanoramaUnits {
            f_number: None,
            iso: None,
            radiance_scale: 1.0,
        };
        let e = exposure_from(
            Path::new("p.jpg"),
            &Exif::default(),
            &reference,
            &units(1.0),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("p.jpg") && e.contains("ExposureTime") && e.contains("\"auto\""),
            "{e}"
        );
    }
}
