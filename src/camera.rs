//! Cameras: how a film position becomes a primary ray.
//!
//! A [`Camera`] is one of a closed set of models, dispatched by `match` (no
//! trait objects on the per-ray path):
//!
//! | model | what it models | parameters |
//! | --- | --- | --- |
//! | [`PinholeCamera`] | a perspective camera with an infinitely small aperture: everything is sharp | vertical or horizontal field of view (degrees), or focal length and sensor size (mm); `zoom` (a factor > 0) |
//! | [`ThinLensCamera`] | a perspective camera with a real aperture: depth of field | as the pinhole, plus `aperture_radius` and `focus_distance` (scene units, metres in the paper's data) |
//! | [`EquirectCamera`] | a 360° panorama, every direction, in the latitude–longitude layout of [`crate::equirect`] | the pose only |
//! | [`DualFisheyeCamera`] | a 360° camera as it records: two back-to-back equidistant fisheye circles side by side | `fov` of each lens (degrees, 180 to 360) |
//! | [`OrthographicCamera`] | parallel rays | the view's width and height (scene units) |
//! | [`CalibratedCamera`] | a real camera as a calibration describes it: off-centre principal point, lens distortion ([`crate::calibrated_camera`]) | `fx`, `fy`, `cx`, `cy`, `skew` (pixels), `distortion` and its `coefficients` |
//!
//! **Image coordinates.** Pixel `(x, y)` covers `[x, x+1) × [y, y+1)` with
//! `x` to the right and `y` downwards; a film position is a continuous pixel
//! coordinate.
//!
//! **Pose.** Every camera has a [`Pose`]: a position and a right-handed
//! orthonormal frame `(right, up, forward)` with `right = forward × up`. It
//! is given either as look-at (`position`, `look_at`, `up`; `up` need not be
//! perpendicular to the view) or as a 4×4 camera-to-world matrix in the
//! **OpenCV convention**: the camera looks down its local **+Z**, local +X is
//! image right and local **+Y is image down**; the matrix is row-major with
//! the translation (the camera position) in the last column. A calibrated
//! pose from OpenCV or COLMAP (after inverting their world-to-camera `[R|t]`)
//! pastes in as is; an OpenGL/Blender camera-to-world matrix (looking down
//! −Z, +Y up) becomes an OpenCV one by negating its second and third columns.
//!
//! **Zoom** divides the tangent of the half field of view: `zoom = 2` shows
//! the middle half of the `zoom = 1` image at the same resolution, as a zoom
//! lens at twice the focal length would.
//!
//! **Perspective projection.** With `t = tan(vfov/2)/zoom` and
//! `aspect = width/height`, a direction `d` from the camera with camera-space
//! components `(d·right, d·up, d·forward) = (a, b, c)`, `c > 0`, lands at
//! `x = width·(1 + a/(c·t·aspect))/2`, `y = height·(1 − b/(c·t))/2`.
//!
//! **Dual fisheye layout.** The image is split into a left and a right half,
//! each of `width/2 × height` pixels with a circle of radius
//! `min(width/4, height/2)` pixels at its centre. The left circle is the
//! front lens, looking along `forward` with image-right = `right`; the right
//! circle is the back lens, looking along `−forward` with image-right =
//! `−right` (as if the photographer turned round); in both, image-up is `up`.
//! The projection is equidistant: a direction at angle `θ` from the lens axis
//! lies `θ/(fov/2)` of the radius from the circle's centre. Pixels outside
//! both circles see nothing: they produce no ray and stay black (they still
//! count towards the samples per pixel). Where the lenses overlap
//! (`fov > 180°`), [`Camera::project`] picks the lens whose axis is nearer.
//! This is the layout of a Ricoh Theta's dual-fisheye stream with both
//! circles upright.
//!
//! A scene file describes a camera in its `[camera]` table:
//!
//! ```toml
//! [camera]
//! type = "thin_lens"     # pinhole (default), thin_lens, equirectangular, dual_fisheye
//! position = [2.0, -3.0, 1.2]   # metres
//! look_at = [0.0, 0.0, 0.8]
//! up = [0, 0, 1]
//! vfov = 43.6            # degrees; or hfov, or focal_length (+ sensor_height/sensor_width, mm)
//! zoom = 1.0
//! aperture_radius = 0.01 # metres
//! focus_distance = 3.5   # metres; default: the distance to look_at
//! resolution = [400, 300]
//! # or: preset = "paper-table1" (4000×3000, vfov 43.6°, 50 mm), or
//! # to_world = [[1, 0, 0, 0], [0, 0, 1, -3], [0, -1, 0, 1.2], [0, 0, 0, 1]]
//! ```

use crate::accel::Ray;
pub use crate::calibrated_camera::{CalibratedCamera, Intrinsics};
use crate::equirect::{equirect_direction, equirect_uv, SphereFrame};
use crate::warp::square_to_disk_concentric;
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};

/// Default sensor height (mm) when a camera gives `focal_length` alone: 35 mm film.
pub const DEFAULT_SENSOR_HEIGHT_MM: f32 = 24.0;

/// Default field of view of each lens of a dual-fisheye camera, degrees.
pub const DEFAULT_FISHEYE_FOV_DEG: f32 = 190.0;

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
    /// A camera-to-world matrix that is not a rotation plus a translation.
    NotRigid(String),
    /// A zoom factor that is not a positive number.
    BadZoom(f32),
    /// An aperture radius that is negative or not finite.
    BadAperture(f32),
    /// A focus distance that is not a positive number.
    BadFocusDistance(f32),
    /// A fisheye field of view outside [180°, 360°).
    BadFisheyeFov(f32),
    /// An orthographic view size that is not a positive number.
    BadViewSize(f32),
    /// A position beyond [`MAX_COORDINATE`](crate::accel::MAX_COORDINATE).
    TooFar(Vec3),
    /// A calibrated camera's focal length that is not positive, or a
    /// principal point or skew that is not finite (the key, the value).
    BadIntrinsic(&'static str, f64),
}

impl std::fmt::Display for CameraError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CameraError::NoViewDirection => write!(f, "position and look_at coincide"),
            CameraError::UpParallelToView => {
                write!(f, "up is zero or parallel to the viewing direction")
            }
            CameraError::TooFar(p) => write!(
                f,
                "position {p} is beyond ±{:e} scene units",
                crate::accel::MAX_COORDINATE
            ),
            CameraError::BadFov(v) => write!(f, "field of view {v}° is outside (0°, 180°)"),
            CameraError::EmptyImage => write!(f, "resolution must be at least 1×1"),
            CameraError::NotRigid(m) => write!(f, "{m}"),
            CameraError::BadZoom(z) => write!(f, "must be a positive number, got {z}"),
            CameraError::BadAperture(r) => write!(
                f,
                "must be a number ≥ 0 and at most {:e}, got {r}",
                crate::accel::MAX_COORDINATE
            ),
            CameraError::BadFocusDistance(d) => write!(
                f,
                "must be a positive number up to {:e}, got {d}",
                crate::accel::MAX_COORDINATE
            ),
            CameraError::BadFisheyeFov(v) => {
                write!(f, "must be in [180, 360) degrees, got {v}")
            }
            CameraError::BadViewSize(v) => {
                write!(f, "must be a positive number of scene units, got {v}")
            }
            CameraError::BadIntrinsic(key, v) if key.starts_with('f') => {
                write!(f, "{key} must be a positive number of pixels, got {v}")
            }
            CameraError::BadIntrinsic(key, v) => {
                write!(f, "{key} must be a finite number of pixels, got {v}")
            }
        }
    }
}

/// Tolerance on `RᵀR = I` and `det R = 1` for camera-to-world matrices.
pub const RIGID_TOLERANCE: f32 = 1e-3;

/// Where a camera is and where it looks: a position and a right-handed
/// orthonormal frame with `right = forward × up`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Centre of projection (scene units).
    pub position: Vec3,
    /// Unit viewing direction (the image centre).
    pub forward: Vec3,
    /// Unit image-right direction.
    pub right: Vec3,
    /// Unit image-up direction.
    pub up: Vec3,
}

impl Pose {
    /// A camera at `position` looking at `look_at`; `up` decides which way is
    /// up in the image and need not be perpendicular to the view.
    pub fn look_at(position: Vec3, look_at: Vec3, up: Vec3) -> Result<Pose, CameraError> {
        if !crate::accel::within_coordinates(position) {
            return Err(CameraError::TooFar(position));
        }
        let forward = (look_at - position)
            .try_normalize()
            .ok_or(CameraError::NoViewDirection)?;
        let right = forward
            .cross(up)
            .try_normalize()
            .filter(|r| r.is_finite())
            .ok_or(CameraError::UpParallelToView)?;
        Ok(Pose {
            position,
            forward,
            right,
            up: right.cross(forward),
        })
    }

    /// A pose from a row-major 4×4 camera-to-world matrix in the OpenCV
    /// convention (columns: image right, image down, viewing direction,
    /// position). The rotation must be orthonormal with determinant +1 within
    /// [`RIGID_TOLERANCE`], and the last row `[0, 0, 0, 1]`.
    pub fn from_matrix(rows: [[f32; 4]; 4]) -> Result<Pose, CameraError> {
        if rows.iter().flatten().any(|x| !x.is_finite()) {
            return Err(CameraError::NotRigid(
                "every element must be a finite number".into(),
            ));
        }
        if rows[3] != [0.0, 0.0, 0.0, 1.0] {
            return Err(CameraError::NotRigid(format!(
                "the last row must be [0, 0, 0, 1], got {:?}",
                rows[3]
            )));
        }
        let col = |c: usize| Vec3::new(rows[0][c], rows[1][c], rows[2][c]);
        let r = Mat3::from_cols(col(0), col(1), col(2));
        let err = (r.transpose() * r - Mat3::IDENTITY)
            .to_cols_array()
            .iter()
            .fold(0.0f32, |m, x| m.max(x.abs()));
        if err > RIGID_TOLERANCE {
            return Err(CameraError::NotRigid(format!(
                "the upper-left 3×3 block is not a rotation (|RᵀR − I| = {err:.2e}, tolerance {RIGID_TOLERANCE:.0e}): \
                 the camera-to-world matrix must be rigid, without scale or shear"
            )));
        }
        let det = r.determinant();
        if (det - 1.0).abs() > RIGID_TOLERANCE {
            return Err(CameraError::NotRigid(format!(
                "the upper-left 3×3 block has determinant {det:.4}, not +1: a reflection, \
                 not a rotation (columns must be right, down, forward: OpenCV convention)"
            )));
        }
        let forward = col(2).normalize();
        let right = col(0).normalize();
        // Re-orthonormalise within the tolerance.
        let up = right.cross(forward).normalize();
        if !crate::accel::within_coordinates(col(3)) {
            return Err(CameraError::TooFar(col(3)));
        }
        Ok(Pose {
            position: col(3),
            forward,
            right: forward.cross(up),
            up,
        })
    }

    /// The row-major camera-to-world matrix of this pose (OpenCV convention).
    pub fn to_matrix(&self) -> [[f32; 4]; 4] {
        let m = Mat4::from_cols(
            self.right.extend(0.0),
            (-self.up).extend(0.0),
            self.forward.extend(0.0),
            self.position.extend(1.0),
        );
        m.transpose().to_cols_array_2d()
    }

    /// The panorama frame of this pose (centre column along `forward`, top
    /// row along `up`).
    pub fn sphere_frame(&self) -> SphereFrame {
        SphereFrame {
            forward: self.forward,
            right: self.right,
            up: self.up,
        }
    }

    /// Camera-space components `(d·right, d·up, d·forward)` of a world vector.
    #[inline]
    fn local(&self, d: Vec3) -> Vec3 {
        Vec3::new(d.dot(self.right), d.dot(self.up), d.dot(self.forward))
    }
}

/// A field of view for perspective cameras, before zoom.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fov {
    /// Vertical field of view, degrees in (0, 180).
    Vertical(f32),
    /// Horizontal field of view, degrees in (0, 180).
    Horizontal(f32),
}

/// Field of view in degrees from a focal length and the sensor extent along
/// the same axis, both in millimetres: `2·atan(sensor / (2·focal))`.
pub fn fov_from_focal_length(focal_length_mm: f32, sensor_mm: f32) -> f32 {
    2.0 * (0.5 * sensor_mm / focal_length_mm).atan().to_degrees()
}

/// A pinhole (perspective) camera.
#[derive(Debug, Clone, PartialEq)]
pub struct PinholeCamera {
    /// Where it is and where it looks.
    pub pose: Pose,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// `tan(vfov / 2)` after zoom: half the image height at unit distance.
    tan_half_vfov: f32,
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
        let pose = Pose::look_at(position, look_at, up)?;
        PinholeCamera::new(pose, Fov::Vertical(vfov_deg), 1.0, width, height)
    }

    /// A camera with the given pose, field of view (degrees), zoom factor
    /// (> 0; divides `tan(fov/2)`) and image size (pixels).
    pub fn new(
        pose: Pose,
        fov: Fov,
        zoom: f32,
        width: u32,
        height: u32,
    ) -> Result<PinholeCamera, CameraError> {
        let deg = match fov {
            Fov::Vertical(v) | Fov::Horizontal(v) => v,
        };
        if !(deg > 0.0 && deg < 180.0) {
            return Err(CameraError::BadFov(deg));
        }
        if !(zoom > 0.0 && zoom.is_finite()) {
            return Err(CameraError::BadZoom(zoom));
        }
        if width == 0 || height == 0 {
            return Err(CameraError::EmptyImage);
        }
        let aspect = width as f32 / height as f32;
        let tan_half = (deg.to_radians() * 0.5).tan();
        let tan_half_vfov = match fov {
            Fov::Vertical(_) => tan_half,
            Fov::Horizontal(_) => tan_half / aspect,
        } / zoom;
        Ok(PinholeCamera {
            pose,
            width,
            height,
            tan_half_vfov,
        })
    }

    /// Vertical field of view in degrees from a focal length and sensor
    /// height, both in millimetres.
    pub fn vfov_from_focal_length(focal_length_mm: f32, sensor_height_mm: f32) -> f32 {
        fov_from_focal_length(focal_length_mm, sensor_height_mm)
    }

    /// Vertical field of view in degrees (after zoom).
    pub fn vfov_deg(&self) -> f32 {
        2.0 * self.tan_half_vfov.atan().to_degrees()
    }

    /// Horizontal field of view in degrees (after zoom).
    pub fn hfov_deg(&self) -> f32 {
        let aspect = self.width as f32 / self.height as f32;
        2.0 * (self.tan_half_vfov * aspect).atan().to_degrees()
    }

    /// The same camera with another image size, keeping the vertical field of view.
    pub fn with_resolution(&self, width: u32, height: u32) -> Result<PinholeCamera, CameraError> {
        if width == 0 || height == 0 {
            return Err(CameraError::EmptyImage);
        }
        Ok(PinholeCamera {
            width,
            height,
            ..self.clone()
        })
    }

    /// Unnormalised direction through film position `film`, scaled so that
    /// its component along `forward` is 1.
    #[inline]
    fn film_direction(&self, film: Vec2) -> Vec3 {
        let aspect = self.width as f32 / self.height as f32;
        let sx = (2.0 * film.x / self.width as f32 - 1.0) * self.tan_half_vfov * aspect;
        let sy = (1.0 - 2.0 * film.y / self.height as f32) * self.tan_half_vfov;
        self.pose.forward + sx * self.pose.right + sy * self.pose.up
    }

    /// The primary ray through film position `film` (continuous pixel
    /// coordinates). Its direction is normalised, so `t` is distance.
    #[inline]
    pub fn generate_ray(&self, film: Vec2) -> Ray {
        Ray::new(self.pose.position, self.film_direction(film).normalize())
    }

    /// Film position (continuous pixel coordinates) where world point `p`
    /// projects, or `None` if it is not in front of the camera.
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        let d = self.pose.local(p - self.pose.position);
        if d.z <= 0.0 {
            return None;
        }
        let aspect = self.width as f32 / self.height as f32;
        let sx = d.x / d.z / (self.tan_half_vfov * aspect);
        let sy = d.y / d.z / self.tan_half_vfov;
        Some(Vec2::new(
            (sx + 1.0) * 0.5 * self.width as f32,
            (1.0 - sy) * 0.5 * self.height as f32,
        ))
    }
}

/// An orthographic camera: parallel rays along `forward`, from a
/// rectangle of `view_width × view_height` scene units centred on
/// `position` (Mitsuba's `orthographic`: the view spans `[−1, 1]` across
/// times its `to_world` scale). Film position `(x, y)` starts its ray at
/// `position + right·(2x/W − 1)·view_width/2 + up·(1 − 2y/H)·view_height/2`.
#[derive(Debug, Clone, PartialEq)]
pub struct OrthographicCamera {
    /// Where the view rectangle's centre is and which way it looks.
    pub pose: Pose,
    /// Width of the view, scene units.
    pub view_width: f32,
    /// Height of the view, scene units.
    pub view_height: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl OrthographicCamera {
    /// An orthographic camera of `width × height` pixels seeing a
    /// `view_width × view_height` rectangle (scene units, positive).
    pub fn new(
        pose: Pose,
        view_width: f32,
        view_height: f32,
        width: u32,
        height: u32,
    ) -> Result<OrthographicCamera, CameraError> {
        if width == 0 || height == 0 {
            return Err(CameraError::EmptyImage);
        }
        for v in [view_width, view_height] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(CameraError::BadViewSize(v));
            }
        }
        Ok(OrthographicCamera {
            pose,
            view_width,
            view_height,
            width,
            height,
        })
    }

    /// The ray through film position `film`.
    #[inline]
    pub fn generate_ray(&self, film: Vec2) -> Ray {
        let sx = 2.0 * film.x / self.width as f32 - 1.0;
        let sy = 1.0 - 2.0 * film.y / self.height as f32;
        let origin = self.pose.position
            + self.pose.right * (sx * 0.5 * self.view_width)
            + self.pose.up * (sy * 0.5 * self.view_height);
        Ray::new(origin, self.pose.forward)
    }

    /// Film position of world point `p`, or `None` behind the view plane.
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        let d = self.pose.local(p - self.pose.position);
        if d.z < 0.0 {
            return None;
        }
        let sx = d.x / (0.5 * self.view_width);
        let sy = d.y / (0.5 * self.view_height);
        Some(Vec2::new(
            (sx + 1.0) * 0.5 * self.width as f32,
            (1.0 - sy) * 0.5 * self.height as f32,
        ))
    }
}

/// A thin-lens camera: a pinhole camera's projection with a circular
/// aperture of radius `aperture_radius` in the plane through `position`
/// perpendicular to `forward`; points at depth `focus_distance` (measured
/// along `forward`) are in focus.
#[derive(Debug, Clone, PartialEq)]
pub struct ThinLensCamera {
    /// The projection through the lens centre.
    pub pinhole: PinholeCamera,
    /// Radius of the aperture (scene units); 0 is a pinhole.
    pub aperture_radius: f32,
    /// Depth of the plane of focus along `forward` (scene units).
    pub focus_distance: f32,
}

impl ThinLensCamera {
    /// A thin lens over `pinhole` with aperture radius (≥ 0) and focus
    /// distance (> 0), both in scene units.
    pub fn new(
        pinhole: PinholeCamera,
        aperture_radius: f32,
        focus_distance: f32,
    ) -> Result<ThinLensCamera, CameraError> {
        let max = crate::accel::MAX_COORDINATE;
        if !(aperture_radius >= 0.0 && aperture_radius <= max) {
            return Err(CameraError::BadAperture(aperture_radius));
        }
        if !(focus_distance > 0.0 && focus_distance <= max) {
            return Err(CameraError::BadFocusDistance(focus_distance));
        }
        Ok(ThinLensCamera {
            pinhole,
            aperture_radius,
            focus_distance,
        })
    }

    /// The ray through film position `film` from the lens point chosen by
    /// `lens ∈ [0, 1)²` (mapped to the aperture disk by the concentric map).
    #[inline]
    pub fn generate_ray(&self, film: Vec2, lens: Vec2) -> Ray {
        let pose = &self.pinhole.pose;
        let focus = pose.position + self.focus_distance * self.pinhole.film_direction(film);
        let disk = self.aperture_radius * square_to_disk_concentric(lens);
        let origin = pose.position + disk.x * pose.right + disk.y * pose.up;
        Ray::new(origin, (focus - origin).normalize())
    }
}

/// A 360° camera recording an equirectangular panorama in the convention of
/// [`crate::equirect`], oriented by its pose (image centre along `forward`,
/// top row along `up`).
#[derive(Debug, Clone, PartialEq)]
pub struct EquirectCamera {
    /// Where it is and how the panorama is oriented.
    pub pose: Pose,
    /// Image width in pixels (360° of azimuth).
    pub width: u32,
    /// Image height in pixels (180° of elevation).
    pub height: u32,
}

impl EquirectCamera {
    /// A panorama camera of `width × height` pixels (normally 2:1).
    pub fn new(pose: Pose, width: u32, height: u32) -> Result<EquirectCamera, CameraError> {
        if width == 0 || height == 0 {
            return Err(CameraError::EmptyImage);
        }
        Ok(EquirectCamera {
            pose,
            width,
            height,
        })
    }

    /// Film position to `uv ∈ [0, 1]²`.
    #[inline]
    pub fn film_to_uv(&self, film: Vec2) -> Vec2 {
        film / Vec2::new(self.width as f32, self.height as f32)
    }

    /// The ray through film position `film`.
    #[inline]
    pub fn generate_ray(&self, film: Vec2) -> Ray {
        let dir = equirect_direction(self.film_to_uv(film), &self.pose.sphere_frame());
        Ray::new(self.pose.position, dir)
    }

    /// Film position of world point `p` (`None` at the camera's position).
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        let d = p - self.pose.position;
        if d == Vec3::ZERO {
            return None;
        }
        // Normalised: `equirect_uv` takes lengths from 1e-18 to 1e18 only,
        // and a world point may lie farther.
        let uv = equirect_uv(d.normalize(), &self.pose.sphere_frame());
        Some(uv * Vec2::new(self.width as f32, self.height as f32))
    }
}

/// A 360° camera that records two back-to-back equidistant fisheye circles
/// side by side (see the module docs for the layout).
#[derive(Debug, Clone, PartialEq)]
pub struct DualFisheyeCamera {
    /// Where it is; the front lens looks along `forward`.
    pub pose: Pose,
    /// Image width in pixels (both circles).
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Field of view of each lens, degrees in [180, 360).
    pub fov_deg: f32,
}

impl DualFisheyeCamera {
    /// A dual-fisheye camera; `fov_deg` is each lens's full field of view.
    pub fn new(
        pose: Pose,
        fov_deg: f32,
        width: u32,
        height: u32,
    ) -> Result<DualFisheyeCamera, CameraError> {
        if !(180.0..360.0).contains(&fov_deg) {
            return Err(CameraError::BadFisheyeFov(fov_deg));
        }
        if width == 0 || height == 0 {
            return Err(CameraError::EmptyImage);
        }
        Ok(DualFisheyeCamera {
            pose,
            width,
            height,
            fov_deg,
        })
    }

    /// Radius of each circle in pixels.
    #[inline]
    pub fn radius_px(&self) -> f32 {
        (0.25 * self.width as f32).min(0.5 * self.height as f32)
    }

    /// Centre of the front (`back = false`) or back circle, film coordinates.
    #[inline]
    pub fn centre(&self, back: bool) -> Vec2 {
        let w = self.width as f32;
        Vec2::new(
            if back { 0.75 * w } else { 0.25 * w },
            0.5 * self.height as f32,
        )
    }

    /// Lens axis, image-right and image-up of the front or back lens.
    #[inline]
    fn lens_frame(&self, back: bool) -> (Vec3, Vec3, Vec3) {
        let p = &self.pose;
        if back {
            (-p.forward, -p.right, p.up)
        } else {
            (p.forward, p.right, p.up)
        }
    }

    /// The direction seen at film position `film`, or `None` outside both circles.
    #[inline]
    pub fn film_direction(&self, film: Vec2) -> Option<Vec3> {
        let back = film.x >= 0.5 * self.width as f32;
        let offset = (film - self.centre(back)) / self.radius_px();
        let r = offset.length();
        if r > 1.0 {
            return None;
        }
        let theta = r * (0.5 * self.fov_deg).to_radians();
        let (axis, right, up) = self.lens_frame(back);
        let (sin_t, cos_t) = theta.sin_cos();
        // Image y is down, so −offset.y is along image-up.
        let radial = if r > 0.0 {
            (offset.x * right - offset.y * up) / r
        } else {
            Vec3::ZERO
        };
        Some((cos_t * axis + sin_t * radial).normalize())
    }

    /// The ray through film position `film`, or `None` outside both circles.
    #[inline]
    pub fn generate_ray(&self, film: Vec2) -> Option<Ray> {
        self.film_direction(film)
            .map(|d| Ray::new(self.pose.position, d))
    }

    /// Film position where direction `dir` is recorded (by the lens whose
    /// axis is nearer); `None` for a zero direction.
    pub fn project_direction(&self, dir: Vec3) -> Option<Vec2> {
        let d = dir.try_normalize()?;
        let back = d.dot(self.pose.forward) < 0.0;
        let (axis, right, up) = self.lens_frame(back);
        let (a, b) = (d.dot(right), d.dot(up));
        let theta = (a.hypot(b)).atan2(d.dot(axis));
        let radial = Vec2::new(a, -b).normalize_or_zero();
        let r = theta / (0.5 * self.fov_deg).to_radians();
        Some(self.centre(back) + r * self.radius_px() * radial)
    }

    /// Film position of world point `p` (`None` at the camera's position).
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        self.project_direction(p - self.pose.position)
    }
}

/// A camera: one of plsr's camera models.
#[derive(Debug, Clone, PartialEq)]
pub enum Camera {
    /// Perspective, everything sharp.
    Pinhole(PinholeCamera),
    /// Perspective with depth of field.
    ThinLens(ThinLensCamera),
    /// 360° latitude–longitude panorama.
    Equirect(EquirectCamera),
    /// 360° as two fisheye circles.
    DualFisheye(DualFisheyeCamera),
    /// Parallel projection.
    Orthographic(OrthographicCamera),
    /// A real camera's calibration: intrinsics and lens distortion.
    Calibrated(CalibratedCamera),
}

impl From<PinholeCamera> for Camera {
    fn from(c: PinholeCamera) -> Camera {
        Camera::Pinhole(c)
    }
}

impl Camera {
    /// The camera's pose.
    #[inline]
    pub fn pose(&self) -> &Pose {
        match self {
            Camera::Pinhole(c) => &c.pose,
            Camera::ThinLens(c) => &c.pinhole.pose,
            Camera::Equirect(c) => &c.pose,
            Camera::DualFisheye(c) => &c.pose,
            Camera::Orthographic(c) => &c.pose,
            Camera::Calibrated(c) => &c.pose,
        }
    }

    /// The same camera moved to `pose` (a frame of a camera path); every
    /// other setting (field of view, resolution, lens) is kept.
    pub fn with_pose(&self, pose: Pose) -> Camera {
        let mut c = self.clone();
        match &mut c {
            Camera::Pinhole(c) => c.pose = pose,
            Camera::ThinLens(c) => c.pinhole.pose = pose,
            Camera::Equirect(c) => c.pose = pose,
            Camera::DualFisheye(c) => c.pose = pose,
            Camera::Orthographic(c) => c.pose = pose,
            Camera::Calibrated(c) => c.pose = pose,
        }
        c
    }

    /// Centre of projection (scene units).
    #[inline]
    pub fn position(&self) -> Vec3 {
        self.pose().position
    }

    /// Image width in pixels.
    #[inline]
    pub fn width(&self) -> u32 {
        match self {
            Camera::Pinhole(c) => c.width,
            Camera::ThinLens(c) => c.pinhole.width,
            Camera::Equirect(c) => c.width,
            Camera::DualFisheye(c) => c.width,
            Camera::Orthographic(c) => c.width,
            Camera::Calibrated(c) => c.width,
        }
    }

    /// Image height in pixels.
    #[inline]
    pub fn height(&self) -> u32 {
        match self {
            Camera::Pinhole(c) => c.height,
            Camera::ThinLens(c) => c.pinhole.height,
            Camera::Equirect(c) => c.height,
            Camera::DualFisheye(c) => c.height,
            Camera::Orthographic(c) => c.height,
            Camera::Calibrated(c) => c.height,
        }
    }

    /// The model's name as in scene files (`pinhole`, `thin_lens`, ...).
    pub fn type_name(&self) -> &'static str {
        match self {
            Camera::Pinhole(_) => "pinhole",
            Camera::ThinLens(_) => "thin_lens",
            Camera::Equirect(_) => "equirectangular",
            Camera::DualFisheye(_) => "dual_fisheye",
            Camera::Orthographic(_) => "orthographic",
            Camera::Calibrated(_) => "calibrated",
        }
    }

    /// Whether [`Camera::generate_ray`] uses its `lens` sample (callers may
    /// then skip drawing one, keeping the random streams of the others).
    #[inline]
    pub fn needs_lens_sample(&self) -> bool {
        matches!(self, Camera::ThinLens(c) if c.aperture_radius > 0.0)
    }

    /// The primary ray through film position `film` (continuous pixel
    /// coordinates), using `lens ∈ [0, 1)²` to pick a point on the aperture
    /// (thin lens only). `None` where the film records nothing (outside the
    /// circles of a dual fisheye): such a sample is black and hits nothing.
    /// Directions are normalised, so `t` is distance.
    #[inline]
    pub fn generate_ray(&self, film: Vec2, lens: Vec2) -> Option<Ray> {
        match self {
            Camera::Pinhole(c) => Some(c.generate_ray(film)),
            Camera::ThinLens(c) => Some(c.generate_ray(film, lens)),
            Camera::Equirect(c) => Some(c.generate_ray(film)),
            Camera::DualFisheye(c) => c.generate_ray(film),
            Camera::Orthographic(c) => Some(c.generate_ray(film)),
            Camera::Calibrated(c) => c.generate_ray(film),
        }
    }

    /// Film position where world point `p` is seen through the lens centre,
    /// or `None` if this camera does not see it (behind a perspective
    /// camera, or at the camera's position).
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        match self {
            Camera::Pinhole(c) => c.project(p),
            Camera::ThinLens(c) => c.pinhole.project(p),
            Camera::Equirect(c) => c.project(p),
            Camera::DualFisheye(c) => c.project(p),
            Camera::Orthographic(c) => c.project(p),
            Camera::Calibrated(c) => c.project(p),
        }
    }

    /// The depth AOV of a hit at distance `t` along a primary ray of unit
    /// direction `dir`: for perspective cameras the depth along the viewing
    /// axis (`t·dir·forward`), for 360° cameras the distance `t`.
    #[inline]
    pub fn depth(&self, dir: Vec3, t: f32) -> f32 {
        match self {
            Camera::Pinhole(_)
            | Camera::ThinLens(_)
            | Camera::Orthographic(_)
            | Camera::Calibrated(_) => t * dir.dot(self.pose().forward),
            Camera::Equirect(_) | Camera::DualFisheye(_) => t,
        }
    }

    /// The same camera with another image size; perspective cameras keep
    /// their vertical field of view.
    pub fn with_resolution(&self, width: u32, height: u32) -> Result<Camera, CameraError> {
        if width == 0 || height == 0 {
            return Err(CameraError::EmptyImage);
        }
        Ok(match self {
            Camera::Pinhole(c) => Camera::Pinhole(c.with_resolution(width, height)?),
            Camera::ThinLens(c) => Camera::ThinLens(ThinLensCamera {
                pinhole: c.pinhole.with_resolution(width, height)?,
                ..c.clone()
            }),
            Camera::Equirect(c) => Camera::Equirect(EquirectCamera {
                width,
                height,
                ..c.clone()
            }),
            Camera::DualFisheye(c) => Camera::DualFisheye(DualFisheyeCamera {
                width,
                height,
                ..c.clone()
            }),
            // The view keeps its width; its height follows the image's.
            Camera::Orthographic(c) => Camera::Orthographic(OrthographicCamera {
                width,
                height,
                view_height: c.view_width * height as f32 / width as f32,
                ..c.clone()
            }),
            Camera::Calibrated(c) => Camera::Calibrated(c.with_resolution(width, height)?),
        })
    }
}

/// A ready-made camera: its image, lens and photographic settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraPreset {
    /// Name used in scene files (`preset = "..."`).
    pub name: &'static str,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Vertical field of view at zoom 1, degrees.
    pub vfov_deg: f32,
    /// Focal length at zoom 1, millimetres (documentation; `vfov_deg` rules).
    pub focal_length_mm: f32,
    /// Zoom factor.
    pub zoom: f32,
    /// Exposure time, seconds.
    pub shutter_s: f32,
    /// ISO sensitivity.
    pub iso: f32,
    /// White balance, kelvin.
    pub white_balance_k: f32,
}

/// The camera of the paper's Table 1: 4000×3000, vertical FOV 43.6°, 50 mm,
/// zoom 1.0 (its camera 7 uses 1.8), shutter 0.25 s, ISO 400, white balance
/// 4400 K. (Its sensor height is `2·50·tan(21.8°) ≈ 40 mm`.)
pub const PAPER_TABLE1: CameraPreset = CameraPreset {
    name: "paper-table1",
    width: 4000,
    height: 3000,
    vfov_deg: 43.6,
    focal_length_mm: 50.0,
    zoom: 1.0,
    shutter_s: 0.25,
    iso: 400.0,
    white_balance_k: 4400.0,
};

/// Every preset, for lookup by name.
pub const PRESETS: &[CameraPreset] = &[PAPER_TABLE1];

/// The preset called `name`.
pub fn preset(name: &str) -> Option<&'static CameraPreset> {
    PRESETS.iter().find(|p| p.name == name)
}

/// A homogeneous point of a row-major matrix times `p` (helper for tests and
/// callers that hold poses as matrices).
pub fn transform_point(rows: &[[f32; 4]; 4], p: Vec3) -> Vec3 {
    let m = Mat4::from_cols_array_2d(rows).transpose();
    let q = m * Vec4::new(p.x, p.y, p.z, 1.0);
    q.truncate() / q.w
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
        let to_p = (p - cam.pose.position).normalize();
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
        let pose = Pose::look_at(Vec3::ZERO, Vec3::X, Vec3::Y).unwrap();
        assert_eq!(
            PinholeCamera::new(pose, Fov::Vertical(40.0), 0.0, 8, 8),
            Err(CameraError::BadZoom(0.0))
        );
        assert_eq!(
            DualFisheyeCamera::new(pose, 170.0, 8, 4),
            Err(CameraError::BadFisheyeFov(170.0))
        );
    }

    #[test]
    fn zoom_divides_the_tangent_and_hfov_matches_vfov() {
        let pose = Pose::look_at(Vec3::ZERO, Vec3::X, Vec3::Z).unwrap();
        let a = PinholeCamera::new(pose, Fov::Vertical(43.6), 1.8, 40, 30).unwrap();
        let expect = 2.0 * ((21.8f32).to_radians().tan() / 1.8).atan().to_degrees();
        assert!((a.vfov_deg() - expect).abs() < 1e-4);
        let b = PinholeCamera::new(pose, Fov::Horizontal(a.hfov_deg()), 1.0, 40, 30).unwrap();
        assert!((b.vfov_deg() - a.vfov_deg()).abs() < 1e-3);
    }

    #[test]
    fn matrix_pose_round_trips_and_rejects_scale() {
        let pose = Pose::look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, Vec3::Z).unwrap();
        let back = Pose::from_matrix(pose.to_matrix()).unwrap();
        assert!((back.forward - pose.forward).length() < 1e-6);
        assert!((back.up - pose.up).length() < 1e-6);
        assert_eq!(back.position, pose.position);
        // The camera-space point (0, 0, 1) is one unit ahead.
        let ahead = transform_point(&pose.to_matrix(), Vec3::Z);
        assert!((ahead - (pose.position + pose.forward)).length() < 1e-6);
        let mut scaled = pose.to_matrix();
        for row in scaled.iter_mut().take(3) {
            row[0] *= 1.1;
        }
        assert!(matches!(
            Pose::from_matrix(scaled),
            Err(CameraError::NotRigid(_))
        ));
        let mut mirrored = pose.to_matrix();
        for row in mirrored.iter_mut().take(3) {
            row[1] = -row[1];
        }
        assert!(matches!(
            Pose::from_matrix(mirrored),
            Err(CameraError::NotRigid(_))
        ));
    }

    #[test]
    fn dual_fisheye_round_trip() {
        let pose = Pose::look_at(Vec3::ZERO, Vec3::Y, Vec3::Z).unwrap();
        let cam = DualFisheyeCamera::new(pose, 200.0, 64, 32).unwrap();
        for i in 0..40 {
            for j in 0..20 {
                let uv = Vec2::new((i as f32 + 0.5) / 40.0, (j as f32 + 0.5) / 20.0);
                let d = equirect_direction(uv, &SphereFrame::Z_UP);
                let film = cam.project_direction(d).unwrap();
                let back = cam.film_direction(film).unwrap();
                assert!((back - d).length() < 1e-4, "{d} -> {film} -> {back}");
            }
        }
        // Corners are outside both circles.
        assert!(cam.generate_ray(Vec2::new(0.5, 0.5)).is_none());
        // The front lens's centre looks forward, the back lens's backwards.
        let f = cam.film_direction(cam.centre(false)).unwrap();
        let b = cam.film_direction(cam.centre(true)).unwrap();
        assert!((f - pose.forward).length() < 1e-6 && (b + pose.forward).length() < 1e-6);
    }
}
