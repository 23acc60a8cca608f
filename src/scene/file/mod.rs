//! Scene files: TOML (or JSON with the same schema), documented with an
//! example of every item in `docs/scene-format.md`.
//!
//! Parsing is strict: unknown keys, wrong types, non-finite numbers and
//! out-of-range values are errors that name the file and the field
//! (`shapes[2].transform.scale`). Paths inside a scene file are relative to
//! the file's directory.

mod camera;
mod composite;
mod environment;
mod film;
mod keys;
mod light;
mod map;
mod material;
mod photo;
mod render;
mod shape;
mod toml_path;

pub use crate::bsdf::METALS;
pub use crate::camera::{DEFAULT_FISHEYE_FOV_DEG, DEFAULT_SENSOR_HEIGHT_MM};
pub use environment::load_environment;
pub use material::DEFAULT_REFLECTANCE;

use camera::CameraSection;
use environment::EnvironmentSection;
use film::FilmSection;
use light::{LightSection, PlsSection};
use material::MaterialSection;
use photo::PhotoSection;
use plsr_base::Vocabulary;
use render::RenderSection;
use shape::ShapeSection;
use toml_path::{field_at, position_of};

use crate::error::{Error, Result};
use crate::light::PointLight;
use crate::scene::instancing::{Instance, Instancing, MeshGroup};
use crate::scene::{Material, SceneDescription};
use glam::Vec3;
use serde::Deserialize;
use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    #[serde(default)]
    render: RenderSection,
    camera: CameraSection,
    #[serde(default)]
    film: FilmSection,
    environment: Option<EnvironmentSection>,
    photo: Option<PhotoSection>,
    #[serde(default)]
    views: Vec<ViewSection>,
    #[serde(default)]
    materials: Vec<MaterialSection>,
    #[serde(default)]
    shapes: Vec<ShapeSection>,
    #[serde(default)]
    instances: Vec<shape::InstanceSection>,
    #[serde(default)]
    lights: Vec<LightSection>,
    #[serde(default)]
    pls: Vec<PlsSection>,
}

/// Reads and validates a scene file; TOML unless the extension is `.json`.
pub fn load(path: &Path) -> Result<SceneDescription> {
    Ok(load_with_inputs(path)?.0)
}

/// Like [`load`], and also returns every other file the scene read to be
/// built (meshes, MTL libraries, textures, environment image, PLS files),
/// so that a command can refuse an output that would overwrite one.
pub fn load_with_inputs(path: &Path) -> Result<(SceneDescription, Vec<PathBuf>)> {
    let contents = load_contents(path)?;
    Ok((contents.description, contents.inputs))
}

/// Everything a scene file says: the scene, the files it names, and the
/// photograph it is to be composited into.
#[derive(Debug)]
pub struct SceneFileContents {
    /// The scene.
    pub description: SceneDescription,
    /// Every other file the scene names (meshes, MTL libraries, textures,
    /// environment image, PLS files, the photo and its response curve).
    pub inputs: Vec<PathBuf>,
    /// The `[photo]` table, if any.
    pub photo: Option<crate::scene::photo::PhotoSpec>,
    /// The `[[views]]`: more photos of the scene, each with its camera
    /// (for fitting).
    pub views: Vec<crate::scene::photo::ViewSpec>,
    /// The camera's path (`[[camera.path]]`), for animations.
    pub camera_path: Option<crate::camera_path::CameraPath>,
    /// What a translation from another format approximated (one line per
    /// approximation, naming the element); empty for plsr's own files.
    pub notes: Vec<String>,
}

/// `[[views]]`: a photo of the scene and the camera that took it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ViewSection {
    camera: CameraSection,
    photo: PhotoSection,
}

/// Reads and validates a scene file with its `[photo]`; see [`load`].
/// A Mitsuba 3 XML file (by its `.xml` name or its leading `<`) is first
/// translated into a plsr scene ([`crate::scene::mitsuba`]).
pub fn load_contents(path: &Path) -> Result<SceneFileContents> {
    load_contents_with(path, &crate::scene::mitsuba::Options::default())
}

/// [`load_contents`] with the options of a Mitsuba scene (`-D name=value`
/// parameters); refused for other scene files when any is given.
pub fn load_contents_with(
    path: &Path,
    options: &crate::scene::mitsuba::Options,
) -> Result<SceneFileContents> {
    crate::input::check_input_file(path)?;
    let bytes = std::fs::read(path).map_err(|source| Error::io(path.to_path_buf(), source))?;
    if crate::scene::gltf_scene::looks_like_gltf(path, &bytes) {
        refuse_defines(path, options)?;
        let time = options.time.unwrap_or(0.0);
        let wrapper = crate::scene::gltf_scene::scene_toml_at(path, time)?;
        let mut contents = from_text(path, &wrapper.toml, false)?;
        let mut notes = wrapper.notes;
        notes.append(&mut contents.notes);
        contents.notes = notes;
        return Ok(contents);
    }
    check_scene_format(path)?;
    let text = String::from_utf8(bytes).map_err(|_| {
        Error::input(
            path,
            "",
            "unsupported scene format: not a text file (plsr reads TOML scene files, \
             JSON with the same schema, or Mitsuba 3 XML; see docs/scene-format.md)",
        )
    })?;
    refuse_time(path, options)?;
    if crate::scene::mitsuba::looks_like_xml(path, text.as_bytes()) {
        let translation = crate::scene::mitsuba::translate_with(path, &text, options)?;
        // What the builder finds wrong is in the translation, not the XML.
        let mut contents = from_text(path, &translation.toml, false).map_err(|e| match e {
            Error::Base(plsr_base::Error::Input {
                file,
                field,
                message,
            }) => Error::Base(plsr_base::Error::Input {
                file,
                field: if field.is_empty() {
                    "(translated scene)".into()
                } else {
                    format!("(translated scene) {field}")
                },
                message: format!(
                    "{message} (the Mitsuba scene translated into plsr's format, \
                     which `plsr import` writes out, has this fault)"
                ),
            }),
            other => other,
        })?;
        let mut notes = translation.notes;
        notes.append(&mut contents.notes);
        contents.notes = notes;
        let mut inputs = translation.included;
        inputs.append(&mut contents.inputs);
        contents.inputs = inputs;
        return Ok(contents);
    }
    refuse_defines(path, options)?;
    let is_json = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    from_text(path, &text, is_json)
}

/// `--anim-time` given for a scene that is not a glTF file is refused.
fn refuse_time(path: &Path, options: &crate::scene::mitsuba::Options) -> Result<()> {
    match options.time {
        Some(t) => Err(Error::invalid_argument(format!(
            "--anim-time {t}: picks the moment of a glTF file given as the scene, and {} is not one \
             (in a scene file, a `gltf` shape takes `time = {t}`)",
            path.display()
        ))),
        None => Ok(()),
    }
}

/// `-D` parameters given for a scene that is not Mitsuba XML are refused.
fn refuse_defines(path: &Path, options: &crate::scene::mitsuba::Options) -> Result<()> {
    match options.defines.first() {
        Some((name, value)) => Err(Error::invalid_argument(format!(
            "-D {name}={value}: parameters are for Mitsuba XML scenes, and {} is not one",
            path.display()
        ))),
        None => Ok(()),
    }
}

/// [`load_contents`] of a TOML scene's text as if it were the file `path`
/// (the files it names are found from `path`'s folder): to check a scene
/// before it is written.
pub fn load_contents_from_text(path: &Path, text: &str) -> Result<SceneFileContents> {
    from_text(path, text, false)
}

/// [`load_contents`] of a scene file's text (TOML, or JSON if `is_json`).
fn from_text(path: &Path, text: &str, is_json: bool) -> Result<SceneFileContents> {
    let parsed: SceneFile = if is_json {
        // Errors name the field, as for TOML.
        let mut json = serde_json::Deserializer::from_str(text);
        serde_path_to_error::deserialize(&mut json).map_err(|e| {
            let field = e.path().to_string();
            let field = if field == "." { String::new() } else { field };
            Error::input(path, field, e.into_inner().to_string())
        })?
    } else {
        toml::from_str(text).map_err(|e| {
            let (field, at) = e
                .span()
                .map(|s| {
                    let line = text[..s.start].matches('\n').count() + 1;
                    let col = s.start - text[..s.start].rfind('\n').map_or(0, |i| i + 1) + 1;
                    (
                        field_at(text, s.start),
                        format!("line {line}, column {col}: "),
                    )
                })
                .unwrap_or_default();
            // A key missing from the whole file is placed at its start,
            // which is not the first table's fault.
            let field = if e.span().is_some_and(|s| s.start == 0)
                && e.message().starts_with("missing field")
            {
                String::new()
            } else {
                field
            };
            Error::input(path, field, format!("{at}{}", e.message().trim_end()))
        })?
    };
    let base = path.parent().unwrap_or(Path::new("."));
    let builder = Builder {
        file: path,
        base,
        toml: (!is_json).then_some(text),
        inputs: RefCell::new(Vec::new()),
        notes: RefCell::new(Vec::new()),
    };
    // `exposure = "exif"` finds the render's units in the environment map.
    let environment = parsed.environment.as_ref().and_then(|e| {
        e.file
            .as_ref()
            .map(|f| (base.join(f), e.scale.unwrap_or(1.0)))
    });
    let photo = match &parsed.photo {
        Some(p) => Some(builder.photo(p, environment.clone())?),
        None => None,
    };
    let mut views = Vec::with_capacity(parsed.views.len());
    for (i, v) in parsed.views.iter().enumerate() {
        // The builders name `camera.…` and `photo.…`: place them in the view.
        let within = |e: Error| match e {
            Error::Base(plsr_base::Error::Input {
                file,
                field,
                message,
            }) => Error::Base(plsr_base::Error::Input {
                file,
                field: format!("views[{i}].{field}"),
                message,
            }),
            other => other,
        };
        if v.camera.path.is_some() {
            return Err(builder.err(
                format!("views[{i}].camera.path"),
                "a view is one photo: its camera has no path",
            ));
        }
        let (camera, _) = builder.camera(&v.camera).map_err(within)?;
        let photo = builder
            .photo(&v.photo, environment.clone())
            .map_err(within)?;
        views.push(crate::scene::photo::ViewSpec { camera, photo });
    }
    let camera_path = builder.camera_path(&parsed.camera)?;
    let description = builder.build(parsed)?;
    Ok(SceneFileContents {
        description,
        inputs: builder.inputs.into_inner(),
        photo,
        views,
        camera_path,
        notes: builder.notes.into_inner(),
    })
}

/// Refuses, with "unsupported scene format", files that are recognisably
/// another program's scene or a bare mesh (by extension), rather than
/// reporting a TOML syntax error in them.
fn check_scene_format(path: &Path) -> Result<()> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let what = if matches!(ext.as_str(), "obj" | "ply" | "stl" | "fbx") {
        Some("a mesh: place it in a scene file's [[shapes]] (type = \"obj\", \"ply\" or \"gltf\")")
    } else if matches!(
        ext.as_str(),
        "pbrt"
            | "blend"
            | "usd"
            | "usda"
            | "usdc"
            | "usdz"
            | "dae"
            | "3ds"
            | "yaml"
            | "yml"
            | "exr"
            | "hdr"
            | "png"
            | "jpg"
            | "jpeg"
            | "tif"
            | "tiff"
    ) {
        Some("not a plsr scene file")
    } else {
        None
    };
    match what {
        Some(what) => Err(Error::input(
            path,
            "",
            format!(
                "unsupported scene format: {what}; plsr reads TOML scene files, JSON \
                 with the same schema, or Mitsuba 3 XML (see docs/scene-format.md)"
            ),
        )),
        None => Ok(()),
    }
}

struct Builder<'a> {
    file: &'a Path,
    base: &'a Path,
    /// The text of a TOML file, to place errors found after parsing.
    toml: Option<&'a str>,
    /// The files read so far, besides the scene file.
    inputs: RefCell<Vec<PathBuf>>,
    /// What was approximated on the way (an imported file's unsupported
    /// features), for [`SceneFileContents::notes`].
    notes: RefCell<Vec<String>>,
}

impl Builder<'_> {
    /// Records something plsr approximated or left out.
    fn note(&self, note: String) {
        let mut notes = self.notes.borrow_mut();
        if !notes.contains(&note) {
            notes.push(note);
        }
    }

    /// Records that the scene read `path`.
    fn read_input(&self, path: &Path) {
        self.inputs.borrow_mut().push(path.to_path_buf());
    }

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

    fn positive_count(&self, field: &str, v: i64, max: i64) -> Result<u32> {
        if v < 1 || v > max {
            return Err(self.err(field, format!("must be between 1 and {max}, got {v}")));
        }
        Ok(v as u32)
    }

    fn positive(&self, field: &str, v: f32) -> Result<f32> {
        let v = self.finite(field, v)?;
        if v <= 0.0 {
            return Err(self.err(field, format!("must be positive, got {v}")));
        }
        Ok(v)
    }

    fn build(&self, f: SceneFile) -> Result<SceneDescription> {
        let job = self.job(&f.render)?;
        let robust = f.render.robust.unwrap_or(false);
        let light_picking = self.light_picking(&f.render)?;
        let (camera, preset) = self.camera(&f.camera)?;
        let film = self.film(&f.film, preset, (camera.width(), camera.height()))?;

        let mut materials = Vec::new();
        let mut by_name = HashMap::new();
        let mut pending = composite::PendingComposites::default();
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
            if let Some(keys) = self.composite_keys(&field, m)? {
                // A placeholder until every material it names is read.
                pending.composites.insert(materials.len(), keys);
                by_name.insert(m.name.clone(), materials.len() as u32);
                materials.push(Material::new(
                    m.name.clone(),
                    crate::bsdf::Bsdf::diffuse(Vec3::ZERO),
                ));
                continue;
            }
            let keys = self.material_keys(&field, m)?;
            let bsdf = self.material(&field, &keys)?;
            if let Some(back) = &m.back {
                pending.backs.insert(materials.len(), back.clone());
            }
            by_name.insert(m.name.clone(), materials.len() as u32);
            let textures = self.material_textures(&field, &keys, m)?;
            // Like an image map, the mesh's colours replace the constant
            // base colour (which they multiply, see `Material::bsdf_at`).
            let bsdf = match textures.base_color_attribute {
                Some(_) => bsdf.with_base_color(Vec3::ONE),
                None => bsdf,
            };
            if m.two_sided == Some(false) && bsdf.transmits() {
                return Err(self.err(
                    format!("{field}.two_sided"),
                    "a dielectric has two sides by nature: two_sided = false is for \
                     opaque materials",
                ));
            }
            materials.push(Material {
                name: m.name.clone(),
                bsdf,
                textures,
                two_sided: m.two_sided.unwrap_or(true),
                composite: None,
            });
        }
        self.resolve_composites(&mut materials, &by_name, &pending)?;

        let mut meshes = Vec::new();
        let mut instancing = Instancing::default();
        for (i, s) in f.shapes.iter().enumerate() {
            // A grouped shape's meshes go to its group, in the group's space.
            let group = match &s.group {
                None => None,
                Some(name) => {
                    if s.emission.is_some() {
                        return Err(self.err(
                            format!("shapes[{i}].emission"),
                            "a shape in a group cannot emit (as in Mitsuba's shapegroup)",
                        ));
                    }
                    let g = match instancing.groups.iter().position(|g| &g.name == name) {
                        Some(g) => g,
                        None => {
                            instancing.groups.push(MeshGroup {
                                name: name.clone(),
                                meshes: Vec::new(),
                            });
                            instancing.groups.len() - 1
                        }
                    };
                    Some(g)
                }
            };
            let target = match group {
                Some(g) => &mut instancing.groups[g].meshes,
                None => &mut meshes,
            };
            let first = target.len();
            self.shape(i, s, &by_name, &mut materials, target)?;
            if s.flip_v == Some(true) {
                // `flip_v`: texture coordinates (u, 1 − v), the shape's
                // meshes as they come from the file or the built-in shape.
                for m in &mut target[first..] {
                    m.uvs.iter_mut().for_each(|uv| uv.y = 1.0 - uv.y);
                    if let Some(map) = &mut m.emission_map {
                        map.uvs.iter_mut().for_each(|uv| uv.y = 1.0 - uv.y);
                    }
                    m.uv_map = m.uv_map.flipped_v();
                }
            }
        }
        for (k, inst) in f.instances.iter().enumerate() {
            let field = format!("instances[{k}]");
            let Some(g) = instancing.groups.iter().position(|g| g.name == inst.group) else {
                let known: Vec<&str> = instancing.groups.iter().map(|g| g.name.as_str()).collect();
                return Err(self.err(
                    format!("{field}.group"),
                    format!(
                        "no shape is in group `{}` (groups: {})",
                        inst.group,
                        if known.is_empty() {
                            "none".to_string()
                        } else {
                            known.join(", ")
                        }
                    ),
                ));
            };
            let to_world = match &inst.transform {
                Some(t) => self.transform(&format!("{field}.transform"), t)?,
                None => glam::Mat4::IDENTITY,
            };
            let to_world = glam::Affine3A::from_mat4(to_world);
            let object_id = (f.shapes.len() + k) as u32;
            let instance = Instance::new(g as u32, to_world, object_id).ok_or_else(|| {
                self.err(format!("{field}.transform"), "is singular or not finite")
            })?;
            instancing.instances.push(instance);
        }

        let mut point_lights = Vec::new();
        let mut directional_lights = Vec::new();
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
                    self.light_keys(&field, l, "point light", &["position", "intensity"])?;
                    point_lights.push(PointLight::isotropic(
                        self.vec3(&format!("{field}.position"), position)?,
                        self.colour(&format!("{field}.intensity"), intensity, None)?,
                    ));
                }
                "spot" => point_lights.push(self.spot_light(&field, l)?),
                "projector" => point_lights.push(self.projector(&field, l)?),
                "directional" => directional_lights.push(self.directional_light(&field, l)?),
                other => {
                    return Err(self.err(
                        format!("{field}.type"),
                        format!(
                        "unknown light type `{other}` (known: point, spot, directional, projector)"
                    ),
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
            directional_lights,
            environment,
            camera,
            film,
            job,
            robust,
            light_picking,
            instancing,
        })
    }
}
