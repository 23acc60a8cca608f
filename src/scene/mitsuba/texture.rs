//! Colours and textures: `<rgb>`, `<spectrum>`, `<float>` and the texture
//! plugins, as a plsr material's constants and maps.

use super::document::Element;
use super::spectrum::{self, SpectrumError, SpectrumUse};
use super::table::{string, vec3};
use super::translator::{Params, Translator};
use crate::error::Result;

/// A colour parameter: a constant, or a texture as a plsr `*_map` value
/// (an image's file name, or a table).
pub(super) enum Colour {
    Rgb([f64; 3]),
    Map(toml::Value),
}

impl<'a> Translator<'a> {
    /// A colour element: `<rgb>`, a `<spectrum>` (one value, wavelength:value
    /// pairs, a file, a blackbody), a `<float>`, or a `bitmap` texture
    /// (nested or by `<ref>`), converted to linear sRGB as Mitsuba's RGB
    /// variants convert it for a parameter of kind `usage`.
    pub(super) fn colour_of(&self, c: &'a Element, usage: SpectrumUse) -> Result<Colour> {
        let fault = |e: SpectrumError| self.err(c, e.to_string());
        match c.tag.as_str() {
            "rgb" => {
                let v = self.triple(c, true, 0.0)?;
                Ok(Colour::Rgb(spectrum::rgb_to_rgb(v, usage).map_err(fault)?))
            }
            "float" | "integer" => {
                let v = self.required_attr(c, "value")?;
                Ok(Colour::Rgb(spectrum::float_to_rgb(
                    self.number(c, &v)?,
                    usage,
                )))
            }
            "spectrum" => self.spectrum(c, usage).map(Colour::Rgb),
            "texture" => self.texture(c, usage),
            "ref" => self.colour_of(self.deref(c)?, usage),
            other => Err(self.err(c, format!("<{other}> is not a colour"))),
        }
    }

    /// A `<texture>`: `bitmap` (`filename`, `filter_type`, `wrap_mode`,
    /// `raw`, `to_uv`), `checkerboard` (`color0`, `color1`, `to_uv`) or
    /// `mesh_attribute` (`name`), as a plsr map: the file name alone where
    /// Mitsuba's defaults hold, else a table.
    fn texture(&self, c: &'a Element, usage: SpectrumUse) -> Result<Colour> {
        let kind = self.required_attr(c, "type")?;
        let mut p = self.params(c)?;
        let mut map = toml::Table::new();
        match kind.as_str() {
            "bitmap" => {
                let file = self
                    .take_string(&mut p, "filename")?
                    .ok_or_else(|| self.err(c, "a bitmap needs `filename`"))?;
                map.insert("file".into(), string(self.file_name(c, file)));
                match self.take_string(&mut p, "filter_type")?.as_deref() {
                    None | Some("bilinear") => {}
                    Some("nearest") => {
                        map.insert("filter".into(), string("nearest"));
                    }
                    Some(o) => {
                        return Err(
                            self.err(c, format!("filter_type `{o}` is not bilinear or nearest"))
                        )
                    }
                }
                match self.take_string(&mut p, "wrap_mode")?.as_deref() {
                    None | Some("repeat") => {}
                    Some(w @ ("mirror" | "clamp")) => {
                        map.insert("wrap".into(), string(w));
                    }
                    Some(o) => {
                        return Err(
                            self.err(c, format!("wrap_mode `{o}` is not repeat, mirror or clamp"))
                        )
                    }
                }
                // Mitsuba decodes 8-bit images from sRGB unless `raw`; plsr
                // decodes colour maps and not data maps unless told.
                let raw = self.take_bool(&mut p, "raw")?.unwrap_or(false);
                match (raw, usage) {
                    (true, SpectrumUse::Reflectance | SpectrumUse::Emission) => {
                        map.insert("encoding".into(), string("linear"));
                    }
                    (false, SpectrumUse::Unbounded) => {
                        map.insert("encoding".into(), string("srgb"));
                    }
                    _ => {}
                }
                self.take(&mut p, "format");
            }
            "checkerboard" => {
                let mut colour = |name: &str, default: f64| -> Result<toml::Value> {
                    match self.take_colour(&mut p, name, usage)? {
                        None => Ok(vec3([default; 3])),
                        Some(Colour::Rgb(v)) => Ok(vec3(v)),
                        Some(Colour::Map(_)) => Err(self.err(
                            c,
                            format!("`{name}` of a checkerboard must be a constant in plsr"),
                        )),
                    }
                };
                let (c0, c1) = (colour("color0", 0.4)?, colour("color1", 0.2)?);
                map.insert("checkerboard".into(), toml::Value::Array(vec![c0, c1]));
            }
            "mesh_attribute" => {
                let name = self
                    .take_string(&mut p, "name")?
                    .ok_or_else(|| self.err(c, "a mesh_attribute needs `name`"))?;
                if !(name.starts_with("vertex_") || name.starts_with("face_")) {
                    return Err(self.err(
                        c,
                        format!("mesh_attribute `{name}`: the name must start with vertex_ or face_"),
                    ));
                }
                if usage != SpectrumUse::Reflectance {
                    return Err(self.err(
                        c,
                        "a mesh_attribute gives plsr a reflectance (a base colour) only",
                    ));
                }
                if let Some(s) = self.take_float(&mut p, "scale")? {
                    if s != 1.0 {
                        return Err(self.err(
                            c,
                            format!("mesh_attribute `scale` {s}: plsr takes the colours as stored (scale 1)"),
                        ));
                    }
                }
                self.leftovers(&p)?;
                map.insert("attribute".into(), string(name));
                return Ok(Colour::Map(toml::Value::Table(map)));
            }
            other => {
                return Err(self.err(
                    c,
                    format!(
                        "texture type `{other}` is not supported (supported: bitmap, checkerboard, mesh_attribute)"
                    ),
                ))
            }
        }
        let image = kind == "bitmap";
        match self.take_transform(&mut p, "to_uv")? {
            Some(m) => {
                map.insert("to_uv".into(), to_uv(&m, image));
            }
            // The identity, which for a checkerboard is still a flip.
            None if !image => {
                map.insert("to_uv".into(), to_uv(&glam::DMat4::IDENTITY, image));
            }
            None => {}
        }
        self.leftovers(&p)?;
        if map.len() == 1 && map.contains_key("file") {
            return Ok(Colour::Map(
                map.remove("file").unwrap_or(toml::Value::Boolean(false)),
            ));
        }
        Ok(Colour::Map(toml::Value::Table(map)))
    }

    /// A `<spectrum>`: `value` (one number or wavelength:value pairs),
    /// `filename` (an `.spd` file of wavelength and value lines), or
    /// `type="blackbody"` with its `temperature` (kelvin; emitters only).
    fn spectrum(&self, c: &'a Element, usage: SpectrumUse) -> Result<[f64; 3]> {
        let fault = |e: SpectrumError| self.err(c, e.to_string());
        if let Some(kind) = c.attribute("type") {
            if kind != "blackbody" {
                return Err(self.err(
                    c,
                    format!("spectrum type `{kind}` is not supported (supported: blackbody)"),
                ));
            }
            if usage != SpectrumUse::Emission {
                return Err(self.err(c, "a blackbody spectrum is an emitter's, not a reflectance"));
            }
            let mut p = self.params(c)?;
            let t = self
                .take_float(&mut p, "temperature")?
                .ok_or_else(|| self.err(c, "a blackbody needs `temperature` (kelvin)"))?;
            self.leftovers(&p)?;
            return spectrum::blackbody_to_rgb(t).map_err(fault);
        }
        match (c.attribute("value"), c.attribute("filename")) {
            (Some(v), None) => spectrum::parse_spectrum_value(v)
                .and_then(|s| s.to_rgb(usage))
                .map_err(fault),
            (None, Some(name)) => {
                let path = self.doc.base_path(&self.file_name(c, name.to_string()));
                let text = read_small_text(&path, 16 << 20).map_err(|m| self.err(c, m))?;
                let (w, v) = spectrum::parse_spd_file(&text)
                    .map_err(|e| self.err(c, format!("{}: {e}", path.display())))?;
                spectrum::sampled_to_rgb(&w, &v, usage).map_err(fault)
            }
            _ => Err(self.err(c, "a <spectrum> needs `value` or `filename` (one of them)")),
        }
    }

    /// The colour parameter `name` of kind `usage`.
    pub(super) fn take_colour(
        &self,
        p: &mut Params<'a>,
        name: &str,
        usage: SpectrumUse,
    ) -> Result<Option<Colour>> {
        match self.take(p, name) {
            Some(c) => self.colour_of(c, usage).map(Some),
            None => Ok(None),
        }
    }

    /// Like [`Self::take_colour`], for parameters plsr takes as a constant.
    pub(super) fn take_rgb(
        &self,
        p: &mut Params<'a>,
        name: &str,
        usage: SpectrumUse,
    ) -> Result<Option<[f64; 3]>> {
        match self.take_colour(p, name, usage)? {
            Some(Colour::Rgb(v)) => Ok(Some(v)),
            Some(Colour::Map(_)) => Err(self.err(
                self.take(p, name).unwrap_or(p.node),
                format!("`{name}` cannot be a texture in plsr: give a constant"),
            )),
            None => Ok(None),
        }
    }
}

/// The text of a small file (at most `limit` bytes), or a message.
fn read_small_text(path: &std::path::Path, limit: u64) -> std::result::Result<String, String> {
    let size = std::fs::metadata(path)
        .map_err(|e| format!("{}: {e}", path.display()))?
        .len();
    if size > limit {
        return Err(format!(
            "{}: {size} bytes, more than a spectrum file may hold ({limit})",
            path.display()
        ));
    }
    crate::input::read_text_lenient(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// Mitsuba's `to_uv` `T` (the 2D affine part of a `<transform>`: rows x
/// and y, columns u, v and the translation) as plsr's `to_uv`. Translated
/// shapes have `flip_v`, so that their `v` is `1 − v` of Mitsuba's: with
/// `F(u, v) = (u, 1 − v)`, a checkerboard (a formula of the looked-up
/// point, the same in both) needs `T ∘ F`; an image, whose rows Mitsuba
/// counts down from `v = 0` and plsr up from `v = 0`, `F ∘ T ∘ F`.
fn to_uv(m: &glam::DMat4, image: bool) -> toml::Value {
    let e = |i: usize, j: usize| m.col(j)[i];
    let (a, b, c) = (e(0, 0), e(0, 1), e(0, 3));
    let (d, e_, f) = (e(1, 0), e(1, 1), e(1, 3));
    let row = |r: [f64; 3]| toml::Value::Array(r.iter().map(|&x| toml::Value::Float(x)).collect());
    let rows = if image {
        [[a, -b, b + c], [-d, e_, 1.0 - e_ - f]]
    } else {
        [[a, -b, b + c], [d, -e_, e_ + f]]
    };
    toml::Value::Array(rows.into_iter().map(row).collect())
}
