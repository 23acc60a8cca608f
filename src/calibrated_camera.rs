//! A calibrated camera: a real camera as OpenCV, COLMAP or a phone's AR
//! framework describe it, so that a render registers with its photo to the
//! pixel.
//!
//! Its **intrinsics** are the focal lengths `f_x, f_y` and principal point
//! `c_x, c_y` in pixels and the skew `s` (OpenCV's camera matrix
//! `[[f_x, s, c_x], [0, f_y, c_y], [0, 0, 1]]`); its [`LensDistortion`] moves
//! a direction's image as the lens does. A direction `(x, y, z)` in the
//! camera's frame (OpenCV axes: x right, y down, z forward) lands at
//!
//! ```text
//! (x_d, y_d) = distort(x, y, z)
//! u = f_x·x_d + s·y_d + c_x,   v = f_y·y_d + c_y
//! ```
//!
//! **Pixel convention.** `(u, v)` are in **OpenCV's convention**: the centre
//! of the top-left pixel is `(0, 0)`. plsr's film positions put that centre
//! at `(0.5, 0.5)`, so film = `(u + 0.5, v + 0.5)`. COLMAP's convention is
//! plsr's: its `c_x, c_y` are OpenCV's plus 0.5 (the importers convert).
//!
//! Rays are traced through the inverse map ([`LensDistortion::undistort`]),
//! so a render's pixels land where the photo's do; pixels beyond the lens
//! model's valid radius get no ray and stay black.

use crate::accel::Ray;
use crate::camera::{CameraError, Pose};
use crate::lens_distortion::LensDistortion;
use glam::{DVec2, DVec3, Vec2, Vec3};

/// A camera's intrinsics, pixels, in OpenCV's pixel convention.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point, x (pixels; the top-left pixel's centre is 0).
    pub cx: f64,
    /// Principal point, y (pixels; the top-left pixel's centre is 0).
    pub cy: f64,
    /// Skew (pixels per unit of `y_d` added to `u`; 0 for every modern sensor).
    pub skew: f64,
}

impl Intrinsics {
    /// The intrinsics of the same camera imaging `width × height` pixels
    /// instead of `from_width × from_height` (the sensor kept, pixels resized).
    pub fn rescaled(&self, from: (u32, u32), to: (u32, u32)) -> Intrinsics {
        let sx = to.0 as f64 / from.0 as f64;
        let sy = to.1 as f64 / from.1 as f64;
        Intrinsics {
            fx: self.fx * sx,
            fy: self.fy * sy,
            cx: (self.cx + 0.5) * sx - 0.5,
            cy: (self.cy + 0.5) * sy - 0.5,
            skew: self.skew * sx,
        }
    }

    /// Pixel `(u, v)` (OpenCV's convention) of distorted normalised
    /// coordinates.
    #[inline]
    pub fn to_pixel(&self, d: DVec2) -> DVec2 {
        DVec2::new(
            self.fx * d.x + self.skew * d.y + self.cx,
            self.fy * d.y + self.cy,
        )
    }

    /// Distorted normalised coordinates of pixel `(u, v)` (OpenCV's convention).
    #[inline]
    pub fn from_pixel(&self, p: DVec2) -> DVec2 {
        let y = (p.y - self.cy) / self.fy;
        DVec2::new((p.x - self.cx - self.skew * y) / self.fx, y)
    }
}

/// A camera with calibrated intrinsics and lens distortion (see the
/// module's doc).
#[derive(Debug, Clone, PartialEq)]
pub struct CalibratedCamera {
    /// Where it is and where it looks (`forward` is the optical axis).
    pub pose: Pose,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Focal lengths, principal point and skew.
    pub intrinsics: Intrinsics,
    /// The lens's distortion.
    pub distortion: LensDistortion,
}

impl CalibratedCamera {
    /// A calibrated camera; the focal lengths must be positive, the
    /// principal point and skew finite.
    pub fn new(
        pose: Pose,
        width: u32,
        height: u32,
        intrinsics: Intrinsics,
        distortion: LensDistortion,
    ) -> Result<CalibratedCamera, CameraError> {
        if width == 0 || height == 0 {
            return Err(CameraError::EmptyImage);
        }
        let Intrinsics {
            fx,
            fy,
            cx,
            cy,
            skew,
        } = intrinsics;
        for (name, v) in [("fx", fx), ("fy", fy)] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(CameraError::BadIntrinsic(name, v));
            }
        }
        for (name, v) in [("cx", cx), ("cy", cy), ("skew", skew)] {
            if !v.is_finite() || v.abs() > 1e9 {
                return Err(CameraError::BadIntrinsic(name, v));
            }
        }
        Ok(CalibratedCamera {
            pose,
            width,
            height,
            intrinsics,
            distortion,
        })
    }

    /// The same camera imaging `width × height` pixels (intrinsics rescaled).
    pub fn with_resolution(
        &self,
        width: u32,
        height: u32,
    ) -> Result<CalibratedCamera, CameraError> {
        if width == 0 || height == 0 {
            return Err(CameraError::EmptyImage);
        }
        Ok(CalibratedCamera {
            width,
            height,
            intrinsics: self
                .intrinsics
                .rescaled((self.width, self.height), (width, height)),
            ..self.clone()
        })
    }

    /// World direction of a camera-frame direction (OpenCV axes).
    #[inline]
    fn to_world(&self, d: DVec3) -> Vec3 {
        let p = &self.pose;
        let d = d.as_vec3();
        p.right * d.x - p.up * d.y + p.forward * d.z
    }

    /// The unit direction in the camera's frame (OpenCV axes) seen at film
    /// position `film` (plsr's convention), or `None` beyond the lens
    /// model's valid radius.
    #[inline]
    pub fn film_direction(&self, film: Vec2) -> Option<DVec3> {
        let pixel = film.as_dvec2() - DVec2::splat(0.5);
        self.distortion.undistort(self.intrinsics.from_pixel(pixel))
    }

    /// The primary ray through film position `film`; `None` where the lens
    /// model has no direction (the pixel stays black).
    #[inline]
    pub fn generate_ray(&self, film: Vec2) -> Option<Ray> {
        let d = self.film_direction(film)?;
        let dir = self.to_world(d).try_normalize()?;
        Some(Ray::new(self.pose.position, dir))
    }

    /// Pixel `(u, v)` in OpenCV's convention where world point `p` is
    /// imaged, in double precision, or `None` if the lens does not see it.
    pub fn project_pixel(&self, p: DVec3) -> Option<DVec2> {
        let pose = &self.pose;
        let v = p - pose.position.as_dvec3();
        let local = DVec3::new(
            v.dot(pose.right.as_dvec3()),
            -v.dot(pose.up.as_dvec3()),
            v.dot(pose.forward.as_dvec3()),
        );
        if local == DVec3::ZERO {
            return None;
        }
        let d = self.distortion.distort(local)?;
        Some(self.intrinsics.to_pixel(d))
    }

    /// Film position (plsr's convention) where world point `p` is imaged, or
    /// `None` if the lens does not see it.
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        let px = self.project_pixel(p.as_dvec3())?;
        Some((px + DVec2::splat(0.5)).as_vec2())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(distortion: LensDistortion) -> CalibratedCamera {
        let pose =
            Pose::look_at(Vec3::new(0.3, -2.0, 1.0), Vec3::new(0.0, 0.0, 0.8), Vec3::Z).unwrap();
        let intrinsics = Intrinsics {
            fx: 520.5,
            fy: 518.25,
            cx: 321.7,
            cy: 238.4,
            skew: 1.5,
        };
        CalibratedCamera::new(pose, 640, 480, intrinsics, distortion).unwrap()
    }

    #[test]
    fn rays_and_projection_agree_at_every_pixel() {
        for distortion in [
            LensDistortion::None,
            LensDistortion::brown_conrady(&[-0.25, 0.08, 0.001, -0.0007, -0.01]).unwrap(),
            LensDistortion::fisheye(&[0.05, -0.01, 0.003, -0.0005]).unwrap(),
        ] {
            let c = camera(distortion);
            for (x, y) in [
                (0.0, 0.0),
                (639.5, 0.25),
                (320.0, 240.0),
                (17.25, 470.75),
                (640.0, 480.0),
            ] {
                let film = Vec2::new(x, y);
                let ray = c.generate_ray(film).expect("a ray");
                let back = c.project(ray.org + ray.dir * 3.0).expect("seen");
                assert!(
                    (back - film).length() < 2e-3,
                    "{film} -> {back} ({distortion:?})"
                );
            }
        }
    }

    #[test]
    fn the_principal_point_is_the_optical_axis() {
        let c = camera(LensDistortion::brown_conrady(&[-0.25, 0.08, 0.0, 0.0]).unwrap());
        // OpenCV's (cx, cy) is plsr's film (cx + 0.5, cy + 0.5).
        let film = Vec2::new(321.7 + 0.5, 238.4 + 0.5);
        let ray = c.generate_ray(film).unwrap();
        assert!((ray.dir - c.pose.forward).length() < 1e-6, "{}", ray.dir);
        // Image right is +x, image down is +y.
        let right = c
            .project(c.pose.position + c.pose.forward + 0.1 * c.pose.right)
            .unwrap();
        let up = c
            .project(c.pose.position + c.pose.forward + 0.1 * c.pose.up)
            .unwrap();
        assert!(right.x > film.x && up.y < film.y, "{right} {up}");
    }

    #[test]
    fn rescaling_keeps_the_field_of_view() {
        let c = camera(LensDistortion::brown_conrady(&[-0.25, 0.08, 0.001, -0.0007]).unwrap());
        let half = c.with_resolution(320, 240).unwrap();
        // A corner's ray is the same ray at any resolution.
        for (x, y) in [(0.0, 0.0), (1.0, 1.0), (0.3, 0.8)] {
            let a = c.generate_ray(Vec2::new(x * 640.0, y * 480.0)).unwrap();
            let b = half.generate_ray(Vec2::new(x * 320.0, y * 240.0)).unwrap();
            assert!((a.dir - b.dir).length() < 1e-6, "({x}, {y})");
        }
    }

    #[test]
    fn bad_intrinsics_are_refused() {
        let pose = camera(LensDistortion::None).pose;
        let good = camera(LensDistortion::None).intrinsics;
        for bad in [
            Intrinsics { fx: 0.0, ..good },
            Intrinsics { fy: -3.0, ..good },
            Intrinsics {
                cx: f64::NAN,
                ..good
            },
            Intrinsics {
                skew: f64::INFINITY,
                ..good
            },
        ] {
            assert!(CalibratedCamera::new(pose, 640, 480, bad, LensDistortion::None).is_err());
        }
    }
}
