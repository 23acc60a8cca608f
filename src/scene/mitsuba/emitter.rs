//! Emitters outside shapes: `point`, `spot` (with its `texture`),
//! `projector`, `directional`, `envmap`, `constant`.

use super::document::Element;
use super::spectrum::SpectrumUse;
use super::table::{dvec, float, vec3, Table};
use super::texture::Colour;
use super::translator::Translator;
use crate::error::Result;
use glam::{DMat4, DVec3};
use toml::Value;

impl<'a> Translator<'a> {
    /// An emitter's `sampling_weight`: plsr picks Mitsuba's emitters
    /// uniformly (`[render] light_picking = "uniform"`), Mitsuba's rule
    /// when every weight is 1, the default; other weights are refused.
    pub(super) fn sampling_weight(
        &self,
        node: &'a Element,
        p: &mut super::translator::Params<'a>,
    ) -> Result<()> {
        match self.take_float(p, "sampling_weight")? {
            Some(w) if w != 1.0 => Err(self.err(
                node,
                format!(
                    "sampling_weight = {w}: plsr picks every emitter equally likely \
                     (Mitsuba's default, weight 1); other weights are not supported"
                ),
            )),
            _ => Ok(()),
        }
    }

    pub(super) fn emitter(&mut self, node: &'a Element) -> Result<()> {
        let kind = self.required_attr(node, "type")?;
        let mut p = self.params(node)?;
        self.sampling_weight(node, &mut p)?;
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
                let texture = match self.take(&mut p, "texture") {
                    None => None,
                    Some(t) => match self.colour_of(t, SpectrumUse::Reflectance)? {
                        Colour::Map(m) => Some(m),
                        Colour::Rgb(_) => {
                            return Err(self.err(
                                t,
                                "a spot light's `texture` must vary (a bitmap), as Mitsuba \
                                 requires",
                            ))
                        }
                    },
                };
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
                if let Some(map) = texture {
                    if cutoff >= 90.0 {
                        return Err(self.err(
                            node,
                            format!("a textured spot light's cutoff_angle {cutoff} must be below 90 degrees"),
                        ));
                    }
                    l.insert("up", dvec(self.rigid_up(node, &m, "spot light")?));
                    l.insert("intensity_map", map);
                }
                self.lights.push(l);
            }
            "projector" => {
                let m = self
                    .take_transform(&mut p, "to_world")?
                    .unwrap_or(DMat4::IDENTITY);
                let up = self.rigid_up(node, &m, "projector")?;
                let scale = self.take_float(&mut p, "scale")?.unwrap_or(1.0);
                let mut l = Table::new();
                l.insert("type", Value::String("projector".into()));
                l.insert("position", dvec(m.transform_point3(DVec3::ZERO)));
                l.insert("direction", dvec(m.transform_vector3(DVec3::Z).normalize()));
                l.insert("up", dvec(up));
                // The image's size sets the frustum's aspect (a constant is
                // one texel: square).
                let mut size = (1.0, 1.0);
                match self.take_colour(&mut p, "irradiance", SpectrumUse::Emission)? {
                    None => l.insert("irradiance", vec3([scale; 3])),
                    Some(Colour::Rgb(v)) => l.insert("irradiance", vec3(v.map(|c| c * scale))),
                    Some(Colour::Map(map)) => {
                        let file = match &map {
                            Value::String(f) => Some(f.clone()),
                            Value::Table(t) => {
                                t.get("file").and_then(|f| f.as_str()).map(String::from)
                            }
                            _ => None,
                        };
                        let Some(file) = file else {
                            return Err(self
                                .err(node, "a projector's irradiance is a bitmap or a constant"));
                        };
                        let path = self.doc.base_path(&file);
                        let (w, h) = image::image_dimensions(&path)
                            .map_err(|e| self.err(node, format!("{}: {e}", path.display())))?;
                        size = (w as f64, h as f64);
                        l.insert("irradiance", vec3([scale; 3]));
                        l.insert("irradiance_map", map);
                    }
                }
                let mut fov = Table::new();
                self.sensor_fov(node, &mut p, size, &mut fov)?;
                for (k, v) in fov.0 {
                    l.insert(k, v);
                }
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
                         projector, directional, envmap, constant, and area inside a shape)"
                    ),
                ))
            }
        }
        self.leftovers(&p)
    }

    /// The up direction (`+y`) of a light's `to_world`, which must be a
    /// rotation and translation (plsr's projected images have a rigid
    /// frame; Mitsuba's `look_at` builds one).
    fn rigid_up(&self, node: &'a Element, m: &DMat4, what: &str) -> Result<DVec3> {
        let (x, y, z) = (
            m.transform_vector3(DVec3::X),
            m.transform_vector3(DVec3::Y),
            m.transform_vector3(DVec3::Z),
        );
        let unit = |v: DVec3| (v.length() - 1.0).abs() < 1e-4;
        let rigid = unit(x)
            && unit(y)
            && unit(z)
            && x.dot(y).abs() < 1e-4
            && y.dot(z).abs() < 1e-4
            && z.dot(x).abs() < 1e-4
            && x.dot(y.cross(z)) > 0.0;
        if !rigid {
            return Err(self.err(
                node,
                format!(
                    "the {what}'s to_world must be a rotation and a translation (no scale, \
                     shear or mirror) for plsr to place its image"
                ),
            ));
        }
        Ok(y)
    }
}
