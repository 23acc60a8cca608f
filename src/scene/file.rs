//! Scene files: TOML (or JSON with the same schema), documented with an
//! example of every item in `docs/scene-format.md`.
//!
//! Parsing is strict: unknown keys, wrong types, non-finite numbers and
//! out-of-range values are errors that name the file and the field
//! (`shapes[2].transform.scale`). Paths inside a scene file are relative to
//! the file's directory.

use super::shapes::{self, flip_winding, transform_mesh};
use super::{Emission, Material, Mesh, RenderSettings, SceneDescription};
use crate::bsdf::Bsdf;
use crate::camera::{CameraError, PinholeCamera};
use crate::error::{Error, Result};
use crate::light::PointLight;
use glam::{Mat4, Quat, Vec3};
use serde::Deserialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Default sensor height (mm) when a camera gives `focal_length` alone: 35 mm film.
pub const DEFAULT_SENSOR_HEIGHT_MM: f32 = 24.0;

/// Default albedo of OBJ objects whose MTL material has no `Kd`.
pub const DEFAULT_REFLECTANCE: f32 = 0.8;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    #[serde(default)]
    render: RenderSection,
    camera: CameraSection,
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
    position: [f32; 3],
    look_at: [f32; 3],
    up: [f32; 3],
    vfov: Option<f32>,
    focal_length: Option<f32>,
    sensor_height: Option<f32>,
    resolution: [i64; 2],
}

fn pinhole() -> String {
    "pinhole".into()
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialSection {
    name: String,
    #[serde(rename = "type")]
    kind: String,
    reflectance: Option<[f32; 3]>,
}

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

    fn positive_count(&self, field: &str, v: i64, max: i64) -> Result<u32> {
        if v < 1 || v > max {
            return Err(self.err(field, format!("must be between 1 and {max}, got {v}")));
        }
        Ok(v as u32)
    }

    fn build(&self, f: SceneFile) -> Result<SceneDescription> {
        let settings = self.settings(&f.render)?;
        let camera = self.camera(&f.camera)?;

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
            let bsdf = match m.kind.as_str() {
                "diffuse" => {
                    let r = m.reflectance.unwrap_or([DEFAULT_REFLECTANCE; 3]);
                    Bsdf::diffuse(self.colour(&format!("{field}.reflectance"), r, Some(1.0))?)
                }
                other => {
                    return Err(self.err(
                        format!("{field}.type"),
                        format!("unknown material type `{other}` (known: diffuse)"),
                    ))
                }
            };
            by_name.insert(m.name.clone(), materials.len() as u32);
            materials.push(Material {
                name: m.name.clone(),
                bsdf,
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

        Ok(SceneDescription {
            meshes,
            materials,
            point_lights,
            camera,
            settings,
        })
    }

    fn settings(&self, r: &RenderSection) -> Result<RenderSettings> {
        let d = RenderSettings::default();
        Ok(RenderSettings {
            spp: match r.spp {
                Some(v) => self.positive_count("render.spp", v, 1 << 24)?,
                None => d.spp,
            },
            max_depth: match r.max_depth {
                Some(v) => self.positive_count("render.max_depth", v, 1024)?,
                None => d.max_depth,
            },
            seed: r.seed.unwrap_or(d.seed),
            robust: r.robust.unwrap_or(d.robust),
        })
    }

    fn camera(&self, c: &CameraSection) -> Result<PinholeCamera> {
        if c.kind != "pinhole" {
            return Err(self.err(
                "camera.type",
                format!("unknown camera type `{}` (known: pinhole)", c.kind),
            ));
        }
        let position = self.vec3("camera.position", c.position)?;
        let look_at = self.vec3("camera.look_at", c.look_at)?;
        let up = self.vec3("camera.up", c.up)?;
        let vfov = match (c.vfov, c.focal_length) {
            (Some(v), None) => {
                if c.sensor_height.is_some() {
                    return Err(self.err("camera.sensor_height", "only used with focal_length"));
                }
                let v = self.finite("camera.vfov", v)?;
                if !(v > 0.0 && v < 180.0) {
                    return Err(self.err(
                        "camera.vfov",
                        format!("must be in (0, 180) degrees, got {v}"),
                    ));
                }
                v
            }
            (None, Some(f)) => {
                let f = self.finite("camera.focal_length", f)?;
                let h = self.finite(
                    "camera.sensor_height",
                    c.sensor_height.unwrap_or(DEFAULT_SENSOR_HEIGHT_MM),
                )?;
                if f <= 0.0 {
                    return Err(
                        self.err("camera.focal_length", format!("must be positive, got {f}"))
                    );
                }
                if h <= 0.0 {
                    return Err(
                        self.err("camera.sensor_height", format!("must be positive, got {h}"))
                    );
                }
                PinholeCamera::vfov_from_focal_length(f, h)
            }
            (Some(_), Some(_)) => {
                return Err(self.err(
                    "camera.focal_length",
                    "give either vfov or focal_length, not both",
                ))
            }
            (None, None) => {
                return Err(self.err("camera.vfov", "give vfov (degrees) or focal_length (mm)"))
            }
        };
        let w = self.positive_count("camera.resolution[0]", c.resolution[0], 1 << 16)?;
        let h = self.positive_count("camera.resolution[1]", c.resolution[1], 1 << 16)?;
        PinholeCamera::look_at(position, look_at, up, vfov, w, h).map_err(|e| {
            let field = match e {
                CameraError::NoViewDirection => "camera.look_at",
                CameraError::UpParallelToView => "camera.up",
                CameraError::BadFov(_) => "camera.vfov",
                CameraError::EmptyImage => "camera.resolution",
            };
            self.err(field, e.to_string())
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
        let mut lighting = crate::pls::file::load(&path)
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
        let nf = s.nf.unwrap_or(crate::pls::DEFAULT_NF);
        if nf == 0 || nf > 4096 {
            return Err(self.err(
                format!("{field}.nf"),
                format!("must be between 1 and 4096, got {nf}"),
            ));
        }
        // PLS emitters do not reflect: a black material.
        let black = match materials.iter().position(|m| m.name == "(pls)") {
            Some(i) => i as u32,
            None => {
                materials.push(Material {
                    name: "(pls)".into(),
                    bsdf: Bsdf::diffuse(Vec3::ZERO),
                });
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
            materials.push(Material {
                name: name.into(),
                bsdf: Bsdf::diffuse(Vec3::splat(DEFAULT_REFLECTANCE)),
            });
            (materials.len() - 1) as u32
        };
        let shape_name = s
            .name
            .clone()
            .unwrap_or_else(|| format!("{field} ({})", s.kind));
        let object_id = index as u32;

        let (mut positions, mut triangles) = match s.kind.as_str() {
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
                    let mtl = o.material.and_then(|m| obj.materials.get(m));
                    let mat = match (material, o.material, mtl) {
                        (Some(m), _, _) => m,
                        (None, Some(mi), Some(mtl)) => match mtl_index.get(&mi) {
                            Some(&m) => m,
                            None => {
                                // load_obj checked Kd ∈ [0, 1].
                                let kd = mtl.diffuse.unwrap_or(Vec3::splat(DEFAULT_REFLECTANCE));
                                materials.push(Material {
                                    name: format!("{}:{}", rel.display(), mtl.name),
                                    bsdf: Bsdf::diffuse(kd),
                                });
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
                        material: mat,
                        emission: emission.or(mtl_emission),
                        object_id,
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
                shapes::rectangle()
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
                shapes::icosphere(center, radius, subdivisions)
            }
            other => {
                return Err(self.err(
                    format!("{field}.type"),
                    format!("unknown shape type `{other}` (known: obj, rectangle, sphere)"),
                ))
            }
        };
        if s.flip_normals.unwrap_or(false) {
            flip_winding(&mut triangles);
        }
        transform_mesh(&matrix, &mut positions, &mut triangles);
        let material = match material {
            Some(m) => m,
            None => default_material(materials),
        };
        meshes.push(Mesh {
            name: shape_name,
            positions,
            triangles,
            material,
            emission,
            object_id,
        });
        Ok(())
    }
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
