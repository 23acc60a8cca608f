//! `[camera]`: the camera's type, pose, field of view and resolution.

use super::keys::key_names;
use super::Builder;
use crate::camera::{
    fov_from_focal_length, preset as camera_preset, CalibratedCamera, Camera, CameraError,
    CameraPreset, DualFisheyeCamera, EquirectCamera, Fov, Intrinsics, OrthographicCamera,
    PinholeCamera, Pose, ThinLensCamera, DEFAULT_FISHEYE_FOV_DEG, DEFAULT_SENSOR_HEIGHT_MM,
    PRESETS,
};
use crate::camera_path::{CameraPath, CameraPathError, PathKey, MAX_FRAME};
use crate::error::Result;
use crate::lens_distortion::LensDistortion;
use glam::Vec3;
use serde::Deserialize;

/// `[camera]` as read: the keys every camera has, and the keys of its
/// type, checked by the type's own struct ([`LensKeys`], [`FisheyeKeys`],
/// [`EquirectKeys`]).
#[derive(Debug, Deserialize)]
pub(super) struct CameraSection {
    #[serde(rename = "type", default = "pinhole")]
    pub(super) kind: String,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) position: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) look_at: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) up: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "crate::input::exact::option_matrix")]
    pub(super) to_world: Option<[[f32; 4]; 4]>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) resolution: Option<[i64; 2]>,
    /// `[[camera.path]]`: keyframes of an animation (see [`CameraPath`]).
    #[serde(default)]
    pub(super) path: Option<Vec<PathKeySection>>,
    #[serde(flatten)]
    pub(super) keys: toml::Table,
}

/// `[[camera.path]]`: one keyframe of a camera path.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PathKeySection {
    frame: i64,
    #[serde(deserialize_with = "crate::input::exact::array")]
    position: [f32; 3],
    #[serde(deserialize_with = "crate::input::exact::array")]
    look_at: [f32; 3],
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    up: Option<[f32; 3]>,
}

/// The keys of a perspective camera (`pinhole`, `thin_lens`; the aperture
/// and focus are the thin lens's alone).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct LensKeys {
    preset: Option<String>,
    vfov: Option<f32>,
    hfov: Option<f32>,
    focal_length: Option<f32>,
    sensor_height: Option<f32>,
    sensor_width: Option<f32>,
    zoom: Option<f32>,
    aperture_radius: Option<f32>,
    focus_distance: Option<f32>,
}

/// The keys of a `dual_fisheye` camera.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FisheyeKeys {
    fov: Option<f32>,
}

/// The keys of an `orthographic` camera: the size of its view.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct OrthoKeys {
    view_width: Option<f32>,
    view_height: Option<f32>,
}

/// The keys of a `calibrated` camera: intrinsics (pixels, OpenCV's
/// convention) and the lens's distortion.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CalibratedKeys {
    fx: Option<f64>,
    fy: Option<f64>,
    cx: Option<f64>,
    cy: Option<f64>,
    skew: Option<f64>,
    distortion: Option<String>,
    coefficients: Option<Vec<f64>>,
}

/// The keys of an `equirectangular` camera: none of its own.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct EquirectKeys {}

/// The keys every camera has (besides `type`).
const CAMERA_KEYS: [&str; 6] = [
    "position",
    "look_at",
    "up",
    "to_world",
    "resolution",
    "path",
];

/// The type-specific keys of a camera, one of which is read.
type CameraTypeKeys = (
    Option<LensKeys>,
    Option<FisheyeKeys>,
    Option<OrthoKeys>,
    Option<CalibratedKeys>,
);

fn pinhole() -> String {
    "pinhole".into()
}

impl Builder<'_> {
    pub(super) fn fov_degrees(&self, field: &str, v: f32) -> Result<f32> {
        let v = self.finite(field, v)?;
        if !(v > 0.0 && v < 180.0) {
            return Err(self.err(field, format!("must be in (0, 180) degrees, got {v}")));
        }
        Ok(v)
    }

    /// The camera, and the preset it names (whose photographic settings are
    /// the `[film]` defaults).
    pub(super) fn camera(
        &self,
        c: &CameraSection,
    ) -> Result<(Camera, Option<&'static CameraPreset>)> {
        const TYPES: &str =
            "pinhole, thin_lens, equirectangular, dual_fisheye, orthographic, calibrated";
        let kind = c.kind.as_str();
        if !matches!(
            kind,
            "pinhole"
                | "thin_lens"
                | "equirectangular"
                | "dual_fisheye"
                | "orthographic"
                | "calibrated"
        ) {
            return Err(self.err(
                "camera.type",
                format!("unknown camera type `{kind}` (known: {TYPES})"),
            ));
        }
        let (lens, fisheye, ortho, calibrated) = self.camera_type_keys(c, kind)?;
        let preset = self.camera_preset_named(lens.as_ref())?;
        let pose = self.camera_pose(c)?;
        let (w, h) = self.camera_size(c, preset)?;
        let camera = match kind {
            "equirectangular" => Camera::Equirect(
                EquirectCamera::new(pose, w, h)
                    .map_err(|e| self.err(camera_field(&e, "camera"), e.to_string()))?,
            ),
            "orthographic" => {
                let ortho = ortho.expect("orthographic cameras read their keys");
                let view_width =
                    self.positive("camera.view_width", ortho.view_width.unwrap_or(2.0))?;
                let view_height = self.positive(
                    "camera.view_height",
                    ortho
                        .view_height
                        .unwrap_or(view_width * h as f32 / w as f32),
                )?;
                Camera::Orthographic(
                    OrthographicCamera::new(pose, view_width, view_height, w, h)
                        .map_err(|e| self.err(camera_field(&e, "camera"), e.to_string()))?,
                )
            }
            "calibrated" => {
                let keys = calibrated.expect("calibrated cameras read their keys");
                Camera::Calibrated(self.calibrated_camera(&keys, pose, (w, h))?)
            }
            "dual_fisheye" => {
                let fov = fisheye.and_then(|f| f.fov);
                let fov = self.finite("camera.fov", fov.unwrap_or(DEFAULT_FISHEYE_FOV_DEG))?;
                Camera::DualFisheye(
                    DualFisheyeCamera::new(pose, fov, w, h)
                        .map_err(|e| self.err(camera_field(&e, "camera"), e.to_string()))?,
                )
            }
            _ => {
                let lens = lens.expect("perspective cameras read their lens keys");
                self.perspective_camera(c, kind, &lens, preset, pose, (w, h))?
            }
        };
        Ok((camera, preset))
    }

    /// The keys of the camera's type: a perspective camera's lens, a dual
    /// fisheye's field of view (a key of another type is "not used"; any
    /// other key unknown).
    fn camera_type_keys(&self, c: &CameraSection, kind: &str) -> Result<CameraTypeKeys> {
        let unknown = |key: &str| {
            let mut all = CAMERA_KEYS.to_vec();
            all.extend(key_names::<LensKeys>());
            all.extend(key_names::<FisheyeKeys>());
            all.extend(key_names::<OrthoKeys>());
            all.extend(key_names::<CalibratedKeys>());
            if all.contains(&key) {
                format!("not used by cameras of type `{kind}`")
            } else {
                let list: Vec<String> = std::iter::once("type")
                    .chain(all)
                    .map(|k| format!("`{k}`"))
                    .collect();
                format!("unknown field `{key}`, expected one of {}", list.join(", "))
            }
        };
        Ok(match kind {
            "pinhole" | "thin_lens" => {
                let lens: LensKeys = self.typed_keys("camera", &c.keys, unknown)?;
                if kind == "pinhole" {
                    // A pinhole has no aperture to focus.
                    for (name, present) in [
                        ("aperture_radius", lens.aperture_radius.is_some()),
                        ("focus_distance", lens.focus_distance.is_some()),
                    ] {
                        if present {
                            return Err(self.err(
                                format!("camera.{name}"),
                                format!("not used by cameras of type `{kind}`"),
                            ));
                        }
                    }
                }
                (Some(lens), None, None, None)
            }
            "dual_fisheye" => {
                let fisheye: FisheyeKeys = self.typed_keys("camera", &c.keys, unknown)?;
                (None, Some(fisheye), None, None)
            }
            "orthographic" => {
                let ortho: OrthoKeys = self.typed_keys("camera", &c.keys, unknown)?;
                (None, None, Some(ortho), None)
            }
            "calibrated" => {
                let keys: CalibratedKeys = self.typed_keys("camera", &c.keys, unknown)?;
                (None, None, None, Some(keys))
            }
            _ => {
                let _: EquirectKeys = self.typed_keys("camera", &c.keys, unknown)?;
                (None, None, None, None)
            }
        })
    }

    /// A calibrated camera: `fx` and `fy` are required, the principal point
    /// defaults to the image's centre, the skew to 0, the distortion to none.
    fn calibrated_camera(
        &self,
        k: &CalibratedKeys,
        pose: Pose,
        (w, h): (u32, u32),
    ) -> Result<CalibratedCamera> {
        let get = |name: &str, v: Option<f64>, default: Option<f64>| -> Result<f64> {
            let field = format!("camera.{name}");
            match v.or(default) {
                Some(x) if x.is_finite() => Ok(x),
                Some(x) => Err(self.err(field, format!("must be a finite number, got {x}"))),
                None => Err(self.err(
                    field,
                    "required for a calibrated camera (pixels: the focal length times the \
                     pixels per unit of sensor, as a calibration gives it)",
                )),
            }
        };
        let intrinsics = Intrinsics {
            fx: get("fx", k.fx, None)?,
            fy: get("fy", k.fy, None)?,
            cx: get("cx", k.cx, Some(w as f64 / 2.0 - 0.5))?,
            cy: get("cy", k.cy, Some(h as f64 / 2.0 - 0.5))?,
            skew: get("skew", k.skew, Some(0.0))?,
        };
        let coefficients = k.coefficients.as_deref().unwrap_or(&[]);
        let distortion = match k.distortion.as_deref().unwrap_or("none") {
            "none" if coefficients.is_empty() => LensDistortion::None,
            "none" => {
                return Err(self.err(
                    "camera.coefficients",
                    "given with distortion = \"none\": name the model \
                     (distortion = \"brown_conrady\" or \"fisheye\")",
                ))
            }
            "brown_conrady" => LensDistortion::brown_conrady(coefficients)
                .map_err(|e| self.err("camera.coefficients", e.to_string()))?,
            "fisheye" => LensDistortion::fisheye(coefficients)
                .map_err(|e| self.err("camera.coefficients", e.to_string()))?,
            other => {
                return Err(self.err(
                    "camera.distortion",
                    format!(
                        "unknown distortion model `{other}` (known: none, brown_conrady \
                         (OpenCV's default, rational and thin-prism models), fisheye (OpenCV's \
                         cv::fisheye))"
                    ),
                ))
            }
        };
        CalibratedCamera::new(pose, w, h, intrinsics, distortion).map_err(|e| {
            let field = match &e {
                CameraError::BadIntrinsic(key, _) => format!("camera.{key}"),
                _ => "camera".to_string(),
            };
            self.err(field, e.to_string())
        })
    }

    /// The preset the lens keys name, if any.
    fn camera_preset_named(
        &self,
        lens: Option<&LensKeys>,
    ) -> Result<Option<&'static CameraPreset>> {
        Ok(match lens.and_then(|l| l.preset.as_ref()) {
            Some(name) => Some(camera_preset(name).ok_or_else(|| {
                let known: Vec<_> = PRESETS.iter().map(|p| p.name).collect();
                self.err(
                    "camera.preset",
                    format!("unknown preset `{name}` (known: {})", known.join(", ")),
                )
            })?),
            None => None,
        })
    }

    /// The camera's pose: look-at or a camera-to-world matrix (a camera with
    /// a path may leave its pose to the first key).
    fn camera_pose(&self, c: &CameraSection) -> Result<Pose> {
        Ok(match &c.to_world {
            Some(m) => {
                for (name, present) in [
                    ("position", c.position.is_some()),
                    ("look_at", c.look_at.is_some()),
                    ("up", c.up.is_some()),
                ] {
                    if present {
                        return Err(self.err(
                            format!("camera.{name}"),
                            "give either to_world or position/look_at/up, not both",
                        ));
                    }
                }
                for (r, row) in m.iter().enumerate() {
                    for (k, x) in row.iter().enumerate() {
                        self.finite(&format!("camera.to_world[{r}][{k}]"), *x)?;
                    }
                }
                Pose::from_matrix(*m).map_err(|e| self.err("camera.to_world", e.to_string()))?
            }
            None => {
                let get = |name: &str, v: Option<[f32; 3]>| -> Result<Vec3> {
                    let v = v.ok_or_else(|| {
                        self.err(
                            format!("camera.{name}"),
                            "required (give position, look_at and up, or to_world)",
                        )
                    })?;
                    self.vec3(&format!("camera.{name}"), v)
                };
                let first = c.path.as_ref().and_then(|p| p.first());
                let position = match (c.position, first) {
                    (None, Some(k)) => self.vec3("camera.path[0].position", k.position)?,
                    _ => get("position", c.position)?,
                };
                let look_at = match (c.look_at, first) {
                    (None, Some(k)) => self.vec3("camera.path[0].look_at", k.look_at)?,
                    _ => get("look_at", c.look_at)?,
                };
                let up = match (c.up, first.and_then(|k| k.up)) {
                    (None, Some(u)) => self.vec3("camera.path[0].up", u)?,
                    (None, None) if first.is_some() => Vec3::Y,
                    _ => get("up", c.up)?,
                };
                Pose::look_at(position, look_at, up).map_err(|e| {
                    let field = match e {
                        CameraError::NoViewDirection => "camera.look_at",
                        _ => "camera.up",
                    };
                    self.err(field, e.to_string())
                })?
            }
        })
    }

    /// The image size in pixels: `resolution`, or the preset's.
    fn camera_size(
        &self,
        c: &CameraSection,
        preset: Option<&'static CameraPreset>,
    ) -> Result<(u32, u32)> {
        Ok(match (c.resolution, preset) {
            (Some(r), _) => (
                self.positive_count("camera.resolution[0]", r[0], 1 << 16)?,
                self.positive_count("camera.resolution[1]", r[1], 1 << 16)?,
            ),
            (None, Some(p)) => (p.width, p.height),
            (None, None) => {
                return Err(self.err(
                    "camera.resolution",
                    "required: [width, height] in pixels (or a preset)",
                ))
            }
        })
    }

    /// A pinhole or thin-lens camera: field of view, zoom, and the thin
    /// lens's aperture and focus distance.
    fn perspective_camera(
        &self,
        c: &CameraSection,
        kind: &str,
        lens: &LensKeys,
        preset: Option<&'static CameraPreset>,
        pose: Pose,
        (w, h): (u32, u32),
    ) -> Result<Camera> {
        let fov = self.perspective_fov(lens, preset)?;
        let zoom = match lens.zoom {
            Some(z) => self.finite("camera.zoom", z)?,
            None => preset.map_or(1.0, |p| p.zoom),
        };
        let pinhole = PinholeCamera::new(pose, fov, zoom, w, h)
            .map_err(|e| self.err(camera_field(&e, "camera"), e.to_string()))?;
        if kind == "pinhole" {
            return Ok(Camera::Pinhole(pinhole));
        }
        let radius = lens.aperture_radius.ok_or_else(|| {
            self.err(
                "camera.aperture_radius",
                "required for a thin_lens camera (scene units)",
            )
        })?;
        let radius = self.finite("camera.aperture_radius", radius)?;
        let focus =
            match (lens.focus_distance, c.look_at) {
                (Some(d), _) => self.finite("camera.focus_distance", d)?,
                (None, Some(l)) => (Vec3::from_array(l) - pose.position).length(),
                (None, None) => return Err(self.err(
                    "camera.focus_distance",
                    "required with to_world (with look_at it defaults to the distance to look_at)",
                )),
            };
        Ok(Camera::ThinLens(
            ThinLensCamera::new(pinhole, radius, focus)
                .map_err(|e| self.err(camera_field(&e, "camera"), e.to_string()))?,
        ))
    }

    /// The camera path of `[[camera.path]]`, if any.
    pub(super) fn camera_path(&self, c: &CameraSection) -> Result<Option<CameraPath>> {
        let Some(keys) = &c.path else {
            return Ok(None);
        };
        if c.to_world.is_some() {
            return Err(self.err(
                "camera.path",
                "a path is made of look-at poses: give it with position/look_at/up, not to_world",
            ));
        }
        let default_up = match c.up {
            Some(u) => self.vec3("camera.up", u)?,
            None => Vec3::Y,
        };
        let mut path = Vec::with_capacity(keys.len());
        for (i, k) in keys.iter().enumerate() {
            let field = format!("camera.path[{i}]");
            if !(0..=MAX_FRAME as i64).contains(&k.frame) {
                return Err(self.err(
                    format!("{field}.frame"),
                    format!("must be between 0 and {MAX_FRAME}, got {}", k.frame),
                ));
            }
            path.push(PathKey {
                frame: k.frame as u32,
                position: self.vec3(&format!("{field}.position"), k.position)?,
                look_at: self.vec3(&format!("{field}.look_at"), k.look_at)?,
                up: match k.up {
                    Some(u) => self.vec3(&format!("{field}.up"), u)?,
                    None => default_up,
                },
            });
        }
        CameraPath::new(path).map(Some).map_err(|e| {
            let field = match &e {
                CameraPathError::Empty => "camera.path".to_string(),
                CameraPathError::FrameTooLarge { key, .. }
                | CameraPathError::NotIncreasing { key, .. } => {
                    format!("camera.path[{key}].frame")
                }
                CameraPathError::BadPose { .. } => "camera.path".to_string(),
            };
            self.err(field, e.to_string())
        })
    }

    /// The field of view of a perspective camera: from the preset, or from
    /// exactly one of vfov, hfov and focal_length.
    pub(super) fn perspective_fov(
        &self,
        c: &LensKeys,
        preset: Option<&CameraPreset>,
    ) -> Result<Fov> {
        let given: Vec<&str> = [
            ("vfov", c.vfov.is_some()),
            ("hfov", c.hfov.is_some()),
            ("focal_length", c.focal_length.is_some()),
        ]
        .iter()
        .filter(|(_, p)| *p)
        .map(|(n, _)| *n)
        .collect();
        if let Some(p) = preset {
            let sensor = [
                ("sensor_height", c.sensor_height.is_some()),
                ("sensor_width", c.sensor_width.is_some()),
            ];
            if let Some(name) = given
                .first()
                .copied()
                .or_else(|| sensor.iter().find(|(_, b)| *b).map(|(n, _)| *n))
            {
                return Err(self.err(
                    format!("camera.{name}"),
                    format!(
                        "the preset `{}` fixes the field of view (use zoom to change it)",
                        p.name
                    ),
                ));
            }
            return Ok(Fov::Vertical(p.vfov_deg));
        }
        if given.len() > 1 {
            let msg = if given == ["vfov", "focal_length"] {
                "give either vfov or focal_length, not both".to_string()
            } else {
                format!(
                    "give only one of vfov, hfov and focal_length, not {}",
                    given.join(" and ")
                )
            };
            return Err(self.err(format!("camera.{}", given[1]), msg));
        }
        if c.focal_length.is_none() {
            for (name, present) in [
                ("sensor_height", c.sensor_height.is_some()),
                ("sensor_width", c.sensor_width.is_some()),
            ] {
                if present {
                    return Err(self.err(format!("camera.{name}"), "only used with focal_length"));
                }
            }
        }
        if let Some(v) = c.vfov {
            return Ok(Fov::Vertical(self.fov_degrees("camera.vfov", v)?));
        }
        if let Some(v) = c.hfov {
            return Ok(Fov::Horizontal(self.fov_degrees("camera.hfov", v)?));
        }
        let Some(f) = c.focal_length else {
            return Err(self.err(
                "camera.vfov",
                "give vfov or hfov (degrees) or focal_length (mm)",
            ));
        };
        let f = self.positive("camera.focal_length", f)?;
        match (c.sensor_height, c.sensor_width) {
            (Some(_), Some(_)) => Err(self.err(
                "camera.sensor_width",
                "give either sensor_height or sensor_width, not both",
            )),
            (None, Some(sw)) => {
                let sw = self.positive("camera.sensor_width", sw)?;
                Ok(Fov::Horizontal(fov_from_focal_length(f, sw)))
            }
            (sh, None) => {
                let sh = self.positive(
                    "camera.sensor_height",
                    sh.unwrap_or(DEFAULT_SENSOR_HEIGHT_MM),
                )?;
                Ok(Fov::Vertical(fov_from_focal_length(f, sh)))
            }
        }
    }
}

/// The scene field a camera's construction error is about (`default` when
/// no one field is).
fn camera_field(e: &CameraError, default: &'static str) -> &'static str {
    match e {
        CameraError::BadFov(_) => "camera.vfov",
        CameraError::BadZoom(_) => "camera.zoom",
        CameraError::EmptyImage => "camera.resolution",
        CameraError::BadAperture(_) => "camera.aperture_radius",
        CameraError::BadFocusDistance(_) => "camera.focus_distance",
        CameraError::BadFisheyeFov(_) => "camera.fov",
        CameraError::BadViewSize(_) => "camera.view_width",
        CameraError::TooFar(_) => "camera.position",
        _ => default,
    }
}
