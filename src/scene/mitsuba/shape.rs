//! Shapes: meshes and Mitsuba's built-in shapes, with their BSDF and area
//! emitter.

use super::document::Element;
use super::spectrum::SpectrumUse;
use super::table::{float, vec3, vec3_row, Table};
use super::translator::Translator;
use crate::error::Result;
use toml::Value;

impl<'a> Translator<'a> {
    pub(super) fn shape(&mut self, node: &'a Element) -> Result<()> {
        let kind = self.required_attr(node, "type")?;
        match kind.as_str() {
            "shapegroup" => return self.shapegroup(node),
            "instance" => return self.instance(node),
            _ => {}
        }
        let mut p = self.params(node)?;
        let mut s = Table::new();
        match kind.as_str() {
            "obj" | "ply" | "serialized" => {
                s.insert("type", Value::String(kind.clone()));
                let file = self
                    .take_string(&mut p, "filename")?
                    .ok_or_else(|| self.err(node, "a mesh needs `filename`"))?;
                s.insert("file", Value::String(self.file_name(node, file)));
                if kind == "serialized" {
                    if let Some(i) = self.take_int(&mut p, "shape_index")? {
                        let i = u32::try_from(i).map_err(|_| {
                            self.err(node, format!("shape_index = {i} must be 0 or more"))
                        })?;
                        s.insert("shape_index", Value::Integer(i.into()));
                    }
                }
                let face_normals = self.take_bool(&mut p, "face_normals")?.unwrap_or(false);
                if face_normals && kind == "obj" {
                    self.note(
                        node,
                        "face_normals = true: plsr keeps an OBJ file's own normals, if it has any",
                    );
                } else if face_normals {
                    s.insert("face_normals", Value::Boolean(true));
                } else {
                    // Mitsuba gives meshes without normals smooth ones.
                    s.insert("smooth_normals", Value::Boolean(true));
                }
                if self.take_bool(&mut p, "flip_normals")? == Some(true) {
                    if kind == "obj" {
                        return Err(self.err(node, "flip_normals is not supported for obj in plsr"));
                    }
                    s.insert("flip_normals", Value::Boolean(true));
                }
                // Mitsuba's images run down from v = 0: its OBJ reader flips
                // v (`flip_tex_coords`, default true), which plsr's
                // convention already is; every other shape is flipped
                // (see `texture::to_uv`).
                let flip_tex = self.take_bool(&mut p, "flip_tex_coords")?.unwrap_or(true);
                if kind != "obj" || !flip_tex {
                    s.insert("flip_v", Value::Boolean(true));
                }
            }
            "rectangle" | "disk" | "cube" | "sphere" | "cylinder" => {
                s.insert("type", Value::String(kind.clone()));
                s.insert("flip_v", Value::Boolean(true));
                if self.take_bool(&mut p, "flip_normals")? == Some(true) {
                    s.insert("flip_normals", Value::Boolean(true));
                }
                if kind == "cylinder" {
                    for end in ["p0", "p1"] {
                        if let Some(c) = self.take_point(&mut p, end)? {
                            s.insert(end, vec3(c));
                        }
                    }
                    if let Some(r) = self.take_float(&mut p, "radius")? {
                        s.insert("radius", float(r));
                    }
                }
                if kind == "sphere" {
                    if let Some(c) = self.take_point(&mut p, "center")? {
                        s.insert("center", vec3(c));
                    }
                    if let Some(r) = self.take_float(&mut p, "radius")? {
                        s.insert("radius", float(r));
                    }
                }
            }
            "bsplinecurve" | "linearcurve" => {
                s.insert("type", Value::String("curves".into()));
                let file = self
                    .take_string(&mut p, "filename")?
                    .ok_or_else(|| self.err(node, "curves need `filename`"))?;
                s.insert("file", Value::String(self.file_name(node, file)));
                let basis = if kind == "bsplinecurve" {
                    "bspline"
                } else {
                    "linear"
                };
                s.insert("basis", Value::String(basis.into()));
                s.insert("flip_v", Value::Boolean(true));
                // Only for differentiable silhouettes.
                self.take_float(&mut p, "silhouette_sampling_weight")?;
                self.note(
                    node,
                    "plsr meshes curves (32 sides, 16 rings per B-spline segment): \
                     set `sides` and `steps` in the translated scene for finer tubes",
                );
            }
            "sdfgrid" => {
                s.insert("type", Value::String("sdf_grid".into()));
                let file = self
                    .take_string(&mut p, "filename")?
                    .ok_or_else(|| self.err(node, "plsr reads an sdfgrid from `filename`"))?;
                s.insert("file", Value::String(self.file_name(node, file)));
                if let Some(n) = self.take_string(&mut p, "normals")? {
                    if !matches!(n.as_str(), "smooth" | "analytic") {
                        return Err(
                            self.err(node, format!("normals `{n}` is not smooth or analytic"))
                        );
                    }
                    s.insert("normals", Value::String(n));
                }
                self.note(
                    node,
                    "plsr meshes the SDF grid's surface (each cell refined twice): \
                     set `subdivisions` in the translated scene for a finer mesh",
                );
            }
            other => {
                return Err(self.err(
                    node,
                    format!(
                        "the `{other}` shape is not supported (supported: obj, ply, serialized, \
                         rectangle, sphere, disk, cylinder, cube, bsplinecurve, linearcurve, \
                         sdfgrid, shapegroup, instance)"
                    ),
                ))
            }
        }
        let to_world = self.take_transform(&mut p, "to_world")?;
        if let Some(group) = &self.group {
            s.insert("group", Value::String(group.clone()));
        }
        if let Some(m) = to_world {
            let rows: Vec<Value> = (0..4).map(|r| vec3_row(m.row(r))).collect();
            s.insert("transform.matrix", Value::Array(rows));
        }
        let mut bsdf = None;
        for c in node.children.iter() {
            let name = c.attribute("name");
            let target = if c.tag == "ref" { self.deref(c)? } else { c };
            match target.tag.as_str() {
                "bsdf" => {
                    if bsdf.is_some() {
                        return Err(self.err(c, "a shape has one BSDF: this is the second"));
                    }
                    bsdf = Some(self.material(target)?);
                }
                "emitter" if self.group.is_some() => {
                    return Err(self.err(c, "a shape in a shapegroup cannot emit (as in Mitsuba)"));
                }
                "emitter" => {
                    if s.get("emission").is_some() {
                        return Err(self.err(c, "a shape has one emitter: this is the second"));
                    }
                    let radiance = self.area_emitter(target)?;
                    s.insert("emission", vec3(radiance));
                }
                _ if name.is_some() => continue,
                other => {
                    return Err(self.err(c, format!("<{other}> is not supported inside a shape")))
                }
            }
            if let Some(n) = name {
                p.used.insert(n.to_string());
            }
        }
        let material = match bsdf {
            Some(m) => m,
            // Mitsuba's default BSDF is black on an emitter.
            None if s.get("emission").is_some() => self.default_diffuse(0.0),
            None => self.default_material(),
        };
        s.insert("material", Value::String(material));
        self.leftovers(&p)?;
        self.shapes.push(s);
        Ok(())
    }

    /// A `shapegroup` where it is defined: nothing is drawn (its shapes
    /// are placed by instances); its children are checked to be shapes.
    fn shapegroup(&mut self, node: &'a Element) -> Result<()> {
        if self.group.is_some() {
            return Err(self.err(
                node,
                "a shapegroup inside a shapegroup (as in Mitsuba, refused)",
            ));
        }
        for c in &node.children {
            let target = if c.tag == "ref" { self.deref(c)? } else { c };
            if target.tag != "shape" {
                return Err(self.err(c, format!("<{}> in a shapegroup: only shapes", target.tag)));
            }
            let kind = self.required_attr(target, "type")?;
            if matches!(kind.as_str(), "shapegroup" | "instance") {
                return Err(self.err(target, format!("a {kind} inside a shapegroup is refused")));
            }
        }
        Ok(())
    }

    /// An `instance`: an `[[instances]]` entry placing its `shapegroup`
    /// (an Embree instance of the group's own BVH); the group's shapes are
    /// written once, with the group's name as their `group`, in the
    /// group's own space.
    fn instance(&mut self, node: &'a Element) -> Result<()> {
        if self.group.is_some() {
            return Err(self.err(
                node,
                "an instance inside a shapegroup (as in Mitsuba, refused)",
            ));
        }
        let mut p = self.params(node)?;
        let to_world = self
            .take_transform(&mut p, "to_world")?
            .unwrap_or(glam::DMat4::IDENTITY);
        let mut group = None;
        for c in node
            .children
            .iter()
            .filter(|c| c.attribute("name").is_none())
        {
            let target = if c.tag == "ref" { self.deref(c)? } else { c };
            let is_group =
                target.tag == "shape" && self.required_attr(target, "type")? == "shapegroup";
            if !is_group || group.is_some() {
                return Err(self.err(
                    c,
                    "an instance holds one shapegroup (by <ref>) and nothing else",
                ));
            }
            group = Some(target);
        }
        let group =
            group.ok_or_else(|| self.err(node, "an instance needs a <ref> to a shapegroup"))?;
        self.leftovers(&p)?;
        self.shapegroup(group)?;
        let name = match group.attribute("id") {
            Some(id) => id.to_string(),
            None => format!("shapegroup-line-{}", group.line),
        };
        if self.groups_written.insert(name.clone()) {
            self.group = Some(name.clone());
            let written = group.children.iter().try_for_each(|c| {
                let target = if c.tag == "ref" { self.deref(c)? } else { c };
                self.shape(target)
            });
            self.group = None;
            written?;
        }
        let mut t = Table::new();
        t.insert("group", Value::String(name));
        if to_world != glam::DMat4::IDENTITY {
            let rows: Vec<Value> = (0..4).map(|r| vec3_row(to_world.row(r))).collect();
            t.insert("transform.matrix", Value::Array(rows));
        }
        self.instances.push(t);
        Ok(())
    }

    /// An `area` emitter's radiance (linear sRGB, W/(m²·sr)).
    fn area_emitter(&mut self, e: &'a Element) -> Result<[f64; 3]> {
        let kind = self.required_attr(e, "type")?;
        if kind != "area" {
            return Err(self.err(e, format!("a shape's emitter must be `area`, not `{kind}`")));
        }
        let mut ep = self.params(e)?;
        self.sampling_weight(e, &mut ep)?;
        let radiance = self
            .take_rgb(&mut ep, "radiance", SpectrumUse::Emission)?
            .unwrap_or([1.0; 3]);
        self.leftovers(&ep)?;
        Ok(radiance)
    }

    /// Mitsuba's BSDF for shapes without one: diffuse, 0.5 grey.
    pub(super) fn default_material(&mut self) -> String {
        self.default_diffuse(0.5)
    }

    /// The BSDF Mitsuba gives a shape without one: a one-sided diffuse of
    /// reflectance `reflectance` (0.5, or 0 on an emitter: a light without
    /// a BSDF reflects nothing).
    pub(super) fn default_diffuse(&mut self, reflectance: f64) -> String {
        let name = if reflectance == 0.0 {
            "mitsuba-default-emitter-black".to_string()
        } else {
            "mitsuba-default-diffuse".to_string()
        };
        if !self
            .materials
            .iter()
            .any(|m| m.get("name") == Some(&Value::String(name.clone())))
        {
            let mut m = Table::new();
            m.insert("name", Value::String(name.clone()));
            m.insert("type", Value::String("diffuse".into()));
            m.insert("reflectance", vec3([reflectance; 3]));
            // One-sided, as all Mitsuba's opaque BSDFs without `twosided`.
            m.insert("two_sided", Value::Boolean(false));
            self.materials.push(m);
        }
        name
    }
}
