//! OpenCV's calibration files: what `cv::FileStorage` writes after
//! `calibrateCamera` (YAML with its `%YAML:1.0` header and
//! `!!opencv-matrix` tags, or JSON with `"type_id": "opencv-matrix"`), and
//! ROS's `camera_info` YAML (what `camera_calibration` writes).
//!
//! Keys read (the first present of each row):
//!
//! | what | keys |
//! |---|---|
//! | camera matrix (3×3) | `camera_matrix`, `cameraMatrix`, `K` |
//! | distortion (4, 5, 8 or 12; fisheye 4) | `distortion_coefficients`, `dist_coeffs`, `distCoeffs`, `D` |
//! | image size | `image_width` + `image_height`, `image_size`/`imageSize` `[w, h]` |
//! | model | `fisheye_model: 1` (OpenCV's sample), `distortion_model: equidistant` (ROS) |
//! | per-view poses | `extrinsic_parameters` (one row `rvec, tvec` per view) |
//! | RMS reprojection error | `avg_reprojection_error`, `rms` |
//!
//! OpenCV writes numbers such as `0.`, which JSON forbids; both forms are
//! read by one YAML reader (YAML's flow style takes JSON).

use super::{pose_from_world_to_camera, rodrigues_matrix, Calibration, CameraModel, PosedImage};
use crate::calibrated_camera::Intrinsics;
use crate::error::{Error, Result};
use crate::lens_distortion::LensDistortion;
use plsr_base::Vocabulary;
use serde_yaml::{Mapping, Value};
use std::path::Path;

/// Largest calibration file read, bytes (a calibration is a few kB; image
/// points of many views can make it a few MB).
const MAX_FILE_BYTES: u64 = 64 << 20;

/// Reads an OpenCV or ROS calibration file; `fisheye` forces the fisheye
/// model when the file does not name its model.
pub fn read(path: &Path, fisheye: bool) -> Result<Calibration> {
    let text = super::read_text(path, MAX_FILE_BYTES, "a YAML or JSON calibration")?;
    parse(&text, fisheye).map_err(|(field, fault)| Error::input(path, field, fault))
}

/// A fault: the key and what is wrong with it.
type Fault = (String, String);

fn fault(field: &str, text: impl Into<String>) -> Fault {
    (field.to_string(), text.into())
}

/// Parses the text of an OpenCV or ROS calibration.
pub fn parse(text: &str, fisheye: bool) -> std::result::Result<Calibration, Fault> {
    // FileStorage's `%YAML:1.0` is YAML 1.0's directive, which YAML 1.2
    // readers refuse; it says nothing plsr needs.
    let body: String = text
        .lines()
        .skip_while(|l| l.starts_with('%'))
        .collect::<Vec<_>>()
        .join("\n");
    let root: Value =
        serde_yaml::from_str(&body).map_err(|e| fault("", format!("not YAML or JSON: {e}")))?;
    let Value::Mapping(map) = untag(&root) else {
        return Err(fault(
            "",
            "not a calibration: the file is not a mapping of keys",
        ));
    };
    let (key, k) = first_of(map, &["camera_matrix", "cameraMatrix", "K"]).ok_or_else(|| {
        fault(
            "camera_matrix",
            "missing: no camera matrix (camera_matrix, cameraMatrix or K)",
        )
    })?;
    let k = matrix(k, key)?;
    if k.len() != 9 {
        return Err(fault(key, format!("must be 3×3, got {} numbers", k.len())));
    }
    if k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0 {
        return Err(fault(
            key,
            "not a camera matrix: its rows must be [fx, s, cx], [0, fy, cy], [0, 0, 1]",
        ));
    }
    let intrinsics = Intrinsics {
        fx: k[0],
        fy: k[4],
        cx: k[2],
        cy: k[5],
        skew: k[1],
    };
    let (width, height) = image_size(map)?;
    let model = distortion_model(map, fisheye)?;
    let distortion = match first_of(
        map,
        &["distortion_coefficients", "dist_coeffs", "distCoeffs", "D"],
    ) {
        None => LensDistortion::None,
        Some((key, d)) => {
            let d = matrix(d, key)?;
            let all_zero = d.iter().all(|&x| x == 0.0);
            match model {
                _ if d.is_empty() => Ok(LensDistortion::None),
                Model::Fisheye => LensDistortion::fisheye(&d),
                // Checked first (the count), then zeros are no distortion.
                Model::BrownConrady => LensDistortion::brown_conrady(&d).map(|m| {
                    if all_zero {
                        LensDistortion::None
                    } else {
                        m
                    }
                }),
            }
            .map_err(|e| fault(key, e.to_string()))?
        }
    };
    let camera = CameraModel {
        width,
        height,
        intrinsics,
        distortion,
    };
    camera.check().map_err(|e| fault(key, e.to_string()))?;
    let images = extrinsics(map)?;
    let reprojection_error = first_of(map, &["avg_reprojection_error", "rms"])
        .and_then(|(_, v)| number(v))
        .filter(|e| e.is_finite() && *e >= 0.0);
    Ok(Calibration {
        cameras: vec![camera],
        images,
        reprojection_error,
    })
}

enum Model {
    BrownConrady,
    Fisheye,
}

/// The distortion model the file names (OpenCV's sample writes
/// `fisheye_model`, ROS `distortion_model`).
fn distortion_model(map: &Mapping, fisheye: bool) -> std::result::Result<Model, Fault> {
    if fisheye {
        return Ok(Model::Fisheye);
    }
    if let Some(v) = get(map, "fisheye_model") {
        return match number(v) {
            Some(0.0) => Ok(Model::BrownConrady),
            Some(1.0) => Ok(Model::Fisheye),
            _ => Err(fault("fisheye_model", "must be 0 or 1")),
        };
    }
    if let Some(v) = get(map, "distortion_model") {
        return match untag(v).as_str() {
            Some("plumb_bob" | "rational_polynomial" | "radtan") => Ok(Model::BrownConrady),
            Some("equidistant" | "fisheye" | "kannala_brandt") => Ok(Model::Fisheye),
            Some(other) => Err(fault(
                "distortion_model",
                format!(
                    "`{other}` is not a model plsr reads (plumb_bob, rational_polynomial, equidistant)"
                ),
            )),
            None => Err(fault("distortion_model", "must be a name")),
        };
    }
    Ok(Model::BrownConrady)
}

/// The image size: `image_width` and `image_height`, or `image_size`.
fn image_size(map: &Mapping) -> std::result::Result<(u32, u32), Fault> {
    let dim = |key: &str, v: &Value| -> std::result::Result<u32, Fault> {
        match number(v) {
            Some(x) if (1.0..=65536.0).contains(&x) && x.fract() == 0.0 => Ok(x as u32),
            _ => Err(fault(
                key,
                "must be a whole number of pixels from 1 to 65536",
            )),
        }
    };
    if let (Some(w), Some(h)) = (get(map, "image_width"), get(map, "image_height")) {
        return Ok((dim("image_width", w)?, dim("image_height", h)?));
    }
    if let Some((key, v)) = first_of(map, &["image_size", "imageSize"]) {
        let s = matrix(v, key)?;
        if s.len() != 2 {
            return Err(fault(key, "must be [width, height]"));
        }
        let n = |x: f64| Value::Number(serde_yaml::Number::from(x));
        return Ok((dim(key, &n(s[0]))?, dim(key, &n(s[1]))?));
    }
    Err(fault(
        "image_width",
        "missing: the image size the calibration is for (image_width and image_height, or image_size)",
    ))
}

/// The per-view poses of `extrinsic_parameters` (rows of `rvec, tvec`).
fn extrinsics(map: &Mapping) -> std::result::Result<Vec<PosedImage>, Fault> {
    let Some(v) = get(map, "extrinsic_parameters") else {
        return Ok(Vec::new());
    };
    let key = "extrinsic_parameters";
    let data = matrix(v, key)?;
    if data.len() % 6 != 0 {
        return Err(fault(key, "must have 6 numbers per view (rvec, tvec)"));
    }
    data.chunks(6)
        .enumerate()
        .map(|(i, row)| {
            let r = rodrigues_matrix([row[0], row[1], row[2]]);
            let pose = pose_from_world_to_camera(r, [row[3], row[4], row[5]])
                .map_err(|e| fault(&format!("{key}[{i}]"), e.to_string()))?;
            Ok(PosedImage {
                name: format!("view {i}"),
                camera: 0,
                pose,
            })
        })
        .collect()
}

/// The value under `key`, untagged.
fn get<'a>(map: &'a Mapping, key: &str) -> Option<&'a Value> {
    map.get(key).map(untag)
}

/// The first of `keys` present, with its name.
fn first_of<'a>(map: &'a Mapping, keys: &[&'static str]) -> Option<(&'static str, &'a Value)> {
    keys.iter().find_map(|k| get(map, k).map(|v| (*k, v)))
}

/// A value without its YAML tag (`!!opencv-matrix`).
fn untag(v: &Value) -> &Value {
    match v {
        Value::Tagged(t) => untag(&t.value),
        v => v,
    }
}

fn number(v: &Value) -> Option<f64> {
    match untag(v) {
        Value::Number(n) => n.as_f64(),
        _ => None,
    }
}

/// The numbers of a matrix: an OpenCV matrix (`rows`, `cols`, `data`), a
/// ROS one (`rows`, `cols`, `data`), or a plain (nested) list, row-major.
fn matrix(v: &Value, key: &str) -> std::result::Result<Vec<f64>, Fault> {
    let mut out = Vec::new();
    match untag(v) {
        Value::Mapping(m) => {
            let data = get(m, "data").ok_or_else(|| fault(key, "a matrix without `data`"))?;
            flatten(data, key, &mut out)?;
            let dim = |name: &str| get(m, name).and_then(number);
            if let (Some(rows), Some(cols)) = (dim("rows"), dim("cols")) {
                if rows * cols != out.len() as f64 {
                    return Err(fault(
                        key,
                        format!("says {rows}×{cols} but holds {} numbers", out.len()),
                    ));
                }
            }
        }
        other => flatten(other, key, &mut out)?,
    }
    if let Some(i) = out.iter().position(|x| !x.is_finite()) {
        return Err(fault(key, format!("element {i} is not a finite number")));
    }
    Ok(out)
}

fn flatten(v: &Value, key: &str, out: &mut Vec<f64>) -> std::result::Result<(), Fault> {
    const MAX_NUMBERS: usize = 1 << 20;
    match untag(v) {
        Value::Sequence(items) => {
            for item in items {
                flatten(item, key, out)?;
            }
            Ok(())
        }
        v => match number(v) {
            Some(x) if out.len() < MAX_NUMBERS => {
                out.push(x);
                Ok(())
            }
            Some(_) => Err(fault(key, format!("more than {MAX_NUMBERS} numbers"))),
            None => Err(fault(key, "must hold numbers only")),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const OPENCV_YAML: &str = "%YAML:1.0
---
image_width: 640
image_height: 480
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 5.2050000000000000e+02, 0., 3.2170000000000002e+02, 0.,
       5.1825000000000000e+02, 2.3840000000000001e+02, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 5
   cols: 1
   dt: d
   data: [ -2.8e-01, 9.0e-02, 1.2e-03, -8.0e-04, -1.2e-02 ]
avg_reprojection_error: 0.21
";

    #[test]
    fn reads_filestorage_yaml() {
        let c = parse(OPENCV_YAML, false).unwrap();
        let cam = &c.cameras[0];
        assert_eq!((cam.width, cam.height), (640, 480));
        assert_eq!(cam.intrinsics.fx, 520.5);
        assert_eq!(cam.intrinsics.cy, 238.4);
        assert_eq!(
            cam.distortion.coefficients(),
            vec![-0.28, 0.09, 0.0012, -0.0008, -0.012]
        );
        assert_eq!(c.reprojection_error, Some(0.21));
    }

    #[test]
    fn reads_filestorage_json_with_opencvs_numbers() {
        let json = r#"{
    "image_width": 640,
    "image_height": 480,
    "camera_matrix": {
        "type_id": "opencv-matrix",
        "rows": 3,
        "cols": 3,
        "dt": "d",
        "data": [ 5.2050000000000000e+02, 0., 3.2170000000000002e+02, 0.,
            5.1825000000000000e+02, 2.3840000000000001e+02, 0., 0., 1. ]
    },
    "distortion_coefficients": {
        "type_id": "opencv-matrix",
        "rows": 4,
        "cols": 1,
        "dt": "d",
        "data": [ 5.0e-02, -1.0e-02, 3.0e-03, -5.0e-04 ]
    },
    "fisheye_model": 1
}"#;
        let c = parse(json, false).unwrap();
        assert_eq!(c.cameras[0].distortion.model_name(), "fisheye");
        assert_eq!(c.cameras[0].intrinsics.fx, 520.5);
    }

    #[test]
    fn faults_name_the_key() {
        let no_size = OPENCV_YAML.replace("image_width: 640\n", "");
        assert_eq!(parse(&no_size, false).unwrap_err().0, "image_width");
        let bad = OPENCV_YAML.replace("rows: 5", "rows: 6");
        let (key, text) = parse(&bad, false).unwrap_err();
        assert_eq!(key, "distortion_coefficients");
        assert!(text.contains("6×1"), "{text}");
        let not_k = OPENCV_YAML.replace("0., 0., 1. ]", "0., 0., 2. ]");
        assert_eq!(parse(&not_k, false).unwrap_err().0, "camera_matrix");
        assert!(parse("[1, 2", false).is_err());
    }
}
