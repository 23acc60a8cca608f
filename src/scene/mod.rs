//! The scene: meshes, materials, lights and camera, plus the
//! Embree acceleration structure built over them.
//!
//! A scene is described either by a file ([`Scene::load`], see
//! `docs/scene-format.md` and [`file`](mod@file)) or in code ([`SceneDescription`]), and
//! turned by [`Scene::build`] into a [`Scene`] ready to render. Geometry id
//! `i` in Embree is `meshes[i]`, so a hit names its mesh directly.

mod confined;
pub mod curves;
pub mod file;
pub mod gltf_animation;
mod gltf_files;
pub mod gltf_materials;
pub mod gltf_scene;
mod gltf_tangents;
pub mod instancing;
pub mod mitsuba;
pub mod photo;
pub mod ply;
pub mod sdf_grid;
pub mod serialized;
pub mod shapes;
pub mod uv_map;

use crate::accel::{Accel, Device, SceneOptions};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::film::FilmSettings;
use crate::job::RenderJob;
use crate::light::pls::{BrightnessMode, Pls, PlsEmitter};
use crate::light::{
    Cone, DirectionalLight, EnvironmentLight, Light, LightPicking, LightSet, PointLight, Reach,
    TriangleLight,
};
use glam::{Vec2, Vec3};
use plsr_base::Vocabulary;
use std::path::Path;
use std::sync::Arc;

/// Environment variable holding extra Embree device configuration (e.g.
/// `verbose=1`), passed to `rtcNewDevice`.
pub const EMBREE_CONFIG_VAR: &str = "PLSR_EMBREE_CONFIG";

pub use crate::material::{Material, MaterialTextures};

/// Emission of an area light: constant radiance over a mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Emission {
    /// Emitted radiance, W/(m²·sr) per linear RGB channel.
    pub radiance: Vec3,
    /// Whether both sides emit (default: the geometric normal's side only).
    pub two_sided: bool,
    /// For a parametric light source: the cone it emits into (its window
    /// function); `None` emits into the whole hemisphere.
    pub cone: Option<Cone>,
}

/// A triangle mesh in world space.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    /// Name (from the scene file or the OBJ object), for messages.
    pub name: String,
    /// World-space vertex positions (scene units).
    pub positions: Vec<Vec3>,
    /// Counter-clockwise triangles (seen from the geometric normal's side).
    pub triangles: Vec<[u32; 3]>,
    /// Per-vertex unit shading normals (world space), or empty: shade with
    /// the geometric normal.
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates, or empty.
    pub uvs: Vec<Vec2>,
    /// Per-vertex unit tangents (world space, along increasing `u`) with the
    /// bitangent's sign in `w` (glTF's `TANGENT`: bitangent =
    /// `w·(normal × tangent)`), or empty: normal maps then take their frame
    /// from the texture coordinates. Only normal maps use them.
    pub tangents: Vec<glam::Vec4>,
    /// Index into the scene's materials.
    pub material: u32,
    /// Emission, when the mesh is an area light.
    pub emission: Option<Emission>,
    /// Object identity written to the film's object AOV (the scene-file shape
    /// index), so that later compositing can cut objects out.
    pub object_id: u32,
    /// For the emitter of a parametric light: the light it tessellates.
    pub pls: Option<PlsEmitter>,
    /// Whether the mesh is a virtual object, inserted into a photograph of
    /// the real scene (the rest of the scene stands for the real one). A
    /// job with [`RenderJob::hide_virtual`] renders as if it were absent.
    pub is_virtual: bool,
    /// How texture coordinates are found at a hit: interpolated from
    /// `uvs`, or computed from the hit point (the built-in sphere and disk).
    pub uv_map: uv_map::UvMap,
    /// Colours stored with the mesh (a PLY's `vertex_color`, glTF's
    /// `COLOR_0`), which multiply the base colour of a material whose
    /// `base_color_attribute` is set; `None` leaves it as it is.
    pub colors: Option<MeshColors>,
    /// A texture that multiplies `emission`'s radiance over the surface
    /// (glTF's emissive texture), with its own texture coordinates.
    pub emission_map: Option<MeshEmissionMap>,
    /// Whether rays pass through the mesh's back faces (those they meet
    /// along its winding's normal), as through the inside of Mitsuba's
    /// curves, whose tubes are open-ended.
    pub cull_back: bool,
}

/// A texture that multiplies a mesh's emitted radiance, looked up by
/// texture coordinates of its own (glTF's emissive texture may read another
/// UV set than the shading textures).
#[derive(Debug, Clone, PartialEq)]
pub struct MeshEmissionMap {
    /// Linear factors, per texel.
    pub texture: Arc<crate::texture::ImageTexture>,
    /// One per vertex of the mesh (plsr's convention: `v` up).
    pub uvs: Vec<Vec2>,
}

/// Linear RGB colours stored with a mesh, per vertex (interpolated over
/// each triangle) or per triangle (constant over it).
#[derive(Debug, Clone, PartialEq)]
pub enum MeshColors {
    /// One colour per vertex.
    Vertex(Vec<Vec3>),
    /// One colour per triangle.
    Face(Vec<Vec3>),
}

impl MeshColors {
    /// The colour on triangle `prim` at barycentrics `(b1, b2)` (Embree's:
    /// `p = (1 − b1 − b2)·p0 + b1·p1 + b2·p2`).
    #[inline]
    pub fn at(&self, triangles: &[[u32; 3]], prim: usize, b1: f32, b2: f32) -> Vec3 {
        match self {
            MeshColors::Vertex(c) => {
                let [i0, i1, i2] = triangles[prim].map(|i| i as usize);
                c[i0] * (1.0 - b1 - b2) + c[i1] * b1 + c[i2] * b2
            }
            MeshColors::Face(c) => c[prim],
        }
    }
}

/// Why a mesh is invalid.
#[derive(Debug, Clone, PartialEq)]
pub enum MeshError {
    /// No vertices or no triangles.
    Empty,
    /// Vertex `i`'s position is not finite.
    NonFinitePosition(usize),
    /// Triangle `i` refers to a vertex past the last.
    IndexOutOfRange {
        /// The triangle.
        triangle: usize,
        /// How many vertices there are.
        vertices: usize,
    },
    /// The normals or texture coordinates are neither empty nor one per vertex.
    AttributeCount {
        /// `"normals"` or `"uvs"`.
        attribute: &'static str,
        /// How many were given.
        given: usize,
        /// How many vertices there are.
        vertices: usize,
    },
    /// More vertices than 32-bit indices can address.
    TooManyVertices(usize),
    /// Vertex `i` lies beyond [`MAX_COORDINATE`](crate::accel::MAX_COORDINATE).
    PositionTooFar(usize),
    /// Face colours that are not one per triangle.
    FaceColorCount {
        /// How many were given.
        given: usize,
        /// How many triangles there are.
        triangles: usize,
    },
    /// Colour `i` is not finite.
    NonFiniteColor(usize),
}

impl std::fmt::Display for MeshError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MeshError::Empty => write!(f, "a mesh needs at least one vertex and one triangle"),
            MeshError::NonFinitePosition(i) => write!(f, "position {i} is not finite"),
            MeshError::IndexOutOfRange { triangle, vertices } => write!(
                f,
                "triangle {triangle} refers to a vertex past the {vertices} given"
            ),
            MeshError::AttributeCount {
                attribute,
                given,
                vertices,
            } => write!(
                f,
                "{given} {attribute} for {vertices} vertices (give one per vertex, or none)"
            ),
            MeshError::TooManyVertices(n) => write!(f, "{n} vertices: at most 2^32"),
            MeshError::FaceColorCount { given, triangles } => write!(
                f,
                "{given} face colours for {triangles} triangles (give one per triangle, or none)"
            ),
            MeshError::NonFiniteColor(i) => write!(f, "colour {i} is not finite"),
            MeshError::PositionTooFar(i) => write!(
                f,
                "position {i} is beyond ±{:e} scene units",
                crate::accel::MAX_COORDINATE
            ),
        }
    }
}

impl std::error::Error for MeshError {}

impl Mesh {
    /// The Embree mask of the mesh: [`VIRTUAL_MASK`](crate::accel::VIRTUAL_MASK)
    /// for virtual objects, [`REAL_MASK`](crate::accel::REAL_MASK) otherwise.
    #[inline]
    pub fn mask(&self) -> u32 {
        if self.is_virtual {
            crate::accel::VIRTUAL_MASK
        } else {
            crate::accel::REAL_MASK
        }
    }

    /// The value of the film's object layer for this mesh: its object id,
    /// or −1 for light fixtures (`object_id == u32::MAX`), which are not
    /// objects.
    #[inline]
    pub fn object_layer(&self) -> f32 {
        if self.object_id == u32::MAX {
            -1.0
        } else {
            self.object_id as f32
        }
    }

    /// A checked mesh of `positions` and counter-clockwise `triangles`, with
    /// material `material`, no normals, texture coordinates or emission,
    /// and object id `object_id`.
    pub fn new(
        name: impl Into<String>,
        positions: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        material: u32,
        object_id: u32,
    ) -> std::result::Result<Mesh, MeshError> {
        if positions.is_empty() || triangles.is_empty() {
            return Err(MeshError::Empty);
        }
        let mesh = Mesh {
            cull_back: false,
            name: name.into(),
            positions,
            triangles,
            normals: Vec::new(),
            uvs: Vec::new(),
            tangents: Vec::new(),
            material,
            emission: None,
            object_id,
            pls: None,
            is_virtual: false,
            uv_map: uv_map::UvMap::Vertices,
            colors: None,
            emission_map: None,
        };
        mesh.validate()?;
        Ok(mesh)
    }

    /// Checks what Embree and the integrator rely on: finite positions,
    /// indices in range, one normal and one texture coordinate per vertex
    /// (or none). Empty meshes pass (scene files may hold them); only
    /// [`Mesh::new`] refuses them.
    pub fn validate(&self) -> std::result::Result<(), MeshError> {
        let n = self.positions.len();
        if n > u32::MAX as usize {
            return Err(MeshError::TooManyVertices(n));
        }
        if let Some(i) = self.positions.iter().position(|v| !v.is_finite()) {
            return Err(MeshError::NonFinitePosition(i));
        }
        if let Some(i) = self
            .positions
            .iter()
            .position(|v| !crate::accel::within_coordinates(*v))
        {
            return Err(MeshError::PositionTooFar(i));
        }
        if let Some(t) = self
            .triangles
            .iter()
            .position(|tri| tri.iter().any(|&k| k as usize >= n))
        {
            return Err(MeshError::IndexOutOfRange {
                triangle: t,
                vertices: n,
            });
        }
        for (attribute, given) in [
            ("normals", self.normals.len()),
            ("uvs", self.uvs.len()),
            ("tangents", self.tangents.len()),
        ] {
            if given != 0 && given != n {
                return Err(MeshError::AttributeCount {
                    attribute,
                    given,
                    vertices: n,
                });
            }
        }
        match &self.colors {
            Some(MeshColors::Vertex(c)) if c.len() != n => {
                return Err(MeshError::AttributeCount {
                    attribute: "vertex colours",
                    given: c.len(),
                    vertices: n,
                })
            }
            Some(MeshColors::Face(c)) if c.len() != self.triangles.len() => {
                return Err(MeshError::FaceColorCount {
                    given: c.len(),
                    triangles: self.triangles.len(),
                })
            }
            Some(MeshColors::Vertex(c) | MeshColors::Face(c)) => {
                if let Some(i) = c.iter().position(|v| !v.is_finite()) {
                    return Err(MeshError::NonFiniteColor(i));
                }
            }
            None => {}
        }
        Ok(())
    }
}

/// The emitter of a parametric light source as a mesh: its outline
/// tessellated into `nf` quads, emitting `light.radiance(mode, area)` into its
/// cone, with material `material` (normally black: fixtures do not reflect).
/// Light fixtures are not objects: their `object_id` is `u32::MAX`. The mesh
/// keeps the light's parameters ([`Mesh::pls`]).
pub fn pls_mesh(light: &Pls, mode: BrightnessMode, nf: u32, material: u32, name: String) -> Mesh {
    let emitter = PlsEmitter {
        light: light.clone(),
        mode,
        nf,
    };
    let mesh = emitter.tessellate();
    let radiance = emitter.radiance(mesh.area());
    Mesh {
        cull_back: false,
        name,
        positions: mesh.positions,
        triangles: mesh.triangles,
        normals: Vec::new(),
        uvs: Vec::new(),
        tangents: Vec::new(),
        material,
        emission: Some(Emission {
            radiance,
            two_sided: false,
            cone: Some(emitter.cone()),
        }),
        object_id: u32::MAX,
        pls: Some(emitter),
        is_virtual: false,
        uv_map: uv_map::UvMap::Vertices,
        colors: None,
        emission_map: None,
    }
}

/// The centre and radius of the sphere a mesh tessellates, when it is the
/// built-in sphere shape under a transform that keeps it round (rotation,
/// uniform scale, translation); its vertices then lie on that sphere.
fn exact_sphere(m: &Mesh) -> Option<(Vec3, f32)> {
    let uv_map::UvMap::Sphere { to_local, .. } = m.uv_map else {
        return None;
    };
    let world = to_local.inverse();
    let axes = [
        world.matrix3.x_axis,
        world.matrix3.y_axis,
        world.matrix3.z_axis,
    ];
    let r = axes[0].length();
    let round = axes.iter().all(|a| (a.length() - r).abs() <= 1e-4 * r)
        && axes[0].dot(axes[1]).abs() <= 1e-4 * r * r
        && axes[1].dot(axes[2]).abs() <= 1e-4 * r * r
        && axes[2].dot(axes[0]).abs() <= 1e-4 * r * r;
    (round && r > 0.0 && r.is_finite()).then(|| (Vec3::from(world.translation), r))
}

/// Everything needed to build a scene, before Embree sees it.
#[derive(Debug, Clone)]
pub struct SceneDescription {
    /// Meshes; their order is their Embree geometry id.
    pub meshes: Vec<Mesh>,
    /// Materials, indexed by `Mesh::material`.
    pub materials: Vec<Material>,
    /// Point and spot lights.
    pub point_lights: Vec<PointLight>,
    /// Directional lights (parallel light from one direction).
    pub directional_lights: Vec<DirectionalLight>,
    /// The environment at infinity, if any (HDR panorama or constant sky).
    pub environment: Option<EnvironmentLight>,
    /// The camera.
    pub camera: Camera,
    /// Pixel filter, exposure and white balance.
    pub film: FilmSettings,
    /// The render the scene file (or builder) asks for; [`Scene::default_job`]
    /// keeps it, and any other job may render the built scene.
    pub job: RenderJob,
    /// Embree's robust intersection mode (watertight, a little slower).
    pub robust: bool,
    /// How next-event estimation picks a light at each shading point.
    pub light_picking: LightPicking,
    /// Groups of meshes placed by instances (none: every mesh is in
    /// `meshes`).
    pub instancing: instancing::Instancing,
}

/// The mesh a ray hit, and the instance that placed it (then the mesh is
/// in its group's space).
#[derive(Clone, Copy)]
pub struct MeshHit<'a> {
    /// The mesh.
    pub mesh: &'a Mesh,
    /// The instance, for a mesh of a group.
    pub instance: Option<&'a instancing::Instance>,
}

impl MeshHit<'_> {
    /// `hit` with its geometric normal in the world (an instance's hit
    /// reports it in its group's space).
    #[inline]
    pub fn world(&self, hit: crate::accel::Hit) -> crate::accel::Hit {
        match self.instance {
            None => hit,
            Some(i) => crate::accel::Hit {
                ng: i.geometric(hit.ng),
                ..hit
            },
        }
    }

    /// The object identity the film's object layer records.
    pub fn object_layer(&self) -> f32 {
        match self.instance {
            Some(i) => i.object_id as f32,
            None => self.mesh.object_layer(),
        }
    }
}

/// A scene ready to render: the meshes, materials, lights and camera, and
/// Embree's acceleration structure over the meshes. What to render of it
/// (spp, depth, seed) is a [`RenderJob`], given to each render.
pub struct Scene {
    /// Meshes, indexed by Embree geometry id.
    meshes: Vec<Mesh>,
    /// For each mesh, the index in `lights.lights` of its first triangle's
    /// light (emissive meshes only).
    first_light: Vec<Option<u32>>,
    /// Materials.
    materials: Vec<Material>,
    /// All lights.
    lights: LightSet,
    /// Index in `lights.lights` of the environment, if any.
    environment: Option<usize>,
    /// The camera.
    camera: Camera,
    /// Pixel filter, exposure and white balance.
    film: FilmSettings,
    /// The job the description asked for.
    default_job: RenderJob,
    /// Embree's acceleration structure over `meshes` and the instances.
    accel: Accel,
    /// The groups and their instances (geometry ids from `meshes.len()`).
    instancing: instancing::Instancing,
    /// Each group's acceleration structure, which its instances place.
    _group_accels: Vec<Accel>,
    /// Whether any light can be hit by a ray (area lights, environment).
    has_hittable_lights: bool,
}

impl Scene {
    /// Loads a scene file (TOML, or JSON with the same schema by extension).
    pub fn load(path: &Path) -> Result<Scene> {
        let desc = file::load(path)?;
        Scene::build(desc)
    }

    /// Builds the lights and the Embree scene of a description.
    pub fn build(desc: SceneDescription) -> Result<Scene> {
        let SceneDescription {
            meshes,
            materials,
            point_lights,
            directional_lights,
            environment,
            camera,
            film,
            job,
            robust,
            light_picking,
            instancing,
        } = desc;
        job.validate()
            .map_err(|e| Error::invalid_argument(format!("render: {e}")))?;
        if meshes.len() >= u32::MAX as usize {
            return Err(Error::invalid_argument("too many meshes"));
        }
        // Tabulate the albedos energy-conserving materials need now rather
        // than in the middle of the render.
        for (i, m) in materials.iter().enumerate() {
            let leaves = m.composite.iter().flat_map(|c| c.leaves());
            for leaf in std::iter::once(m).chain(leaves) {
                if let crate::bsdf::Bsdf::Principled(p) = &leaf.bsdf {
                    p.validate().map_err(|e| {
                        Error::invalid_argument(format!("material {i} ({}): {e}", m.name))
                    })?;
                    p.prepare();
                }
                // The rough plastic's transmittance table, likewise.
                if let crate::bsdf::Bsdf::RoughPlastic(p) = &leaf.bsdf {
                    p.validate().map_err(|e| {
                        Error::invalid_argument(format!("material {i} ({}): {e}", m.name))
                    })?;
                    p.prepare();
                }
            }
            if let Some(c) = &m.composite {
                for (side, layers) in [("front", Some(&c.front)), ("back", c.back.as_ref())] {
                    let parts =
                        layers.map_or(0, |l| l.iter().filter(|l| l.material.is_some()).count());
                    if parts > crate::bsdf::mixture::MAX_PARTS {
                        return Err(Error::invalid_argument(format!(
                            "material {i} ({}): its {side} mixes {parts} materials (at most {})",
                            m.name,
                            crate::bsdf::mixture::MAX_PARTS
                        )));
                    }
                }
            }
        }
        let grouped = instancing.groups.iter().enumerate().flat_map(|(g, group)| {
            group
                .meshes
                .iter()
                .enumerate()
                .map(move |(i, m)| (format!("group {g} ({}), mesh {i}", group.name), m))
        });
        let all = meshes
            .iter()
            .enumerate()
            .map(|(i, m)| (format!("mesh {i}"), m))
            .chain(grouped);
        for (what, m) in all {
            m.validate()
                .map_err(|e| Error::invalid_argument(format!("{what} ({}): {e}", m.name)))?;
            if m.material as usize >= materials.len() {
                return Err(Error::invalid_argument(format!(
                    "{what} ({}) uses material {} of {}",
                    m.name,
                    m.material,
                    materials.len()
                )));
            }
        }
        for (i, l) in point_lights.iter().enumerate() {
            if !crate::accel::within_coordinates(l.position) {
                return Err(Error::invalid_argument(format!(
                    "point light {i}: position {} is beyond ±{:e} scene units",
                    l.position,
                    crate::accel::MAX_COORDINATE
                )));
            }
            if !(l.intensity.is_finite() && l.intensity.min_element() >= 0.0) {
                return Err(Error::invalid_argument(format!(
                    "point light {i}: intensity {} must be finite and not negative",
                    l.intensity
                )));
            }
        }
        let mut groups = Vec::new();
        let mut lights: Vec<Light> = point_lights.into_iter().map(Light::Point).collect();
        for i in 0..lights.len() as u32 {
            groups.push((i..i + 1, None));
        }
        let mut first_light = Vec::with_capacity(meshes.len());
        for (geom, m) in meshes.iter().enumerate() {
            match m.emission {
                Some(e) if e.radiance.max_element() > 0.0 => {
                    let first = lights.len() as u32;
                    first_light.push(Some(first));
                    // A sphere light's triangles are sampled together by
                    // the cone of its exact sphere.
                    let sphere = match (e.cone, &m.pls) {
                        (None, None) => exact_sphere(m),
                        _ => None,
                    };
                    let map_peak = m
                        .emission_map
                        .as_ref()
                        .map_or(0.0, |t| t.texture.max_value());
                    for t in &m.triangles {
                        let p = t.map(|i| m.positions[i as usize]);
                        // Zero-area triangles keep their slot (with zero power,
                        // never picked) so that light index = first + prim id.
                        let light = TriangleLight::new(p, e.radiance, e.two_sided).unwrap_or(
                            TriangleLight {
                                p,
                                n: Vec3::Z,
                                area: 0.0,
                                radiance: Vec3::ZERO,
                                two_sided: false,
                                cone: None,
                                sphere: None,
                                map: None,
                            },
                        );
                        let light = match &m.emission_map {
                            Some(map) if map.uvs.len() == m.positions.len() => TriangleLight {
                                map: Some(crate::light::EmissionMap::new(
                                    map.texture.clone(),
                                    t.map(|i| map.uvs[i as usize]),
                                    map_peak,
                                )),
                                ..light
                            },
                            _ => light,
                        };
                        let light = match e.cone {
                            Some(c) => light.with_cone(c),
                            None => light,
                        };
                        lights.push(Light::Triangle(light));
                    }
                    if let Some((center, radius)) = sphere {
                        // Each triangle's share of the group's area (its
                        // radiance is the group's).
                        let group = &mut lights[first as usize..];
                        let total: f64 = group
                            .iter()
                            .map(|l| match l {
                                Light::Triangle(t) => t.area as f64,
                                _ => 0.0,
                            })
                            .sum();
                        for l in group {
                            if let Light::Triangle(t) = l {
                                if t.area > 0.0 {
                                    t.sphere = Some(crate::light::SphereCap {
                                        center,
                                        radius,
                                        geom: geom as u32,
                                        share: (t.area as f64 / total) as f32,
                                    });
                                }
                            }
                        }
                    }
                    let reach = e.cone.map(|c| {
                        let tris = m
                            .triangles
                            .iter()
                            .map(|t| t.map(|i| m.positions[i as usize]));
                        Reach::new(c, tris.collect())
                    });
                    groups.push((first..lights.len() as u32, reach));
                }
                _ => first_light.push(None),
            }
        }
        // The bounding sphere of the geometry sets the selection power of
        // the lights at infinity against the scene's other lights.
        let scene_radius = {
            let placed = instancing.instances.iter().flat_map(|i| {
                let group = &instancing.groups[i.group as usize];
                group
                    .meshes
                    .iter()
                    .flat_map(|m| &m.positions)
                    .map(|p| i.point(*p))
            });
            let (lo, hi) = meshes
                .iter()
                .flat_map(|m| m.positions.iter().copied())
                .chain(placed)
                .fold(
                    (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                    |(lo, hi), p| (lo.min(p), hi.max(p)),
                );
            let r = if lo.x <= hi.x {
                0.5 * (hi - lo).length()
            } else {
                1.0
            };
            r.max(1e-3)
        };
        for (i, light) in directional_lights.into_iter().enumerate() {
            let d = light.direction;
            if !(d.is_finite() && (d.length() - 1.0).abs() < 1e-3) {
                return Err(Error::invalid_argument(format!(
                    "directional light {i}: direction {d} must be a unit vector"
                )));
            }
            if !(light.irradiance.is_finite() && light.irradiance.min_element() >= 0.0) {
                return Err(Error::invalid_argument(format!(
                    "directional light {i}: irradiance {} must be finite and not negative",
                    light.irradiance
                )));
            }
            let index = lights.len() as u32;
            lights.push(Light::Directional {
                light,
                scene_radius,
            });
            groups.push((index..index + 1, None));
        }
        let environment = environment.map(|env| {
            let index = lights.len();
            lights.push(Light::Environment {
                light: Box::new(env),
                scene_radius,
            });
            groups.push((index as u32..index as u32 + 1, None));
            index
        });
        let has_hittable_lights = first_light.iter().any(Option::is_some) || environment.is_some();

        let config = std::env::var(EMBREE_CONFIG_VAR).unwrap_or_default();
        let device = Device::with_config(&config)?;
        let mut builder = device.scene_builder(SceneOptions { robust })?;
        for (i, m) in meshes.iter().enumerate() {
            builder
                .add_triangle_mesh(i as u32, &m.positions, &m.triangles, m.mask(), m.cull_back)
                .map_err(|mut e| {
                    e.message = format!("mesh {i} ({}): {}", m.name, e.message);
                    e
                })?;
        }
        let mut group_accels = Vec::with_capacity(instancing.groups.len());
        for (g, group) in instancing.groups.iter().enumerate() {
            let mut b = device.scene_builder(SceneOptions { robust })?;
            for (i, m) in group.meshes.iter().enumerate() {
                if m.emission.is_some() || m.pls.is_some() {
                    return Err(Error::invalid_argument(format!(
                        "group {g} ({}), mesh {i} ({}): a mesh placed by instances cannot emit",
                        group.name, m.name
                    )));
                }
                b.add_triangle_mesh(i as u32, &m.positions, &m.triangles, m.mask(), m.cull_back)
                    .map_err(|mut e| {
                        e.message = format!(
                            "group {g} ({}), mesh {i} ({}): {}",
                            group.name, m.name, e.message
                        );
                        e
                    })?;
            }
            group_accels.push(b.commit()?);
        }
        for (k, i) in instancing.instances.iter().enumerate() {
            let Some(prototype) = group_accels.get(i.group as usize) else {
                return Err(Error::invalid_argument(format!(
                    "instance {k}: no group {}",
                    i.group
                )));
            };
            let id = u32::try_from(meshes.len() + k)
                .map_err(|_| Error::invalid_argument("too many meshes and instances"))?;
            builder.add_instance(id, prototype, &i.to_world)?;
        }
        let accel = builder.commit()?;
        Ok(Scene {
            instancing,
            _group_accels: group_accels,
            meshes,
            first_light,
            materials,
            lights: LightSet::with_groups_picked_by(lights, groups, light_picking),
            camera,
            film,
            default_job: job,
            accel,
            environment,
            has_hittable_lights,
        })
    }

    /// The lights (indices into `lights().lights`) made of mesh `mesh`'s
    /// triangles, if it emits.
    pub fn mesh_lights(&self, mesh: usize) -> Option<std::ops::Range<usize>> {
        let first = self.first_light.get(mesh).copied().flatten()? as usize;
        Some(first..first + self.meshes[mesh].triangles.len())
    }

    /// Replaces material `index`'s BSDF (for fitting), after checking its
    /// parameters.
    pub fn set_material_bsdf(&mut self, index: usize, bsdf: crate::bsdf::Bsdf) -> Result<()> {
        let Some(material) = self.materials.get_mut(index) else {
            return Err(Error::invalid_argument(format!("no material {index}")));
        };
        if let crate::bsdf::Bsdf::Principled(p) = &bsdf {
            p.validate().map_err(|e| {
                Error::invalid_argument(format!("material {index} ({}): {e}", material.name))
            })?;
            p.prepare();
        }
        if let crate::bsdf::Bsdf::RoughPlastic(p) = &bsdf {
            p.validate().map_err(|e| {
                Error::invalid_argument(format!("material {index} ({}): {e}", material.name))
            })?;
            p.prepare();
        }
        material.bsdf = bsdf;
        Ok(())
    }

    /// Changes the lights in place (see [`LightSet::edit`]), for fitting a
    /// light's brightness or window.
    pub fn edit_lights(&mut self, f: impl FnOnce(&mut [Light])) {
        self.lights.edit(f);
    }

    /// Picks lights by `picking` instead of the scene's rule (see
    /// [`LightPicking`]). Every rule is unbiased; they differ in noise.
    pub fn set_light_picking(&mut self, picking: LightPicking) {
        self.lights = std::mem::take(&mut self.lights).with_picking(picking);
    }

    /// The rule lights are picked by.
    pub fn light_picking(&self) -> LightPicking {
        self.lights.picking()
    }

    /// Sets the PLS light of mesh `mesh` (an emitter made by [`pls_mesh`])
    /// to `light`'s brightness, colour and window; its outline stays.
    pub fn set_pls_window_and_brightness(&mut self, mesh: usize, light: &Pls) -> Result<()> {
        let Some(emitter) = self.meshes.get(mesh).and_then(|m| m.pls.clone()) else {
            return Err(Error::invalid_argument(format!(
                "mesh {mesh} is not a PLS light"
            )));
        };
        let mut updated = emitter.light.clone();
        updated.b = light.b;
        updated.c = light.c;
        updated.a_deg = light.a_deg;
        updated.penumbra_deg = light.penumbra_deg;
        updated
            .validate(0)
            .map_err(|e| Error::invalid_argument(format!("{}: {e}", self.meshes[mesh].name)))?;
        let new = crate::light::pls::PlsEmitter {
            light: updated,
            ..emitter
        };
        // The area as the emitter was made (`pls_mesh`).
        let area = new.tessellate().area();
        let (radiance, cone) = (new.radiance(area), new.cone());
        if let Some(range) = self.mesh_lights(mesh) {
            self.lights.edit(|lights| {
                for l in &mut lights[range] {
                    if let Light::Triangle(t) = l {
                        t.radiance = radiance;
                        t.cone = Some(cone);
                    }
                }
            });
        }
        if let Some(e) = &mut self.meshes[mesh].emission {
            e.radiance = radiance;
            e.cone = Some(cone);
        }
        self.meshes[mesh].pls = Some(new);
        Ok(())
    }

    /// Multiplies the emission of the lights `range` by `factor` (see
    /// [`LightSet::scale_emission`]), for fitting light brightness.
    pub fn scale_light_emission(&mut self, range: std::ops::Range<usize>, factor: Vec3) {
        self.lights.scale_emission(range, factor);
    }

    /// The meshes, indexed by Embree geometry id.
    #[inline]
    pub fn meshes(&self) -> &[Mesh] {
        &self.meshes
    }

    /// The materials, indexed by [`Mesh::material`].
    #[inline]
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// All lights, with the distribution that picks among them.
    #[inline]
    pub fn lights(&self) -> &LightSet {
        &self.lights
    }

    /// Index in `lights().lights` of the environment, if any: rays that
    /// leave the scene see it.
    #[inline]
    pub fn environment_index(&self) -> Option<usize> {
        self.environment
    }

    /// The camera.
    #[inline]
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Replaces the camera (no rebuild: the geometry is unchanged).
    pub fn set_camera(&mut self, camera: Camera) {
        self.camera = camera;
    }

    /// The film's filter, exposure and white balance.
    #[inline]
    pub fn film(&self) -> &FilmSettings {
        &self.film
    }

    /// The film's settings, to change between renders.
    pub fn film_mut(&mut self) -> &mut FilmSettings {
        &mut self.film
    }

    /// The job the scene file (or builder) asked for: `[render]`'s spp,
    /// max_depth and seed.
    #[inline]
    pub fn default_job(&self) -> RenderJob {
        self.default_job
    }

    /// Embree's acceleration structure over the meshes.
    #[inline]
    pub fn accel(&self) -> &Accel {
        &self.accel
    }

    /// Whether any light can be hit by a ray (area lights, environment):
    /// otherwise a path need not trace the ray after its last light sample.
    #[inline]
    pub fn has_hittable_lights(&self) -> bool {
        self.has_hittable_lights
    }

    /// The parametric lights, each with the Embree geometry id of its
    /// tessellated emitter.
    pub fn pls_emitters(&self) -> impl Iterator<Item = (u32, &PlsEmitter)> {
        self.meshes
            .iter()
            .enumerate()
            .filter_map(|(i, m)| m.pls.as_ref().map(|e| (i as u32, e)))
    }

    /// Index in `lights.lights` of the light of triangle `prim` of mesh `geom`.
    #[inline]
    pub fn light_index(&self, geom: u32, prim: u32) -> Option<usize> {
        self.first_light[geom as usize].map(|f| (f + prim) as usize)
    }

    /// The light of a hit's triangle ([`Scene::light_index`]); none on an
    /// instance (groups do not emit).
    #[inline]
    pub fn hit_light(&self, hit: &crate::accel::Hit) -> Option<usize> {
        match hit.instance {
            Some(_) => None,
            None => self.light_index(hit.geom_id, hit.prim_id),
        }
    }

    /// The mesh a hit is on, and the instance that placed it.
    #[inline]
    pub fn mesh_hit(&self, hit: &crate::accel::Hit) -> MeshHit<'_> {
        match hit.instance {
            None => MeshHit {
                mesh: &self.meshes[hit.geom_id as usize],
                instance: None,
            },
            Some(id) => {
                let instance = &self.instancing.instances[id as usize - self.meshes.len()];
                MeshHit {
                    mesh: &self.instancing.groups[instance.group as usize].meshes
                        [hit.geom_id as usize],
                    instance: Some(instance),
                }
            }
        }
    }

    /// The groups of meshes and their instances.
    pub fn instancing(&self) -> &instancing::Instancing {
        &self.instancing
    }

    /// Number of triangles in the scene (an instance's counted each time
    /// it is placed).
    pub fn triangle_count(&self) -> usize {
        let placed: usize = self
            .instancing
            .instances
            .iter()
            .map(|i| {
                let group = &self.instancing.groups[i.group as usize];
                group
                    .meshes
                    .iter()
                    .map(|m| m.triangles.len())
                    .sum::<usize>()
            })
            .sum();
        self.meshes.iter().map(|m| m.triangles.len()).sum::<usize>() + placed
    }
}
