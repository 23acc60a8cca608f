//! `plsr import`: a Mitsuba 3 XML scene translated into plsr's scene
//! format (TOML), checked by building it, written or printed; or a camera
//! calibration (OpenCV, ROS, COLMAP) written as a scene's `[camera]`,
//! `[photo]` and `[[views]]`.

use crate::error::{Error, Result};
use plsr::atomic_write::{check_extension, same_file, write_atomically};
use plsr_base::Vocabulary;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Arguments of `plsr import`.
#[derive(Debug, clap::Args)]
pub struct ImportArgs {
    /// A Mitsuba 3 scene (XML), or a camera calibration: OpenCV's
    /// (`cv::FileStorage` YAML or JSON with camera_matrix and
    /// distortion_coefficients), ROS's camera_info YAML, or a COLMAP text
    /// model (its folder, cameras.txt or images.txt).
    #[arg(value_name = "SCENE.xml|CALIBRATION")]
    pub input: PathBuf,
    /// The plsr scene file to write (TOML); printed if not given. File
    /// names in it are rewritten to name the same files from its folder.
    #[arg(short, long, value_name = "OUT.toml")]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub params: crate::scene_params::SceneParams,
    #[command(flatten)]
    pub calibration: CalibrationImportArgs,
}

/// The options of `plsr import` for a camera calibration.
#[derive(Debug, Default, clap::Args)]
pub struct CalibrationImportArgs {
    /// Calibration: write the camera into this scene (its [camera] replaced;
    /// a calibration without poses keeps the scene's pose; [photo] and
    /// [[views]] replaced with --photos). Without it, the camera tables
    /// alone are written.
    #[arg(long, value_name = "SCENE.toml")]
    pub scene: Option<PathBuf>,
    /// Calibration: the photo (its name in the COLMAP model, or `view N` of
    /// OpenCV's extrinsics) whose camera becomes [camera]; default the first.
    #[arg(long, value_name = "NAME")]
    pub image: Option<String>,
    /// Calibration: the folder of the photos, as the scene should name it
    /// (relative to the scene's folder): writes [photo] for --image and a
    /// [[views]] entry for every other posed photo.
    #[arg(long, value_name = "DIR")]
    pub photos: Option<String>,
    /// Calibration: OpenCV's fisheye model (cv::fisheye) for a file that does
    /// not say which model its four coefficients are for.
    #[arg(long)]
    pub fisheye: bool,
}

/// Runs `plsr import`.
pub fn run(a: &ImportArgs) -> Result<()> {
    if is_calibration(&a.input) {
        return import_calibration(a);
    }
    let c = &a.calibration;
    if c.scene.is_some() || c.image.is_some() || c.photos.is_some() || c.fisheye {
        return Err(Error::invalid_argument(
            "--scene, --image, --photos and --fisheye are for camera calibrations \
             (.yaml, .yml, .json, a COLMAP model), not Mitsuba scenes",
        ));
    }
    plsr::input::check_input_file(&a.input)?;
    let bytes = std::fs::read(&a.input).map_err(|source| Error::io(a.input.clone(), source))?;
    if !plsr::scene::mitsuba::looks_like_xml(&a.input, &bytes) {
        return Err(Error::input(
            &a.input,
            "",
            "not XML: `plsr import` translates Mitsuba 3 scenes (.xml)",
        ));
    }
    let text = String::from_utf8(bytes).map_err(|_| {
        Error::input(
            &a.input,
            "",
            "not UTF-8 text (a Mitsuba 3 XML scene was expected)",
        )
    })?;
    // Building the scene checks everything the translation names (meshes,
    // textures, values) before anything is written.
    let contents = plsr::scene::file::load_contents_with(&a.input, &a.params.options())?;
    let translation = match &a.output {
        Some(out) => {
            check_extension(out, "toml", "a plsr scene (TOML)")
                .map_err(|m| Error::invalid_argument(format!("-o {}: {m}", out.display())))?;
            if same_file(out, &a.input) || contents.inputs.iter().any(|i| same_file(out, i)) {
                return Err(Error::invalid_argument(format!(
                    "-o {}: would replace the scene or a file it reads",
                    out.display()
                )));
            }
            let dir = match out.parent() {
                Some(d) if !d.as_os_str().is_empty() => d,
                _ => Path::new("."),
            };
            plsr::scene::mitsuba::translate_for(&a.input, &text, &a.params.options(), dir)?
        }
        None => plsr::scene::mitsuba::translate_with(&a.input, &text, &a.params.options())?,
    };
    for n in &translation.notes {
        crate::note!("note: {n}");
    }
    write_or_print(a.output.as_ref(), &translation.toml)
}

/// Whether `path` names a calibration rather than a Mitsuba scene.
fn is_calibration(path: &Path) -> bool {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    path.is_dir()
        || plsr::calibration::colmap::is_model_file(path)
        || matches!(ext.as_str(), "yaml" | "yml" | "json")
}

/// `plsr import CALIBRATION`: the calibration as scene tables, checked by
/// loading the scene they make when it is complete.
fn import_calibration(a: &ImportArgs) -> Result<()> {
    let c = &a.calibration;
    let params = a.params.options();
    if !params.defines.is_empty() || params.time.is_some() {
        return Err(Error::invalid_argument(
            "-D and --anim-time are for Mitsuba scenes and glTF, not camera calibrations",
        ));
    }
    if let Some(out) = &a.output {
        check_extension(out, "toml", "a plsr scene (TOML)")
            .map_err(|m| Error::invalid_argument(format!("-o {}: {m}", out.display())))?;
    }
    let calibration = plsr::calibration::read(&a.input, c.fisheye)?;
    let base = match &c.scene {
        Some(scene) => {
            plsr::input::check_input_file(scene)?;
            let text = std::fs::read_to_string(scene)
                .map_err(|source| Error::io(scene.clone(), source))?;
            Some(text)
        }
        None => None,
    };
    let options = plsr::calibration::scene_toml::SceneTomlOptions {
        image: c.image.clone(),
        photos: c.photos.clone(),
        views: c.photos.is_some(),
    };
    let toml = plsr::calibration::scene_toml::scene_toml(base.as_deref(), &calibration, &options)
        .map_err(|m| match &c.scene {
        Some(scene) if m.starts_with("the scene") => Error::input(scene, "", m),
        _ => Error::invalid_argument(m),
    })?;
    if let Some(scene) = &c.scene {
        // The scene names its files from its folder: so must the output.
        if let Some(out) = &a.output {
            let folder = |p: &Path| {
                let d = p.parent().unwrap_or(Path::new(""));
                let d = if d.as_os_str().is_empty() {
                    Path::new(".")
                } else {
                    d
                };
                std::fs::canonicalize(d).ok()
            };
            if folder(out) != folder(scene) {
                return Err(Error::invalid_argument(format!(
                    "-o {}: write it beside {} (the scene names its files from its own folder)",
                    out.display(),
                    scene.display()
                )));
            }
        }
        let contents = plsr::scene::file::load_contents_from_text(scene, &toml)?;
        if let Some(out) = &a.output {
            if let Some(input) = contents.inputs.iter().find(|i| same_file(out, i)) {
                return Err(Error::invalid_argument(format!(
                    "-o {}: would replace {}, which the scene reads",
                    out.display(),
                    input.display()
                )));
            }
        }
    }
    let cameras = calibration.cameras.len();
    let images = calibration.images.len();
    let mut summary = format!(
        "{cameras} camera{} ({}), {images} posed photo{}",
        if cameras == 1 { "" } else { "s" },
        calibration
            .cameras
            .iter()
            .map(|m| m.distortion.model_name())
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect::<Vec<_>>()
            .join(", "),
        if images == 1 { "" } else { "s" },
    );
    if let Some(e) = calibration.reprojection_error {
        summary.push_str(&format!(", reprojection error {e:.3} px"));
    }
    crate::note!("calibration: {summary}");
    if let Some(out) = &a.output {
        if same_file(out, &a.input) || c.scene.as_ref().is_some_and(|s| same_file(out, s)) {
            return Err(Error::invalid_argument(format!(
                "-o {}: would replace the calibration or the scene it reads",
                out.display()
            )));
        }
    }
    write_or_print(a.output.as_ref(), &toml)
}

/// Writes `text` to `out` (all at once), or prints it when no output is
/// given.
fn write_or_print(out: Option<&PathBuf>, text: &str) -> Result<()> {
    match out {
        Some(out) => {
            write_atomically(out, |w| {
                w.write_all(text.as_bytes())
                    .map_err(|source| Error::io(out.clone(), source))
            })?;
            crate::note!("wrote {}", out.display());
        }
        None => print!("{text}"),
    }
    Ok(())
}
