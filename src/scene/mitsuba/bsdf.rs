//! BSDFs: each Mitsuba plugin as a plsr material.

use super::conductors::CONDUCTORS;
use super::document::Element;
use super::spectrum::SpectrumUse;
use super::table::{float, set, vec3, Table};
use super::texture::Colour;
use super::translator::{Params, Translator};
use crate::error::Result;
use toml::Value;

/// Indices of refraction of Mitsuba's named materials (its
/// `dielectric` `int_ior`/`ext_ior` strings), at 589 nm.
const NAMED_IORS: [(&str, f64); 23] = [
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.333),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.47),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.575),
    ("diamond", 2.419),
];

/// The metal presets plsr has, by Mitsuba's names for them.
const METAL_NAMES: [&str; 5] = ["none", "Au", "Ag", "Cu", "Al"];

impl<'a> Translator<'a> {
    /// Translates a BSDF element into a `[[materials]]` entry (once per
    /// element) and returns its name.
    pub(super) fn material(&mut self, node: &'a Element) -> Result<String> {
        let key = node.key;
        if let Some(name) = self.material_names.get(&key) {
            return Ok(name.clone());
        }
        // A `bumpmap` or `normalmap` around the BSDF: the BSDF with plsr's
        // `bump_map` or `normal_map`.
        let (outer, bump, bump_shadowing) = self.peel_bumpmap(node)?;
        let (outer, normal_map, shadowing) = self.peel_normalmap(outer)?;
        if bump.is_some() && normal_map.is_some() {
            return Err(self.err(
                node,
                "a bumpmap and a normalmap on one BSDF are not supported",
            ));
        }
        let shadowing = shadowing || bump_shadowing;
        let kind = self.required_attr(outer, "type")?;
        let composite = matches!(kind.as_str(), "blendbsdf" | "mask" | "null");
        if composite && (normal_map.is_some() || bump.is_some()) {
            return Err(self.err(
                node,
                format!("a normalmap or bumpmap around a {kind} is not supported: put it inside"),
            ));
        }
        let (inner, twosided, back) = if composite {
            (outer, false, None)
        } else if kind == "twosided" {
            let node = outer;
            let mut p = self.params(node)?;
            if let Some(true) = self.take_bool(&mut p, "allow_transmission")? {
                return Err(self.err(node, "a twosided with allow_transmission is not supported"));
            }
            self.leftovers(&p)?;
            let bsdfs = self.nested_bsdfs(node)?;
            match bsdfs.as_slice() {
                [one] => (*one, true, None),
                [front, back] => {
                    let back = self.material(back)?;
                    (*front, false, Some(back))
                }
                _ => return Err(self.err(node, "twosided needs one or two BSDFs inside")),
            }
        } else {
            (outer, false, None)
        };
        let mut table = if composite {
            self.composite(inner, &kind)?
        } else {
            self.bsdf(inner, twosided)?
        };
        if let Some(back) = back {
            set(&mut table, "back", Value::String(back));
        }
        if let Some((map, scale)) = bump {
            set(&mut table, "bump_map", map);
            set(&mut table, "bump_scale", float(scale));
            if shadowing {
                set(&mut table, "normal_shadowing", Value::Boolean(true));
            }
        }
        if let Some(file) = normal_map {
            set(&mut table, "normal_map", Value::String(file));
            // Mitsuba's frame: y = n × ∂p/∂u, whichever way v runs.
            set(&mut table, "normal_frame", Value::String("tangent".into()));
            if shadowing {
                set(&mut table, "normal_shadowing", Value::Boolean(true));
            }
        }
        let taken = |name: &str| {
            self.materials
                .iter()
                .any(|m| m.get("name").and_then(Value::as_str) == Some(name))
        };
        let name = match self.attr(node, "id")? {
            Some(id) => {
                if taken(&id) {
                    return Err(self.err(node, format!("a material named `{id}` exists already")));
                }
                id
            }
            // Anonymous BSDFs are named by their line (and, several on one
            // line, a count).
            None => {
                let base = format!("bsdf-line-{}", node.line);
                let mut name = base.clone();
                let mut k = 1;
                while taken(&name) {
                    k += 1;
                    name = format!("{base}-{k}");
                }
                name
            }
        };
        let mut entry = Table::new();
        entry.insert("name", Value::String(name.clone()));
        entry.0.append(&mut table.0);
        self.materials.push(entry);
        self.material_names.insert(key, name.clone());
        Ok(name)
    }

    /// Mitsuba's `bumpmap` BSDF: the BSDF inside it, its height texture as
    /// a plsr map (a bitmap's luminance, sRGB-decoded unless `raw`) with
    /// its `scale`, and whether it attenuates grazing light
    /// (`use_shadowing_function`); any other element as it is.
    #[allow(clippy::type_complexity)]
    fn peel_bumpmap(
        &mut self,
        node: &'a Element,
    ) -> Result<(&'a Element, Option<(Value, f64)>, bool)> {
        if self.required_attr(node, "type")? != "bumpmap" {
            return Ok((node, None, false));
        }
        let mut p = self.params(node)?;
        let shadowing = self
            .take_bool(&mut p, "use_shadowing_function")?
            .unwrap_or(true);
        let scale = self.take_float(&mut p, "scale")?.unwrap_or(1.0);
        if self.take_bool(&mut p, "flip_invalid_normals")? == Some(false) {
            self.note(
                node,
                "flip_invalid_normals = false: plsr shades a surface seen from below its \
                 bumped normal with the unbumped one either way",
            );
        }
        // The height: the one texture (of any name) among the parameters.
        let textures: Vec<&'a Element> = p
            .named
            .iter()
            .map(|(_, e)| *e)
            .filter(|e| matches!(e.tag.as_str(), "texture" | "ref"))
            .collect();
        let [tex] = textures.as_slice() else {
            return Err(self.err(node, "a bumpmap needs one height <texture>"));
        };
        let name = tex.attribute("name").unwrap_or_default().to_string();
        p.used.insert(name);
        let map = match self.colour_of(tex, SpectrumUse::Unbounded)? {
            Colour::Map(m) => Some((m, scale)),
            Colour::Rgb(_) => {
                self.note(node, "a bumpmap of a constant height has no slope: ignored");
                None
            }
        };
        let inner = self.nested_bsdfs(node)?;
        let [bsdf] = inner.as_slice() else {
            return Err(self.err(node, "a bumpmap holds one BSDF"));
        };
        self.leftovers(&p)?;
        Ok((bsdf, map, shadowing))
    }

    /// Mitsuba's `normalmap` BSDF: the BSDF inside it, the file of its
    /// `normalmap` texture (a `bitmap`, read raw: `2·rgb − 1` in the
    /// shading frame, as plsr's `normal_map`) and whether it attenuates
    /// grazing light (`use_shadowing_function`); any other element as it is.
    fn peel_normalmap(&mut self, node: &'a Element) -> Result<(&'a Element, Option<String>, bool)> {
        if self.required_attr(node, "type")? != "normalmap" {
            return Ok((node, None, false));
        }
        let mut p = self.params(node)?;
        // Mitsuba attenuates grazing light by Estevez et al.'s term unless
        // told not to.
        let shadowing = self
            .take_bool(&mut p, "use_shadowing_function")?
            .unwrap_or(true);
        let tex = self
            .take(&mut p, "normalmap")
            .ok_or_else(|| self.err(node, "a normalmap needs a <texture name=\"normalmap\">"))?;
        let tex = if tex.tag == "ref" {
            self.deref(tex)?
        } else {
            tex
        };
        if tex.tag != "texture" || self.required_attr(tex, "type")? != "bitmap" {
            return Err(self.err(tex, "a normalmap's texture must be a bitmap"));
        }
        let mut tp = self.params(tex)?;
        let file = self
            .take_string(&mut tp, "filename")?
            .ok_or_else(|| self.err(tex, "a bitmap needs `filename`"))?;
        if self.take_bool(&mut tp, "raw")? == Some(false) {
            return Err(self.err(
                tex,
                "a normal map read as sRGB (raw = false) is not supported: give raw = true",
            ));
        }
        for (key, default) in [("filter_type", "bilinear"), ("wrap_mode", "repeat")] {
            if let Some(v) = self.take_string(&mut tp, key)? {
                if v != default {
                    return Err(self.err(
                        tex,
                        format!("a normal map's {key} `{v}` is not supported (only {default})"),
                    ));
                }
            }
        }
        self.leftovers(&tp)?;
        let file = self.file_name(tex, file);
        let mut inner = node
            .children
            .iter()
            .filter(|c| c.attribute("name").is_none());
        let bsdf = inner
            .next()
            .ok_or_else(|| self.err(node, "a normalmap needs a BSDF inside"))?;
        if let Some(extra) = inner.next() {
            return Err(self.err(extra, "a normalmap holds one BSDF"));
        }
        let bsdf = if bsdf.tag == "ref" {
            self.deref(bsdf)?
        } else {
            bsdf
        };
        if bsdf.tag != "bsdf" {
            return Err(self.err(bsdf, "a normalmap needs a <bsdf> inside"));
        }
        self.leftovers(&p)?;
        Ok((bsdf, Some(file), shadowing))
    }

    /// The BSDFs nested in `node` (unnamed children, `<ref>`s followed).
    fn nested_bsdfs(&self, node: &'a Element) -> Result<Vec<&'a Element>> {
        let mut out = Vec::new();
        for c in node
            .children
            .iter()
            .filter(|c| c.attribute("name").is_none())
        {
            let c = self.deref(c)?;
            if c.tag != "bsdf" {
                return Err(self.err(c, format!("<{}> is not a BSDF", c.tag)));
            }
            out.push(c);
        }
        Ok(out)
    }

    /// `blendbsdf` (two BSDFs and their `weight`), `mask` (a BSDF and its
    /// `opacity`, default 0.5) and `null`, as plsr's `blend`, `mask` and
    /// `null` materials naming the materials they are made of.
    fn composite(&mut self, node: &'a Element, kind: &str) -> Result<Table> {
        let mut p = self.params(node)?;
        let bsdfs = self.nested_bsdfs(node)?;
        let mut t = Table::new();
        match kind {
            "null" => {
                if let Some(b) = bsdfs.first() {
                    return Err(self.err(b, "a null BSDF holds nothing"));
                }
                set(&mut t, "type", Value::String("null".into()));
            }
            "mask" => {
                let [inner] = bsdfs.as_slice() else {
                    return Err(self.err(node, "a mask holds one BSDF"));
                };
                let inner = self.material(inner)?;
                set(&mut t, "type", Value::String("mask".into()));
                set(&mut t, "material", Value::String(inner));
                self.scalar(&mut p, &mut t, "opacity", Some(0.5))?;
            }
            _ => {
                let [a, b] = bsdfs.as_slice() else {
                    return Err(self.err(node, "a blendbsdf holds two BSDFs"));
                };
                let names = vec![
                    Value::String(self.material(a)?),
                    Value::String(self.material(b)?),
                ];
                set(&mut t, "type", Value::String("blend".into()));
                set(&mut t, "materials", Value::Array(names));
                // Mitsuba requires the weight (its documentation's default
                // of 0.5 is not in the code).
                self.scalar(&mut p, &mut t, "weight", None)?;
            }
        }
        self.leftovers(&p)?;
        Ok(t)
    }

    /// A scalar texture parameter `name` as `name` (a constant: a float, or
    /// the mean of an RGB value, as Mitsuba's `eval_1`) or `name_map` (a
    /// bitmap's luminance, sRGB-decoded unless `raw`).
    fn scalar(
        &self,
        p: &mut Params<'a>,
        t: &mut Table,
        name: &str,
        default: Option<f64>,
    ) -> Result<()> {
        let node = p.node;
        match self.take_colour(p, name, SpectrumUse::Unbounded)? {
            Some(Colour::Rgb(v)) => {
                let mean = (v[0] + v[1] + v[2]) / 3.0;
                set(t, name, float(mean.clamp(0.0, 1.0)));
            }
            Some(Colour::Map(m)) => set(t, &format!("{name}_map"), scalar_map(m)),
            None => match default {
                Some(d) => set(t, name, float(d)),
                None => return Err(self.err(node, format!("`{name}` is required"))),
            },
        }
        Ok(())
    }

    /// The plsr keys (with `type`) of one BSDF.
    pub(super) fn bsdf(&mut self, node: &'a Element, twosided: bool) -> Result<Table> {
        let kind = self.required_attr(node, "type")?;
        let mut p = self.params(node)?;
        let mut t = Table::new();
        let opaque = !matches!(
            kind.as_str(),
            "dielectric" | "roughdielectric" | "thindielectric" | "principledthin"
        );
        match kind.as_str() {
            "diffuse" => self.bsdf_diffuse(&mut p, &mut t)?,
            "roughconductor" | "conductor" => self.bsdf_conductor(node, &kind, &mut p, &mut t)?,
            "roughdielectric" | "dielectric" => {
                self.bsdf_dielectric(node, &kind, &mut p, &mut t)?
            }
            "principled" => self.bsdf_principled(node, &mut p, &mut t)?,
            "principledthin" => self.bsdf_principled_thin(node, &mut p, &mut t)?,
            "thindielectric" => self.bsdf_thin_dielectric(node, &mut p, &mut t)?,
            "plastic" | "roughplastic" => self.bsdf_plastic(node, &kind, &mut p, &mut t)?,
            "twosided" => return Err(self.err(node, "a twosided inside a twosided")),
            other => {
                return Err(self.err(
                    node,
                    format!(
                        "the `{other}` BSDF is not supported (supported: diffuse, conductor, \
                         roughconductor, dielectric, roughdielectric, thindielectric, plastic, \
                         roughplastic, principled, principledthin, twosided, blendbsdf, mask, null, \
                         bumpmap, normalmap)"
                    ),
                ))
            }
        }
        self.leftovers(&p)?;
        if let Some(c) = node.children.iter().find(|c| c.attribute("name").is_none()) {
            return Err(self.err(c, "not supported inside a BSDF"));
        }
        // Mitsuba's opaque BSDFs are black from behind unless `twosided`; a
        // principled BSDF with a transmission lobe has an inside.
        let transmissive_principled = kind == "principled"
            && (t.get("spec_trans_map").is_some()
                || t.get("spec_trans")
                    .is_some_and(|v| v.as_float() != Some(0.0)));
        if opaque && !twosided && !transmissive_principled {
            set(&mut t, "two_sided", Value::Boolean(false));
        }
        Ok(t)
    }

    /// `diffuse`: plsr's diffuse, its reflectance a colour or a bitmap.
    pub(super) fn bsdf_diffuse(&mut self, p: &mut Params<'a>, t: &mut Table) -> Result<()> {
        set(t, "type", Value::String("diffuse".into()));
        match self
            .take_colour(p, "reflectance", SpectrumUse::Reflectance)?
            .unwrap_or(Colour::Rgb([0.5; 3]))
        {
            Colour::Rgb(v) => set(t, "reflectance", vec3(v)),
            Colour::Map(m) => set(t, "base_color_map", m),
        }
        Ok(())
    }

    /// `conductor` and `roughconductor`: Cook–Torrance with a conductor's
    /// Fresnel (a preset metal, or `eta` and `k`).
    pub(super) fn bsdf_conductor(
        &mut self,
        node: &'a Element,
        kind: &str,
        p: &mut Params<'a>,
        t: &mut Table,
    ) -> Result<()> {
        set(t, "type", Value::String("cook_torrance".into()));
        set(t, "fresnel", Value::String("conductor".into()));
        if kind == "conductor" {
            self.note(
                node,
                "a smooth conductor is rendered as GGX with α = 1e-4 (numerically a mirror)",
            );
            set(t, "alpha", float(0.0));
        } else {
            self.roughness(p, t, node, true)?;
        }
        let eta = self.take_rgb(p, "eta", SpectrumUse::Unbounded)?;
        let k = self.take_rgb(p, "k", SpectrumUse::Unbounded)?;
        let preset = self.take_string(p, "material")?;
        match (preset, eta, k) {
            (Some(_), Some(_), _) | (Some(_), _, Some(_)) => {
                return Err(self.err(node, "give `material` or `eta` and `k`, not both"))
            }
            (Some(m), None, None) => {
                if METAL_NAMES.contains(&m.as_str()) {
                    set(t, "metal", Value::String(m));
                } else if let Some((_, eta, k)) = CONDUCTORS.iter().find(|(n, _, _)| *n == m) {
                    // Mitsuba's other named conductors, as its RGB
                    // variants see them.
                    set(t, "eta", vec3(*eta));
                    set(t, "k", vec3(*k));
                } else {
                    return Err(self.err(
                        node,
                        format!("material `{m}` is not one of Mitsuba's named conductors"),
                    ));
                }
            }
            (None, None, None) => set(t, "metal", Value::String("none".into())),
            (None, eta, k) => {
                set(t, "eta", vec3(eta.unwrap_or([0.0; 3])));
                set(t, "k", vec3(k.unwrap_or([1.0; 3])));
            }
        }
        if let Some(s) = self.take_rgb(p, "specular_reflectance", SpectrumUse::Reflectance)? {
            set(t, "specular_reflectance", vec3(s));
        }
        Ok(())
    }

    /// `dielectric` and `roughdielectric`: plsr's dielectric of relative
    /// index `int_ior / ext_ior` (numbers or named materials).
    pub(super) fn bsdf_dielectric(
        &mut self,
        node: &'a Element,
        kind: &str,
        p: &mut Params<'a>,
        t: &mut Table,
    ) -> Result<()> {
        set(t, "type", Value::String("dielectric".into()));
        set(t, "ior", float(self.relative_ior(node, p)?));
        if kind == "roughdielectric" {
            self.roughness(p, t, node, true)?;
        }
        for s in ["specular_reflectance", "specular_transmittance"] {
            if let Some(v) = self.take_rgb(p, s, SpectrumUse::Reflectance)? {
                if v != [1.0; 3] {
                    return Err(self.err(node, format!("`{s}` other than 1 is not supported")));
                }
            }
        }
        Ok(())
    }

    /// `thindielectric`: plsr's `thin_dielectric` with `int_ior / ext_ior`
    /// and the two tints.
    pub(super) fn bsdf_thin_dielectric(
        &mut self,
        node: &'a Element,
        p: &mut Params<'a>,
        t: &mut Table,
    ) -> Result<()> {
        set(t, "type", Value::String("thin_dielectric".into()));
        set(t, "ior", float(self.relative_ior(node, p)?));
        for s in ["specular_reflectance", "specular_transmittance"] {
            if let Some(v) = self.take_rgb(p, s, SpectrumUse::Reflectance)? {
                set(t, s, vec3(v));
            }
        }
        Ok(())
    }

    /// `int_ior / ext_ior` of a dielectric (defaults bk7 inside, air
    /// outside), refused unless both are positive and they differ.
    fn relative_ior(&self, node: &'a Element, p: &mut Params<'a>) -> Result<f64> {
        let int_ior = self.ior(p, "int_ior", 1.5046)?;
        let ext_ior = self.ior(p, "ext_ior", 1.000277)?;
        if !(int_ior > 0.0 && ext_ior > 0.0) || int_ior == ext_ior {
            return Err(self.err(
                node,
                format!("int_ior {int_ior} and ext_ior {ext_ior} must be positive and differ"),
            ));
        }
        Ok(int_ior / ext_ior)
    }

    /// An index of refraction: a number or one of Mitsuba's named materials
    /// (`"bk7"`, `"water"`, …).
    fn ior(&self, p: &mut Params<'a>, name: &str, default: f64) -> Result<f64> {
        let Some(c) = self.take(p, name) else {
            return Ok(default);
        };
        match c.tag.as_str() {
            "float" => self.number(c, &self.required_attr(c, "value")?),
            "string" => {
                let v = self.required_attr(c, "value")?;
                NAMED_IORS
                    .iter()
                    .find(|(n, _)| *n == v)
                    .map(|(_, i)| *i)
                    .ok_or_else(|| self.err(c, format!("`{v}` is not a known material's index")))
            }
            _ => Err(self.err(c, format!("`{name}` must be a <float> or <string>"))),
        }
    }

    /// `plastic` and `roughplastic`: plsr's `plastic` and `rough_plastic`,
    /// with Mitsuba's parameters (the substrate's colour may be a texture).
    pub(super) fn bsdf_plastic(
        &mut self,
        node: &'a Element,
        kind: &str,
        p: &mut Params<'a>,
        t: &mut Table,
    ) -> Result<()> {
        let rough = kind == "roughplastic";
        set(
            t,
            "type",
            Value::String(if rough { "rough_plastic" } else { "plastic" }.into()),
        );
        match self.take_colour(p, "diffuse_reflectance", SpectrumUse::Reflectance)? {
            Some(Colour::Rgb(v)) => set(t, "diffuse_reflectance", vec3(v)),
            Some(Colour::Map(m)) => set(t, "base_color_map", m),
            None => {}
        }
        if let Some(v) = self.take_rgb(p, "specular_reflectance", SpectrumUse::Reflectance)? {
            set(t, "specular_reflectance", vec3(v));
        }
        let int_ior = self.ior(p, "int_ior", 1.49)?;
        let ext_ior = self.ior(p, "ext_ior", 1.000277)?;
        set(t, "int_ior", float(int_ior));
        set(t, "ext_ior", float(ext_ior));
        if let Some(n) = self.take_bool(p, "nonlinear")? {
            set(t, "nonlinear", Value::Boolean(n));
        }
        if rough {
            let d = self
                .take_string(p, "distribution")?
                .unwrap_or_else(|| "beckmann".into());
            if !matches!(d.as_str(), "ggx" | "beckmann") {
                return Err(self.err(node, format!("distribution `{d}` is not ggx or beckmann")));
            }
            set(t, "distribution", Value::String(d));
            if let Some(a) = self.take_float(p, "alpha")? {
                set(t, "alpha", float(a));
            }
            if let Some(v) = self.take_bool(p, "sample_visible")? {
                set(t, "sample_visible", Value::Boolean(v));
            }
        }
        Ok(())
    }

    /// `principled`: plsr's principled; the lobes plsr does not model must
    /// be 0.
    pub(super) fn bsdf_principled(
        &mut self,
        node: &'a Element,
        p: &mut Params<'a>,
        t: &mut Table,
    ) -> Result<()> {
        set(t, "type", Value::String("principled".into()));
        match self.take_colour(p, "base_color", SpectrumUse::Reflectance)? {
            Some(Colour::Rgb(v)) => set(t, "base_color", vec3(v)),
            Some(Colour::Map(m)) => set(t, "base_color_map", m),
            None => {}
        }
        for (name, map) in [("roughness", "roughness_map"), ("metallic", "metallic_map")] {
            match self.take_colour(p, name, SpectrumUse::Unbounded)? {
                Some(Colour::Rgb([a, b, c])) if a == b && b == c => set(t, name, float(a)),
                Some(Colour::Rgb(_)) => {
                    return Err(self.err(node, format!("`{name}` must be one number")))
                }
                Some(Colour::Map(m)) => {
                    self.note(
                        node,
                        format!("`{name}` texture: plsr reads its red channel"),
                    );
                    set(t, map, scalar_map(m))
                }
                None => {}
            }
        }
        for name in [
            "anisotropic",
            "specular",
            "spec_tint",
            "sheen",
            "sheen_tint",
            "clearcoat",
            "clearcoat_gloss",
            "spec_trans",
            "flatness",
        ] {
            self.take_weight(node, p, t, name)?;
        }
        if let Some(eta) = self.take_float(p, "eta")? {
            // Mitsuba: η given instead of `specular` (both is an error).
            if t.get("specular").is_some() || t.get("specular_map").is_some() {
                return Err(self.err(node, "give one of `eta` and `specular`, as Mitsuba asks"));
            }
            set(t, "eta", float(eta));
        }
        self.note_sampling_rates(
            node,
            p,
            &[
                "main_specular_sampling_rate",
                "clearcoat_sampling_rate",
                "diffuse_reflectance_sampling_rate",
            ],
        )
    }

    /// Mitsuba's lobe sampling rates among `names`: plsr draws the lobes at
    /// rate 1, which changes the noise, not the image (a note for any other
    /// rate).
    fn note_sampling_rates(
        &mut self,
        node: &'a Element,
        p: &mut Params<'a>,
        names: &[&str],
    ) -> Result<()> {
        for name in names {
            if let Some(v) = self.take_float(p, name)? {
                if v != 1.0 {
                    self.note(
                        node,
                        format!(
                            "`{name}` = {v}: plsr picks the lobes by their weights (rate 1); \
                             the image is the same, its noise differs"
                        ),
                    );
                }
            }
        }
        Ok(())
    }

    /// `principledthin`: plsr's `principled_thin`, every parameter a number
    /// or (the weights) a texture; its sampling rates are Mitsuba's defaults.
    pub(super) fn bsdf_principled_thin(
        &mut self,
        node: &'a Element,
        p: &mut Params<'a>,
        t: &mut Table,
    ) -> Result<()> {
        set(t, "type", Value::String("principled_thin".into()));
        match self.take_colour(p, "base_color", SpectrumUse::Reflectance)? {
            Some(Colour::Rgb(v)) => set(t, "base_color", vec3(v)),
            Some(Colour::Map(m)) => set(t, "base_color_map", m),
            None => {}
        }
        match self.take_colour(p, "roughness", SpectrumUse::Unbounded)? {
            Some(Colour::Rgb([a, b, c])) if a == b && b == c => set(t, "roughness", float(a)),
            Some(Colour::Rgb(_)) => return Err(self.err(node, "`roughness` must be one number")),
            Some(Colour::Map(m)) => {
                self.note(node, "`roughness` texture: plsr reads its red channel");
                set(t, "roughness_map", scalar_map(m))
            }
            None => {}
        }
        for name in [
            "anisotropic",
            "spec_trans",
            "spec_tint",
            "sheen",
            "sheen_tint",
            "flatness",
        ] {
            self.take_weight(node, p, t, name)?;
        }
        for name in ["eta", "diff_trans"] {
            if let Some(v) = self.take_float(p, name)? {
                set(t, name, float(v));
            }
        }
        self.note_sampling_rates(
            node,
            p,
            &[
                "diffuse_reflectance_sampling_rate",
                "specular_reflectance_sampling_rate",
                "specular_transmittance_sampling_rate",
                "diffuse_transmittance_sampling_rate",
            ],
        )
    }

    /// A principled weight: a number as `name`, a texture as `name_map`
    /// (read by its luminance, as Mitsuba reads it).
    fn take_weight(
        &mut self,
        node: &'a Element,
        p: &mut Params<'a>,
        t: &mut Table,
        name: &str,
    ) -> Result<()> {
        match self.take_colour(p, name, SpectrumUse::Unbounded)? {
            Some(Colour::Rgb([a, b, c])) if a == b && b == c => set(t, name, float(a)),
            Some(Colour::Rgb(_)) => {
                return Err(self.err(node, format!("`{name}` must be one number")))
            }
            Some(Colour::Map(m)) => set(t, &format!("{name}_map"), scalar_map(m)),
            None => {}
        }
        Ok(())
    }

    /// `distribution` and `alpha` / `alpha_u`, `alpha_v` (Mitsuba's default:
    /// Beckmann, α 0.1).
    pub(super) fn roughness(
        &self,
        p: &mut Params<'a>,
        t: &mut Table,
        node: &Element,
        maps: bool,
    ) -> Result<()> {
        let d = self
            .take_string(p, "distribution")?
            .unwrap_or_else(|| "beckmann".into());
        if !matches!(d.as_str(), "ggx" | "beckmann") {
            return Err(self.err(node, format!("distribution `{d}` is not ggx or beckmann")));
        }
        t.insert("distribution", Value::String(d));
        // Each α a number or (where `maps`) a texture, as plsr's
        // `alpha_map`, `alpha_u_map` and `alpha_v_map`.
        let mut take = |name: &str| -> Result<Option<Result<f64, Value>>> {
            let Some(e) = self.take(p, name) else {
                return Ok(None);
            };
            let e = self.deref(e)?;
            if e.tag == "texture" {
                if !maps {
                    return Err(self.err(e, format!("`{name}` of this BSDF must be a <float>")));
                }
                return match self.colour_of(e, SpectrumUse::Unbounded)? {
                    Colour::Map(m) => Ok(Some(Err(scalar_map(m)))),
                    Colour::Rgb(v) => Ok(Some(Ok((v[0] + v[1] + v[2]) / 3.0))),
                };
            }
            let v = self.required_attr(e, "value")?;
            Ok(Some(Ok(self.number(e, &v)?)))
        };
        let alpha = take("alpha")?;
        let u = take("alpha_u")?;
        let v = take("alpha_v")?;
        let mut put = |key: &str, a: Result<f64, Value>| match a {
            Ok(x) => {
                t.insert(key, float(x));
            }
            Err(m) => {
                t.insert(format!("{key}_map"), m);
            }
        };
        match (alpha, u, v) {
            (Some(_), Some(_), _) | (Some(_), _, Some(_)) => {
                return Err(self.err(node, "give alpha or alpha_u with alpha_v, not both"))
            }
            (_, Some(u), Some(v)) => {
                // plsr pairs constants with constants and maps with maps.
                match (u, v) {
                    (Ok(u), Ok(v)) => {
                        put("alpha_u", Ok(u));
                        put("alpha_v", Ok(v));
                    }
                    (Err(u), Err(v)) => {
                        put("alpha_u", Err(u));
                        put("alpha_v", Err(v));
                    }
                    _ => {
                        return Err(self.err(
                            node,
                            "alpha_u and alpha_v: both numbers or both textures in plsr",
                        ))
                    }
                }
            }
            (_, Some(_), None) | (_, None, Some(_)) => {
                return Err(self.err(node, "alpha_u and alpha_v go together"))
            }
            (a, None, None) => put("alpha", a.unwrap_or(Ok(0.1))),
        }
        Ok(())
    }
}

/// A map that Mitsuba reads as a scalar (`eval_1`: blend weights,
/// opacities, roughness): a `checkerboard`'s scalar lookup takes `color1`
/// where its colour lookup takes `color0` and the other way round (Mitsuba
/// 3's `checkerboard` tests the squares' parity the other way in
/// `eval_1`), so its two values are swapped to land where Mitsuba puts
/// them.
fn scalar_map(map: Value) -> Value {
    match map {
        Value::Table(mut t) => {
            if let Some(Value::Array(colours)) = t.get_mut("checkerboard") {
                colours.reverse();
            }
            Value::Table(t)
        }
        other => other,
    }
}
