//! A calibration written as scene-file tables: `[camera]` of type
//! `calibrated` with the chosen photo's pose, `[photo]` naming that photo,
//! and `[[views]]` for the calibration's other posed photos; either a new
//! scene file or an existing one whose camera, photo and views are
//! replaced (everything else is kept as written).

use super::{Calibration, CameraModel, PosedImage};
use crate::camera::Pose;
use std::path::Path;
use toml_edit::{value, Array, DocumentMut, Item, Table};

/// What to write of a calibration.
#[derive(Debug, Clone, Default)]
pub struct SceneTomlOptions {
    /// The photo whose camera becomes `[camera]` (by its name in the
    /// calibration); the first posed photo if `None`.
    pub image: Option<String>,
    /// The folder of the photos, as the scene file should name it (relative
    /// to the scene file's folder); `None`: no `[photo]` or `[[views]]`.
    pub photos: Option<String>,
    /// Write the other posed photos as `[[views]]` (needs `photos`).
    pub views: bool,
}

/// The keys a `[camera]` table may hold that say its pose.
const POSE_KEYS: [&str; 4] = ["position", "look_at", "up", "to_world"];
/// The keys of `[photo]` that the calibration does not decide.
const PHOTO_KEYS_KEPT: [&str; 2] = ["response", "exposure"];

/// The scene file text: `base` (an existing scene's text, or `None` for a
/// new one) with the calibration's camera, photo and views. Returns the
/// text, or why it cannot be made.
pub fn scene_toml(
    base: Option<&str>,
    calibration: &Calibration,
    options: &SceneTomlOptions,
) -> Result<String, String> {
    let mut doc: DocumentMut = match base {
        Some(text) => text
            .parse()
            .map_err(|e| format!("the scene is not valid TOML: {e}"))?,
        None => DocumentMut::new(),
    };
    let chosen: Option<&PosedImage> = match &options.image {
        Some(name) => Some(
            calibration
                .images
                .iter()
                .find(|i| &i.name == name)
                .ok_or_else(|| {
                    let names: Vec<&str> = calibration
                        .images
                        .iter()
                        .take(8)
                        .map(|i| i.name.as_str())
                        .collect();
                    format!(
                        "the calibration has no photo named `{name}` ({} posed photos{}{})",
                        calibration.images.len(),
                        if names.is_empty() { "" } else { ": " },
                        names.join(", ")
                    )
                })?,
        ),
        None => calibration.images.first(),
    };
    let model = match chosen {
        Some(image) => &calibration.cameras[image.camera],
        None if calibration.cameras.len() == 1 => &calibration.cameras[0],
        None => {
            return Err(format!(
                "the model has {} cameras and no posed photo: name the photo (--image)",
                calibration.cameras.len()
            ))
        }
    };
    // The camera: the base's pose is kept when the calibration has none,
    // and so are the comments above the base's table.
    let old = doc.get("camera").and_then(Item::as_table).cloned();
    let mut camera = camera_table(model, chosen.map(|i| &i.pose));
    let mut posed = chosen.is_some();
    if let Some(old) = &old {
        if !posed && POSE_KEYS.iter().any(|k| old.contains_key(k)) {
            for k in POSE_KEYS {
                if let Some(item) = old.get(k) {
                    camera.insert(k, item.clone());
                }
            }
            posed = true;
        }
        if let Some(path) = old.get("path") {
            camera.insert("path", path.clone());
        }
        *camera.decor_mut() = old.decor().clone();
    }
    if !posed {
        let prefix = camera
            .decor()
            .prefix()
            .and_then(|p| p.as_str())
            .unwrap_or("")
            .to_string();
        camera.decor_mut().set_prefix(format!(
            "{prefix}# The calibration gives no pose: add position, look_at and up, or to_world.\n"
        ));
    }
    doc.insert("camera", Item::Table(camera));
    let Some(photos) = &options.photos else {
        return Ok(doc.to_string());
    };
    if let Some(image) = chosen {
        let old = doc.get("photo").and_then(Item::as_table).cloned();
        doc.insert(
            "photo",
            Item::Table(photo_table(photos, &image.name, old.as_ref())),
        );
    }
    if options.views {
        let mut views = toml_edit::ArrayOfTables::new();
        for image in calibration.images.iter() {
            if chosen.is_some_and(|c| std::ptr::eq(c, image)) {
                continue;
            }
            let mut view = Table::new();
            view.insert(
                "camera",
                Item::Table(camera_table(
                    &calibration.cameras[image.camera],
                    Some(&image.pose),
                )),
            );
            view.insert("photo", Item::Table(photo_table(photos, &image.name, None)));
            views.push(view);
        }
        doc.remove("views");
        if !views.is_empty() {
            doc.insert("views", Item::ArrayOfTables(views));
        }
    }
    Ok(doc.to_string())
}

/// A `[camera]` table of type `calibrated`.
pub fn camera_table(model: &CameraModel, pose: Option<&Pose>) -> Table {
    let mut t = Table::new();
    t.insert("type", value("calibrated"));
    t.insert(
        "resolution",
        value(Array::from_iter([model.width as i64, model.height as i64])),
    );
    if let Some(pose) = pose {
        let mut rows = Array::new();
        for row in pose.to_matrix() {
            rows.push(Array::from_iter(row.iter().map(|&x| x as f64)));
        }
        t.insert("to_world", value(rows));
    }
    let k = model.intrinsics;
    t.insert("fx", value(k.fx));
    t.insert("fy", value(k.fy));
    t.insert("cx", value(k.cx));
    t.insert("cy", value(k.cy));
    if k.skew != 0.0 {
        t.insert("skew", value(k.skew));
    }
    t.insert("distortion", value(model.distortion.model_name()));
    let c = model.distortion.coefficients();
    if !c.is_empty() {
        t.insert("coefficients", value(Array::from_iter(c)));
    }
    t
}

/// A `[photo]` table naming `name` in the folder `photos`, keeping the
/// response and exposure of `old`.
fn photo_table(photos: &str, name: &str, old: Option<&Table>) -> Table {
    let mut t = Table::new();
    let file = Path::new(photos).join(name);
    t.insert("file", value(file.to_string_lossy().replace('\\', "/")));
    if let Some(old) = old {
        for k in PHOTO_KEYS_KEPT {
            if let Some(item) = old.get(k) {
                t.insert(k, item.clone());
            }
        }
    }
    t
}
