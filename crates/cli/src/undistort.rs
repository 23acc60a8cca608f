//! `plsr undistort`: a photo resampled into the ideal pinhole image of its
//! calibrated camera (see docs/calibration.md), for workflows that want
//! straight lines rather than renders through the lens.

use crate::error::{Error, Result};
use plsr::atomic_write::same_file;
use plsr::calibration::{undistort, CameraModel};
use plsr::camera::Camera;
use plsr_base::Vocabulary;
use plsr_hdr::oiio::{self, PixelType};
use std::path::{Path, PathBuf};

/// Arguments of `plsr undistort`.
#[derive(Debug, clap::Args)]
pub struct UndistortArgs {
    /// The photo (any image format plsr reads: JPEG, PNG, TIFF, OpenEXR, …).
    #[arg(value_name = "PHOTO")]
    pub input: PathBuf,
    /// The undistorted image; its extension picks the format (8- or 16-bit
    /// for PNG and TIFF as the photo is, float for OpenEXR).
    #[arg(short, long, value_name = "OUT")]
    pub output: PathBuf,
    /// The camera's calibration: OpenCV or ROS (.yaml, .yml, .json), a
    /// COLMAP text model (folder, cameras.txt or images.txt), or a plsr
    /// scene whose [camera] is `calibrated`.
    #[arg(short, long, value_name = "CALIBRATION")]
    pub calibration: PathBuf,
    /// The photo's name in a COLMAP model with several cameras (default: the
    /// photo's own file name).
    #[arg(long, value_name = "NAME")]
    pub image: Option<String>,
    /// OpenCV's fisheye model for a calibration that does not say which
    /// model its four coefficients are for.
    #[arg(long)]
    pub fisheye: bool,
}

/// Runs `plsr undistort`.
pub fn run(a: &UndistortArgs) -> Result<()> {
    plsr::input::check_input_file(&a.input)?;
    if same_file(&a.output, &a.input) || same_file(&a.output, &a.calibration) {
        return Err(Error::invalid_argument(format!(
            "-o {}: would replace the photo or the calibration",
            a.output.display()
        )));
    }
    let model = camera_model(a)?;
    let (info, pixels) = oiio::read_image_f32(&a.input)?;
    let model = fit_to_photo(&model, &a.input, (info.width as u32, info.height as u32))?;
    let out = undistort::undistort(&model, &pixels, info.channels);
    let ext = a
        .output
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let stored = match ext.as_str() {
        "exr" | "hdr" => PixelType::F32,
        "png" | "tif" | "tiff" if info.format == PixelType::U16 => PixelType::U16,
        "tif" | "tiff" if info.format == PixelType::F32 => PixelType::F32,
        _ => PixelType::U8,
    };
    oiio::write_image(
        &a.output,
        info.width,
        info.height,
        info.channels,
        stored,
        &[],
        &out,
    )?;
    crate::note!(
        "undistorted {} ({}×{}, {} lens) into {}: render it with the same [camera] and \
         distortion = \"none\"",
        a.input.display(),
        info.width,
        info.height,
        model.distortion.model_name(),
        a.output.display()
    );
    Ok(())
}

/// The camera of `--calibration` (and `--image`).
fn camera_model(a: &UndistortArgs) -> Result<CameraModel> {
    let path = &a.calibration;
    let is_scene = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml") || e.eq_ignore_ascii_case("xml"));
    if is_scene {
        let contents = plsr::scene::file::load_contents(path)?;
        return match contents.description.camera {
            Camera::Calibrated(c) => Ok(CameraModel {
                width: c.width,
                height: c.height,
                intrinsics: c.intrinsics,
                distortion: c.distortion,
            }),
            other => Err(Error::input(
                path,
                "camera.type",
                format!(
                    "`{}`: undistorting needs a `calibrated` camera (plsr import CALIBRATION)",
                    other.type_name()
                ),
            )),
        };
    }
    let calibration = plsr::calibration::read(path, a.fisheye)?;
    if calibration.cameras.len() == 1 {
        return Ok(calibration.cameras[0].clone());
    }
    let name = match &a.image {
        Some(n) => n.clone(),
        None => a
            .input
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
    };
    let image = calibration
        .images
        .iter()
        .find(|i| i.name == name || Path::new(&i.name).file_name() == Some(name.as_ref()))
        .ok_or_else(|| {
            Error::invalid_argument(format!(
                "{}: {} cameras and no photo named `{name}`: name the photo as the model does (--image)",
                path.display(),
                calibration.cameras.len()
            ))
        })?;
    Ok(calibration.cameras[image.camera].clone())
}

/// The camera for a photo of `size`: the calibration's, rescaled when the
/// photo was resized (same aspect ratio, to within a pixel).
fn fit_to_photo(model: &CameraModel, photo: &Path, size: (u32, u32)) -> Result<CameraModel> {
    let from = (model.width, model.height);
    if from == size {
        return Ok(model.clone());
    }
    let scaled_height = from.1 as f64 * size.0 as f64 / from.0 as f64;
    if (scaled_height - size.1 as f64).abs() > 1.0 {
        return Err(Error::input(
            photo,
            "",
            format!(
                "{}×{} pixels, but the calibration is for {}×{}: not the same camera or a crop \
                 (a resized photo keeps the aspect ratio)",
                size.0, size.1, from.0, from.1
            ),
        ));
    }
    Ok(CameraModel {
        width: size.0,
        height: size.1,
        intrinsics: model.intrinsics.rescaled(from, size),
        distortion: model.distortion,
    })
}
