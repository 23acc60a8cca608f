//! The PLS file format (TOML, or JSON with the same schema by extension),
//! documented in `docs/pls-format.md`.
//!
//! ```toml
//! brightness = "intensity"      # or "radiance"; see BrightnessMode
//!
//! [[lights]]
//! name = "flashlight"
//! n = [-0.697, -0.339, -0.632]  # emitting side
//! a = 10.983                    # divergence half-angle, degrees
//! c = [0.271, 0.239, 0.412]     # linear RGB
//! b = 7.011                     # W/sr (intensity mode)
//! e1 = [2.398, 2.564, 1.249]    # metres
//! e2 = [2.401, 2.536, 1.260]
//! alpha1 = 0.0
//! alpha2 = 1.0
//! d = [0.0, 0.021, 0.021, 0.0]  # metres
//! ```
//!
//! Instead of `e1, e2, alpha1, alpha2, d`, a light may give
//! `circle = { center = [x, y, z], radius = r, axis = [x, y, z] }` (the
//! paper's disk approximation, [`Pls::circle`]).

use super::{BrightnessMode, Pls, PlsGeometry, PlsLighting};
use crate::atomic_write::write_atomically;
use crate::error::{Error, Result};
use glam::Vec3;
use plsr_base::Vocabulary;
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::Path;

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct PlsFile {
    #[serde(default)]
    brightness: Option<String>,
    #[serde(default)]
    lights: Vec<LightEntry>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct LightEntry {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    name: Option<String>,
    #[serde(deserialize_with = "crate::input::exact::array")]
    n: [f32; 3],
    a: f32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    penumbra: Option<f32>,
    #[serde(deserialize_with = "crate::input::exact::array")]
    c: [f32; 3],
    b: f32,
    #[serde(
        default,
        deserialize_with = "crate::input::exact::option",
        skip_serializing_if = "Option::is_none"
    )]
    e1: Option<[f32; 3]>,
    #[serde(
        default,
        deserialize_with = "crate::input::exact::option",
        skip_serializing_if = "Option::is_none"
    )]
    e2: Option<[f32; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    alpha1: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    alpha2: Option<f32>,
    #[serde(
        default,
        deserialize_with = "crate::input::exact::option",
        skip_serializing_if = "Option::is_none"
    )]
    d: Option<[f32; 4]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    circle: Option<CircleEntry>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct CircleEntry {
    #[serde(deserialize_with = "crate::input::exact::array")]
    center: [f32; 3],
    radius: f32,
    #[serde(deserialize_with = "crate::input::exact::array")]
    axis: [f32; 3],
}

fn is_json(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
}

/// Parses a PLS document; `path` is used for messages and to pick the syntax.
pub fn parse(text: &str, path: &Path) -> Result<PlsLighting> {
    let file: PlsFile = if is_json(path) {
        serde_json::from_str(text).map_err(|e| Error::input(path, "", e.to_string()))?
    } else {
        toml::from_str(text).map_err(|e| {
            let at = e
                .span()
                .map(|s| {
                    let line = text[..s.start].matches('\n').count() + 1;
                    format!("line {line}: ")
                })
                .unwrap_or_default();
            Error::input(path, "", format!("{at}{}", e.message().trim_end()))
        })?
    };
    let mode = match file.brightness.as_deref() {
        None | Some("intensity") => BrightnessMode::Intensity,
        Some("radiance") => BrightnessMode::Radiance,
        Some(other) => {
            return Err(Error::input(
                path,
                "brightness",
                format!("unknown brightness mode `{other}` (known: intensity, radiance)"),
            ))
        }
    };
    let mut lights = Vec::with_capacity(file.lights.len());
    for (i, e) in file.lights.into_iter().enumerate() {
        let label = match &e.name {
            Some(n) => format!("lights[{i}] ({n})"),
            None => format!("lights[{i}]"),
        };
        let missing = |p: &str| {
            Error::input(
                path,
                format!("{label}.{p}"),
                "required (or give `circle` instead of e1, e2, alpha1, alpha2, d)",
            )
        };
        let light = match e.circle {
            Some(c) => {
                for (p, present) in [
                    ("e1", e.e1.is_some()),
                    ("e2", e.e2.is_some()),
                    ("alpha1", e.alpha1.is_some()),
                    ("alpha2", e.alpha2.is_some()),
                    ("d", e.d.is_some()),
                ] {
                    if present {
                        return Err(Error::input(
                            path,
                            format!("{label}.{p}"),
                            "cannot be combined with `circle`",
                        ));
                    }
                }
                let (centre, axis) = (Vec3::from_array(c.center), Vec3::from_array(c.axis));
                if !centre.is_finite()
                    || !axis.is_finite()
                    || !c.radius.is_finite()
                    || c.radius <= 0.0
                {
                    return Err(Error::input(
                        path,
                        format!("{label}.circle"),
                        "center and axis must be finite and radius positive",
                    ));
                }
                let mut l = Pls::circle(
                    centre,
                    c.radius,
                    Vec3::from_array(e.n),
                    axis,
                    e.a,
                    Vec3::from_array(e.c),
                    e.b,
                )
                .ok_or_else(|| {
                    Error::input(
                        path,
                        format!("{label}.circle.axis"),
                        "must not be zero or parallel to n",
                    )
                })?;
                l.name = e.name;
                l.penumbra_deg = e.penumbra.unwrap_or(0.0);
                l
            }
            None => Pls {
                name: e.name,
                n: Vec3::from_array(e.n),
                g: PlsGeometry {
                    e1: Vec3::from_array(e.e1.ok_or_else(|| missing("e1"))?),
                    e2: Vec3::from_array(e.e2.ok_or_else(|| missing("e2"))?),
                    alpha1: e.alpha1.ok_or_else(|| missing("alpha1"))?,
                    alpha2: e.alpha2.ok_or_else(|| missing("alpha2"))?,
                    d: e.d.ok_or_else(|| missing("d"))?,
                },
                a_deg: e.a,
                penumbra_deg: e.penumbra.unwrap_or(0.0),
                c: Vec3::from_array(e.c),
                b: e.b,
            },
        };
        light
            .validate(i)
            .map_err(|v| Error::input(path, format!("{}.{}", v.light, v.parameter), v.message))?;
        lights.push(light);
    }
    Ok(PlsLighting { mode, lights })
}

/// Reads and validates a PLS file.
pub fn load(path: &Path) -> Result<PlsLighting> {
    crate::input::check_input_file(path)?;
    let text =
        std::fs::read_to_string(path).map_err(|source| Error::io(path.to_path_buf(), source))?;
    parse(&text, path)
}

/// Serialises a lighting in the PLS format (TOML, or JSON by extension of
/// `path`), every light written with its explicit geometry.
pub fn to_string(lighting: &PlsLighting, path: &Path) -> Result<String> {
    let file = PlsFile {
        brightness: Some(
            match lighting.mode {
                BrightnessMode::Intensity => "intensity",
                BrightnessMode::Radiance => "radiance",
            }
            .into(),
        ),
        lights: lighting
            .lights
            .iter()
            .map(|l| LightEntry {
                name: l.name.clone(),
                n: l.n.to_array(),
                a: l.a_deg,
                penumbra: (l.penumbra_deg > 0.0).then_some(l.penumbra_deg),
                c: l.c.to_array(),
                b: l.b,
                e1: Some(l.g.e1.to_array()),
                e2: Some(l.g.e2.to_array()),
                alpha1: Some(l.g.alpha1),
                alpha2: Some(l.g.alpha2),
                d: Some(l.g.d),
                circle: None,
            })
            .collect(),
    };
    let out = if is_json(path) {
        serde_json::to_string_pretty(&file).map_err(|e| e.to_string())
    } else {
        toml::to_string(&file).map_err(|e| e.to_string())
    };
    out.map_err(|message| Error::output(path.to_path_buf(), message))
}

/// Writes a lighting to a PLS file, atomically.
pub fn save(lighting: &PlsLighting, path: &Path) -> Result<()> {
    let text = to_string(lighting, path)?;
    write_atomically(path, |w| {
        w.write_all(text.as_bytes())
            .map_err(|source| Error::io(path.to_path_buf(), source))
    })
}

/// Writes the tessellated lights as an OBJ: one object per light, faces
/// counter-clockwise seen from the emitting side.
pub fn save_obj(lighting: &PlsLighting, nf: u32, path: &Path) -> Result<()> {
    let io = |source| Error::io(path.to_path_buf(), source);
    write_atomically(path, |w| {
        writeln!(
            w,
            "# plsr pls mesh: {} light(s), Nf = {nf}",
            lighting.lights.len()
        )
        .map_err(io)?;
        let mut base = 1u32;
        for (i, l) in lighting.lights.iter().enumerate() {
            let m = l.tessellate(nf);
            let name = l.name.clone().unwrap_or_else(|| format!("light{i}"));
            writeln!(w, "o {}", name.replace(char::is_whitespace, "_")).map_err(io)?;
            for p in &m.positions {
                writeln!(w, "v {} {} {}", p.x, p.y, p.z).map_err(io)?;
            }
            for t in &m.triangles {
                writeln!(w, "f {} {} {}", t[0] + base, t[1] + base, t[2] + base).map_err(io)?;
            }
            base += m.positions.len() as u32;
        }
        Ok(())
    })
}
