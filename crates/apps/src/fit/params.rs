//! The parameters a fit can change: which exist in a scene, how they are
//! named and selected, their bounds, and how a value reaches the built
//! scene and the gradient's slots.
//!
//! A parameter is named `OWNER.FIELD`:
//!
//! | owner | fields |
//! | --- | --- |
//! | a `diffuse` material's name | `reflectance` (RGB) |
//! | a `principled` material's name | `base_color` (RGB), `roughness`, `metallic`, `anisotropic`, `specular` |
//! | a PLS light: its `name`, else `pls[i]/lights[k]` | `b`, `c` (RGB) |
//! | a point light, `lights[i]` | `intensity` (RGB) |
//! | an emitting shape's name | `emission` (RGB) |
//! | `environment` | `scale` |
//!
//! Patterns select parameters with `*` matching any run of characters:
//! `wall.reflectance`, `floor.*`, `*.roughness`, `lamp.b`.

use crate::error::{Error, Result};
use glam::Vec3;
use plsr::bsdf::{Bsdf, BsdfParam};
use plsr::integrator::gradient::GradientMap;
use plsr::light::Light;
use plsr::scene::Scene;
use plsr_base::Vocabulary;

/// What a parameter belongs to.
#[derive(Debug, Clone, PartialEq)]
pub enum Owner {
    /// A material (index into `Scene::materials`).
    Material(usize),
    /// A PLS light: its mesh (index into `Scene::meshes`), the `[[pls]]`
    /// table it came from and its index in that table's file.
    Pls {
        /// Mesh index.
        mesh: usize,
        /// Index of the `[[pls]]` table.
        table: usize,
        /// Index of the light in its PLS file.
        light: usize,
    },
    /// A point light (index into the scene file's `[[lights]]`, which is
    /// also its index among the scene's lights).
    PointLight(usize),
    /// An emitting shape (mesh index).
    Shape(usize),
    /// The environment.
    Environment,
}

/// One fittable quantity: a colour (three numbers) or a scalar.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    /// `OWNER.FIELD`, as patterns match it and reports print it.
    pub name: String,
    /// What it belongs to.
    pub owner: Owner,
    /// The field's key in the scene (or PLS) file.
    pub field: &'static str,
    /// The current value (1 or 3 numbers).
    pub value: Vec<f32>,
    /// The value the fit started from.
    pub initial: Vec<f32>,
    /// The interval every number is kept in (projected Adam).
    pub bounds: (f32, f32),
    /// The first gradient slot; a colour has three.
    pub slot: u32,
}

impl Parameter {
    /// Whether the optimiser steps in units of the initial value (light
    /// brightness, whose scale is arbitrary) rather than absolute units.
    pub fn relative(&self) -> bool {
        !matches!(self.owner, Owner::Material(_))
    }

    /// The value as RGB (a scalar repeated).
    pub fn rgb(&self) -> Vec3 {
        match self.value[..] {
            [v] => Vec3::splat(v),
            [r, g, b] => Vec3::new(r, g, b),
            _ => Vec3::ZERO,
        }
    }
}

/// Whether `text` matches `pattern`, where `*` matches any run of
/// characters.
pub fn glob_match(pattern: &str, text: &str) -> bool {
    let parts: Vec<&str> = pattern.split('*').collect();
    if parts.len() == 1 {
        return pattern == text;
    }
    let mut rest = text;
    for (i, part) in parts.iter().enumerate() {
        if i == 0 {
            let Some(r) = rest.strip_prefix(part) else {
                return false;
            };
            rest = r;
        } else if i == parts.len() - 1 {
            return rest.ends_with(part);
        } else {
            match rest.find(part) {
                Some(k) => rest = &rest[k + part.len()..],
                None => return false,
            }
        }
    }
    true
}

/// The material fields of a BSDF: `(field, parameter slot of its first
/// number, whether a colour, bounds)`.
fn material_fields(bsdf: &Bsdf) -> Vec<(&'static str, BsdfParam, bool, (f32, f32))> {
    match bsdf {
        Bsdf::Diffuse(_) => vec![("reflectance", BsdfParam::Red, true, (0.0, 1.0))],
        Bsdf::Principled(_) => vec![
            ("base_color", BsdfParam::Red, true, (0.0, 1.0)),
            ("roughness", BsdfParam::Roughness, false, (0.01, 1.0)),
            ("metallic", BsdfParam::Metallic, false, (0.0, 1.0)),
            ("anisotropic", BsdfParam::Anisotropic, false, (0.0, 1.0)),
            ("specular", BsdfParam::Specular, false, (0.01, 1.0)),
        ],
        _ => Vec::new(),
    }
}

/// The fields the paper fits by default (base colour, roughness, metallic,
/// anisotropic; Lambert's reflectance).
const DEFAULT_FIELDS: [&str; 5] = [
    "reflectance",
    "base_color",
    "roughness",
    "metallic",
    "anisotropic",
];

fn material_value(bsdf: &Bsdf, field: &str) -> Vec<f32> {
    match (bsdf, field) {
        (Bsdf::Diffuse(p), "reflectance") => p.reflectance.to_array().to_vec(),
        (Bsdf::Principled(p), "base_color") => p.base_color.to_array().to_vec(),
        (Bsdf::Principled(p), "roughness") => vec![p.roughness],
        (Bsdf::Principled(p), "metallic") => vec![p.metallic],
        (Bsdf::Principled(p), "anisotropic") => vec![p.anisotropic],
        (Bsdf::Principled(p), "specular") => vec![p.specular],
        _ => Vec::new(),
    }
}

/// A parameter the scene has, before selection: owner, field, value,
/// bounds, whether a default choice, and (for materials) why it cannot be
/// fitted.
struct Candidate {
    name: String,
    alias: Option<String>,
    owner: Owner,
    field: &'static str,
    value: Vec<f32>,
    bounds: (f32, f32),
    default: bool,
    refusal: Option<String>,
}

/// Each PLS light's `(mesh, [[pls]] table, index in its file)`, from the
/// meshes' names (`pls[TABLE]/…`, in file order).
pub(crate) fn pls_lights(scene: &Scene) -> Vec<(usize, usize, usize)> {
    let mut out = Vec::new();
    let mut last: Option<(usize, usize)> = None;
    for (i, m) in scene.meshes().iter().enumerate() {
        if m.pls.is_none() {
            continue;
        }
        let table = m
            .name
            .strip_prefix("pls[")
            .and_then(|r| r.split(']').next())
            .and_then(|t| t.parse().ok())
            .unwrap_or(0);
        let light = match last {
            Some((t, k)) if t == table => k + 1,
            _ => 0,
        };
        last = Some((table, light));
        out.push((i, table, light));
    }
    out
}

/// Every parameter the scene offers. `environment_scale` is the scene
/// file's `environment.scale` (the built environment holds scaled texels).
fn candidates(scene: &Scene, environment_scale: f32) -> Vec<Candidate> {
    let mut out = Vec::new();
    // Materials seen by the real (not virtual) surfaces, and not emitters'.
    let mut used = vec![false; scene.materials().len()];
    for (i, m) in scene.meshes().iter().enumerate() {
        if !m.is_virtual && m.pls.is_none() && scene.mesh_lights(i).is_none() {
            used[m.material as usize] = true;
        }
    }
    for (i, material) in scene.materials().iter().enumerate() {
        if !used[i] {
            continue;
        }
        let support = material.bsdf.gradient_support();
        for (field, _, _, bounds) in material_fields(&material.bsdf) {
            let refusal = if !material.textures.is_empty() {
                Some(format!(
                    "material `{}` is textured; fitting textured materials is not supported",
                    material.name
                ))
            } else {
                support
                    .err()
                    .map(|m| format!("material `{}`: {m}", material.name))
            };
            out.push(Candidate {
                name: format!("{}.{field}", material.name),
                alias: None,
                owner: Owner::Material(i),
                field,
                value: material_value(&material.bsdf, field),
                bounds,
                default: DEFAULT_FIELDS.contains(&field),
                refusal,
            });
        }
    }
    for (mesh, table, light) in pls_lights(scene) {
        let m = &scene.meshes()[mesh];
        let Some(pls) = &m.pls else { continue };
        // Named by the light's name where it has one (`lamp.b`), else by its
        // place (`pls[0]/lights[1].b`); the mesh's full name also matches.
        let owner_name = match &pls.light.name {
            Some(n) => n.clone(),
            None => format!("pls[{table}]/lights[{light}]"),
        };
        let alias = Some(format!("{}.", m.name));
        out.push(Candidate {
            name: format!("{owner_name}.b"),
            alias: alias.clone().map(|a| a + "b"),
            owner: Owner::Pls { mesh, table, light },
            field: "b",
            value: vec![pls.light.b],
            bounds: (pls.light.b * 1e-6, f32::MAX),
            default: false,
            refusal: None,
        });
        out.push(Candidate {
            name: format!("{owner_name}.c"),
            alias: alias.map(|a| a + "c"),
            owner: Owner::Pls { mesh, table, light },
            field: "c",
            value: pls.light.c.to_array().to_vec(),
            bounds: (1e-4, f32::MAX),
            default: false,
            refusal: None,
        });
    }
    for (i, light) in scene.lights().lights.iter().enumerate() {
        if let Light::Point(p) = light {
            out.push(Candidate {
                name: format!("lights[{i}].intensity"),
                alias: None,
                owner: Owner::PointLight(i),
                field: "intensity",
                value: p.intensity.to_array().to_vec(),
                bounds: (1e-6 * p.intensity.max_element().max(1e-6), f32::MAX),
                default: false,
                refusal: None,
            });
        }
    }
    for (i, m) in scene.meshes().iter().enumerate() {
        if m.pls.is_some() {
            continue;
        }
        if let (Some(e), Some(_)) = (m.emission, scene.mesh_lights(i)) {
            out.push(Candidate {
                name: format!("{}.emission", m.name),
                alias: None,
                owner: Owner::Shape(i),
                field: "emission",
                value: e.radiance.to_array().to_vec(),
                bounds: (1e-6 * e.radiance.max_element(), f32::MAX),
                default: false,
                refusal: None,
            });
        }
    }
    if scene.environment_index().is_some() {
        out.push(Candidate {
            name: "environment.scale".into(),
            alias: None,
            owner: Owner::Environment,
            field: "scale",
            value: vec![environment_scale],
            bounds: (environment_scale * 1e-6, f32::MAX),
            default: false,
            refusal: None,
        });
    }
    out
}

/// Selects the parameters named by `patterns` (none: the paper's default,
/// every real surface's colour, roughness, metallic and anisotropic) and
/// gives them gradient slots. A pattern that matches nothing, or names a
/// parameter that cannot be fitted, is an error that lists what can.
pub fn select(
    scene: &Scene,
    patterns: &[String],
    environment_scale: f32,
) -> Result<Vec<Parameter>> {
    let all = candidates(scene, environment_scale);
    let names: Vec<&str> = all
        .iter()
        .filter(|c| c.refusal.is_none())
        .map(|c| c.name.as_str())
        .collect();
    let available = if names.is_empty() {
        "none".to_string()
    } else {
        names.join(", ")
    };
    let mut chosen = vec![false; all.len()];
    if patterns.is_empty() {
        for (k, c) in all.iter().enumerate() {
            chosen[k] = c.default && c.refusal.is_none();
        }
    }
    for pattern in patterns {
        let mut any = false;
        for (k, c) in all.iter().enumerate() {
            let hit = glob_match(pattern, &c.name)
                || c.alias.as_deref().is_some_and(|a| glob_match(pattern, a));
            if !hit {
                continue;
            }
            if let Some(why) = &c.refusal {
                // A wildcard passes over what cannot be fitted; a name
                // that means it exactly is refused.
                if !pattern.contains('*') {
                    return Err(Error::invalid_argument(format!("--param {pattern}: {why}")));
                }
                continue;
            }
            chosen[k] = true;
            any = true;
        }
        if !any {
            return Err(Error::invalid_argument(format!(
                "--param {pattern} matches no parameter of the scene (available: {})",
                available
            )));
        }
    }
    let mut slot = 0u32;
    let mut out = Vec::new();
    for (k, c) in all.into_iter().enumerate() {
        if !chosen[k] {
            continue;
        }
        let n = c.value.len() as u32;
        out.push(Parameter {
            name: c.name,
            owner: c.owner,
            field: c.field,
            initial: c.value.clone(),
            value: c.value,
            bounds: c.bounds,
            slot,
        });
        slot += n;
    }
    if out.is_empty() {
        return Err(Error::invalid_argument(format!(
            "the scene has no parameter to fit (available: {})",
            available
        )));
    }
    Ok(out)
}

/// The gradient map of `params` for `scene`: each material field's and
/// each light parameter's slots, with the lights' current values.
pub fn gradient_map(scene: &Scene, params: &[Parameter]) -> GradientMap {
    let mut map = GradientMap::empty(scene);
    for p in params {
        map.len = map.len.max((p.slot as usize) + p.value.len());
        match &p.owner {
            Owner::Material(i) => {
                for (field, first, colour, _) in material_fields(&scene.materials()[*i].bsdf) {
                    if field == p.field {
                        let n = if colour { 3 } else { 1 };
                        for k in 0..n {
                            map.materials[*i][first as usize + k] = Some(p.slot + k as u32);
                        }
                    }
                }
            }
            owner => {
                for li in light_range(scene, owner) {
                    let slots = &mut map.lights[li];
                    if p.value.len() == 1 {
                        slots.scalar = Some((p.slot, p.value[0]));
                    } else {
                        slots.colour = Some((p.slot, p.rgb()));
                    }
                }
            }
        }
    }
    map
}

/// The lights (indices into `Scene::lights().lights`) a light owner feeds.
fn light_range(scene: &Scene, owner: &Owner) -> std::ops::Range<usize> {
    match owner {
        Owner::Pls { mesh, .. } | Owner::Shape(mesh) => scene.mesh_lights(*mesh).unwrap_or(0..0),
        Owner::PointLight(i) => *i..*i + 1,
        Owner::Environment => match scene.environment_index() {
            Some(e) => e..e + 1,
            None => 0..0,
        },
        Owner::Material(_) => 0..0,
    }
}

/// Sets `param` in the built scene to `value` (the parameter still holding
/// the value the scene has).
pub fn apply(scene: &mut Scene, param: &Parameter, value: &[f32]) -> Result<()> {
    match &param.owner {
        Owner::Material(i) => {
            let mut bsdf = scene.materials()[*i].bsdf;
            let rgb = || match value {
                [r, g, b] => Vec3::new(*r, *g, *b),
                _ => Vec3::ZERO,
            };
            match (&mut bsdf, param.field) {
                (Bsdf::Diffuse(p), "reflectance") => p.reflectance = rgb(),
                (Bsdf::Principled(p), "base_color") => p.base_color = rgb(),
                (Bsdf::Principled(p), "roughness") => p.roughness = value[0],
                (Bsdf::Principled(p), "metallic") => p.metallic = value[0],
                (Bsdf::Principled(p), "anisotropic") => p.anisotropic = value[0],
                (Bsdf::Principled(p), "specular") => p.specular = value[0],
                _ => {}
            }
            Ok(scene.set_material_bsdf(*i, bsdf)?)
        }
        owner => {
            let old = param.rgb();
            let new = match value {
                [v] => Vec3::splat(*v),
                [r, g, b] => Vec3::new(*r, *g, *b),
                _ => old,
            };
            let factor = Vec3::select(old.cmpgt(Vec3::ZERO), new / old, Vec3::ONE);
            scene.scale_light_emission(light_range(scene, owner), factor);
            Ok(())
        }
    }
}
