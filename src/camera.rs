//! Cameras: how a film position becomes a primary ray.
//!
//! Image coordinates: pixel `(x, y)` covers `[x, x+1) × [y, y+1)` with `x` to
//! the right and `y` downwards; a film position is a continuous pixel
//! coordinate. The camera looks along `forward`, with `right = forward × up`
//! (right-handed world) and the image's up along the projected `up` vector.
//!
//! ```toml
//! [camera]
//! type = "pinhole"
//! position = [278, 273, -800]
//! look_at = [278, 273, 0]
//! up = [0, 1, 0]
//! vfov = 37            # vertical field of view in degrees, or:
//! # focal_length = 50  # mm, together with sensor_height (mm, default 24)
//! resolution = [512, 512]
//! ```

use crate::accel::Ray;
use glam::{Vec2, Vec3};

/// A pinhole (perspective) camera.
#[derive(Debug, Clone, PartialEq)]
pub struct PinholeCamera {
    /// Centre of projection (scene units).
    pub position: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Unit image-right direction.
    pub right: Vec3,
    /// Unit image-up direction.
    pub up: Vec3,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// `tan(vfov / 2)`: half the image height at unit distance.
    tan_half_vfov: f32,
}

/// Why a camera cannot be built.
#[derive(Debug, Clone, PartialEq)]
pub enum CameraError {
    /// `position` and `look_at` coincide.
    NoViewDirection,
    /// `up` is zero or parallel to the viewing direction.
    UpParallelToView,
    /// The field of view is outside (0°, 180°).
    BadFov(f32),
    /// A zero resolution.
    EmptyImage,
}

impl std::fmt::Display for CameraError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CameraError::NoViewDirection => write!(f, "position and look_at coincide"),
            CameraError::UpParallelToView => {
                write!(f, "up is zero or parallel to the viewing direction")
            }
            CameraError::BadFov(v) => write!(f, "field of view {v}° is outside (0°, 180°)"),
            CameraError::EmptyImage => write!(f, "resolution must be at least 1×1"),
        }
    }
}

impl PinholeCamera {
    /// A camera at `position` looking at `look_at`, with vertical field of view
    /// `vfov_deg` (degrees) and an image of `width × height` pixels.
    pub fn look_at(
        position: Vec3,
        look_at: Vec3,
        up: Vec3,
        vfov_deg: f32,
        width: u32,
        height: u32,
    ) -> Result<PinholeCamera, CameraError> {
        let forward = (look_at - position).try_normalize();
        let forward = forward.ok_or(CameraError::NoViewDirection)?;
        let right = forward
            .cross(up)
            .try_normalize()
            .filter(|r| r.is_finite())
            .ok_or(CameraError::UpParallelToView)?;
        if !(vfov_deg > 0.0 && vfov_deg < 180.0) {
            return Err(CameraError::BadFov(vfov_deg));
        }
        if width == 0 || height == 0 {
            return Err(CameraError::EmptyImage);
        }
        Ok(PinholeCamera {
            position,
            forward,
            right,
            up: right.cross(forward),
            width,
            height,
            tan_half_vfov: (vfov_deg.to_radians() * 0.5).tan(),
        })
    }

    /// Vertical field of view in degrees from a focal length and sensor
    /// height, both in millimetres.
    pub fn vfov_from_focal_length(focal_length_mm: f32, sensor_height_mm: f32) -> f32 {
        2.0 * (0.5 * sensor_height_mm / focal_length_mm)
            .atan()
            .to_degrees()
    }

    /// Vertical field of view in degrees.
    pub fn vfov_deg(&self) -> f32 {
        2.0 * self.tan_half_vfov.atan().to_degrees()
    }

    /// The primary ray through film position `film` (continuous pixel
    /// coordinates). Its direction is normalised, so `t` is distance.
    #[inline]
    pub fn generate_ray(&self, film: Vec2) -> Ray {
        let aspect = self.width as f32 / self.height as f32;
        let sx = (2.0 * film.x / self.width as f32 - 1.0) * self.tan_half_vfov * aspect;
        let sy = (1.0 - 2.0 * film.y / self.height as f32) * self.tan_half_vfov;
        let dir = (self.forward + sx * self.right + sy * self.up).normalize();
        Ray::new(self.position, dir)
    }

    /// Film position (continuous pixel coordinates) where world point `p`
    /// projects, or `None` if it is behind the camera.
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        let d = p - self.position;
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let aspect = self.width as f32 / self.height as f32;
        let sx = d.dot(self.right) / z / (self.tan_half_vfov * aspect);
        let sy = d.dot(self.up) / z / self.tan_half_vfov;
        Some(Vec2::new(
            (sx + 1.0) * 0.5 * self.width as f32,
            (1.0 - sy) * 0.5 * self.height as f32,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> PinholeCamera {
        PinholeCamera::look_at(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::Y,
            40.0,
            64,
            48,
        )
        .unwrap()
    }

    #[test]
    fn projection_and_ray_generation_agree() {
        let cam = camera();
        let p = Vec3::new(0.3, -0.2, 0.1);
        let film = cam.project(p).unwrap();
        let ray = cam.generate_ray(film);
        let to_p = (p - cam.position).normalize();
        assert!(
            ray.dir.dot(to_p) > 1.0 - 1e-6,
            "{:?} vs {:?}",
            ray.dir,
            to_p
        );
    }

    #[test]
    fn look_at_point_projects_to_image_centre() {
        let cam = camera();
        let c = cam.project(Vec3::ZERO).unwrap();
        assert!((c - Vec2::new(32.0, 24.0)).length() < 1e-3);
    }

    #[test]
    fn image_right_and_up_are_where_expected() {
        // Looking down −z with y up: +x is to the right, +y is up (smaller row).
        let cam = PinholeCamera::look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y, 60.0, 10, 10).unwrap();
        let right = cam.project(Vec3::new(0.5, 0.0, -2.0)).unwrap();
        let up = cam.project(Vec3::new(0.0, 0.5, -2.0)).unwrap();
        assert!(right.x > 5.0 && (right.y - 5.0).abs() < 1e-4);
        assert!(up.y < 5.0 && (up.x - 5.0).abs() < 1e-4);
    }

    #[test]
    fn focal_length_gives_the_papers_field_of_view() {
        // The paper's camera: 50 mm and a vertical FOV of 43.6° (sensor ≈ 40 mm).
        let v = PinholeCamera::vfov_from_focal_length(50.0, 40.0);
        assert!((v - 43.6).abs() < 0.1, "{v}");
    }

    #[test]
    fn degenerate_cameras_are_rejected() {
        assert_eq!(
            PinholeCamera::look_at(Vec3::ZERO, Vec3::ZERO, Vec3::Y, 40.0, 8, 8),
            Err(CameraError::NoViewDirection)
        );
        assert_eq!(
            PinholeCamera::look_at(Vec3::ZERO, Vec3::Y, Vec3::Y, 40.0, 8, 8),
            Err(CameraError::UpParallelToView)
        );
        assert!(PinholeCamera::look_at(Vec3::ZERO, Vec3::X, Vec3::Y, 0.0, 8, 8).is_err());
    }
}
