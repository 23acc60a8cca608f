//! The `<scene>`'s children, the integrator, and the plsr scene they make.

use super::document::Element;
use super::sensor::DEFAULT_HFOV_DEG;
use super::spectrum::SpectrumUse;
use super::table::{float, vec3, Table};
use super::translator::{Params, Translator};
use crate::error::Result;
use toml::Value;

impl<'a> Translator<'a> {
    /// The `<scene>`'s children, in order.
    pub(super) fn scene(&mut self, root: &'a Element) -> Result<()> {
        for c in root.children.iter() {
            match c.tag.as_str() {
                "integrator" => {
                    if self.integrated {
                        return Err(self.err(c, "a scene has one integrator: this is the second"));
                    }
                    self.integrated = true;
                    self.integrator(c)?;
                }
                "sensor" => {
                    if self.camera.is_some() {
                        return Err(self.err(c, "plsr renders one sensor: this is the second"));
                    }
                    self.sensor(c)?;
                }
                "bsdf" => {
                    // Translated where used, and here (so that faults show).
                    self.material(c)?;
                }
                "texture" => {
                    self.colour_of(c, SpectrumUse::Reflectance)?;
                }
                "shape" => self.shape(c)?,
                // An area emitter with an id is for shapes to refer to.
                "emitter" if c.attribute("type") == Some("area") && c.attribute("id").is_some() => {
                }
                "emitter" => self.emitter(c)?,
                // Defined for a sensor to refer to.
                "sampler" | "film" | "rfilter" if c.attribute("id").is_some() => {}
                // Resolved when the ids were collected.
                "alias" => {}
                "ref" => {
                    let target = self.deref(c)?;
                    return Err(self.err(
                        c,
                        format!(
                            "a <ref> to a <{}> directly inside the <scene>: plsr adds \
                             objects to the scene where they are defined",
                            target.tag
                        ),
                    ));
                }
                "medium" | "volume" => {
                    return Err(self.err(
                        c,
                        "participating media are not supported: plsr renders surfaces in \
                         vacuum",
                    ))
                }
                other => {
                    return Err(self.err(
                        c,
                        format!(
                            "<{other}> is not supported by plsr (supported: default, path, \
                             include, alias, integrator, sensor, bsdf, texture, shape, emitter)"
                        ),
                    ))
                }
            }
        }
        Ok(())
    }

    /// The integrator: `path` and `direct` as they are; the integrators
    /// that estimate the same image in a scene without media as plsr's
    /// path tracer; `moment` and `aov` by the integrator they wrap.
    pub(super) fn integrator(&mut self, node: &'a Element) -> Result<()> {
        let kind = self.required_attr(node, "type")?;
        match kind.as_str() {
            "path" => {}
            "volpath" | "volpathmis" | "ptracer" | "prb" | "prb_basic" | "direct_projective"
            | "prb_projective" => {
                self.note(
                    node,
                    format!(
                        "the `{kind}` integrator is rendered by plsr's path tracer (it \
                         estimates the same image in a scene without media)"
                    ),
                );
                return self.path_like(node, &kind);
            }
            "direct" => {
                self.render.insert("max_depth", Value::Integer(1));
                let mut p = self.params(node)?;
                for s in ["emitter_samples", "bsdf_samples"] {
                    if let Some(n) = self.take_int(&mut p, s)? {
                        if n != 1 {
                            self.note(
                                node,
                                format!(
                                    "{s} = {n}: plsr takes one light and one BSDF sample \
                                     per bounce (raise the sample count instead)"
                                ),
                            );
                        }
                    }
                }
                self.hide_emitters(node, &mut p)?;
                return self.leftovers_of_integrator(&p);
            }
            "moment" => {
                self.note(
                    node,
                    "moment: plsr's EXR holds the variance of every pixel's mean \
                     (`variance.R/G/B`); the nested integrator renders the image",
                );
                return self.nested_integrator(node);
            }
            "aov" => return self.aov(node),
            other => {
                return Err(self.err(
                    node,
                    format!(
                        "the `{other}` integrator is not supported (supported: path, \
                         direct, volpath, volpathmis, ptracer, prb, prb_basic, \
                         direct_projective, prb_projective, moment, aov)"
                    ),
                ))
            }
        }
        self.path_like(node, &kind)
    }

    /// The one integrator nested in a `moment` or `aov` (none: `path`).
    fn nested_integrator(&mut self, node: &'a Element) -> Result<()> {
        let mut nested = Vec::new();
        for c in &node.children {
            let c = if c.tag == "ref" { self.deref(c)? } else { c };
            if c.tag == "integrator" {
                nested.push(c);
            } else if !(c.tag == "string" && c.attribute("name") == Some("aovs")) {
                return Err(self.err(c, format!("not supported inside a `{}`", node.tag)));
            }
        }
        match nested.as_slice() {
            [] => {
                self.render.insert("max_depth", Value::Integer(1024));
                Ok(())
            }
            [one] => self.integrator(one),
            [_, second, ..] => Err(self.err(
                second,
                "plsr renders one integrator's image: this is the second nested one",
            )),
        }
    }

    /// `aov`: the AOVs plsr's EXR has (depth, shading normal, albedo, shape
    /// index) are written anyway; the others are noted.
    fn aov(&mut self, node: &'a Element) -> Result<()> {
        let mut p = self.params(node)?;
        let list = self.take_string(&mut p, "aovs")?.unwrap_or_default();
        for entry in list.split(',').map(str::trim).filter(|e| !e.is_empty()) {
            let kind = entry.rsplit(':').next().unwrap_or(entry);
            let layer = match kind {
                "depth" => Some("Z (the mean depth along the view axis)"),
                "sh_normal" | "geo_normal" => Some("normal.X/Y/Z (world space)"),
                "albedo" => Some("albedo.R/G/B"),
                "shape_index" => Some("object_id"),
                _ => None,
            };
            match layer {
                Some(l) => self.note(node, format!("aov `{entry}` is plsr's EXR layer {l}")),
                None => self.note(
                    node,
                    format!("aov `{entry}`: plsr's EXR has no such layer; not written"),
                ),
            }
        }
        self.nested_integrator(node)
    }

    /// `path` and the integrators rendered as it: the depths, Mitsuba's
    /// counting converted.
    fn path_like(&mut self, node: &'a Element, kind: &str) -> Result<()> {
        let mut p = self.params(node)?;
        let max_depth = self.take_int(&mut p, "max_depth")?.unwrap_or(-1);
        let depth = match max_depth {
            -1 => {
                self.note(
                    node,
                    "max_depth -1 (unlimited) becomes plsr's largest, 1024 (Russian roulette \
                     ends the paths)",
                );
                1024
            }
            d if d >= 1 => (d - 1).min(1024),
            d => {
                return Err(self.err(
                    node,
                    format!(
                        "max_depth = {d}: an image of nothing; plsr's max_depth is \
                         Mitsuba's − 1 (Mitsuba's 1: only the emitters the camera sees)"
                    ),
                ))
            }
        };
        self.render.insert("max_depth", Value::Integer(depth));
        let rr = self.take_int(&mut p, "rr_depth")?.unwrap_or(5);
        if rr < 1 {
            return Err(self.err(node, format!("rr_depth = {rr} must be at least 1")));
        }
        self.render
            .insert("rr_depth", Value::Integer((rr - 1).clamp(1, 1024)));
        self.hide_emitters(node, &mut p)?;
        // What the other integrators add to `path` and that changes nothing
        // here (no media, no differentiation).
        if kind != "path" {
            for ignored in [
                "samples_per_pass",
                "sppc",
                "sppp",
                "sppi",
                "reparam_max_depth",
            ] {
                self.take(&mut p, ignored);
            }
        }
        self.leftovers_of_integrator(&p)
    }

    fn hide_emitters(&mut self, node: &'a Element, p: &mut Params<'a>) -> Result<()> {
        if self.take_bool(p, "hide_emitters")? == Some(true) {
            return Err(self.err(node, "hide_emitters = true is not supported"));
        }
        Ok(())
    }

    pub(super) fn leftovers_of_integrator(&self, p: &Params) -> Result<()> {
        self.leftovers(p)?;
        if let Some(c) = p
            .node
            .children
            .iter()
            .find(|c| c.attribute("name").is_none())
        {
            return Err(self.err(c, "not supported inside an integrator"));
        }
        Ok(())
    }

    /// The plsr scene as TOML.
    pub(super) fn finish(&mut self) -> String {
        let mut out = format!(
            "# Translated from Mitsuba 3 XML ({}) by plsr {}.\n",
            self.doc.files[0].display(),
            env!("CARGO_PKG_VERSION")
        );
        for n in &self.notes {
            out.push_str(&format!("# note: {n}\n"));
        }
        let camera = self.camera.take().unwrap_or_else(|| {
            // Mitsuba's default sensor: at the origin, looking along +z,
            // a 50 mm lens.
            let mut c = Table::new();
            c.insert(
                "resolution",
                Value::Array(vec![Value::Integer(768), Value::Integer(576)]),
            );
            c.insert("position", vec3([0.0; 3]));
            c.insert("look_at", vec3([0.0, 0.0, 1.0]));
            c.insert("up", vec3([0.0, 1.0, 0.0]));
            c.insert("hfov", float(DEFAULT_HFOV_DEG));
            c
        });
        let sections = [
            ("render", Some(std::mem::take(&mut self.render))),
            ("camera", Some(camera)),
            ("film", Some(std::mem::take(&mut self.film))),
            ("environment", self.environment.take()),
        ];
        for (name, table) in sections {
            if let Some(t) = table.filter(|t| !t.is_empty()) {
                out.push_str(&format!("\n[{name}]\n"));
                t.write(&mut out);
            }
        }
        let arrays = [
            ("materials", std::mem::take(&mut self.materials)),
            ("shapes", std::mem::take(&mut self.shapes)),
            ("instances", std::mem::take(&mut self.instances)),
            ("lights", std::mem::take(&mut self.lights)),
        ];
        for (name, list) in arrays {
            for t in list {
                out.push_str(&format!("\n[[{name}]]\n"));
                t.write(&mut out);
            }
        }
        out
    }
}
