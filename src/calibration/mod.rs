//! Camera calibrations made by other tools, read into plsr's calibrated
//! camera ([`crate::calibrated_camera`]): OpenCV's calibration files
//! ([`opencv`]: FileStorage YAML or JSON, and ROS's `camera_info` YAML) and
//! COLMAP's sparse models in text form ([`colmap`]); [`scene_toml`] writes
//! what was read as a scene file's `[camera]` (and `[[views]]`), and
//! [`undistort`] resamples a photo into the ideal pinhole image of its
//! camera.

pub mod colmap;
pub mod opencv;
pub mod scene_toml;
pub mod undistort;

use crate::calibrated_camera::{CalibratedCamera, Intrinsics};
use crate::camera::Pose;
use crate::error::Result;
use crate::lens_distortion::LensDistortion;
use plsr_base::Vocabulary;
use std::path::Path;

/// One camera's intrinsics and lens, and the image size they were
/// calibrated at.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraModel {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal lengths, principal point (OpenCV's pixel convention), skew.
    pub intrinsics: Intrinsics,
    /// The lens's distortion.
    pub distortion: LensDistortion,
}

impl CameraModel {
    /// Checks the intrinsics (positive focal lengths, finite principal
    /// point and skew) and the size.
    pub fn check(&self) -> std::result::Result<(), crate::camera::CameraError> {
        let pose = Pose::look_at(glam::Vec3::ZERO, glam::Vec3::Z, glam::Vec3::Y)?;
        self.at(pose).map(|_| ())
    }

    /// This camera at `pose`.
    pub fn at(
        &self,
        pose: Pose,
    ) -> std::result::Result<CalibratedCamera, crate::camera::CameraError> {
        CalibratedCamera::new(
            pose,
            self.width,
            self.height,
            self.intrinsics,
            self.distortion,
        )
    }
}

/// A photo's pose as a calibration gives it, and the photo's name there.
#[derive(Debug, Clone, PartialEq)]
pub struct PosedImage {
    /// The photo's name (COLMAP's image name, or `view N` for OpenCV's
    /// per-view extrinsics).
    pub name: String,
    /// Which of the calibration's cameras took it.
    pub camera: usize,
    /// Where the camera was (world-to-camera inverted).
    pub pose: Pose,
}

/// What a calibration file or model holds.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// The cameras (one for an OpenCV file; any number for COLMAP).
    pub cameras: Vec<CameraModel>,
    /// The posed photos, in the file's order (none when it gives no pose).
    pub images: Vec<PosedImage>,
    /// The calibration's own RMS reprojection error, pixels, if it states it.
    pub reprojection_error: Option<f64>,
}

/// Reads a calibration: an OpenCV or ROS file (`.yaml`, `.yml`, `.json`), or
/// a COLMAP text model (its folder, or its `cameras.txt` or `images.txt`).
/// `fisheye` forces OpenCV's fisheye model for a file that does not say
/// which model its coefficients are for.
pub fn read(path: &Path, fisheye: bool) -> Result<Calibration> {
    if !path.exists() {
        crate::input::check_input_file(path)?;
    }
    if path.is_dir() || colmap::is_model_file(path) {
        return colmap::read_model(path);
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("xml") => Err(crate::error::Error::input(
            path,
            "",
            "OpenCV's XML FileStorage is not read: save the calibration as YAML or JSON \
                 (cv::FileStorage with a .yaml or .json name)",
        )),
        Some("yaml" | "yml" | "json") => opencv::read(path, fisheye),
        _ => Err(crate::error::Error::input(
            path,
            "",
            "not a calibration plsr reads: an OpenCV or ROS calibration (.yaml, .yml, .json) \
             or a COLMAP text model (its folder, cameras.txt or images.txt)",
        )),
    }
}

/// The text of a calibration file of at most `max_bytes` (checked before
/// it is read), refused naming the file when larger or not UTF-8; `what`
/// says what the file should be.
fn read_text(path: &Path, max_bytes: u64, what: &str) -> Result<String> {
    use crate::error::Error;
    crate::input::check_input_file(path)?;
    let size = std::fs::metadata(path)
        .map_err(|source| Error::io(path.to_path_buf(), source))?
        .len();
    if size > max_bytes {
        return Err(Error::input(
            path,
            "",
            format!("{size} bytes: larger than {what} can be ({max_bytes} bytes at most)"),
        ));
    }
    let bytes = std::fs::read(path).map_err(|source| Error::io(path.to_path_buf(), source))?;
    String::from_utf8(bytes).map_err(|_| Error::input(path, "", format!("not UTF-8 text ({what})")))
}

/// The rotation matrix (rows) of a unit quaternion `(w, x, y, z)`.
pub fn quaternion_matrix(q: [f64; 4]) -> [[f64; 3]; 3] {
    let [w, x, y, z] = q;
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

/// The rotation matrix (rows) of a Rodrigues vector (axis × angle, radians).
pub fn rodrigues_matrix(r: [f64; 3]) -> [[f64; 3]; 3] {
    let angle = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
    if angle < 1e-300 {
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    }
    let half = 0.5 * angle;
    let s = half.sin() / angle;
    quaternion_matrix([half.cos(), r[0] * s, r[1] * s, r[2] * s])
}

/// The camera pose of a world-to-camera transform `x_cam = R·x_world + t`
/// (OpenCV's and COLMAP's extrinsics): the camera sits at `−Rᵀt` and its
/// axes (right, down, forward) are the rows of `R`.
pub fn pose_from_world_to_camera(
    r: [[f64; 3]; 3],
    t: [f64; 3],
) -> std::result::Result<Pose, crate::camera::CameraError> {
    let mut centre = [0.0f64; 3];
    for (i, c) in centre.iter_mut().enumerate() {
        *c = -(r[0][i] * t[0] + r[1][i] * t[1] + r[2][i] * t[2]);
    }
    let mut rows = [[0.0f32; 4]; 4];
    for i in 0..3 {
        for j in 0..3 {
            rows[i][j] = r[j][i] as f32;
        }
        rows[i][3] = centre[i] as f32;
    }
    rows[3] = [0.0, 0.0, 0.0, 1.0];
    Pose::from_matrix(rows)
}

/// The world-to-camera `(R, t)` of a pose: the inverse of
/// [`pose_from_world_to_camera`].
pub fn world_to_camera(pose: &Pose) -> ([[f64; 3]; 3], [f64; 3]) {
    let axes = [pose.right, -pose.up, pose.forward].map(|a| a.as_dvec3());
    let c = pose.position.as_dvec3();
    let r = axes.map(|a| a.to_array());
    let t = axes.map(|a| -a.dot(c));
    (r, t)
}

/// The unit quaternion `(w, x, y, z)` of a rotation matrix (rows), with
/// `w ≥ 0` (Shepperd's method).
pub fn matrix_quaternion(m: [[f64; 3]; 3]) -> [f64; 4] {
    let trace = m[0][0] + m[1][1] + m[2][2];
    let q = if trace > 0.0 {
        let s = (trace + 1.0).sqrt() * 2.0;
        [
            0.25 * s,
            (m[2][1] - m[1][2]) / s,
            (m[0][2] - m[2][0]) / s,
            (m[1][0] - m[0][1]) / s,
        ]
    } else if m[0][0] > m[1][1] && m[0][0] > m[2][2] {
        let s = (1.0 + m[0][0] - m[1][1] - m[2][2]).sqrt() * 2.0;
        [
            (m[2][1] - m[1][2]) / s,
            0.25 * s,
            (m[0][1] + m[1][0]) / s,
            (m[0][2] + m[2][0]) / s,
        ]
    } else if m[1][1] > m[2][2] {
        let s = (1.0 + m[1][1] - m[0][0] - m[2][2]).sqrt() * 2.0;
        [
            (m[0][2] - m[2][0]) / s,
            (m[0][1] + m[1][0]) / s,
            0.25 * s,
            (m[1][2] + m[2][1]) / s,
        ]
    } else {
        let s = (1.0 + m[2][2] - m[0][0] - m[1][1]).sqrt() * 2.0;
        [
            (m[1][0] - m[0][1]) / s,
            (m[0][2] + m[2][0]) / s,
            (m[1][2] + m[2][1]) / s,
            0.25 * s,
        ]
    };
    let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    let sign = if q[0] < 0.0 { -1.0 } else { 1.0 };
    q.map(|x| sign * x / n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn quaternions_and_poses_round_trip() {
        let pose =
            Pose::look_at(Vec3::new(1.0, -2.0, 0.5), Vec3::new(0.2, 0.3, 0.9), Vec3::Z).unwrap();
        let (r, t) = world_to_camera(&pose);
        let q = matrix_quaternion(r);
        let back = pose_from_world_to_camera(quaternion_matrix(q), t).unwrap();
        assert!((back.position - pose.position).length() < 1e-5);
        assert!((back.forward - pose.forward).length() < 1e-6);
        assert!((back.up - pose.up).length() < 1e-6);
        // A Rodrigues vector of π/2 about z turns x into y.
        let m = rodrigues_matrix([0.0, 0.0, std::f64::consts::FRAC_PI_2]);
        assert!((m[1][0] - 1.0).abs() < 1e-12 && m[0][0].abs() < 1e-12);
    }
}
