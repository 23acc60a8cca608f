//! `[[shapes]]`: spheres, rectangles and OBJ meshes, their transforms,
//! materials and emission.

use super::keys::key_names;
use super::{Builder, DEFAULT_REFLECTANCE};
use crate::bsdf::Bsdf;
use crate::error::Result;
use crate::scene::shapes::{self, flip_winding, transform_mesh};
use crate::scene::uv_map::UvMap;
use crate::scene::{Emission, Material, Mesh};
use glam::{Mat4, Quat, Vec2, Vec3};
use serde::Deserialize;
use std::collections::HashMap;
use std::path::PathBuf;

/// `[[shapes]]` as read: the keys every shape has, and the keys of its
/// type, checked by the type's own struct ([`ObjKeys`], [`RectangleKeys`],
/// [`SphereKeys`]).
#[derive(Debug, Deserialize)]
pub(super) struct ShapeSection {
    #[serde(rename = "type")]
    pub(super) kind: String,
    pub(super) name: Option<String>,
    pub(super) material: Option<String>,
    pub(super) transform: Option<TransformSection>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) emission: Option<[f32; 3]>,
    pub(super) two_sided: Option<bool>,
    /// Texture coordinates `(u, 1 − v)` instead of the file's or the
    /// shape's `(u, v)` (for textures laid out with `v` running down).
    pub(super) flip_v: Option<bool>,
    /// A virtual object, inserted into the photograph (`plsr composite`).
    #[serde(rename = "virtual")]
    pub(super) is_virtual: Option<bool>,
    /// The group the shape belongs to: it is then drawn only where
    /// `[[instances]]` place the group.
    pub(super) group: Option<String>,
    #[serde(flatten)]
    pub(super) keys: toml::Table,
}

/// `[[instances]]`: a group of shapes placed by a transform.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct InstanceSection {
    /// The group (the `group` key of its shapes).
    pub(super) group: String,
    /// The group's space to the world (identity when absent).
    pub(super) transform: Option<TransformSection>,
}

/// The keys of an `obj` shape.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ObjKeys {
    file: Option<PathBuf>,
    smooth_normals: Option<bool>,
}

/// The keys of a `gltf` shape.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct GltfKeys {
    file: Option<PathBuf>,
    smooth_normals: Option<bool>,
    time: Option<f32>,
}

/// The keys of a `rectangle` shape.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RectangleKeys {
    flip_normals: Option<bool>,
}

/// The keys of a `ply` shape.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlyKeys {
    file: Option<PathBuf>,
    smooth_normals: Option<bool>,
    face_normals: Option<bool>,
    flip_normals: Option<bool>,
}

/// The keys of a `serialized` shape (Mitsuba's mesh format).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SerializedKeys {
    file: Option<PathBuf>,
    shape_index: Option<u32>,
    smooth_normals: Option<bool>,
    face_normals: Option<bool>,
    flip_normals: Option<bool>,
}

/// The keys of a `curves` shape (Mitsuba's `bsplinecurve` and
/// `linearcurve`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CurvesKeys {
    file: Option<PathBuf>,
    basis: Option<String>,
    sides: Option<u32>,
    steps: Option<u32>,
}

/// The keys of an `sdf_grid` shape (Mitsuba's `sdfgrid`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SdfGridKeys {
    file: Option<PathBuf>,
    normals: Option<String>,
    subdivisions: Option<u32>,
}

/// Default refinements of an SDF grid's cells for meshing.
const DEFAULT_SDF_SUBDIVISIONS: u32 = 2;
/// The largest SDF grid file read (bytes).
const MAX_SDF_FILE: u64 = 512 << 20;

/// Default vertices round a curve's ring.
const DEFAULT_CURVE_SIDES: u32 = 32;
/// Default rings per B-spline segment.
const DEFAULT_CURVE_STEPS: u32 = 16;
/// The largest curve file read (bytes): about a million control points.
const MAX_CURVE_FILE: u64 = 64 << 20;
/// The most triangles a `curves` shape may become.
const MAX_CURVE_TRIANGLES: u64 = 1 << 26;

/// The keys of a `disk` shape.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DiskKeys {
    segments: Option<u32>,
    flip_normals: Option<bool>,
}

/// The keys of a `cylinder` shape (Mitsuba's: open at both ends).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CylinderKeys {
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    p0: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    p1: Option<[f32; 3]>,
    radius: Option<f32>,
    segments: Option<u32>,
    flip_normals: Option<bool>,
}

/// The keys of a `cube` shape.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CubeKeys {
    flip_normals: Option<bool>,
}

/// The keys of a `sphere` shape.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereKeys {
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    center: Option<[f32; 3]>,
    radius: Option<f32>,
    subdivisions: Option<u32>,
    flip_normals: Option<bool>,
}

/// Triangles of a `disk` unless `segments` says otherwise: its area is
/// within 0.04 % of the round disk's.
const DEFAULT_DISK_SEGMENTS: u32 = 128;
/// The most triangles a `disk` may have.
const MAX_DISK_SEGMENTS: u32 = 1 << 20;

/// The keys every shape has (besides `type`).
const SHAPE_KEYS: [&str; 6] = [
    "name",
    "material",
    "transform",
    "emission",
    "two_sided",
    "virtual",
];

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct TransformSection {
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) translate: Option<[f32; 3]>,
    pub(super) rotate: Option<RotateSection>,
    pub(super) scale: Option<ScaleValue>,
    #[serde(default, deserialize_with = "crate::input::exact::option_matrix")]
    pub(super) matrix: Option<[[f32; 4]; 4]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RotateSection {
    #[serde(deserialize_with = "crate::input::exact::array")]
    pub(super) axis: [f32; 3],
    pub(super) angle: f32,
}

#[derive(Debug, Deserialize)]
#[serde(untagged, expecting = "a number or an array of three numbers")]
pub(super) enum ScaleValue {
    Uniform(f32),
    PerAxis(#[serde(deserialize_with = "crate::input::exact::array")] [f32; 3]),
}

impl Builder<'_> {
    pub(super) fn transform(&self, field: &str, t: &TransformSection) -> Result<Mat4> {
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

    pub(super) fn shape(
        &self,
        index: usize,
        s: &ShapeSection,
        by_name: &HashMap<String, u32>,
        materials: &mut Vec<Material>,
        meshes: &mut Vec<Mesh>,
    ) -> Result<()> {
        let first = meshes.len();
        self.shape_meshes(index, s, by_name, materials, meshes)?;
        self.check_coordinates(index, s, &meshes[first..])
    }

    /// Refuses a shape whose vertices, placed in the scene, leave plsr's
    /// coordinate range ([`crate::accel::MAX_COORDINATE`]), naming the
    /// shape (its `transform` when it has one), the mesh and the vertex.
    fn check_coordinates(&self, index: usize, s: &ShapeSection, meshes: &[Mesh]) -> Result<()> {
        for m in meshes {
            if let Some((v, p)) = m
                .positions
                .iter()
                .enumerate()
                .find(|(_, p)| !crate::accel::within_coordinates(**p))
            {
                let field = match s.transform {
                    Some(_) => format!("shapes[{index}].transform"),
                    None => format!("shapes[{index}]"),
                };
                // The mesh file the vertex comes from, if any.
                let of_file = match s.keys.get("file").and_then(|f| f.as_str()) {
                    Some(f) => format!(" of {}", self.base.join(f).display()),
                    None => String::new(),
                };
                return Err(self.err(
                    field,
                    format!(
                        "mesh `{}`{of_file}: vertex {v} lands at {p}, beyond ±{:e} scene units \
                         (plsr's coordinate limit): scale the shape or its transform down",
                        m.name,
                        crate::accel::MAX_COORDINATE
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The meshes of shape `index`, placed in the scene, appended to
    /// `meshes` (see [`Self::shape`]).
    fn shape_meshes(
        &self,
        index: usize,
        s: &ShapeSection,
        by_name: &HashMap<String, u32>,
        materials: &mut Vec<Material>,
        meshes: &mut Vec<Mesh>,
    ) -> Result<()> {
        let field = format!("shapes[{index}]");
        let unknown = |key: &str| unknown_shape_key(&s.kind, key);
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
        let emission = self.shape_emission(&field, s)?;
        let shape_name = s
            .name
            .clone()
            .unwrap_or_else(|| format!("{field} ({})", s.kind));
        let object_id = index as u32;
        let is_virtual = s.is_virtual.unwrap_or(false);
        if is_virtual && emission.is_some() {
            return Err(self.err(
                format!("{field}.emission"),
                "a virtual object cannot emit: the real scene's lights light it",
            ));
        }

        let flip;
        // Whether the mesh is already in world space, and rays pass
        // through its back faces (curves).
        let mut world_space = false;
        let mut cull_back = false;
        // For the sphere and the disk: the unit shape's frame in the
        // shape's own coordinates, for exact texture coordinates at hits.
        let mut round: Option<(Mat4, Round)> = None;
        // Colours and other attributes the mesh file stores.
        let mut attributes: Vec<crate::scene::ply::PlyAttribute> = Vec::new();
        let (mut positions, mut triangles, normals, uvs) = match s.kind.as_str() {
            "obj" | "gltf" => {
                let shape = Common {
                    field: &field,
                    matrix,
                    material,
                    emission,
                    two_sided: s.two_sided.unwrap_or(false),
                    name: &shape_name,
                    object_id,
                    is_virtual,
                };
                // Their files carry no colours a named material could take.
                if let Some(m) = material {
                    self.mesh_colors(&field, s, &materials[m as usize], Vec::new())?;
                }
                return if s.kind == "obj" {
                    let keys: ObjKeys = self.typed_keys(&field, &s.keys, unknown)?;
                    self.obj_meshes(&shape, &keys, materials, meshes)
                } else {
                    let keys: GltfKeys = self.typed_keys(&field, &s.keys, unknown)?;
                    self.gltf_meshes(&shape, &keys, materials, meshes)
                };
            }
            "rectangle" => {
                let keys: RectangleKeys = self.typed_keys(&field, &s.keys, unknown)?;
                flip = keys.flip_normals.unwrap_or(false);
                let (p, t) = shapes::rectangle();
                // u along +x, v along +y, (0, 0) at the (−1, −1) corner.
                let uvs = p
                    .iter()
                    .map(|q| Vec2::new(0.5 * (q.x + 1.0), 0.5 * (q.y + 1.0)))
                    .collect();
                (p, t, Vec::new(), uvs)
            }
            "sphere" => {
                let keys: SphereKeys = self.typed_keys(&field, &s.keys, unknown)?;
                flip = keys.flip_normals.unwrap_or(false);
                let (mesh, frame) = self.sphere_mesh(&field, &keys)?;
                round = Some((frame, Round::Sphere));
                mesh
            }
            "ply" => {
                let keys: PlyKeys = self.typed_keys(&field, &s.keys, unknown)?;
                flip = keys.flip_normals.unwrap_or(false);
                let (mesh, a) = self.ply_mesh(&field, &keys)?;
                attributes = a;
                mesh
            }
            "serialized" => {
                let keys: SerializedKeys = self.typed_keys(&field, &s.keys, unknown)?;
                flip = keys.flip_normals.unwrap_or(false);
                let (mesh, a) = self.serialized_mesh(&field, &keys)?;
                attributes = a;
                mesh
            }
            "disk" => {
                let keys: DiskKeys = self.typed_keys(&field, &s.keys, unknown)?;
                flip = keys.flip_normals.unwrap_or(false);
                let segments = keys.segments.unwrap_or(DEFAULT_DISK_SEGMENTS);
                if !(3..=MAX_DISK_SEGMENTS).contains(&segments) {
                    return Err(self.err(
                        format!("{field}.segments"),
                        format!("must be between 3 and {MAX_DISK_SEGMENTS}, got {segments}"),
                    ));
                }
                let (p, t, uv) = shapes::disk(segments);
                round = Some((Mat4::IDENTITY, Round::Disk));
                (p, t, Vec::new(), uv)
            }
            "cylinder" => {
                let keys: CylinderKeys = self.typed_keys(&field, &s.keys, unknown)?;
                flip = keys.flip_normals.unwrap_or(false);
                let (mesh, frame) = self.cylinder_mesh(&field, &keys)?;
                round = Some((frame, Round::Cylinder));
                mesh
            }
            "curves" => {
                let keys: CurvesKeys = self.typed_keys(&field, &s.keys, unknown)?;
                flip = false;
                // Built in world space: the transform moves the control
                // points, not the radii.
                let mesh = self.curves_mesh(&field, &keys, &matrix)?;
                world_space = true;
                cull_back = true;
                mesh
            }
            "sdf_grid" => {
                let keys: SdfGridKeys = self.typed_keys(&field, &s.keys, unknown)?;
                flip = false;
                self.sdf_grid_mesh(&field, &keys)?
            }
            "cube" => {
                let keys: CubeKeys = self.typed_keys(&field, &s.keys, unknown)?;
                flip = keys.flip_normals.unwrap_or(false);
                let (p, t, uv) = shapes::cube();
                (p, t, Vec::new(), uv)
            }
            other => {
                return Err(self.err(
                    format!("{field}.type"),
                    format!(
                    "unknown shape type `{other}` (known: obj, ply, serialized, gltf, rectangle, sphere, disk, cylinder, cube, curves, sdf_grid)"
                ),
                ))
            }
        };
        if flip {
            flip_winding(&mut triangles);
        }
        let uv_map = match round {
            None => UvMap::Vertices,
            Some((frame, kind)) => {
                // The transform is invertible (checked when read).
                let to_local = glam::Affine3A::from_mat4((matrix * frame).inverse());
                let flip_v = false;
                match kind {
                    Round::Sphere => UvMap::Sphere { to_local, flip_v },
                    Round::Disk => UvMap::Disk { to_local, flip_v },
                    Round::Cylinder => UvMap::Cylinder { to_local, flip_v },
                }
            }
        };
        let mut normals = if world_space {
            normals
        } else {
            transform_mesh(&matrix, &mut positions, &mut triangles);
            transform_normals(&matrix, normals)
        };
        if flip {
            normals.iter_mut().for_each(|n| *n = -*n);
        }
        let material = match material {
            Some(m) => m,
            None => default_material(materials),
        };
        let colors = self.mesh_colors(&field, s, &materials[material as usize], attributes)?;
        meshes.push(Mesh {
            cull_back,
            name: shape_name,
            positions,
            triangles,
            normals,
            uvs,
            tangents: Vec::new(),
            material,
            emission,
            object_id,
            pls: None,
            is_virtual,
            uv_map,
            colors,
            emission_map: None,
        });
        Ok(())
    }

    /// A shape's `emission` (and `two_sided`, which needs it except on OBJ
    /// and glTF shapes, whose files may emit).
    fn shape_emission(&self, field: &str, s: &ShapeSection) -> Result<Option<Emission>> {
        Ok(match s.emission {
            Some(e) => Some(Emission {
                radiance: self.colour(&format!("{field}.emission"), e, None)?,
                two_sided: s.two_sided.unwrap_or(false),
                cone: None,
            }),
            None => {
                // On OBJ shapes, two_sided also applies to MTL `Ke` emission.
                if s.two_sided.is_some() && s.kind != "obj" && s.kind != "gltf" {
                    return Err(self.err(
                        format!("{field}.two_sided"),
                        "only used together with `emission`",
                    ));
                }
                None
            }
        })
    }

    /// The colours a shape's mesh keeps: those its material takes its base
    /// colour from (`base_color_map = { attribute = … }`, also in a
    /// composite's parts), found among the file's `attributes`. Refused,
    /// naming what the file has, when the file lacks them or the parts
    /// ask for different ones.
    fn mesh_colors(
        &self,
        field: &str,
        s: &ShapeSection,
        material: &Material,
        attributes: Vec<crate::scene::ply::PlyAttribute>,
    ) -> Result<Option<crate::scene::MeshColors>> {
        let mut wanted: Vec<&str> = std::iter::once(material)
            .chain(material.composite.iter().flat_map(|c| c.leaves()))
            .filter_map(|m| m.textures.base_color_attribute.as_deref())
            .collect();
        wanted.dedup();
        let name = match wanted.as_slice() {
            [] => return Ok(None),
            [one] => *one,
            [a, b, ..] => {
                return Err(self.err(
                    format!("{field}.material"),
                    format!(
                        "material `{}` takes its colours from both `{a}` and `{b}`: \
                         a mesh gives one",
                        material.name
                    ),
                ))
            }
        };
        let have: Vec<&str> = attributes.iter().map(|a| a.name.as_str()).collect();
        let Some(found) = attributes.iter().position(|a| a.name == name) else {
            let has = if !have.is_empty() {
                format!("its file has {}", have.join(", "))
            } else if s.kind == "ply" || s.kind == "serialized" {
                "its file has none".to_string()
            } else {
                format!("{} shapes carry none (PLY and serialized files do)", s.kind)
            };
            return Err(self.err(
                format!("{field}.material"),
                format!(
                    "material `{}` takes its base colour from the mesh's `{name}`, \
                     but {has}",
                    material.name
                ),
            ));
        };
        let values = attributes.into_iter().nth(found).map(|a| a.values);
        Ok(values.map(|v| {
            if name.starts_with("face_") {
                crate::scene::MeshColors::Face(v)
            } else {
                crate::scene::MeshColors::Vertex(v)
            }
        }))
    }

    /// A `ply` shape's mesh in file coordinates: positions, triangles,
    /// normals (computed if asked for and missing), texture coordinates;
    /// and the file's attributes.
    fn ply_mesh(
        &self,
        field: &str,
        keys: &PlyKeys,
    ) -> Result<(MeshData, Vec<crate::scene::ply::PlyAttribute>)> {
        let rel = keys
            .file
            .as_ref()
            .ok_or_else(|| self.err(format!("{field}.file"), "required for a PLY shape"))?;
        let path = self.base.join(rel);
        crate::input::check_input_file(&path)
            .map_err(|e| self.err(format!("{field}.file"), e.to_string()))?;
        let ply = crate::scene::ply::read_ply(&path)
            .map_err(|m| self.err(format!("{field}.file"), format!("{}: {m}", path.display())))?;
        self.read_input(&path);
        if ply.triangles.is_empty() {
            return Err(self.err(
                format!("{field}.file"),
                format!("{} has no faces", path.display()),
            ));
        }
        let normals = mesh_normals(
            ply.normals,
            keys.face_normals,
            keys.smooth_normals,
            (&ply.positions, &ply.triangles),
        );
        Ok((
            (ply.positions, ply.triangles, normals, ply.uvs),
            ply.attributes,
        ))
    }

    /// The mesh of a `serialized` shape: shape `shape_index` (default 0)
    /// of a file in Mitsuba's `serialized` format, with its vertex colours
    /// as the attribute `vertex_color` (Mitsuba's name).
    /// The mesh of a `curves` shape: its file read and checked, moved by
    /// `matrix` (the radii unchanged) and meshed.
    fn curves_mesh(&self, field: &str, keys: &CurvesKeys, matrix: &Mat4) -> Result<MeshData> {
        use crate::scene::curves::{curve_mesh, parse_curves, CurveBasis};
        let basis = match keys.basis.as_deref().unwrap_or("bspline") {
            "bspline" => CurveBasis::BSpline,
            "linear" => CurveBasis::Linear,
            other => {
                return Err(self.err(
                    format!("{field}.basis"),
                    format!("unknown basis `{other}` (known: bspline, linear)"),
                ))
            }
        };
        let sides = keys.sides.unwrap_or(DEFAULT_CURVE_SIDES);
        if !(3..=1024).contains(&sides) {
            return Err(self.err(
                format!("{field}.sides"),
                format!("must be between 3 and 1024, got {sides}"),
            ));
        }
        let steps = keys.steps.unwrap_or(DEFAULT_CURVE_STEPS);
        if !(1..=1024).contains(&steps) {
            return Err(self.err(
                format!("{field}.steps"),
                format!("must be between 1 and 1024, got {steps}"),
            ));
        }
        let rel = keys
            .file
            .as_ref()
            .ok_or_else(|| self.err(format!("{field}.file"), "required for curves"))?;
        let path = self.base.join(rel);
        crate::input::check_input_file(&path)
            .map_err(|e| self.err(format!("{field}.file"), e.to_string()))?;
        let size = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        if size > MAX_CURVE_FILE {
            return Err(self.err(
                format!("{field}.file"),
                format!(
                    "{}: {size} bytes, more than the {MAX_CURVE_FILE} a curve file may have",
                    path.display()
                ),
            ));
        }
        let text = crate::input::read_text_lenient(&path)
            .map_err(|e| self.err(format!("{field}.file"), format!("{}: {e}", path.display())))?;
        self.read_input(&path);
        let curves = parse_curves(&text, basis)
            .map_err(|m| self.err(format!("{field}.file"), format!("{}: {m}", path.display())))?;
        // Rings (or sphere stacks) per curve, each `2·sides` triangles.
        let rings: u64 = curves
            .iter()
            .map(|c| match basis {
                CurveBasis::BSpline => (c.len() as u64 - 3) * steps as u64,
                CurveBasis::Linear => (c.len() as u64 - 1) * (2 + sides as u64 / 2),
            })
            .sum();
        if rings * 2 * sides as u64 > MAX_CURVE_TRIANGLES {
            return Err(self.err(
                format!("{field}.file"),
                format!(
                    "{}: its curves would make {} triangles, more than {MAX_CURVE_TRIANGLES} \
                     (lower `sides` or `steps`)",
                    path.display(),
                    rings * 2 * sides as u64
                ),
            ));
        }
        Ok(curve_mesh(&curves, basis, matrix, sides, steps))
    }

    /// The mesh of an `sdf_grid` shape (object space, the unit cube).
    fn sdf_grid_mesh(&self, field: &str, keys: &SdfGridKeys) -> Result<MeshData> {
        use crate::scene::sdf_grid::{read_vol, SdfNormals};
        let mode = match keys.normals.as_deref().unwrap_or("smooth") {
            "smooth" => SdfNormals::Smooth,
            "analytic" => SdfNormals::Analytic,
            other => {
                return Err(self.err(
                    format!("{field}.normals"),
                    format!("unknown normals `{other}` (known: smooth, analytic)"),
                ))
            }
        };
        let subdivisions = keys.subdivisions.unwrap_or(DEFAULT_SDF_SUBDIVISIONS);
        if !(1..=8).contains(&subdivisions) {
            return Err(self.err(
                format!("{field}.subdivisions"),
                format!("must be between 1 and 8, got {subdivisions}"),
            ));
        }
        let rel = keys
            .file
            .as_ref()
            .ok_or_else(|| self.err(format!("{field}.file"), "required for an SDF grid"))?;
        let path = self.base.join(rel);
        crate::input::check_input_file(&path)
            .map_err(|e| self.err(format!("{field}.file"), e.to_string()))?;
        let size = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        if size > MAX_SDF_FILE {
            return Err(self.err(
                format!("{field}.file"),
                format!(
                    "{}: {size} bytes, more than the {MAX_SDF_FILE} an SDF grid may have",
                    path.display()
                ),
            ));
        }
        let bytes = std::fs::read(&path)
            .map_err(|e| self.err(format!("{field}.file"), format!("{}: {e}", path.display())))?;
        self.read_input(&path);
        let grid = read_vol(&bytes)
            .map_err(|m| self.err(format!("{field}.file"), format!("{}: {m}", path.display())))?;
        let cells: u64 = grid
            .size
            .iter()
            .map(|&n| (n as u64 - 1) * subdivisions as u64)
            .product();
        if cells > 1 << 30 {
            return Err(self.err(
                format!("{field}.subdivisions"),
                format!("{cells} cells to march, more than 2^30: lower `subdivisions`"),
            ));
        }
        let (p, t, n) = grid.mesh(subdivisions, mode);
        if t.is_empty() {
            return Err(self.err(
                format!("{field}.file"),
                format!(
                    "{}: the grid has no surface (no sign change)",
                    path.display()
                ),
            ));
        }
        Ok((p, t, n, Vec::new()))
    }

    fn serialized_mesh(
        &self,
        field: &str,
        keys: &SerializedKeys,
    ) -> Result<(MeshData, Vec<crate::scene::ply::PlyAttribute>)> {
        let rel = keys
            .file
            .as_ref()
            .ok_or_else(|| self.err(format!("{field}.file"), "required for a serialized shape"))?;
        let path = self.base.join(rel);
        crate::input::check_input_file(&path)
            .map_err(|e| self.err(format!("{field}.file"), e.to_string()))?;
        let index = keys.shape_index.unwrap_or(0);
        let mesh = crate::scene::serialized::read_serialized(&path, index).map_err(|m| {
            let key = if m.to_string().contains("shape_index") {
                "shape_index"
            } else {
                "file"
            };
            self.err(format!("{field}.{key}"), format!("{}: {m}", path.display()))
        })?;
        self.read_input(&path);
        if mesh.triangles.is_empty() {
            return Err(self.err(
                format!("{field}.file"),
                format!("{} has no faces in shape {index}", path.display()),
            ));
        }
        let normals = mesh_normals(
            mesh.normals,
            keys.face_normals,
            keys.smooth_normals,
            (&mesh.positions, &mesh.triangles),
        );
        let attributes = if mesh.colors.is_empty() {
            Vec::new()
        } else {
            vec![crate::scene::ply::PlyAttribute {
                name: "vertex_color".into(),
                values: mesh.colors,
            }]
        };
        Ok((
            (mesh.positions, mesh.triangles, normals, mesh.uvs),
            attributes,
        ))
    }

    /// The meshes of an `obj` shape: one per object of the file, with the
    /// shape's material or the file's MTL materials.
    fn obj_meshes(
        &self,
        shape: &Common,
        keys: &ObjKeys,
        materials: &mut Vec<Material>,
        meshes: &mut Vec<Mesh>,
    ) -> Result<()> {
        let field = shape.field;
        let rel = keys
            .file
            .as_ref()
            .ok_or_else(|| self.err(format!("{field}.file"), "required for an OBJ shape"))?;
        let path = self.base.join(rel);
        let obj = shapes::load_obj(&path, self.file, &format!("{field}.file"))?;
        self.read_input(&path);
        for lib in &obj.libraries {
            self.read_input(lib);
        }
        if obj.objects.is_empty() {
            return Err(self.err(
                format!("{field}.file"),
                format!("{} has no triangles", path.display()),
            ));
        }
        // One material per MTL entry used, shared by the file's objects.
        let mut mtl_index: HashMap<usize, u32> = HashMap::new();
        for o in obj.objects {
            // Smooth normals for objects the file gives none, computed in
            // the file's coordinates like the file's own normals.
            let normals = if o.normals.is_empty() && keys.smooth_normals.unwrap_or(false) {
                shapes::angle_weighted_normals(&o.positions, &o.triangles)
            } else {
                o.normals
            };
            let (mut p, mut t) = (o.positions, o.triangles);
            transform_mesh(&shape.matrix, &mut p, &mut t);
            let normals = transform_normals(&shape.matrix, normals);
            let mtl = o.material.and_then(|m| obj.materials.get(m));
            let mat = match (shape.material, o.material, mtl) {
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
                    two_sided: shape.two_sided,
                    cone: None,
                });
            meshes.push(Mesh {
                cull_back: false,
                name: format!("{}/{}", shape.name, o.name),
                positions: p,
                triangles: t,
                normals,
                uvs: o.uvs,
                tangents: Vec::new(),
                material: mat,
                emission: shape.emission.or(mtl_emission),
                object_id: shape.object_id,
                pls: None,
                is_virtual: shape.is_virtual,
                uv_map: crate::scene::uv_map::UvMap::Vertices,
                colors: None,
                emission_map: None,
            });
        }
        Ok(())
    }

    /// The meshes of a `gltf` shape: one per triangle primitive of the
    /// file's default scene (node transforms, then the shape's), with the
    /// shape's material or the file's own (as `principled`), and the
    /// shape's emission or the file's emissive factors.
    fn gltf_meshes(
        &self,
        shape: &Common,
        keys: &GltfKeys,
        materials: &mut Vec<Material>,
        meshes: &mut Vec<Mesh>,
    ) -> Result<()> {
        let field = shape.field;
        let rel = keys
            .file
            .as_ref()
            .ok_or_else(|| self.err(format!("{field}.file"), "required for a glTF shape"))?;
        let path = self.base.join(rel);
        crate::input::check_input_file(&path)
            .map_err(|e| self.err(format!("{field}.file"), e.to_string()))?;
        let time = keys.time.unwrap_or(0.0);
        if !time.is_finite() {
            return Err(self.err(
                format!("{field}.time"),
                "must be a finite number of seconds",
            ));
        }
        let gltf = crate::scene::gltf_scene::read_gltf_at(&path, time)
            .map_err(|m| self.err(format!("{field}.file"), format!("{}: {m}", path.display())))?;
        self.read_input(&path);
        for f in &gltf.files {
            self.read_input(f);
        }
        for n in &gltf.notes {
            self.note(format!("{field} ({}): {n}", rel.display()));
        }
        if gltf.objects.is_empty() {
            return Err(self.err(
                format!("{field}.file"),
                format!("{}: its default scene has no triangles", path.display()),
            ));
        }
        // One plsr material per glTF material, and another where vertex
        // colours multiply its base colour.
        let mut index: HashMap<(Option<usize>, bool), u32> = HashMap::new();
        for o in gltf.objects {
            let colored = !o.colors.is_empty();
            let mat = match shape.material {
                Some(m) => m,
                None => match index.get(&(o.material, colored)) {
                    Some(&m) => m,
                    None => {
                        let material = match o.material {
                            Some(i) => {
                                let mut m = gltf.materials[i].clone();
                                m.name = format!("{}:{}", rel.display(), m.name);
                                m
                            }
                            // glTF's default material: white, metallic 1,
                            // roughness 1.
                            None => Material::new(
                                format!("{}:(default)", rel.display()),
                                Bsdf::Principled(crate::bsdf::PrincipledParams {
                                    base_color: Vec3::ONE,
                                    roughness: 1.0,
                                    metallic: 1.0,
                                    anisotropic: 0.0,
                                    specular: 0.5,
                                    spec_tint: 0.0,
                                    energy_conserving: true,
                                }),
                            ),
                        };
                        let material = match colored {
                            true => crate::scene::gltf_scene::with_vertex_colors(material),
                            false => material,
                        };
                        materials.push(material);
                        let m = (materials.len() - 1) as u32;
                        index.insert((o.material, colored), m);
                        m
                    }
                },
            };
            let normals = if o.normals.is_empty() && keys.smooth_normals.unwrap_or(false) {
                shapes::angle_weighted_normals(&o.positions, &o.triangles)
            } else {
                o.normals
            };
            let (mut p, mut t) = (o.positions, o.triangles);
            transform_mesh(&shape.matrix, &mut p, &mut t);
            let normals = transform_normals(&shape.matrix, normals);
            let extras = o.material.and_then(|m| gltf.extras.get(m));
            // glTF's default material is one-sided.
            let double_sided = extras.is_some_and(|e| e.double_sided);
            let emission_map = match extras.and_then(|e| e.emission_map.clone()) {
                Some(_) if shape.emission.is_some() => None,
                Some(_) if o.emission_uvs.is_empty() => {
                    self.note(format!(
                        "{field} ({}): `{}` has an emissive texture but no texture \
                         coordinates: it emits its emissive factor everywhere",
                        rel.display(),
                        o.name
                    ));
                    None
                }
                map => map.map(|texture| crate::scene::MeshEmissionMap {
                    texture,
                    uvs: o.emission_uvs,
                }),
            };
            let file_emission = extras
                .map(|e| e.emission)
                .filter(|e| e.max_element() > 0.0)
                .map(|radiance| Emission {
                    radiance,
                    two_sided: shape.two_sided,
                    cone: None,
                });
            let emission = shape.emission.or(file_emission);
            if shape.is_virtual && emission.is_some() {
                return Err(self.err(
                    format!("{field}.file"),
                    format!(
                        "{}: `{}` emits, and a virtual object cannot emit",
                        path.display(),
                        o.name
                    ),
                ));
            }
            let colors = match colored && shape.material.is_none() {
                true => Some(crate::scene::MeshColors::Vertex(o.colors)),
                false => None,
            };
            meshes.push(Mesh {
                cull_back: !double_sided,
                name: format!("{}/{}", shape.name, o.name),
                positions: p,
                triangles: t,
                normals,
                uvs: o.uvs,
                tangents: crate::scene::gltf_scene::transform_tangents(&shape.matrix, o.tangents),
                material: mat,
                emission,
                object_id: shape.object_id,
                pls: None,
                is_virtual: shape.is_virtual,
                uv_map: crate::scene::uv_map::UvMap::Vertices,
                colors,
                emission_map,
            });
        }
        Ok(())
    }

    /// The tube of a `cylinder` shape in its unit frame, with its outward
    /// normals and texture coordinates, and that frame in the shape's
    /// coordinates: Mitsuba's `translate(p0) · frame(axis) · scale(r, r,
    /// |p1 − p0|)`, the frame's first axis Mitsuba's `coordinate_system`
    /// of the axis (where `u = 0` lies).
    fn cylinder_mesh(&self, field: &str, keys: &CylinderKeys) -> Result<(MeshParts, Mat4)> {
        let p0 = self.vec3(&format!("{field}.p0"), keys.p0.unwrap_or([0.0; 3]))?;
        let p1 = self.vec3(&format!("{field}.p1"), keys.p1.unwrap_or([0.0, 0.0, 1.0]))?;
        let radius = self.finite(&format!("{field}.radius"), keys.radius.unwrap_or(1.0))?;
        if radius <= 0.0 {
            return Err(self.err(
                format!("{field}.radius"),
                format!("must be positive, got {radius}"),
            ));
        }
        let length = (p1 - p0).length();
        if length == 0.0 || !length.is_finite() {
            return Err(self.err(format!("{field}.p1"), "must differ from p0"));
        }
        let segments = keys.segments.unwrap_or(DEFAULT_DISK_SEGMENTS);
        if !(3..=MAX_DISK_SEGMENTS).contains(&segments) {
            return Err(self.err(
                format!("{field}.segments"),
                format!("must be between 3 and {MAX_DISK_SEGMENTS}, got {segments}"),
            ));
        }
        let axis = (p1 - p0) / length;
        let (s, t) = shapes::coordinate_system(axis);
        let frame = Mat4::from_translation(p0)
            * Mat4::from_cols(
                s.extend(0.0),
                t.extend(0.0),
                axis.extend(0.0),
                Vec3::ZERO.extend(1.0),
            )
            * Mat4::from_scale(Vec3::new(radius, radius, length));
        let (mut p, tris, n, uv) = shapes::cylinder(segments);
        let normal_matrix = glam::Mat3::from_mat4(frame).inverse().transpose();
        for q in &mut p {
            *q = frame.transform_point3(*q);
        }
        let n = n
            .into_iter()
            .map(|v| (normal_matrix * v).normalize())
            .collect();
        Ok(((p, tris, n, uv), frame))
    }

    /// The icosphere of a `sphere` shape, with its smooth normals and
    /// spherical texture coordinates, and the unit sphere's frame (centre
    /// and radius) in the shape's coordinates.
    fn sphere_mesh(&self, field: &str, keys: &SphereKeys) -> Result<(MeshParts, Mat4)> {
        let center = self.vec3(&format!("{field}.center"), keys.center.unwrap_or([0.0; 3]))?;
        let radius = self.finite(&format!("{field}.radius"), keys.radius.unwrap_or(1.0))?;
        if radius <= 0.0 {
            return Err(self.err(
                format!("{field}.radius"),
                format!("must be positive, got {radius}"),
            ));
        }
        let subdivisions = keys.subdivisions.unwrap_or(4);
        if subdivisions > 8 {
            return Err(self.err(
                format!("{field}.subdivisions"),
                format!("must be at most 8 (20·4^8 triangles), got {subdivisions}"),
            ));
        }
        let (p, t, uv) = shapes::icosphere_with_uvs(center, radius, subdivisions);
        // The smooth sphere's normals shade the facets.
        let normals = p.iter().map(|q| (*q - center) / radius).collect();
        let frame = Mat4::from_translation(center) * Mat4::from_scale(Vec3::splat(radius));
        Ok(((p, t, normals, uv), frame))
    }
}

/// The built-in shapes whose texture coordinates are computed at hits.
#[derive(Debug, Clone, Copy)]
enum Round {
    Sphere,
    Disk,
    Cylinder,
}

/// Positions, triangles, normals and texture coordinates of a shape.
type MeshParts = (Vec<Vec3>, Vec<[u32; 3]>, Vec<Vec3>, Vec<Vec2>);

/// What every shape has, read before its type's keys.
struct Common<'a> {
    field: &'a str,
    matrix: Mat4,
    material: Option<u32>,
    emission: Option<Emission>,
    /// Whether emission (the shape's or the MTL's `Ke`) leaves both sides.
    two_sided: bool,
    name: &'a str,
    object_id: u32,
    /// A virtual object (`virtual = true`).
    is_virtual: bool,
}

/// The index of the default material (a grey diffuse), added when first
/// needed.
fn default_material(materials: &mut Vec<Material>) -> u32 {
    let name = "(default)";
    if let Some(i) = materials.iter().position(|m| m.name == name) {
        return i as u32;
    }
    materials.push(Material::new(
        name,
        Bsdf::diffuse(Vec3::splat(DEFAULT_REFLECTANCE)),
    ));
    (materials.len() - 1) as u32
}

/// Normals under the transform `m`: by the inverse transpose of its linear
/// part, renormalised.
pub(super) fn transform_normals(m: &Mat4, normals: Vec<Vec3>) -> Vec<Vec3> {
    if normals.is_empty() {
        return normals;
    }
    let n = glam::Mat3::from_mat4(*m).inverse().transpose();
    normals
        .into_iter()
        .map(|v| (n * v).normalize_or_zero())
        .collect()
}

/// The message for `key`, not a key of shapes of type `kind`: "not used"
/// if another shape type has it, else unknown, with the list of keys.
fn unknown_shape_key(kind: &str, key: &str) -> String {
    let mut all = SHAPE_KEYS.to_vec();
    for k in [
        key_names::<ObjKeys>(),
        key_names::<RectangleKeys>(),
        key_names::<SphereKeys>(),
        key_names::<DiskKeys>(),
        key_names::<CylinderKeys>(),
        key_names::<PlyKeys>(),
        key_names::<CubeKeys>(),
        key_names::<GltfKeys>(),
        key_names::<CurvesKeys>(),
        key_names::<SdfGridKeys>(),
    ]
    .concat()
    {
        if !all.contains(&k) {
            all.push(k);
        }
    }
    if all.contains(&key) {
        format!("not used by shapes of type `{kind}`")
    } else {
        let list: Vec<String> = std::iter::once("type")
            .chain(all)
            .map(|k| format!("`{k}`"))
            .collect();
        format!("unknown field `{key}`, expected one of {}", list.join(", "))
    }
}

/// A mesh's positions, triangles, normals and texture coordinates.
type MeshData = (Vec<Vec3>, Vec<[u32; 3]>, Vec<Vec3>, Vec<Vec2>);

/// A mesh's vertex normals: none with `face_normals` (flat shading);
/// else the file's, or with `smooth_normals` and none in the file,
/// angle-weighted ones.
fn mesh_normals(
    from_file: Vec<Vec3>,
    face_normals: Option<bool>,
    smooth_normals: Option<bool>,
    (positions, triangles): (&[Vec3], &[[u32; 3]]),
) -> Vec<Vec3> {
    if face_normals.unwrap_or(false) {
        Vec::new()
    } else if from_file.is_empty() && smooth_normals.unwrap_or(false) {
        shapes::angle_weighted_normals(positions, triangles)
    } else {
        from_file
    }
}
