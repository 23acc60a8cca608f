//! COLMAP's sparse models in text form: `cameras.txt` (one camera per
//! line: `CAMERA_ID MODEL WIDTH HEIGHT PARAMS…`) and `images.txt` (two lines
//! per image: `IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME`, then its 2-D
//! points, which plsr skips). The pose is world-to-camera
//! (`x_cam = R(q)·x_world + t`) with COLMAP's camera axes, OpenCV's (x
//! right, y down, z forward).
//!
//! Camera models read, with the plsr distortion each becomes:
//!
//! | COLMAP | parameters | plsr |
//! |---|---|---|
//! | `SIMPLE_PINHOLE` | f, cx, cy | none |
//! | `PINHOLE` | fx, fy, cx, cy | none |
//! | `SIMPLE_RADIAL` | f, cx, cy, k | Brown–Conrady `[k, 0, 0, 0]` |
//! | `RADIAL` | f, cx, cy, k1, k2 | Brown–Conrady `[k1, k2, 0, 0]` |
//! | `OPENCV` | fx, fy, cx, cy, k1, k2, p1, p2 | Brown–Conrady |
//! | `FULL_OPENCV` | fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6 | Brown–Conrady (rational) |
//! | `OPENCV_FISHEYE` | fx, fy, cx, cy, k1, k2, k3, k4 | fisheye |
//! | `SIMPLE_RADIAL_FISHEYE` | f, cx, cy, k | fisheye `[k, 0, 0, 0]` |
//! | `RADIAL_FISHEYE` | f, cx, cy, k1, k2 | fisheye `[k1, k2, 0, 0]` |
//!
//! COLMAP puts the centre of the top-left pixel at `(0.5, 0.5)`, OpenCV at
//! `(0, 0)`: the principal point read is COLMAP's minus 0.5, and
//! [`write_cameras`] adds it back.

use super::{
    matrix_quaternion, pose_from_world_to_camera, quaternion_matrix, world_to_camera, Calibration,
    CameraModel, PosedImage,
};
use crate::calibrated_camera::Intrinsics;
use crate::error::{Error, Result};
use crate::lens_distortion::LensDistortion;
use plsr_base::Vocabulary;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

/// Largest model file read, bytes (images.txt with every 2-D point of a
/// large reconstruction).
const MAX_FILE_BYTES: u64 = 4 << 30;
/// Most cameras or images a model may hold.
const MAX_ENTRIES: usize = 1 << 20;

/// Whether `path` names a file of a COLMAP text model.
pub fn is_model_file(path: &Path) -> bool {
    matches!(
        path.file_name().and_then(|n| n.to_str()),
        Some("cameras.txt" | "images.txt")
    )
}

/// Reads a COLMAP text model from its folder (or from its `cameras.txt` or
/// `images.txt`, the other beside it). `images.txt` may be absent: the
/// cameras then come without poses.
pub fn read_model(path: &Path) -> Result<Calibration> {
    let dir = if path.is_dir() {
        path.to_path_buf()
    } else {
        path.parent().map(Path::to_path_buf).unwrap_or_default()
    };
    let cameras_path = dir.join("cameras.txt");
    if !cameras_path.is_file() {
        let binary = dir.join("cameras.bin").is_file();
        return Err(Error::input(
            &cameras_path,
            "",
            if binary {
                "missing: this model is in COLMAP's binary form; convert it with \
                 `colmap model_converter --output_type TXT`"
            } else {
                "missing: a COLMAP text model has cameras.txt and images.txt"
            },
        ));
    }
    let cameras_text = super::read_text(&cameras_path, MAX_FILE_BYTES, "a COLMAP model file")?;
    let (ids, cameras) = parse_cameras(&cameras_text)
        .map_err(|(line, fault)| Error::input(&cameras_path, line_field(line), fault))?;
    let images_path = dir.join("images.txt");
    let images = if images_path.is_file() {
        let text = super::read_text(&images_path, MAX_FILE_BYTES, "a COLMAP model file")?;
        parse_images(&text, &ids)
            .map_err(|(line, fault)| Error::input(&images_path, line_field(line), fault))?
    } else {
        Vec::new()
    };
    Ok(Calibration {
        cameras,
        images,
        reprojection_error: None,
    })
}

fn line_field(line: usize) -> String {
    format!("line {line}")
}

/// A fault: the 1-based line and what is wrong there.
type Fault = (usize, String);

/// Parses `cameras.txt`: the cameras in file order, and each COLMAP camera
/// id's index among them.
pub fn parse_cameras(
    text: &str,
) -> std::result::Result<(HashMap<u64, usize>, Vec<CameraModel>), Fault> {
    let mut ids = HashMap::new();
    let mut cameras = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let n = i + 1;
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let tokens: Vec<&str> = line.split_whitespace().collect();
        if tokens.len() < 4 {
            return Err((n, "expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS…".into()));
        }
        let id: u64 = tokens[0].parse().map_err(|_| {
            (
                n,
                format!("camera id `{}` is not a whole number", tokens[0]),
            )
        })?;
        let size = |t: &str, what: &str| -> std::result::Result<u32, Fault> {
            match t.parse::<u32>() {
                Ok(v) if (1..=65536).contains(&v) => Ok(v),
                _ => Err((
                    n,
                    format!("{what} `{t}` is not a whole number of pixels from 1 to 65536"),
                )),
            }
        };
        let width = size(tokens[2], "width")?;
        let height = size(tokens[3], "height")?;
        let params = tokens[4..]
            .iter()
            .map(|t| match t.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err((n, format!("parameter `{t}` is not a finite number"))),
            })
            .collect::<std::result::Result<Vec<f64>, Fault>>()?;
        let camera = camera_of(tokens[1], width, height, &params).map_err(|f| (n, f))?;
        camera.check().map_err(|e| (n, e.to_string()))?;
        if cameras.len() >= MAX_ENTRIES {
            return Err((n, format!("more than {MAX_ENTRIES} cameras")));
        }
        if ids.insert(id, cameras.len()).is_some() {
            return Err((n, format!("camera id {id} given twice")));
        }
        cameras.push(camera);
    }
    Ok((ids, cameras))
}

/// The plsr camera of a COLMAP camera model and its parameters.
fn camera_of(
    model: &str,
    width: u32,
    height: u32,
    p: &[f64],
) -> std::result::Result<CameraModel, String> {
    let count = match model {
        "SIMPLE_PINHOLE" => 3,
        "PINHOLE" | "SIMPLE_RADIAL" => 4,
        "RADIAL" | "RADIAL_FISHEYE" => 5,
        "SIMPLE_RADIAL_FISHEYE" => 4,
        "OPENCV" | "OPENCV_FISHEYE" => 8,
        "FULL_OPENCV" => 12,
        "FOV"
        | "THIN_PRISM_FISHEYE"
        | "RAD_TAN_THIN_PRISM_FISHEYE"
        | "SIMPLE_DIVISION"
        | "DIVISION" => {
            return Err(format!(
                "camera model {model} is not supported (plsr reads SIMPLE_PINHOLE, PINHOLE, \
                 SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV, OPENCV_FISHEYE, \
                 SIMPLE_RADIAL_FISHEYE, RADIAL_FISHEYE): undistort the images with \
                 `colmap image_undistorter` and import the PINHOLE model it writes"
            ))
        }
        other => return Err(format!("unknown camera model `{other}`")),
    };
    if p.len() != count {
        return Err(format!("{model} takes {count} parameters, got {}", p.len()));
    }
    // Single-focal models: f, cx, cy, ...; the others fx, fy, cx, cy, ...
    let single = matches!(
        model,
        "SIMPLE_PINHOLE" | "SIMPLE_RADIAL" | "RADIAL" | "SIMPLE_RADIAL_FISHEYE" | "RADIAL_FISHEYE"
    );
    let (fx, fy, cx, cy, rest) = if single {
        (p[0], p[0], p[1], p[2], &p[3..])
    } else {
        (p[0], p[1], p[2], p[3], &p[4..])
    };
    let padded = |k: &[f64]| {
        let mut v = k.to_vec();
        v.resize(4, 0.0);
        v
    };
    let distortion = match model {
        "SIMPLE_PINHOLE" | "PINHOLE" => Ok(LensDistortion::None),
        "SIMPLE_RADIAL" | "RADIAL" => LensDistortion::brown_conrady(&padded(rest)),
        "OPENCV" | "FULL_OPENCV" => LensDistortion::brown_conrady(rest),
        _ => LensDistortion::fisheye(&padded(rest)),
    }
    .map_err(|e| e.to_string())?;
    Ok(CameraModel {
        width,
        height,
        intrinsics: Intrinsics {
            fx,
            fy,
            cx: cx - 0.5,
            cy: cy - 0.5,
            skew: 0.0,
        },
        distortion,
    })
}

/// Parses `images.txt`: each image's name, camera and pose.
pub fn parse_images(
    text: &str,
    cameras: &HashMap<u64, usize>,
) -> std::result::Result<Vec<PosedImage>, Fault> {
    let mut images = Vec::new();
    let mut lines = text.lines().enumerate();
    while let Some((i, line)) = lines.next() {
        let n = i + 1;
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        // IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME (the name may hold spaces).
        let tokens: Vec<&str> = line.splitn(10, char::is_whitespace).collect();
        if tokens.len() < 10 {
            return Err((
                n,
                "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME".into(),
            ));
        }
        let mut v = [0.0f64; 7];
        for (k, slot) in v.iter_mut().enumerate() {
            *slot = match tokens[1 + k].parse::<f64>() {
                Ok(x) if x.is_finite() => x,
                _ => return Err((n, format!("`{}` is not a finite number", tokens[1 + k]))),
            };
        }
        let q = [v[0], v[1], v[2], v[3]];
        let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm.is_nan() || norm <= 1e-6 {
            return Err((n, "the quaternion QW QX QY QZ is zero".into()));
        }
        let camera_id: u64 = tokens[8].parse().map_err(|_| {
            (
                n,
                format!("camera id `{}` is not a whole number", tokens[8]),
            )
        })?;
        let camera = *cameras
            .get(&camera_id)
            .ok_or_else(|| (n, format!("camera {camera_id} is not in cameras.txt")))?;
        let r = quaternion_matrix(q.map(|x| x / norm));
        let pose =
            pose_from_world_to_camera(r, [v[4], v[5], v[6]]).map_err(|e| (n, e.to_string()))?;
        if images.len() >= MAX_ENTRIES {
            return Err((n, format!("more than {MAX_ENTRIES} images")));
        }
        images.push(PosedImage {
            name: tokens[9].trim().to_string(),
            camera,
            pose,
        });
        // The next line lists the image's 2-D points (possibly none).
        lines.next();
    }
    Ok(images)
}

/// `cameras.txt` for `cameras` (ids from 1), each in the COLMAP model that
/// says it exactly: PINHOLE, OPENCV, FULL_OPENCV or OPENCV_FISHEYE. Skew
/// cannot be said in COLMAP: a camera with skew is refused (its index).
pub fn write_cameras(cameras: &[CameraModel]) -> std::result::Result<String, usize> {
    let mut out = String::from(
        "# Camera list with one line of data per camera:\n\
         #   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n",
    );
    let _ = writeln!(out, "# Number of cameras: {}", cameras.len());
    for (i, c) in cameras.iter().enumerate() {
        let k = c.intrinsics;
        if k.skew != 0.0 {
            return Err(i);
        }
        let coefficients = c.distortion.coefficients();
        let (model, extra) = match c.distortion {
            LensDistortion::None => ("PINHOLE", Vec::new()),
            LensDistortion::Fisheye { .. } => ("OPENCV_FISHEYE", coefficients),
            LensDistortion::BrownConrady { .. } if coefficients.len() <= 4 => {
                ("OPENCV", coefficients)
            }
            LensDistortion::BrownConrady { .. } if coefficients.len() <= 8 => {
                let mut c = coefficients;
                c.resize(8, 0.0);
                ("FULL_OPENCV", c)
            }
            LensDistortion::BrownConrady { .. } => return Err(i),
        };
        let _ = write!(
            out,
            "{} {model} {} {} {:?} {:?} {:?} {:?}",
            i + 1,
            c.width,
            c.height,
            k.fx,
            k.fy,
            k.cx + 0.5,
            k.cy + 0.5
        );
        for x in extra {
            let _ = write!(out, " {x:?}");
        }
        out.push('\n');
    }
    Ok(out)
}

/// `images.txt` for `images` (ids from 1, cameras from 1, no 2-D points).
pub fn write_images(images: &[PosedImage]) -> String {
    let mut out = String::from(
        "# Image list with two lines of data per image:\n\
         #   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n\
         #   POINTS2D[] as (X, Y, POINT3D_ID)\n",
    );
    let _ = writeln!(out, "# Number of images: {}", images.len());
    for (i, image) in images.iter().enumerate() {
        let (r, t) = world_to_camera(&image.pose);
        let q = matrix_quaternion(r);
        let _ = writeln!(
            out,
            "{} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {} {}\n",
            i + 1,
            q[0],
            q[1],
            q[2],
            q[3],
            t[0],
            t[1],
            t[2],
            image.camera + 1,
            image.name
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const CAMERAS: &str = "# Camera list\n\
        1 OPENCV 800 600 510.5 512.25 400.1 299.7 -0.2 0.05 0.001 -0.002\n\
        2 SIMPLE_RADIAL_FISHEYE 640 640 300 320 320 0.04\n";
    const IMAGES: &str = "# Image list\n\
        1 0.9 0.1 -0.3 0.2 0.5 -0.1 2.0 1 frame 0001.jpg\n\
        100.0 200.0 -1 5 6 7\n\
        2 1 0 0 0 0 0 0 2 b.jpg\n\
        \n";

    #[test]
    fn reads_cameras_and_images() {
        let (ids, cameras) = parse_cameras(CAMERAS).unwrap();
        assert_eq!(cameras.len(), 2);
        assert_eq!(cameras[0].intrinsics.cx, 400.1 - 0.5);
        assert_eq!(cameras[1].distortion.model_name(), "fisheye");
        let images = parse_images(IMAGES, &ids).unwrap();
        assert_eq!(images.len(), 2);
        assert_eq!(images[0].name, "frame 0001.jpg");
        assert_eq!(images[1].camera, 1);
        // The identity pose sits at the origin looking down +z, y down.
        assert!(images[1].pose.position.length() < 1e-7);
        assert!((images[1].pose.forward - glam::Vec3::Z).length() < 1e-7);
        assert!((images[1].pose.up + glam::Vec3::Y).length() < 1e-7);
    }

    #[test]
    fn writing_and_reading_again_gives_the_same_model() {
        let (ids, cameras) = parse_cameras(CAMERAS).unwrap();
        let images = parse_images(IMAGES, &ids).unwrap();
        let (ids2, cameras2) = parse_cameras(&write_cameras(&cameras).unwrap()).unwrap();
        assert_eq!(cameras2, cameras);
        let images2 = parse_images(&write_images(&images), &ids2).unwrap();
        for (a, b) in images.iter().zip(&images2) {
            assert_eq!((&a.name, a.camera), (&b.name, b.camera));
            assert!((a.pose.position - b.pose.position).length() < 1e-5);
            assert!((a.pose.forward - b.pose.forward).length() < 1e-6);
        }
    }

    #[test]
    fn faults_name_the_line() {
        let (n, text) = parse_cameras("# c\n1 FOV 10 10 1 5 5 0.1\n").unwrap_err();
        assert_eq!(n, 2);
        assert!(text.contains("image_undistorter"), "{text}");
        assert_eq!(parse_cameras("1 PINHOLE 10 10 1 1 5\n").unwrap_err().0, 1);
        assert_eq!(parse_cameras("1 PINHOLE 0 10 1 1 5 5\n").unwrap_err().0, 1);
        assert_eq!(
            parse_cameras("1 PINHOLE 10 10 -1 1 5 5\n").unwrap_err().0,
            1
        );
        let (ids, _) = parse_cameras(CAMERAS).unwrap();
        let (n, text) = parse_images("1 1 0 0 0 0 0 0 9 a.jpg\n\n", &ids).unwrap_err();
        assert_eq!(n, 1);
        assert!(text.contains("camera 9"), "{text}");
        assert!(parse_images("1 0 0 0 0 0 0 0 1 a.jpg\n", &ids).is_err());
    }
}
