//! Scene files: TOML (or JSON with the same schema), documented with an
//! example of every item in `docs/scene-format.md`.
//!
//! Parsing is strict: unknown keys, wrong types, non-finite numbers and
//! out-of-range values are errors that name the file and the field
//! (`shapes[2].transform.scale`). Paths inside a scene file are relative to
//! the file's directory.

use super::shapes::{self, flip_winding, transform_mesh};
use super::{Emission, Material, MaterialTextures, Mesh, SceneDescription};
use crate::bsdf::{
    BlinnPhongParams, Bsdf, CookTorranceParams, DielectricParams, Distribution, Fresnel,
    Microfacet, PrincipledParams,
};
use crate::camera::{
    fov_from_focal_length, preset as camera_preset, Camera, CameraError, CameraPreset,
    DualFisheyeCamera, EquirectCamera, Fov, PinholeCamera, Pose, ThinLensCamera, PRESETS,
};
use crate::color::{MAX_TEMPERATURE_K, MIN_TEMPERATURE_K};
use crate::error::{Error, Result};
use crate::film::{CameraExposure, FilmSettings};
use crate::filter::{GaussianFilter, PixelFilter, DEFAULT_GAUSSIAN_RADIUS, DEFAULT_GAUSSIAN_SIGMA};
use crate::job::RenderJob;
use crate::light::{EnvironmentLight, PointLight};
use crate::texture::{self, Encoding, ImageTexture};
use glam::{Mat4, Quat, Vec2, Vec3};
use serde::Deserialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Default sensor height (mm) when a camera gives `focal_length` alone: 35 mm film.
pub const DEFAULT_SENSOR_HEIGHT_MM: f32 = 24.0;

/// Default field of view of each lens of a dual-fisheye camera, degrees.
pub const DEFAULT_FISHEYE_FOV_DEG: f32 = 190.0;

/// Default albedo of OBJ objects whose MTL material has no `Kd`.
pub const DEFAULT_REFLECTANCE: f32 = 0.8;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    #[serde(default)]
    render: RenderSection,
    camera: CameraSection,
    #[serde(default)]
    film: FilmSection,
    environment: Option<EnvironmentSection>,
    #[serde(default)]
    materials: Vec<MaterialSection>,
    #[serde(default)]
    shapes: Vec<ShapeSection>,
    #[serde(default)]
    lights: Vec<LightSection>,
    #[serde(default)]
    pls: Vec<PlsSection>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlsSection {
    file: PathBuf,
    nf: Option<u32>,
    transform: Option<TransformSection>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RenderSection {
    spp: Option<i64>,
    max_depth: Option<i64>,
    seed: Option<u64>,
    robust: Option<bool>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraSection {
    #[serde(rename = "type", default = "pinhole")]
    kind: String,
    preset: Option<String>,
    position: Option<[f32; 3]>,
    look_at: Option<[f32; 3]>,
    up: Option<[f32; 3]>,
    to_world: Option<[[f32; 4]; 4]>,
    vfov: Option<f32>,
    hfov: Option<f32>,
    focal_length: Option<f32>,
    sensor_height: Option<f32>,
    sensor_width: Option<f32>,
    zoom: Option<f32>,
    aperture_radius: Option<f32>,
    focus_distance: Option<f32>,
    fov: Option<f32>,
    resolution: Option<[i64; 2]>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct FilmSection {
    filter: Option<String>,
    filter_sigma: Option<f32>,
    filter_radius: Option<f32>,
    exposure_ev: Option<f32>,
    shutter: Option<f32>,
    iso: Option<f32>,
    f_number: Option<f32>,
    white_balance: Option<f32>,
}

fn pinhole() -> String {
    "pinhole".into()
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct EnvironmentSection {
    file: Option<PathBuf>,
    radiance: Option<[f32; 3]>,
    up: Option<[f32; 3]>,
    forward: Option<[f32; 3]>,
    scale: Option<f32>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialSection {
    name: String,
    #[serde(rename = "type")]
    kind: String,
    reflectance: Option<[f32; 3]>,
    diffuse: Option<[f32; 3]>,
    specular: Option<toml::Value>,
    exponent: Option<f32>,
    distribution: Option<String>,
    roughness: Option<f32>,
    alpha: Option<f32>,
    alpha_u: Option<f32>,
    alpha_v: Option<f32>,
    fresnel: Option<String>,
    f0: Option<[f32; 3]>,
    ior: Option<f32>,
    metal: Option<String>,
    eta: Option<[f32; 3]>,
    k: Option<[f32; 3]>,
    base_color: Option<[f32; 3]>,
    metallic: Option<f32>,
    anisotropic: Option<f32>,
    spec_tint: Option<f32>,
    energy_conserving: Option<bool>,
    base_color_map: Option<PathBuf>,
    roughness_map: Option<PathBuf>,
    metallic_map: Option<PathBuf>,
}

impl MaterialSection {
    /// The keys given, besides `name` and `type`.
    fn given(&self) -> Vec<&'static str> {
        let keys: [(&'static str, bool); 23] = [
            ("base_color_map", self.base_color_map.is_some()),
            ("roughness_map", self.roughness_map.is_some()),
            ("metallic_map", self.metallic_map.is_some()),
            ("reflectance", self.reflectance.is_some()),
            ("diffuse", self.diffuse.is_some()),
            ("specular", self.specular.is_some()),
            ("exponent", self.exponent.is_some()),
            ("distribution", self.distribution.is_some()),
            ("roughness", self.roughness.is_some()),
            ("alpha", self.alpha.is_some()),
            ("alpha_u", self.alpha_u.is_some()),
            ("alpha_v", self.alpha_v.is_some()),
            ("fresnel", self.fresnel.is_some()),
            ("f0", self.f0.is_some()),
            ("ior", self.ior.is_some()),
            ("metal", self.metal.is_some()),
            ("eta", self.eta.is_some()),
            ("k", self.k.is_some()),
            ("base_color", self.base_color.is_some()),
            ("metallic", self.metallic.is_some()),
            ("anisotropic", self.anisotropic.is_some()),
            ("spec_tint", self.spec_tint.is_some()),
            ("energy_conserving", self.energy_conserving.is_some()),
        ];
        keys.iter().filter(|(_, g)| *g).map(|(k, _)| *k).collect()
    }
}

/// Complex indices of refraction `(eta, k)` of common metals at the red,
/// green and blue primaries (about 650, 550 and 450 nm).
pub const METALS: [(&str, [f32; 3], [f32; 3]); 4] = [
    ("Au", [0.143, 0.374, 1.442], [3.983, 2.385, 1.603]),
    ("Ag", [0.155, 0.117, 0.138], [4.828, 3.122, 2.147]),
    ("Cu", [0.200, 0.924, 1.102], [3.912, 2.452, 2.142]),
    ("Al", [1.657, 0.880, 0.521], [9.224, 6.270, 4.837]),
];

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ShapeSection {
    #[serde(rename = "type")]
    kind: String,
    name: Option<String>,
    file: Option<PathBuf>,
    center: Option<[f32; 3]>,
    radius: Option<f32>,
    subdivisions: Option<u32>,
    flip_normals: Option<bool>,
    material: Option<String>,
    transform: Option<TransformSection>,
    emission: Option<[f32; 3]>,
    two_sided: Option<bool>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TransformSection {
    translate: Option<[f32; 3]>,
    rotate: Option<RotateSection>,
    scale: Option<ScaleValue>,
    matrix: Option<[[f32; 4]; 4]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RotateSection {
    axis: [f32; 3],
    angle: f32,
}

#[derive(Debug, Deserialize)]
#[serde(untagged, expecting = "a number or an array of three numbers")]
enum ScaleValue {
    Uniform(f32),
    PerAxis([f32; 3]),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LightSection {
    #[serde(rename = "type")]
    kind: String,
    position: Option<[f32; 3]>,
    intensity: Option<[f32; 3]>,
}

/// Reads and validates a scene file; TOML unless the extension is `.json`.
pub fn load(path: &Path) -> Result<SceneDescription> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
        file: path.to_path_buf(),
        source,
    })?;
    let is_json = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let parsed: SceneFile = if is_json {
        serde_json::from_str(&text).map_err(|e| Error::input(path, "", e.to_string()))?
    } else {
        toml::from_str(&text).map_err(|e| {
            let (field, at) = e
                .span()
                .map(|s| {
                    let line = text[..s.start].matches('\n').count() + 1;
                    let col = s.start - text[..s.start].rfind('\n').map_or(0, |i| i + 1) + 1;
                    (
                        field_at(&text, s.start),
                        format!("line {line}, column {col}: "),
                    )
                })
                .unwrap_or_default();
            Error::input(path, field, format!("{at}{}", e.message().trim_end()))
        })?
    };
    let base = path.parent().unwrap_or(Path::new("."));
    Builder { file: path, base }.build(parsed)
}

/// The table name of a TOML header line (`[a.b]` or `[[a]]`), with whether
/// it is an array-of-tables header; `None` for any other line (including the
/// rows of a multi-line array such as `[1, 0, 0, 0],`).
fn table_header(line: &str) -> Option<(String, bool)> {
    let l = line.split('#').next().unwrap_or("").trim();
    let (inner, array) = if let Some(r) = l.strip_prefix("[[") {
        (r.strip_suffix("]]")?, true)
    } else {
        (l.strip_prefix('[')?.strip_suffix(']')?, false)
    };
    let inner = inner.trim();
    let valid = inner
        .chars()
        .all(|c| c.is_alphanumeric() || matches!(c, '_' | '-' | '.' | '"' | ' '));
    let starts_well = inner
        .chars()
        .next()
        .is_some_and(|c| c.is_alphabetic() || c == '_' || c == '"');
    (valid && starts_well).then(|| (inner.replace(' ', ""), array))
}

/// Best-effort dotted path (`shapes[2].transform.scale`) of the key at byte
/// `offset` of a TOML text, from the table headers up to its line and the
/// key on that line; empty when it cannot tell.
fn field_at(text: &str, offset: usize) -> String {
    let offset = offset.min(text.len());
    let line_start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let line_end = text[line_start..]
        .find('\n')
        .map_or(text.len(), |i| line_start + i);
    let mut table = String::new();
    let mut arrays: HashMap<String, usize> = HashMap::new();
    // Headers up to and including the error's line (a missing key is
    // reported at its table's header).
    for l in text[..line_end].lines() {
        let Some((name, array)) = table_header(l) else {
            continue;
        };
        if array {
            let n = arrays.entry(name.clone()).or_insert(0);
            table = format!("{name}[{n}]");
            *n += 1;
        } else {
            // `[shapes.transform]` after `[[shapes]]` is in the last shape.
            let (head, rest) = name.split_once('.').unwrap_or((&name, ""));
            table = match arrays.get(head) {
                Some(&n) if n > 0 && !rest.is_empty() => format!("{head}[{}].{rest}", n - 1),
                _ => name.clone(),
            };
        }
    }
    let line = &text[line_start..line_end];
    let key = if table_header(line).is_some() {
        ""
    } else {
        line.split_once('=')
            .map(|(k, _)| k.trim())
            .filter(|k| {
                !k.is_empty()
                    && k.chars()
                        .all(|c| c.is_alphanumeric() || matches!(c, '_' | '-' | '.' | '"'))
            })
            .unwrap_or("")
    };
    match (table.is_empty(), key.is_empty()) {
        (_, true) => table,
        (true, false) => key.to_string(),
        (false, false) => format!("{table}.{key}"),
    }
}

struct Builder<'a> {
    file: &'a Path,
    base: &'a Path,
}

impl Builder<'_> {
    fn err(&self, field: impl Into<String>, message: impl Into<String>) -> Error {
        Error::input(self.file, field, message)
    }

    fn finite(&self, field: &str, v: f32) -> Result<f32> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(field, format!("must be a finite number, got {v}")))
        }
    }

    fn vec3(&self, field: &str, v: [f32; 3]) -> Result<Vec3> {
        for (i, x) in v.iter().enumerate() {
            if !x.is_finite() {
                return Err(self.err(
                    format!("{field}[{i}]"),
                    format!("must be a finite number, got {x}"),
                ));
            }
        }
        Ok(Vec3::from_array(v))
    }

    fn colour(&self, field: &str, v: [f32; 3], max: Option<f32>) -> Result<Vec3> {
        let c = self.vec3(field, v)?;
        if c.min_element() < 0.0 {
            return Err(self.err(field, format!("must not be negative, got {v:?}")));
        }
        if let Some(max) = max {
            if c.max_element() > max {
                return Err(self.err(field, format!("must be at most {max}, got {v:?}")));
            }
        }
        Ok(c)
    }

    /// A unit-interval parameter (default `default` when absent).
    fn unit(&self, field: &str, v: Option<f32>, default: f32) -> Result<f32> {
        let v = self.finite(field, v.unwrap_or(default))?;
        if !(0.0..=1.0).contains(&v) {
            return Err(self.err(field, format!("must be in [0, 1], got {v}")));
        }
        Ok(v)
    }

    /// The microfacet distribution of a material: `distribution` (`ggx` or
    /// `beckmann`) and `roughness` (α = roughness²), `alpha`, or
    /// `alpha_u`/`alpha_v` (anisotropic).
    fn microfacet(
        &self,
        field: &str,
        m: &MaterialSection,
        default_roughness: Option<f32>,
    ) -> Result<Option<Microfacet>> {
        let kind = match m.distribution.as_deref().unwrap_or("ggx") {
            "ggx" => Distribution::Ggx,
            "beckmann" => Distribution::Beckmann,
            other => {
                return Err(self.err(
                    format!("{field}.distribution"),
                    format!("unknown distribution `{other}` (known: ggx, beckmann)"),
                ))
            }
        };
        let given = [
            m.roughness.is_some(),
            m.alpha.is_some(),
            m.alpha_u.is_some() || m.alpha_v.is_some(),
        ];
        if given.iter().filter(|&&g| g).count() > 1 {
            return Err(self.err(
                format!("{field}.roughness"),
                "give one of roughness, alpha, or alpha_u with alpha_v",
            ));
        }
        let alpha = |name: &str, v: f32| -> Result<f32> {
            let v = self.finite(&format!("{field}.{name}"), v)?;
            if !(0.0..=4.0).contains(&v) {
                return Err(self.err(
                    format!("{field}.{name}"),
                    format!("must be in [0, 4], got {v}"),
                ));
            }
            Ok(v)
        };
        let (ax, ay) = if let Some(r) = m.roughness {
            let r = self.unit(&format!("{field}.roughness"), Some(r), 0.0)?;
            (r * r, r * r)
        } else if let Some(a) = m.alpha {
            let a = alpha("alpha", a)?;
            (a, a)
        } else if m.alpha_u.is_some() || m.alpha_v.is_some() {
            let (Some(u), Some(v)) = (m.alpha_u, m.alpha_v) else {
                return Err(self.err(
                    format!("{field}.alpha_u"),
                    "alpha_u and alpha_v go together",
                ));
            };
            (alpha("alpha_u", u)?, alpha("alpha_v", v)?)
        } else if let Some(r) = default_roughness {
            (r * r, r * r)
        } else {
            if m.distribution.is_some() {
                return Err(self.err(
                    format!("{field}.distribution"),
                    "only used with a roughness",
                ));
            }
            return Ok(None);
        };
        Ok(Some(Microfacet::new(kind, ax, ay)))
    }

    /// Builds the BSDF of `materials[i]`; rejects keys the type does not use.
    fn material(&self, field: &str, m: &MaterialSection) -> Result<Bsdf> {
        let allowed: &[&str] = match m.kind.as_str() {
            "diffuse" => &["reflectance", "base_color_map"],
            "blinn_phong" => &["diffuse", "specular", "exponent", "base_color_map"],
            "cook_torrance" => &[
                "distribution",
                "roughness",
                "alpha",
                "alpha_u",
                "alpha_v",
                "fresnel",
                "f0",
                "ior",
                "metal",
                "eta",
                "k",
                "roughness_map",
            ],
            "dielectric" => &[
                "ior",
                "distribution",
                "roughness",
                "alpha",
                "alpha_u",
                "alpha_v",
            ],
            "principled" => &[
                "base_color",
                "roughness",
                "metallic",
                "anisotropic",
                "specular",
                "spec_tint",
                "energy_conserving",
                "base_color_map",
                "roughness_map",
                "metallic_map",
            ],
            other => {
                return Err(self.err(
                    format!("{field}.type"),
                    format!(
                        "unknown material type `{other}` (known: diffuse, blinn_phong, \
                         cook_torrance, dielectric, principled)"
                    ),
                ))
            }
        };
        if let Some(k) = m.given().into_iter().find(|k| !allowed.contains(k)) {
            return Err(self.err(
                format!("{field}.{k}"),
                format!(
                    "not a parameter of a `{}` material (its keys: {})",
                    m.kind,
                    allowed.join(", ")
                ),
            ));
        }
        let specular_number = |default: f32| -> Result<f32> {
            match &m.specular {
                None => Ok(default),
                Some(v) => match v.as_float().or_else(|| v.as_integer().map(|i| i as f64)) {
                    Some(x) => self.unit(&format!("{field}.specular"), Some(x as f32), default),
                    None => {
                        Err(self.err(format!("{field}.specular"), "must be a number in [0, 1]"))
                    }
                },
            }
        };
        let colour = |name: &str, v: Option<[f32; 3]>, default: f32| {
            self.colour(
                &format!("{field}.{name}"),
                v.unwrap_or([default; 3]),
                Some(1.0),
            )
        };
        let ior = |default: f32| -> Result<f32> {
            let v = self.finite(&format!("{field}.ior"), m.ior.unwrap_or(default))?;
            if v <= 0.0 || v == 1.0 {
                return Err(self.err(
                    format!("{field}.ior"),
                    format!("must be positive and not 1, got {v}"),
                ));
            }
            Ok(v)
        };
        Ok(match m.kind.as_str() {
            "diffuse" => Bsdf::diffuse(colour("reflectance", m.reflectance, DEFAULT_REFLECTANCE)?),
            "blinn_phong" => {
                let diffuse = colour("diffuse", m.diffuse, 0.5)?;
                let specular = match &m.specular {
                    None => Vec3::splat(0.2),
                    Some(v) => {
                        let arr: [f32; 3] = v.clone().try_into().map_err(|_| {
                            self.err(
                                format!("{field}.specular"),
                                "must be an RGB triple [r, g, b]",
                            )
                        })?;
                        colour("specular", Some(arr), 0.0)?
                    }
                };
                if (diffuse + specular).max_element() > 1.0 {
                    return Err(self.err(
                        format!("{field}.specular"),
                        "diffuse + specular must not exceed 1 in any channel (energy)",
                    ));
                }
                let exponent =
                    self.finite(&format!("{field}.exponent"), m.exponent.unwrap_or(30.0))?;
                if !(0.0..=1e5).contains(&exponent) {
                    return Err(self.err(
                        format!("{field}.exponent"),
                        format!("must be in [0, 100000], got {exponent}"),
                    ));
                }
                Bsdf::BlinnPhong(BlinnPhongParams {
                    diffuse,
                    specular,
                    exponent,
                })
            }
            "cook_torrance" => {
                let microfacet = self
                    .microfacet(field, m, Some(0.3))?
                    .expect("a default roughness");
                let fresnel = match m.fresnel.as_deref().unwrap_or("conductor") {
                    "schlick" => Fresnel::Schlick { f0: colour("f0", m.f0, 0.04)? },
                    "dielectric" => Fresnel::Dielectric { eta: ior(1.5)? },
                    "conductor" => {
                        let (eta, k) = match (&m.metal, m.eta, m.k) {
                            (Some(name), None, None) => {
                                let Some((_, e, k)) = METALS.iter().find(|(n, _, _)| n == name) else {
                                    return Err(self.err(
                                        format!("{field}.metal"),
                                        format!("unknown metal `{name}` (known: Au, Ag, Cu, Al)"),
                                    ));
                                };
                                (Vec3::from(*e), Vec3::from(*k))
                            }
                            (None, Some(e), Some(k)) => (
                                self.colour(&format!("{field}.eta"), e, None)?,
                                self.colour(&format!("{field}.k"), k, None)?,
                            ),
                            (None, None, None) => (Vec3::from(METALS[3].1), Vec3::from(METALS[3].2)),
                            _ => {
                                return Err(self.err(
                                    format!("{field}.metal"),
                                    "give either metal, or eta together with k",
                                ))
                            }
                        };
                        Fresnel::Conductor { eta, k }
                    }
                    other => {
                        return Err(self.err(
                            format!("{field}.fresnel"),
                            format!("unknown Fresnel term `{other}` (known: schlick, dielectric, conductor)"),
                        ))
                    }
                };
                let used = match fresnel {
                    Fresnel::Schlick { .. } => &["f0"][..],
                    Fresnel::Dielectric { .. } => &["ior"][..],
                    Fresnel::Conductor { .. } => &["metal", "eta", "k"][..],
                };
                if let Some(k) = ["f0", "ior", "metal", "eta", "k"]
                    .into_iter()
                    .find(|k| !used.contains(k) && m.given().contains(k))
                {
                    return Err(self.err(format!("{field}.{k}"), "not used by this Fresnel term"));
                }
                Bsdf::CookTorrance(CookTorranceParams {
                    microfacet,
                    fresnel,
                })
            }
            "dielectric" => Bsdf::Dielectric(DielectricParams {
                eta: ior(1.5)?,
                microfacet: self.microfacet(field, m, None)?,
            }),
            "principled" => {
                // The parser checks that each value is a finite number; the
                // ranges are the material's own rule.
                let number = |name: &str, v: Option<f32>, default: f32| {
                    self.finite(&format!("{field}.{name}"), v.unwrap_or(default))
                };
                let params = PrincipledParams {
                    base_color: colour("base_color", m.base_color, 0.5)?,
                    roughness: number("roughness", m.roughness, 0.5)?,
                    metallic: number("metallic", m.metallic, 0.0)?,
                    anisotropic: number("anisotropic", m.anisotropic, 0.0)?,
                    specular: specular_number(0.5)?,
                    spec_tint: number("spec_tint", m.spec_tint, 0.0)?,
                    energy_conserving: m.energy_conserving.unwrap_or(false),
                };
                Bsdf::Principled(params.validate().map_err(|e| {
                    self.err(
                        format!("{field}.{}", e.parameter),
                        format!("must be in {}, got {}", e.range, e.value),
                    )
                })?)
            }
            _ => unreachable!("checked above"),
        })
    }

    /// Loads the textures a material names (`*_map`, relative to the scene
    /// file); data maps must hold values in `[0, 1]`.
    fn material_textures(&self, field: &str, m: &MaterialSection) -> Result<MaterialTextures> {
        self.textures(
            field,
            m.base_color_map.as_ref().map(|p| self.base.join(p)),
            m.roughness_map.as_ref().map(|p| self.base.join(p)),
            m.metallic_map.as_ref().map(|p| self.base.join(p)),
            ["base_color_map", "roughness_map", "metallic_map"],
        )
    }

    /// Loads base colour (sRGB), roughness and metallic (linear) textures;
    /// `keys` name them in errors, under `field`.
    fn textures(
        &self,
        field: &str,
        base_color: Option<PathBuf>,
        roughness: Option<PathBuf>,
        metallic: Option<PathBuf>,
        keys: [&str; 3],
    ) -> Result<MaterialTextures> {
        let load = |path: Option<PathBuf>,
                    key: &str,
                    encoding: Encoding|
         -> Result<Option<Arc<ImageTexture>>> {
            let Some(path) = path else {
                return Ok(None);
            };
            let f = format!("{field}.{key}");
            let t = texture::load_for(self.file, &f, &path, encoding)?;
            if encoding == Encoding::Linear && t.max_value() > 1.0 {
                return Err(self.err(f, format!("{}: values must be in [0, 1]", path.display())));
            }
            Ok(Some(Arc::new(t)))
        };
        Ok(MaterialTextures {
            base_color: load(base_color, keys[0], Encoding::Srgb)?,
            roughness: load(roughness, keys[1], Encoding::Linear)?,
            metallic: load(metallic, keys[2], Encoding::Linear)?,
        })
    }

    /// The material of an MTL entry: `principled` when it has PBR keys
    /// (`Pr`, `Pm`, `map_Pr`, `map_Pm`), `blinn_phong` when it has a
    /// non-zero `Ks` (scaled down where `Kd + Ks` exceeds 1, to conserve
    /// energy), `diffuse` otherwise; `map_Kd` textures the base colour.
    fn mtl_material(
        &self,
        field: &str,
        name: String,
        mtl: &shapes::ObjMaterial,
    ) -> Result<Material> {
        let kd = mtl.diffuse.unwrap_or(Vec3::splat(DEFAULT_REFLECTANCE));
        let pbr = mtl.roughness.is_some()
            || mtl.metallic.is_some()
            || mtl.roughness_map.is_some()
            || mtl.metallic_map.is_some();
        let ks = mtl.specular.filter(|ks| ks.max_element() > 0.0);
        let bsdf = if pbr {
            Bsdf::Principled(PrincipledParams {
                base_color: kd,
                roughness: mtl.roughness.unwrap_or(0.5),
                metallic: mtl.metallic.unwrap_or(0.0),
                anisotropic: 0.0,
                specular: 0.5,
                spec_tint: 0.0,
                energy_conserving: false,
            })
        } else if let Some(ks) = ks {
            let total = (kd + ks).max_element();
            let scale = if total > 1.0 { 1.0 / total } else { 1.0 };
            Bsdf::BlinnPhong(BlinnPhongParams {
                diffuse: kd * scale,
                specular: ks * scale,
                exponent: mtl.shininess.unwrap_or(30.0).min(1e5),
            })
        } else {
            Bsdf::diffuse(kd)
        };
        let textures = self.textures(
            &format!("{field} (MTL `{}`)", mtl.name),
            mtl.diffuse_map.clone(),
            if pbr { mtl.roughness_map.clone() } else { None },
            if pbr { mtl.metallic_map.clone() } else { None },
            ["map_Kd", "map_Pr", "map_Pm"],
        )?;
        Ok(Material {
            name,
            bsdf,
            textures,
        })
    }

    fn positive_count(&self, field: &str, v: i64, max: i64) -> Result<u32> {
        if v < 1 || v > max {
            return Err(self.err(field, format!("must be between 1 and {max}, got {v}")));
        }
        Ok(v as u32)
    }

    fn build(&self, f: SceneFile) -> Result<SceneDescription> {
        let job = self.job(&f.render)?;
        let robust = f.render.robust.unwrap_or(false);
        let (camera, preset) = self.camera(&f.camera)?;
        let film = self.film(&f.film, preset)?;

        let mut materials = Vec::new();
        let mut by_name = HashMap::new();
        for (i, m) in f.materials.iter().enumerate() {
            let field = format!("materials[{i}]");
            if m.name.is_empty() || m.name.starts_with('(') {
                return Err(self.err(
                    format!("{field}.name"),
                    format!(
                        "`{}` is not a valid material name (empty, or reserved: starts with `(`)",
                        m.name
                    ),
                ));
            }
            if by_name.contains_key(&m.name) {
                return Err(self.err(
                    format!("{field}.name"),
                    format!("duplicate material name `{}`", m.name),
                ));
            }
            let bsdf = self.material(&field, m)?;
            by_name.insert(m.name.clone(), materials.len() as u32);
            let textures = self.material_textures(&field, m)?;
            materials.push(Material {
                name: m.name.clone(),
                bsdf,
                textures,
            });
        }

        let mut meshes = Vec::new();
        for (i, s) in f.shapes.iter().enumerate() {
            self.shape(i, s, &by_name, &mut materials, &mut meshes)?;
        }

        let mut point_lights = Vec::new();
        for (i, l) in f.lights.iter().enumerate() {
            let field = format!("lights[{i}]");
            match l.kind.as_str() {
                "point" => {
                    let position = l.position.ok_or_else(|| {
                        self.err(format!("{field}.position"), "required for a point light")
                    })?;
                    let intensity = l.intensity.ok_or_else(|| {
                        self.err(format!("{field}.intensity"), "required for a point light")
                    })?;
                    point_lights.push(PointLight {
                        position: self.vec3(&format!("{field}.position"), position)?,
                        intensity: self.colour(&format!("{field}.intensity"), intensity, None)?,
                    });
                }
                other => {
                    return Err(self.err(
                        format!("{field}.type"),
                        format!("unknown light type `{other}` (known: point)"),
                    ))
                }
            }
        }

        for (i, section) in f.pls.iter().enumerate() {
            self.pls(i, section, &mut materials, &mut meshes)?;
        }

        let environment = match &f.environment {
            Some(e) => Some(self.environment(e)?),
            None => None,
        };

        Ok(SceneDescription {
            meshes,
            materials,
            point_lights,
            environment,
            camera,
            film,
            job,
            robust,
        })
    }

    /// The `[environment]`: an equirectangular image (`file`, EXR or
    /// Radiance HDR) oriented by `up` and `forward`, or a constant
    /// `radiance`; times `scale`.
    fn environment(&self, e: &EnvironmentSection) -> Result<EnvironmentLight> {
        let scale = self.finite("environment.scale", e.scale.unwrap_or(1.0))?;
        if scale < 0.0 {
            return Err(self.err(
                "environment.scale",
                format!("must not be negative, got {scale}"),
            ));
        }
        match (&e.file, e.radiance) {
            (Some(_), Some(_)) => Err(self.err(
                "environment.radiance",
                "give either file or radiance, not both",
            )),
            (None, None) => Err(self.err(
                "environment.file",
                "give an image file or a constant radiance",
            )),
            (None, Some(r)) => {
                for (k, present) in [("up", e.up.is_some()), ("forward", e.forward.is_some())] {
                    if present {
                        return Err(
                            self.err(format!("environment.{k}"), "only used with an image file")
                        );
                    }
                }
                Ok(EnvironmentLight::constant(
                    self.colour("environment.radiance", r, None)? * scale,
                ))
            }
            (Some(rel), None) => {
                let up = e.up.ok_or_else(|| {
                    self.err(
                        "environment.up",
                        "required with an image file: the world direction of its top row",
                    )
                })?;
                let forward = e.forward.ok_or_else(|| {
                    self.err(
                        "environment.forward",
                        "required with an image file: the world direction of its centre column",
                    )
                })?;
                let up = self.vec3("environment.up", up)?;
                let forward = self.vec3("environment.forward", forward)?;
                let frame = crate::equirect::SphereFrame::new(up, forward).ok_or_else(|| {
                    self.err("environment.forward", "must not be zero or parallel to up")
                })?;
                let path = self.base.join(rel);
                checked_environment(&path, frame, scale)
                    .map_err(|m| self.err("environment.file", m))
            }
        }
    }

    fn job(&self, r: &RenderSection) -> Result<RenderJob> {
        let d = RenderJob::default();
        Ok(RenderJob {
            spp: match r.spp {
                Some(v) => self.positive_count("render.spp", v, 1 << 24)?,
                None => d.spp,
            },
            max_depth: match r.max_depth {
                Some(v) => self.positive_count("render.max_depth", v, 1024)?,
                None => d.max_depth,
            },
            seed: r.seed.unwrap_or(d.seed),
            sample_start: 0,
        })
    }

    fn positive(&self, field: &str, v: f32) -> Result<f32> {
        let v = self.finite(field, v)?;
        if v <= 0.0 {
            return Err(self.err(field, format!("must be positive, got {v}")));
        }
        Ok(v)
    }

    fn fov_degrees(&self, field: &str, v: f32) -> Result<f32> {
        let v = self.finite(field, v)?;
        if !(v > 0.0 && v < 180.0) {
            return Err(self.err(field, format!("must be in (0, 180) degrees, got {v}")));
        }
        Ok(v)
    }

    /// The camera, and the preset it names (whose photographic settings are
    /// the `[film]` defaults).
    fn camera(&self, c: &CameraSection) -> Result<(Camera, Option<&'static CameraPreset>)> {
        const TYPES: &str = "pinhole, thin_lens, equirectangular, dual_fisheye";
        let kind = c.kind.as_str();
        if !matches!(
            kind,
            "pinhole" | "thin_lens" | "equirectangular" | "dual_fisheye"
        ) {
            return Err(self.err(
                "camera.type",
                format!("unknown camera type `{kind}` (known: {TYPES})"),
            ));
        }
        let perspective = matches!(kind, "pinhole" | "thin_lens");
        let unused = |name: &str, present: bool| -> Result<()> {
            if present {
                Err(self.err(
                    format!("camera.{name}"),
                    format!("not used by cameras of type `{kind}`"),
                ))
            } else {
                Ok(())
            }
        };
        if !perspective {
            for (name, present) in [
                ("preset", c.preset.is_some()),
                ("vfov", c.vfov.is_some()),
                ("hfov", c.hfov.is_some()),
                ("focal_length", c.focal_length.is_some()),
                ("sensor_height", c.sensor_height.is_some()),
                ("sensor_width", c.sensor_width.is_some()),
                ("zoom", c.zoom.is_some()),
            ] {
                unused(name, present)?;
            }
        }
        if kind != "thin_lens" {
            unused("aperture_radius", c.aperture_radius.is_some())?;
            unused("focus_distance", c.focus_distance.is_some())?;
        }
        if kind != "dual_fisheye" {
            unused("fov", c.fov.is_some())?;
        }
        let preset = match &c.preset {
            Some(name) => Some(camera_preset(name).ok_or_else(|| {
                let known: Vec<_> = PRESETS.iter().map(|p| p.name).collect();
                self.err(
                    "camera.preset",
                    format!("unknown preset `{name}` (known: {})", known.join(", ")),
                )
            })?),
            None => None,
        };

        // Pose: look-at or a camera-to-world matrix.
        let pose = match &c.to_world {
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
                let position = get("position", c.position)?;
                let look_at = get("look_at", c.look_at)?;
                let up = get("up", c.up)?;
                Pose::look_at(position, look_at, up).map_err(|e| {
                    let field = match e {
                        CameraError::NoViewDirection => "camera.look_at",
                        _ => "camera.up",
                    };
                    self.err(field, e.to_string())
                })?
            }
        };

        let (w, h) = match (c.resolution, preset) {
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
        };
        let field_of = |e: &CameraError, default: &'static str| match e {
            CameraError::BadFov(_) => "camera.vfov",
            CameraError::BadZoom(_) => "camera.zoom",
            CameraError::EmptyImage => "camera.resolution",
            CameraError::BadAperture(_) => "camera.aperture_radius",
            CameraError::BadFocusDistance(_) => "camera.focus_distance",
            CameraError::BadFisheyeFov(_) => "camera.fov",
            _ => default,
        };

        let camera = match kind {
            "equirectangular" => Camera::Equirect(
                EquirectCamera::new(pose, w, h)
                    .map_err(|e| self.err(field_of(&e, "camera"), e.to_string()))?,
            ),
            "dual_fisheye" => {
                let fov = self.finite("camera.fov", c.fov.unwrap_or(DEFAULT_FISHEYE_FOV_DEG))?;
                Camera::DualFisheye(
                    DualFisheyeCamera::new(pose, fov, w, h)
                        .map_err(|e| self.err(field_of(&e, "camera"), e.to_string()))?,
                )
            }
            _ => {
                let fov = self.perspective_fov(c, preset)?;
                let zoom = match c.zoom {
                    Some(z) => self.finite("camera.zoom", z)?,
                    None => preset.map_or(1.0, |p| p.zoom),
                };
                let pinhole = PinholeCamera::new(pose, fov, zoom, w, h)
                    .map_err(|e| self.err(field_of(&e, "camera"), e.to_string()))?;
                if kind == "pinhole" {
                    Camera::Pinhole(pinhole)
                } else {
                    let radius = c.aperture_radius.ok_or_else(|| {
                        self.err(
                            "camera.aperture_radius",
                            "required for a thin_lens camera (scene units)",
                        )
                    })?;
                    let radius = self.finite("camera.aperture_radius", radius)?;
                    let focus = match (c.focus_distance, c.look_at) {
                        (Some(d), _) => self.finite("camera.focus_distance", d)?,
                        (None, Some(l)) => (Vec3::from_array(l) - pose.position).length(),
                        (None, None) => {
                            return Err(self.err(
                                "camera.focus_distance",
                                "required with to_world (with look_at it defaults to the distance to look_at)",
                            ))
                        }
                    };
                    Camera::ThinLens(
                        ThinLensCamera::new(pinhole, radius, focus)
                            .map_err(|e| self.err(field_of(&e, "camera"), e.to_string()))?,
                    )
                }
            }
        };
        Ok((camera, preset))
    }

    /// The field of view of a perspective camera: from the preset, or from
    /// exactly one of vfov, hfov and focal_length.
    fn perspective_fov(&self, c: &CameraSection, preset: Option<&CameraPreset>) -> Result<Fov> {
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

    /// Pixel filter, exposure and white balance; a camera preset supplies
    /// the defaults of `shutter`, `iso` and `white_balance`.
    fn film(&self, f: &FilmSection, preset: Option<&CameraPreset>) -> Result<FilmSettings> {
        let filter = match f.filter.as_deref().unwrap_or("box") {
            "box" => {
                for (name, present) in [
                    ("filter_sigma", f.filter_sigma.is_some()),
                    ("filter_radius", f.filter_radius.is_some()),
                ] {
                    if present {
                        return Err(self.err(
                            format!("film.{name}"),
                            "only used with filter = \"gaussian\"",
                        ));
                    }
                }
                PixelFilter::Box
            }
            "gaussian" => {
                let sigma = self.positive(
                    "film.filter_sigma",
                    f.filter_sigma.unwrap_or(DEFAULT_GAUSSIAN_SIGMA),
                )?;
                let radius = self.positive(
                    "film.filter_radius",
                    f.filter_radius.unwrap_or(DEFAULT_GAUSSIAN_RADIUS),
                )?;
                let g = GaussianFilter::new(sigma, radius)
                    .map_err(|e| self.err("film.filter_radius", e))?;
                PixelFilter::Gaussian(g)
            }
            other => {
                return Err(self.err(
                    "film.filter",
                    format!("unknown filter `{other}` (known: box, gaussian)"),
                ))
            }
        };
        let exposure_ev = self.finite("film.exposure_ev", f.exposure_ev.unwrap_or(0.0))?;
        if exposure_ev.abs() > 64.0 {
            return Err(self.err(
                "film.exposure_ev",
                format!("must be between -64 and 64 stops, got {exposure_ev}"),
            ));
        }
        let camera_exposure = match f.f_number {
            Some(n) => {
                let n = self.positive("film.f_number", n)?;
                let from_preset = |name: &str, v: Option<f32>, p: Option<f32>| -> Result<f32> {
                    let v = v.or(p).ok_or_else(|| {
                        self.err(
                            format!("film.{name}"),
                            "required with f_number (shutter in seconds, iso)",
                        )
                    })?;
                    self.positive(&format!("film.{name}"), v)
                };
                Some(CameraExposure {
                    shutter_s: from_preset("shutter", f.shutter, preset.map(|p| p.shutter_s))?,
                    iso: from_preset("iso", f.iso, preset.map(|p| p.iso))?,
                    f_number: n,
                })
            }
            None => {
                if f.shutter.is_some() || f.iso.is_some() {
                    return Err(self.err(
                        "film.f_number",
                        "required with shutter and iso (the exposure is t·S/(100·N²))",
                    ));
                }
                None
            }
        };
        let white_balance_k = match f.white_balance.or(preset.map(|p| p.white_balance_k)) {
            Some(k) => {
                let k = self.finite("film.white_balance", k)?;
                if !(MIN_TEMPERATURE_K..=MAX_TEMPERATURE_K).contains(&k) {
                    return Err(self.err(
                        "film.white_balance",
                        format!(
                            "must be between {MIN_TEMPERATURE_K} and {MAX_TEMPERATURE_K} K, got {k}"
                        ),
                    ));
                }
                Some(k)
            }
            None => None,
        };
        Ok(FilmSettings {
            filter,
            exposure_ev,
            camera_exposure,
            white_balance_k,
        })
    }

    /// Adds the lights of a PLS file as cone-limited emissive meshes.
    fn pls(
        &self,
        index: usize,
        s: &PlsSection,
        materials: &mut Vec<Material>,
        meshes: &mut Vec<Mesh>,
    ) -> Result<()> {
        let field = format!("pls[{index}]");
        let path = self.base.join(&s.file);
        if !path.is_file() {
            return Err(self.err(
                format!("{field}.file"),
                format!(
                    "{}: PLS file not found (paths are relative to the scene file)",
                    path.display()
                ),
            ));
        }
        // Errors inside the PLS file keep its name, light and parameter,
        // behind the scene field that referred to it.
        let mut lighting = crate::light::pls::file::load(&path)
            .map_err(|e| self.err(format!("{field}.file"), e.to_string()))?;
        if let Some(t) = &s.transform {
            let m = self.transform(&format!("{field}.transform"), t)?;
            lighting = lighting.transform(&m);
            lighting.validate().map_err(|e| {
                self.err(
                    format!("{field}.transform"),
                    format!("makes {} invalid: {}", e.light, e.message),
                )
            })?;
        }
        let nf = s.nf.unwrap_or(crate::light::pls::DEFAULT_NF);
        if nf == 0 || nf > crate::light::pls::MAX_NF {
            return Err(self.err(
                format!("{field}.nf"),
                format!(
                    "must be between 1 and {}, got {nf}",
                    crate::light::pls::MAX_NF
                ),
            ));
        }
        // PLS emitters do not reflect: a black material.
        let black = match materials.iter().position(|m| m.name == "(pls)") {
            Some(i) => i as u32,
            None => {
                materials.push(Material::new("(pls)", Bsdf::diffuse(Vec3::ZERO)));
                (materials.len() - 1) as u32
            }
        };
        for (k, light) in lighting.lights.iter().enumerate() {
            let name = format!("{field}/{}", light.label(k));
            meshes.push(super::pls_mesh(light, lighting.mode, nf, black, name));
        }
        Ok(())
    }

    fn transform(&self, field: &str, t: &TransformSection) -> Result<Mat4> {
        if let Some(m) = &t.matrix {
            if t.translate.is_some() || t.rotate.is_some() || t.scale.is_some() {
                return Err(self.err(
                    format!("{field}.matrix"),
                    "a matrix cannot be combined with translate/rotate/scale",
                ));
            }
            for (r, row) in m.iter().enumerate() {
                for (c, x) in row.iter().enumerate() {
                    if !x.is_finite() {
                        return Err(self.err(
                            format!("{field}.matrix[{r}][{c}]"),
                            format!("must be a finite number, got {x}"),
                        ));
                    }
                }
            }
            if m[3] != [0.0, 0.0, 0.0, 1.0] {
                return Err(self.err(
                    format!("{field}.matrix[3]"),
                    format!(
                        "the last row of an affine transform must be [0, 0, 0, 1], got {:?}",
                        m[3]
                    ),
                ));
            }
            // Rows in the file; glam is column-major.
            let mat = Mat4::from_cols_array_2d(m).transpose();
            if mat.determinant() == 0.0 {
                return Err(self.err(format!("{field}.matrix"), "is singular"));
            }
            return Ok(mat);
        }
        let translate = match t.translate {
            Some(v) => self.vec3(&format!("{field}.translate"), v)?,
            None => Vec3::ZERO,
        };
        let rotate = match &t.rotate {
            Some(r) => {
                let axis = self.vec3(&format!("{field}.rotate.axis"), r.axis)?;
                let axis = axis
                    .try_normalize()
                    .ok_or_else(|| self.err(format!("{field}.rotate.axis"), "must not be zero"))?;
                let angle = self.finite(&format!("{field}.rotate.angle"), r.angle)?;
                Quat::from_axis_angle(axis, angle.to_radians())
            }
            None => Quat::IDENTITY,
        };
        let scale = match &t.scale {
            Some(ScaleValue::Uniform(s)) => {
                Vec3::splat(self.finite(&format!("{field}.scale"), *s)?)
            }
            Some(ScaleValue::PerAxis(s)) => self.vec3(&format!("{field}.scale"), *s)?,
            None => Vec3::ONE,
        };
        if scale.cmpeq(Vec3::ZERO).any() {
            return Err(self.err(format!("{field}.scale"), "must not be zero"));
        }
        // Scale first, then rotate, then translate.
        Ok(Mat4::from_scale_rotation_translation(
            scale, rotate, translate,
        ))
    }

    fn shape(
        &self,
        index: usize,
        s: &ShapeSection,
        by_name: &HashMap<String, u32>,
        materials: &mut Vec<Material>,
        meshes: &mut Vec<Mesh>,
    ) -> Result<()> {
        let field = format!("shapes[{index}]");
        let unused = |name: &str, present: bool| -> Result<()> {
            if present {
                Err(self.err(
                    format!("{field}.{name}"),
                    format!("not used by shapes of type `{}`", s.kind),
                ))
            } else {
                Ok(())
            }
        };
        let matrix = match &s.transform {
            Some(t) => self.transform(&format!("{field}.transform"), t)?,
            None => Mat4::IDENTITY,
        };
        let material = match &s.material {
            Some(name) => Some(*by_name.get(name).ok_or_else(|| {
                self.err(
                    format!("{field}.material"),
                    format!("no material named `{name}`"),
                )
            })?),
            None => None,
        };
        let emission = match s.emission {
            Some(e) => Some(Emission {
                radiance: self.colour(&format!("{field}.emission"), e, None)?,
                two_sided: s.two_sided.unwrap_or(false),
                cone: None,
            }),
            None => {
                // On OBJ shapes, two_sided also applies to MTL `Ke` emission.
                if s.two_sided.is_some() && s.kind != "obj" {
                    return Err(self.err(
                        format!("{field}.two_sided"),
                        "only used together with `emission`",
                    ));
                }
                None
            }
        };
        let default_material = |materials: &mut Vec<Material>| -> u32 {
            let name = "(default)";
            if let Some(i) = materials.iter().position(|m| m.name == name) {
                return i as u32;
            }
            materials.push(Material::new(
                name,
                Bsdf::diffuse(Vec3::splat(DEFAULT_REFLECTANCE)),
            ));
            (materials.len() - 1) as u32
        };
        let shape_name = s
            .name
            .clone()
            .unwrap_or_else(|| format!("{field} ({})", s.kind));
        let object_id = index as u32;

        let (mut positions, mut triangles, normals, uvs) = match s.kind.as_str() {
            "obj" => {
                for (name, present) in [
                    ("center", s.center.is_some()),
                    ("radius", s.radius.is_some()),
                    ("subdivisions", s.subdivisions.is_some()),
                    ("flip_normals", s.flip_normals.is_some()),
                ] {
                    unused(name, present)?;
                }
                let rel = s.file.as_ref().ok_or_else(|| {
                    self.err(format!("{field}.file"), "required for an OBJ shape")
                })?;
                let path = self.base.join(rel);
                let obj = shapes::load_obj(&path, self.file, &format!("{field}.file"))?;
                if obj.objects.is_empty() {
                    return Err(self.err(
                        format!("{field}.file"),
                        format!("{} has no triangles", path.display()),
                    ));
                }
                // One material per MTL entry used, shared by the file's objects.
                let mut mtl_index: HashMap<usize, u32> = HashMap::new();
                for o in obj.objects {
                    let (mut p, mut t) = (o.positions, o.triangles);
                    transform_mesh(&matrix, &mut p, &mut t);
                    let normals = transform_normals(&matrix, o.normals);
                    let mtl = o.material.and_then(|m| obj.materials.get(m));
                    let mat = match (material, o.material, mtl) {
                        (Some(m), _, _) => m,
                        (None, Some(mi), Some(mtl)) => match mtl_index.get(&mi) {
                            Some(&m) => m,
                            None => {
                                // load_obj checked the MTL values' ranges.
                                materials.push(self.mtl_material(
                                    &format!("{field}.file"),
                                    format!("{}:{}", rel.display(), mtl.name),
                                    mtl,
                                )?);
                                let m = (materials.len() - 1) as u32;
                                mtl_index.insert(mi, m);
                                m
                            }
                        },
                        _ => default_material(materials),
                    };
                    let mtl_emission = mtl
                        .and_then(|m| m.emission)
                        .filter(|e| e.max_element() > 0.0)
                        .map(|radiance| Emission {
                            radiance,
                            two_sided: s.two_sided.unwrap_or(false),
                            cone: None,
                        });
                    meshes.push(Mesh {
                        name: format!("{shape_name}/{}", o.name),
                        positions: p,
                        triangles: t,
                        normals,
                        uvs: o.uvs,
                        material: mat,
                        emission: emission.or(mtl_emission),
                        object_id,
                        pls: None,
                    });
                }
                return Ok(());
            }
            "rectangle" => {
                for (name, present) in [
                    ("file", s.file.is_some()),
                    ("center", s.center.is_some()),
                    ("radius", s.radius.is_some()),
                    ("subdivisions", s.subdivisions.is_some()),
                ] {
                    unused(name, present)?;
                }
                let (p, t) = shapes::rectangle();
                // u along +x, v along +y, (0, 0) at the (−1, −1) corner.
                let uvs = p
                    .iter()
                    .map(|q| Vec2::new(0.5 * (q.x + 1.0), 0.5 * (q.y + 1.0)))
                    .collect();
                (p, t, Vec::new(), uvs)
            }
            "sphere" => {
                unused("file", s.file.is_some())?;
                let center = self.vec3(&format!("{field}.center"), s.center.unwrap_or([0.0; 3]))?;
                let radius = self.finite(&format!("{field}.radius"), s.radius.unwrap_or(1.0))?;
                if radius <= 0.0 {
                    return Err(self.err(
                        format!("{field}.radius"),
                        format!("must be positive, got {radius}"),
                    ));
                }
                let subdivisions = s.subdivisions.unwrap_or(4);
                if subdivisions > 8 {
                    return Err(self.err(
                        format!("{field}.subdivisions"),
                        format!("must be at most 8 (20·4^8 triangles), got {subdivisions}"),
                    ));
                }
                let (p, t) = shapes::icosphere(center, radius, subdivisions);
                // The smooth sphere's normals shade the facets.
                let normals = p.iter().map(|q| (*q - center) / radius).collect();
                (p, t, normals, Vec::new())
            }
            other => {
                return Err(self.err(
                    format!("{field}.type"),
                    format!("unknown shape type `{other}` (known: obj, rectangle, sphere)"),
                ))
            }
        };
        let flip = s.flip_normals.unwrap_or(false);
        if flip {
            flip_winding(&mut triangles);
        }
        transform_mesh(&matrix, &mut positions, &mut triangles);
        let mut normals = transform_normals(&matrix, normals);
        if flip {
            normals.iter_mut().for_each(|n| *n = -*n);
        }
        let material = match material {
            Some(m) => m,
            None => default_material(materials),
        };
        meshes.push(Mesh {
            name: shape_name,
            positions,
            triangles,
            normals,
            uvs,
            material,
            emission,
            object_id,
            pls: None,
        });
        Ok(())
    }
}

/// Loads an equirectangular environment image (`.exr` or `.hdr`, linear
/// radiance, finite and ≥ 0) oriented by `frame`, times `scale`; errors name
/// the file.
pub fn load_environment(
    path: &Path,
    frame: crate::equirect::SphereFrame,
    scale: f32,
) -> Result<EnvironmentLight> {
    checked_environment(path, frame, scale).map_err(|m| Error::input(path, "", m))
}

fn checked_environment(
    path: &Path,
    frame: crate::equirect::SphereFrame,
    scale: f32,
) -> std::result::Result<EnvironmentLight, String> {
    let (w, h, texels) = load_environment_image(path)?;
    if let Some(i) = texels
        .iter()
        .position(|t| !t.is_finite() || t.min_element() < 0.0)
    {
        return Err(format!(
            "{}: texel ({}, {}) is {}: radiance must be finite and not negative",
            path.display(),
            i % w as usize,
            i / w as usize,
            texels[i]
        ));
    }
    Ok(EnvironmentLight::from_image(w, h, texels, scale, frame))
}

/// Reads an equirectangular image of linear radiance: OpenEXR (`.exr`, its
/// R, G, B channels) or Radiance HDR (`.hdr`). Returns width, height and
/// texels row-major from the top row.
fn load_environment_image(path: &Path) -> std::result::Result<(u32, u32, Vec<Vec3>), String> {
    if !path.is_file() {
        return Err(format!(
            "{}: environment image not found (paths are relative to the scene file)",
            path.display()
        ));
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("exr") => {
            let film = crate::film::Film::read_exr(path)
                .map_err(|e| format!("{}: {e}", path.display()))?;
            Ok((film.width, film.height, film.color))
        }
        Some("hdr") => {
            let img = image::open(path)
                .map_err(|e| format!("{}: cannot read Radiance HDR: {e}", path.display()))?;
            let rgb = img.to_rgb32f();
            let (w, h) = rgb.dimensions();
            Ok((
                w,
                h,
                rgb.pixels().map(|p| Vec3::new(p[0], p[1], p[2])).collect(),
            ))
        }
        _ => Err(format!(
            "{}: unsupported environment image (use .exr or .hdr)",
            path.display()
        )),
    }
}

/// Normals under the transform `m`: by the inverse transpose of its linear
/// part, renormalised.
fn transform_normals(m: &Mat4, normals: Vec<Vec3>) -> Vec<Vec3> {
    if normals.is_empty() {
        return normals;
    }
    let n = glam::Mat3::from_mat4(*m).inverse().transpose();
    normals
        .into_iter()
        .map(|v| (n * v).normalize_or_zero())
        .collect()
}

#[cfg(test)]
mod field_tests {
    use super::field_at;

    fn at(text: &str, needle: &str) -> String {
        field_at(text, text.find(needle).unwrap())
    }

    #[test]
    fn field_paths_follow_tables_and_arrays() {
        let t = "[render]\nspp = 1\n\n[camera]\nup = 1\n\n[[shapes]]\ntype = 1\n\n[[shapes]]\nmatrix = [\n  [1, 0, 0, 0],\n  [0, 1, x, 0],\n]\n[shapes.transform]\nscale = 2\n";
        assert_eq!(at(t, "spp"), "render.spp");
        assert_eq!(at(t, "up"), "camera.up");
        assert_eq!(at(t, "[camera]"), "camera");
        assert_eq!(at(t, "type"), "shapes[0].type");
        assert_eq!(at(t, "x,"), "shapes[1]");
        assert_eq!(at(t, "scale"), "shapes[1].transform.scale");
    }
}
