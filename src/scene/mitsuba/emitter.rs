//! Emitters outside shapes: `point`, `spot`, `directional`, `envmap`,
//! `constant`.

use super::document::Element;
use super::spectrum::SpectrumUse;
use super::table::{dvec, float, vec3, Table};
use super::translator::Translator;
use crate::error::Result;
use glam::{DMat4, DVec3};
use toml::Value;

impl<'a> Translator<'a> {
    pub(super) fn emitter(&mut self, node: &'a Element) -> Result<()> {
        let kind = self.required_attr(node, "type")?;
        let mut p = self.params(node)?;
        match kind.as_str() {
            "point" => {
                let position = self.take_point(&mut p, "position")?;
                let m = self.take_transform(&mut p, "to_world")?;
                let position = match (position, m) {
                    (Some(_), Some(_)) => {
                        return Err(self.err(node, "give position or to_world, not both"))
                    }
                    (Some(pos), None) => DVec3::from(pos),
                    (None, Some(m)) => m.transform_point3(DVec3::ZERO),
                    (None, None) => DVec3::ZERO,
                };
                let intensity = self
                    .take_rgb(&mut p, "intensity", SpectrumUse::Emission)?
                    .unwrap_or([1.0; 3]);
                let mut l = Table::new();
                l.insert("type", Value::String("point".into()));
                l.insert("position", dvec(position));
                l.insert("intensity", vec3(intensity));
                self.lights.push(l);
            }
            "spot" => {
                if let Some(t) = self.take(&mut p, "texture") {
                    return Err(self.err(
                        t,
                        "a spot light's `texture` is not supported (plsr's spot lights \
                         have a uniform beam)",
                    ));
                }
                // The light sits at to_world's origin, its beam along to_world's +z.
                let m = self
                    .take_transform(&mut p, "to_world")?
                    .unwrap_or(DMat4::IDENTITY);
                let position = m.transform_point3(DVec3::ZERO);
                let direction = m.transform_vector3(DVec3::Z);
                if direction.length_squared() == 0.0 {
                    return Err(self.err(node, "the spot light's to_world is degenerate"));
                }
                let intensity = self
                    .take_rgb(&mut p, "intensity", SpectrumUse::Emission)?
                    .unwrap_or([1.0; 3]);
                let cutoff = self.take_float(&mut p, "cutoff_angle")?.unwrap_or(20.0);
                let beam = self
                    .take_float(&mut p, "beam_width")?
                    .unwrap_or(0.75 * cutoff);
                let mut l = Table::new();
                l.insert("type", Value::String("spot".into()));
                l.insert("position", dvec(position));
                l.insert("direction", dvec(direction.normalize()));
                l.insert("intensity", vec3(intensity));
                l.insert("cutoff_angle", float(cutoff));
                l.insert("beam_width", float(beam));
                self.lights.push(l);
            }
            "directional" => {
                // It emits along `direction`, or along to_world's +z.
                let direction = self.take_point(&mut p, "direction")?;
                let m = self.take_transform(&mut p, "to_world")?;
                let direction = match (direction, m) {
                    (Some(_), Some(_)) => {
                        return Err(self.err(node, "give direction or to_world, not both"))
                    }
                    (Some(d), None) => DVec3::from(d),
                    (None, Some(m)) => m.transform_vector3(DVec3::Z),
                    (None, None) => DVec3::Z,
                };
                if !(direction.length_squared() > 0.0 && direction.is_finite()) {
                    return Err(self.err(node, "the directional light's direction is zero"));
                }
                let irradiance = self
                    .take_rgb(&mut p, "irradiance", SpectrumUse::Emission)?
                    .unwrap_or([1.0; 3]);
                let mut l = Table::new();
                l.insert("type", Value::String("directional".into()));
                l.insert("direction", dvec(direction.normalize()));
                l.insert("irradiance", vec3(irradiance));
                self.lights.push(l);
            }
            "envmap" | "constant" => {
                if self.environment.is_some() {
                    return Err(self.err(
                        node,
                        "plsr has one environment: this is the second envmap/constant emitter",
                    ));
                }
                let mut e = Table::new();
                if kind == "envmap" {
                    let file = self
                        .take_string(&mut p, "filename")?
                        .ok_or_else(|| self.err(node, "an envmap needs `filename`"))?;
                    e.insert("file", Value::String(self.file_name(node, file)));
                    let m = self
                        .take_transform(&mut p, "to_world")?
                        .unwrap_or(DMat4::IDENTITY);
                    let up = m.transform_vector3(DVec3::Y);
                    let forward = m.transform_vector3(DVec3::Z);
                    if up.cross(forward).length_squared()
                        < 1e-12 * up.length_squared() * forward.length_squared()
                    {
                        return Err(self.err(node, "the envmap's to_world is degenerate"));
                    }
                    e.insert("up", dvec(up.normalize()));
                    e.insert("forward", dvec(forward.normalize()));
                    e.insert("filter", Value::String("bilinear".into()));
                    // Mitsuba's envmap puts its first and last rows on the
                    // poles (a row is 1/(h−1) of π tall).
                    e.insert("rows", Value::String("poles".into()));
                    if let Some(s) = self.take_float(&mut p, "scale")? {
                        e.insert("scale", float(s));
                    }
                } else {
                    let r = self
                        .take_rgb(&mut p, "radiance", SpectrumUse::Emission)?
                        .unwrap_or([1.0; 3]);
                    e.insert("radiance", vec3(r));
                }
                self.environment = Some(e);
            }
            "area" => {
                return Err(self.err(node, "an area emitter belongs inside a <shape>"));
            }
            other => {
                return Err(self.err(
                    node,
                    format!(
                        "the `{other}` emitter is not supported (supported: point, spot, \
                         directional, envmap, constant, and area inside a shape)"
                    ),
                ))
            }
        }
        self.leftovers(&p)
    }
}
