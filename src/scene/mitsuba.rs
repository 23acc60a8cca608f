//! Mitsuba 3 XML scenes, translated into plsr's scene format.
//!
//! [`translate`] reads the subset of Mitsuba 3's XML that plsr can express
//! and writes the equivalent plsr scene as TOML, which the scene-file
//! reader then builds as it builds any other: `plsr render scene.xml`
//! works, and `plsr import scene.xml -o scene.toml` shows (and keeps) the
//! translation. Every element or parameter outside the subset is an error
//! naming it and its line; where plsr only approximates Mitsuba (a smooth
//! conductor, a pixel filter), the translation carries a note.
//!
//! The subset: shapes `obj`, `ply`, `rectangle`, `sphere`, `disk`, `cube`
//! (with `to_world`, a BSDF by reference or nested, an `area` emitter);
//! BSDFs `diffuse`, `roughconductor`, `conductor`, `roughdielectric`,
//! `dielectric`, `principled`, `twosided`; emitters `point`, `envmap`,
//! `constant`; a `perspective` or `thinlens` sensor with its `hdrfilm`,
//! pixel filter and sampler; the `path` integrator; `<default>` values and
//! their `$name` references. Conventions converted:
//! - depth: Mitsuba's `max_depth` counts path segments including the camera
//!   ray, plsr's counts scattering events: plsr's = Mitsuba's − 1 (and
//!   likewise `rr_depth`); Mitsuba's `-1` (unlimited) becomes 1024;
//! - defaults: Mitsuba's (a `diffuse` 0.5 grey for shapes without a BSDF, a
//!   Gaussian pixel filter, `beckmann` roughness 0.1, 768 × 576 pixels,
//!   4 samples per pixel, horizontal field of view) are written out;
//! - the camera looks along its `to_world`'s +z with +y up, as plsr's
//!   `look_at` and `up`; an environment map's `to_world` maps Mitsuba's
//!   +y (zenith) and +z (image centre) to plsr's `up` and `forward`.

use crate::error::{Error, Result};
use glam::{DMat4, DVec3, DVec4};
use plsr_base::Vocabulary;
use roxmltree::{Document, Node};
use std::collections::{HashMap, HashSet};
use std::path::Path;
use toml::Value;

/// A TOML table that keeps its keys in the order they were set (so that
/// the translation reads like a hand-written scene: `type` first).
#[derive(Debug, Clone, Default)]
struct Table(Vec<(String, Value)>);

impl Table {
    fn new() -> Table {
        Table::default()
    }

    fn insert(&mut self, key: String, value: Value) {
        match self.0.iter_mut().find(|(k, _)| *k == key) {
            Some((_, v)) => *v = value,
            None => self.0.push((key, value)),
        }
    }

    fn get(&self, key: &str) -> Option<&Value> {
        self.0.iter().find(|(k, _)| k == key).map(|(_, v)| v)
    }

    fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The table's `key = value` lines (keys are bare; nested arrays one
    /// row per line).
    fn write(&self, out: &mut String) {
        for (k, v) in &self.0 {
            match v {
                Value::Array(rows) if rows.iter().all(|r| r.is_array()) && !rows.is_empty() => {
                    out.push_str(&format!("{k} = [\n"));
                    for r in rows {
                        out.push_str(&format!("    {r},\n"));
                    }
                    out.push_str("]\n");
                }
                v => out.push_str(&format!("{k} = {v}\n")),
            }
        }
    }
}

/// A translated scene: plsr's TOML, and what was approximated.
#[derive(Debug, Clone)]
pub struct Translation {
    /// The scene in plsr's format (paths as the XML gave them, relative to
    /// the XML file's folder).
    pub toml: String,
    /// One line per approximation, naming the element and its line.
    pub notes: Vec<String>,
}

/// Whether `path`'s name or `text`'s first characters say it is XML.
pub fn looks_like_xml(path: &Path, text: &[u8]) -> bool {
    let start = text
        .strip_prefix(b"\xef\xbb\xbf".as_slice())
        .unwrap_or(text)
        .trim_ascii_start();
    start.starts_with(b"<")
        || path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("xml"))
}

/// Translates the Mitsuba 3 scene `text` (read from `path`, which errors
/// name) into plsr's scene format. File names stay as the XML gives them,
/// relative to its folder.
pub fn translate(path: &Path, text: &str) -> Result<Translation> {
    translate_into(path, text, None)
}

/// [`translate`] for a scene file to be written into the folder `out_dir`:
/// relative file names are rewritten to name the same files from there
/// (absolute if `out_dir` is another folder).
pub fn translate_for(path: &Path, text: &str, out_dir: &Path) -> Result<Translation> {
    let here = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let same = match (std::fs::canonicalize(here), std::fs::canonicalize(out_dir)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    if same {
        return translate_into(path, text, None);
    }
    let base =
        std::fs::canonicalize(here).map_err(|source| Error::io(here.to_path_buf(), source))?;
    translate_into(path, text, Some(base))
}

fn translate_into(
    path: &Path,
    text: &str,
    rebase: Option<std::path::PathBuf>,
) -> Result<Translation> {
    // XML allows nothing before its declaration; be lenient with a byte
    // order mark and blank lines, and count the lines skipped.
    let body = text.strip_prefix('\u{feff}').unwrap_or(text);
    let trimmed = body.trim_start();
    let skipped_lines = body[..body.len() - trimmed.len()].matches('\n').count() as u32;
    let doc = Document::parse(trimmed).map_err(|e| {
        Error::input(
            path,
            "",
            format!("not well-formed XML (a Mitsuba 3 scene was expected): {e}"),
        )
    })?;
    let root = doc.root_element();
    let mut t = Translator {
        file: path,
        rebase,
        skipped_lines,
        doc: &doc,
        defaults: HashMap::new(),
        ids: HashMap::new(),
        materials: Vec::new(),
        material_names: HashMap::new(),
        shapes: Vec::new(),
        lights: Vec::new(),
        environment: None,
        render: Table::new(),
        camera: None,
        film: Table::new(),
        notes: Vec::new(),
        noted: HashSet::new(),
    };
    if root.tag_name().name() != "scene" {
        return Err(Error::input(
            path,
            "",
            format!(
                "unsupported scene format: XML whose root element is <{}>, not a Mitsuba 3 \
                 <scene>; plsr reads TOML scene files, JSON with the same schema, or \
                 Mitsuba 3 XML (see docs/scene-format.md)",
                tag(root)
            ),
        ));
    }
    if let Some(v) = root.attribute("version") {
        if !v.starts_with("3.") && !v.starts_with("2.") {
            t.note(
                root,
                format!("scene version {v}: read as Mitsuba 3 (plsr knows Mitsuba 3's plugins)"),
            );
        }
    }
    t.scene(root)?;
    Ok(Translation {
        toml: t.finish(),
        notes: t.notes,
    })
}

/// Mitsuba's field of view without `fov` or `focal_length`: its default
/// 50 mm lens, `2·atan(18/50)`, horizontal.
const DEFAULT_HFOV_DEG: f64 = 39.597_752_709_049_864;

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

/// Mitsuba's plugin parameters that change nothing plsr renders.
const IGNORED: [&str; 9] = [
    "near_clip",
    "far_clip",
    "pixel_format",
    "component_format",
    "file_format",
    "sample_visible",
    "banner",
    "rfilter_radius_scale",
    "shutter_open",
];

struct Translator<'a, 'input> {
    file: &'a Path,
    /// The XML's folder, to make relative file names absolute with.
    rebase: Option<std::path::PathBuf>,
    /// Blank lines before the XML, not given to the parser.
    skipped_lines: u32,
    doc: &'a Document<'input>,
    defaults: HashMap<String, String>,
    /// Elements with an `id` (BSDFs, textures), by id.
    ids: HashMap<String, Node<'a, 'input>>,
    materials: Vec<Table>,
    /// plsr material names, by the BSDF element's position in the file.
    material_names: HashMap<usize, String>,
    shapes: Vec<Table>,
    lights: Vec<Table>,
    environment: Option<Table>,
    render: Table,
    camera: Option<Table>,
    film: Table,
    notes: Vec<String>,
    noted: HashSet<String>,
}

/// A colour parameter: a constant or a bitmap texture.
enum Colour {
    Rgb([f64; 3]),
    Bitmap(String),
}

/// The parameters of one plugin element, consumed one by one so that
/// those left over can be reported.
struct Params<'a, 'input> {
    node: Node<'a, 'input>,
    /// Named children (`<float name="alpha" …>`), by name.
    named: Vec<(String, Node<'a, 'input>)>,
    used: HashSet<String>,
}

fn tag<'a>(node: Node<'a, '_>) -> &'a str {
    node.tag_name().name()
}

fn float(v: f64) -> Value {
    Value::Float(v)
}

fn vec3(v: [f64; 3]) -> Value {
    Value::Array(v.iter().map(|&x| float(x)).collect())
}

fn dvec(v: DVec3) -> Value {
    vec3(v.to_array())
}

impl<'a, 'input> Translator<'a, 'input> {
    /// The line of the file at byte `at` of the parsed text.
    fn line(&self, at: usize) -> u32 {
        self.doc.text_pos_at(at).row + self.skipped_lines
    }

    /// Where `node` is: its line and its start tag.
    fn at(&self, node: Node) -> String {
        let mut s = format!("line {}, <{}", self.line(node.range().start), tag(node));
        for a in ["type", "name", "id"] {
            if let Some(v) = node.attribute(a) {
                s.push_str(&format!(" {a}=\"{v}\""));
            }
        }
        s.push('>');
        s
    }

    fn err(&self, node: Node, message: impl Into<String>) -> Error {
        Error::input(self.file, self.at(node), message)
    }

    fn note(&mut self, node: Node, message: impl Into<String>) {
        let message = message.into();
        if self.noted.insert(message.clone()) {
            let at = self.at(node);
            self.notes.push(format!("{at}: {message}"));
        }
    }

    /// Attribute `name` of `node`, with `$default` references replaced.
    fn attr(&self, node: Node, name: &str) -> Result<Option<String>> {
        let Some(raw) = node.attribute(name) else {
            return Ok(None);
        };
        if !raw.contains('$') {
            return Ok(Some(raw.to_string()));
        }
        let mut out = String::new();
        let mut rest = raw;
        while let Some(i) = rest.find('$') {
            out.push_str(&rest[..i]);
            let after = &rest[i + 1..];
            let len = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            let key = &after[..len];
            let value = self.defaults.get(key).ok_or_else(|| {
                self.err(
                    node,
                    format!(
                        "`${key}` in {name}=\"{raw}\" has no <default name=\"{key}\" …> \
                         before it"
                    ),
                )
            })?;
            out.push_str(value);
            rest = &after[len..];
        }
        out.push_str(rest);
        Ok(Some(out))
    }

    fn required_attr(&self, node: Node, name: &str) -> Result<String> {
        self.attr(node, name)?
            .ok_or_else(|| self.err(node, format!("the attribute `{name}` is required")))
    }

    fn number(&self, node: Node, text: &str) -> Result<f64> {
        text.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| self.err(node, format!("`{text}` is not a finite number")))
    }

    /// A list of numbers, separated by commas and/or spaces.
    fn numbers(&self, node: Node, text: &str) -> Result<Vec<f64>> {
        text.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|s| !s.is_empty())
            .map(|s| self.number(node, s))
            .collect()
    }

    /// A 3-vector from `value="x, y, z"` (or one number for all three, if
    /// `splat`) or from `x`, `y`, `z` attributes (missing ones `missing`).
    fn triple(&self, node: Node, splat: bool, missing: f64) -> Result<[f64; 3]> {
        if let Some(v) = self.attr(node, "value")? {
            let n = self.numbers(node, &v)?;
            return match n.len() {
                3 => Ok([n[0], n[1], n[2]]),
                1 if splat => Ok([n[0]; 3]),
                _ => Err(self.err(
                    node,
                    format!(
                        "value=\"{v}\" must be three numbers{}",
                        if splat { " or one" } else { "" }
                    ),
                )),
            };
        }
        let mut out = [missing; 3];
        for (i, a) in ["x", "y", "z"].iter().enumerate() {
            if let Some(v) = self.attr(node, a)? {
                out[i] = self.number(node, &v)?;
            }
        }
        Ok(out)
    }

    fn params(&self, node: Node<'a, 'input>) -> Result<Params<'a, 'input>> {
        let mut named = Vec::new();
        for c in node.children().filter(|c| c.is_element()) {
            if let Some(name) = c.attribute("name") {
                if named.iter().any(|(n, _)| n == name) {
                    return Err(self.err(c, format!("`{name}` is given twice")));
                }
                named.push((name.to_string(), c));
            }
        }
        Ok(Params {
            node,
            named,
            used: HashSet::new(),
        })
    }

    fn take<'p>(&self, p: &'p mut Params<'a, 'input>, name: &str) -> Option<Node<'a, 'input>> {
        let node = p.named.iter().find(|(n, _)| n == name).map(|(_, c)| *c);
        if node.is_some() {
            p.used.insert(name.to_string());
        }
        node
    }

    fn take_float(&self, p: &mut Params<'a, 'input>, name: &str) -> Result<Option<f64>> {
        let Some(c) = self.take(p, name) else {
            return Ok(None);
        };
        match tag(c) {
            "float" | "integer" => {
                let v = self.required_attr(c, "value")?;
                Ok(Some(self.number(c, &v)?))
            }
            "spectrum" | "rgb" => match self.colour_of(c)? {
                Colour::Rgb([a, b, d]) if a == b && b == d => Ok(Some(a)),
                _ => Err(self.err(c, format!("`{name}` must be one number here"))),
            },
            other => Err(self.err(c, format!("`{name}` must be a <float>, not <{other}>"))),
        }
    }

    fn take_int(&self, p: &mut Params<'a, 'input>, name: &str) -> Result<Option<i64>> {
        let Some(c) = self.take(p, name) else {
            return Ok(None);
        };
        if tag(c) != "integer" {
            return Err(self.err(c, format!("`{name}` must be an <integer>")));
        }
        let v = self.required_attr(c, "value")?;
        v.trim()
            .parse::<i64>()
            .map(Some)
            .map_err(|_| self.err(c, format!("`{v}` is not an integer")))
    }

    fn take_bool(&self, p: &mut Params<'a, 'input>, name: &str) -> Result<Option<bool>> {
        let Some(c) = self.take(p, name) else {
            return Ok(None);
        };
        if tag(c) != "boolean" {
            return Err(self.err(c, format!("`{name}` must be a <boolean>")));
        }
        match self.required_attr(c, "value")?.as_str() {
            "true" => Ok(Some(true)),
            "false" => Ok(Some(false)),
            other => Err(self.err(c, format!("`{other}` is not true or false"))),
        }
    }

    /// A file name from the XML, as the translated scene must give it.
    fn file_name(&self, name: String) -> String {
        match &self.rebase {
            Some(base) if Path::new(&name).is_relative() => {
                base.join(&name).to_string_lossy().into_owned()
            }
            _ => name,
        }
    }

    fn take_string(&self, p: &mut Params<'a, 'input>, name: &str) -> Result<Option<String>> {
        let Some(c) = self.take(p, name) else {
            return Ok(None);
        };
        if tag(c) != "string" {
            return Err(self.err(c, format!("`{name}` must be a <string>")));
        }
        self.required_attr(c, "value").map(Some)
    }

    fn take_point(&self, p: &mut Params<'a, 'input>, name: &str) -> Result<Option<[f64; 3]>> {
        let Some(c) = self.take(p, name) else {
            return Ok(None);
        };
        if !matches!(tag(c), "point" | "vector") {
            return Err(self.err(c, format!("`{name}` must be a <point>")));
        }
        self.triple(c, false, 0.0).map(Some)
    }

    /// A colour element: `<rgb>`, a constant `<spectrum>`, a `<float>`, or
    /// a `bitmap` texture (nested or by `<ref>`).
    fn colour_of(&self, c: Node<'a, 'input>) -> Result<Colour> {
        match tag(c) {
            "rgb" => {
                let v = self.triple(c, true, 0.0)?;
                Ok(Colour::Rgb(v))
            }
            "float" => {
                let v = self.required_attr(c, "value")?;
                Ok(Colour::Rgb([self.number(c, &v)?; 3]))
            }
            "spectrum" => {
                if c.attribute("filename").is_some() {
                    return Err(self.err(c, "spectra from files are not supported: give <rgb>"));
                }
                let v = self.required_attr(c, "value")?;
                if v.contains(':') {
                    return Err(self.err(
                        c,
                        "sampled spectra (wavelength:value pairs) are not supported: \
                         plsr renders in RGB; give <rgb>",
                    ));
                }
                Ok(Colour::Rgb([self.number(c, &v)?; 3]))
            }
            "texture" => {
                let kind = self.required_attr(c, "type")?;
                if kind != "bitmap" {
                    return Err(self.err(
                        c,
                        format!("texture type `{kind}` is not supported (supported: bitmap)"),
                    ));
                }
                let mut p = self.params(c)?;
                let file = self
                    .take_string(&mut p, "filename")?
                    .ok_or_else(|| self.err(c, "a bitmap needs `filename`"))?;
                for ignored in ["filter_type", "wrap_mode"] {
                    self.take(&mut p, ignored);
                }
                if let Some(raw) = self.take_bool(&mut p, "raw")? {
                    if raw {
                        return Err(self.err(
                            c,
                            "raw = true (linear texels) is not supported for colour maps: \
                             plsr decodes them as sRGB",
                        ));
                    }
                }
                self.leftovers(&p)?;
                Ok(Colour::Bitmap(self.file_name(file)))
            }
            "ref" => {
                let id = self.required_attr(c, "id")?;
                let target = *self
                    .ids
                    .get(&id)
                    .ok_or_else(|| self.err(c, format!("no element with id=\"{id}\" before it")))?;
                self.colour_of(target)
            }
            other => Err(self.err(c, format!("<{other}> is not a colour"))),
        }
    }

    fn take_colour(&self, p: &mut Params<'a, 'input>, name: &str) -> Result<Option<Colour>> {
        match self.take(p, name) {
            Some(c) => self.colour_of(c).map(Some),
            None => Ok(None),
        }
    }

    /// Like [`Self::take_colour`], for parameters plsr takes as a constant.
    fn take_rgb(&self, p: &mut Params<'a, 'input>, name: &str) -> Result<Option<[f64; 3]>> {
        match self.take_colour(p, name)? {
            Some(Colour::Rgb(v)) => Ok(Some(v)),
            Some(Colour::Bitmap(_)) => Err(self.err(
                self.take(p, name).unwrap_or(p.node),
                format!("`{name}` cannot be a texture in plsr: give a constant"),
            )),
            None => Ok(None),
        }
    }

    fn take_transform(&self, p: &mut Params<'a, 'input>, name: &str) -> Result<Option<DMat4>> {
        let Some(c) = self.take(p, name) else {
            return Ok(None);
        };
        if tag(c) != "transform" {
            return Err(self.err(c, format!("`{name}` must be a <transform>")));
        }
        self.transform(c).map(Some)
    }

    /// A `<transform>`: its operations in order, each applied after the
    /// ones before it.
    fn transform(&self, node: Node) -> Result<DMat4> {
        let mut m = DMat4::IDENTITY;
        for c in node.children().filter(|c| c.is_element()) {
            let op = match tag(c) {
                "translate" => DMat4::from_translation(DVec3::from(self.triple(c, false, 0.0)?)),
                "scale" => {
                    let s = self.triple(c, true, 1.0)?;
                    DMat4::from_scale(DVec3::from(s))
                }
                "rotate" => {
                    let axis = DVec3::from(self.triple(c, false, 0.0)?);
                    let angle = self.number(c, &self.required_attr(c, "angle")?)?;
                    if axis.length_squared() == 0.0 {
                        return Err(self.err(c, "the rotation axis is zero"));
                    }
                    DMat4::from_axis_angle(axis.normalize(), angle.to_radians())
                }
                "matrix" => {
                    let v = self.numbers(c, &self.required_attr(c, "value")?)?;
                    match v.len() {
                        16 => DMat4::from_cols_array(&[
                            v[0], v[4], v[8], v[12], v[1], v[5], v[9], v[13], v[2], v[6], v[10],
                            v[14], v[3], v[7], v[11], v[15],
                        ]),
                        9 => DMat4::from_cols_array(&[
                            v[0], v[3], v[6], 0.0, v[1], v[4], v[7], 0.0, v[2], v[5], v[8], 0.0,
                            0.0, 0.0, 0.0, 1.0,
                        ]),
                        n => {
                            return Err(
                                self.err(c, format!("a matrix has 16 (or 9) numbers, not {n}"))
                            )
                        }
                    }
                }
                "lookat" => {
                    let get = |a: &str, required: bool| -> Result<Option<DVec3>> {
                        match self.attr(c, a)? {
                            Some(v) => {
                                let n = self.numbers(c, &v)?;
                                if n.len() != 3 {
                                    return Err(
                                        self.err(c, format!("{a}=\"{v}\" must be three numbers"))
                                    );
                                }
                                Ok(Some(DVec3::new(n[0], n[1], n[2])))
                            }
                            None if required => {
                                Err(self.err(c, format!("the attribute `{a}` is required")))
                            }
                            None => Ok(None),
                        }
                    };
                    let origin = get("origin", true)?.unwrap_or_default();
                    let target = get("target", true)?.unwrap_or_default();
                    let dir = (target - origin)
                        .try_normalize()
                        .ok_or_else(|| self.err(c, "origin and target are the same point"))?;
                    let up = match get("up", false)? {
                        Some(up) => up,
                        // Mitsuba picks any up perpendicular to the direction.
                        None => dir.any_orthonormal_vector(),
                    };
                    let left = up.cross(dir).try_normalize().ok_or_else(|| {
                        self.err(c, "`up` is zero or parallel to the viewing direction")
                    })?;
                    let new_up = dir.cross(left);
                    DMat4::from_cols(
                        left.extend(0.0),
                        new_up.extend(0.0),
                        dir.extend(0.0),
                        origin.extend(1.0),
                    )
                }
                other => {
                    return Err(self.err(
                        c,
                        format!(
                            "<{other}> is not a transform operation \
                             (known: translate, rotate, scale, matrix, lookat)"
                        ),
                    ))
                }
            };
            m = op * m;
        }
        if !m.to_cols_array().iter().all(|x| x.is_finite()) {
            return Err(self.err(node, "the transform is not finite"));
        }
        Ok(m)
    }

    /// Reports the first named parameter nobody took.
    fn leftovers(&self, p: &Params) -> Result<()> {
        for (name, c) in &p.named {
            if !p.used.contains(name) && !IGNORED.contains(&name.as_str()) {
                let kind = p.node.attribute("type").unwrap_or("");
                return Err(self.err(
                    *c,
                    format!(
                        "`{name}` of a `{kind}` {} is not supported by plsr",
                        tag(p.node)
                    ),
                ));
            }
        }
        Ok(())
    }

    fn scene(&mut self, root: Node<'a, 'input>) -> Result<()> {
        for c in root.children().filter(|c| c.is_element()) {
            match tag(c) {
                "default" => {
                    let name = self.required_attr(c, "name")?;
                    let value = self.required_attr(c, "value")?;
                    // The first definition counts (as a `-D` would).
                    self.defaults.entry(name).or_insert(value);
                }
                "integrator" => self.integrator(c)?,
                "sensor" => {
                    if self.camera.is_some() {
                        return Err(self.err(c, "plsr renders one sensor: this is the second"));
                    }
                    self.sensor(c)?;
                }
                "bsdf" | "texture" => {
                    let id = self
                        .attr(c, "id")?
                        .ok_or_else(|| self.err(c, "a top-level element needs an `id`"))?;
                    if self.ids.insert(id.clone(), c).is_some() {
                        return Err(self.err(c, format!("id=\"{id}\" is used twice")));
                    }
                    if tag(c) == "bsdf" {
                        self.material(c)?;
                    } else {
                        // Checked where used.
                        self.colour_of(c)?;
                    }
                }
                "shape" => self.shape(c)?,
                "emitter" => self.emitter(c)?,
                "include" | "path" | "alias" => {
                    return Err(self.err(
                        c,
                        format!("<{}> is not supported: merge the files into one", tag(c)),
                    ))
                }
                other => {
                    return Err(self.err(
                        c,
                        format!(
                            "<{other}> is not supported by plsr (supported: default, \
                             integrator, sensor, bsdf, texture, shape, emitter)"
                        ),
                    ))
                }
            }
        }
        Ok(())
    }

    fn integrator(&mut self, node: Node<'a, 'input>) -> Result<()> {
        let kind = self.required_attr(node, "type")?;
        match kind.as_str() {
            "path" => {}
            "volpath" | "volpathmis" => self.note(
                node,
                format!("the `{kind}` integrator is rendered as `path` (plsr has no media)"),
            ),
            "direct" => {
                self.render.insert("max_depth".into(), Value::Integer(1));
                let p = self.params(node)?;
                return self.leftovers_of_integrator(&p);
            }
            other => {
                return Err(self.err(
                    node,
                    format!("the `{other}` integrator is not supported (supported: path, direct)"),
                ))
            }
        }
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
            d if d >= 2 => (d - 1).min(1024),
            d => {
                return Err(self.err(
                    node,
                    format!(
                        "max_depth = {d}: plsr renders at least one scattering event \
                         (Mitsuba's max_depth 2); plsr's max_depth is Mitsuba's − 1"
                    ),
                ))
            }
        };
        self.render
            .insert("max_depth".into(), Value::Integer(depth));
        let rr = self.take_int(&mut p, "rr_depth")?.unwrap_or(5);
        if rr < 1 {
            return Err(self.err(node, format!("rr_depth = {rr} must be at least 1")));
        }
        self.render
            .insert("rr_depth".into(), Value::Integer((rr - 1).clamp(1, 1024)));
        if self.take_bool(&mut p, "hide_emitters")? == Some(true) {
            return Err(self.err(node, "hide_emitters = true is not supported"));
        }
        self.leftovers_of_integrator(&p)
    }

    fn leftovers_of_integrator(&self, p: &Params) -> Result<()> {
        self.leftovers(p)?;
        if let Some(c) = p
            .node
            .children()
            .find(|c| c.is_element() && c.attribute("name").is_none())
        {
            return Err(self.err(c, "not supported inside an integrator"));
        }
        Ok(())
    }

    fn sensor(&mut self, node: Node<'a, 'input>) -> Result<()> {
        let kind = self.required_attr(node, "type")?;
        let mut camera = Table::new();
        match kind.as_str() {
            "perspective" => {}
            "thinlens" => {
                camera.insert("type".into(), Value::String("thin_lens".into()));
            }
            other => {
                return Err(self.err(
                    node,
                    format!(
                        "the `{other}` sensor is not supported (supported: perspective, thinlens)"
                    ),
                ))
            }
        }
        let mut p = self.params(node)?;
        // The film, filter and sampler first: the field of view needs the size.
        let mut settings = SensorSettings::default();
        for c in node
            .children()
            .filter(|c| c.is_element() && c.attribute("name").is_none())
        {
            match tag(c) {
                "film" => self.sensor_film(c, &mut settings)?,
                "sampler" => self.sensor_sampler(c, &mut settings)?,
                other => return Err(self.err(c, format!("<{other}> is not supported in a sensor"))),
            }
        }
        let SensorSettings {
            width,
            height,
            filter,
            spp,
            seed,
        } = settings;
        if !(1..=65536).contains(&width) || !(1..=65536).contains(&height) {
            return Err(self.err(
                node,
                format!("the film's size {width} × {height} is out of range"),
            ));
        }
        camera.insert(
            "resolution".into(),
            Value::Array(vec![Value::Integer(width), Value::Integer(height)]),
        );
        self.render.insert("spp".into(), Value::Integer(spp));
        if let Some(seed) = seed {
            self.render.insert("seed".into(), Value::Integer(seed));
        }
        if let Some(sigma) = filter {
            self.film
                .insert("filter".into(), Value::String("gaussian".into()));
            self.film.insert("filter_sigma".into(), float(sigma));
            // Mitsuba cuts its Gaussian at 4 σ.
            self.film
                .insert("filter_radius".into(), float((4.0 * sigma).min(64.0)));
        }

        self.sensor_pose(node, &mut p, &mut camera)?;
        self.sensor_fov(node, &mut p, (width as f64, height as f64), &mut camera)?;
        for s in ["principal_point_offset_x", "principal_point_offset_y"] {
            if let Some(v) = self.take_float(&mut p, s)? {
                if v != 0.0 {
                    return Err(self.err(node, format!("`{s}` is not supported")));
                }
            }
        }
        if kind == "thinlens" {
            let r = self.take_float(&mut p, "aperture_radius")?.unwrap_or(1.0);
            camera.insert("aperture_radius".into(), float(r));
            let d = self.take_float(&mut p, "focus_distance")?.unwrap_or(0.0);
            if d > 0.0 {
                camera.insert("focus_distance".into(), float(d));
            }
        }
        if let Some(s) = self.take_float(&mut p, "shutter_close")? {
            if s != 0.0 {
                self.note(node, "shutter_close: plsr renders no motion blur");
            }
        }
        self.leftovers(&p)?;
        self.camera = Some(camera);
        Ok(())
    }

    /// A sensor's `<film>`: its size, and its `<rfilter>` children.
    fn sensor_film(&mut self, c: Node<'a, 'input>, settings: &mut SensorSettings) -> Result<()> {
        let film_kind = self.required_attr(c, "type")?;
        if film_kind != "hdrfilm" {
            return Err(self.err(
                c,
                format!("the `{film_kind}` film is not supported (supported: hdrfilm)"),
            ));
        }
        let mut f = self.params(c)?;
        settings.width = self.take_int(&mut f, "width")?.unwrap_or(settings.width);
        settings.height = self.take_int(&mut f, "height")?.unwrap_or(settings.height);
        for crop in [
            "crop_offset_x",
            "crop_offset_y",
            "crop_width",
            "crop_height",
        ] {
            if self.take(&mut f, crop).is_some() {
                return Err(self.err(
                    c,
                    format!(
                        "`{crop}` is not supported here: render the whole image, \
                         or a window with `plsr render --crop`"
                    ),
                ));
            }
        }
        self.take_bool(&mut f, "sample_border")?;
        self.leftovers(&f)?;
        for r in c
            .children()
            .filter(|r| r.is_element() && r.attribute("name").is_none())
        {
            if tag(r) != "rfilter" {
                return Err(self.err(r, "not supported inside a film"));
            }
            self.sensor_filter(r, settings)?;
        }
        Ok(())
    }

    /// A film's `<rfilter>`: box, or a Gaussian of its σ (others become the
    /// default Gaussian, with a note).
    fn sensor_filter(&mut self, r: Node<'a, 'input>, settings: &mut SensorSettings) -> Result<()> {
        let rk = self.required_attr(r, "type")?;
        let mut rp = self.params(r)?;
        match rk.as_str() {
            "box" => settings.filter = None,
            "gaussian" => {
                settings.filter = Some(self.take_float(&mut rp, "stddev")?.unwrap_or(0.5));
            }
            other => {
                self.note(
                    r,
                    format!(
                        "the `{other}` pixel filter is rendered with a Gaussian \
                         of σ 0.5 px (plsr has box and gaussian)"
                    ),
                );
                rp.used.extend(rp.named.iter().map(|(n, _)| n.clone()));
            }
        }
        self.leftovers(&rp)?;
        Ok(())
    }

    /// A sensor's `<sampler>`: the sample count and seed.
    fn sensor_sampler(&mut self, c: Node<'a, 'input>, settings: &mut SensorSettings) -> Result<()> {
        let mut s = self.params(c)?;
        let sk = self.attr(c, "type")?.unwrap_or_default();
        if !matches!(
            sk.as_str(),
            "independent" | "stratified" | "multijitter" | "ldsampler" | "orthogonal"
        ) {
            return Err(self.err(c, format!("the `{sk}` sampler is not known")));
        }
        if sk != "independent" {
            self.note(
                c,
                format!(
                    "the `{sk}` sampler: plsr uses its own stratified samples \
                     (the sample count is kept)"
                ),
            );
        }
        settings.spp = self
            .take_int(&mut s, "sample_count")?
            .unwrap_or(settings.spp);
        settings.seed = self.take_int(&mut s, "seed")?;
        for ignored in ["jitter", "scramble", "strength"] {
            self.take(&mut s, ignored);
        }
        self.leftovers(&s)?;
        Ok(())
    }

    /// The sensor's pose from its `to_world`: position, look-at point, up.
    fn sensor_pose(
        &mut self,
        node: Node<'a, 'input>,
        p: &mut Params<'a, 'input>,
        camera: &mut Table,
    ) -> Result<()> {
        let m = self
            .take_transform(p, "to_world")?
            .unwrap_or(DMat4::IDENTITY);
        let position = m.transform_point3(DVec3::ZERO);
        let forward = m.transform_vector3(DVec3::Z);
        let up = m.transform_vector3(DVec3::Y);
        let left = m.transform_vector3(DVec3::X);
        if forward.length_squared() == 0.0 || up.cross(forward).length_squared() == 0.0 {
            return Err(self.err(node, "the sensor's to_world is degenerate"));
        }
        if left.dot(up.cross(forward)) < 0.0 {
            return Err(self.err(
                node,
                "the sensor's to_world mirrors the image (plsr's cameras do not mirror)",
            ));
        }
        camera.insert("position".into(), dvec(position));
        camera.insert("look_at".into(), dvec(position + forward.normalize()));
        camera.insert("up".into(), dvec(up.normalize()));

        Ok(())
    }

    /// The field of view from `fov` and `fov_axis` or `focal_length`, for a
    /// film of `(w, h)` pixels.
    fn sensor_fov(
        &mut self,
        node: Node<'a, 'input>,
        p: &mut Params<'a, 'input>,
        (w, h): (f64, f64),
        camera: &mut Table,
    ) -> Result<()> {
        // Field of view: Mitsuba's `fov` is along `fov_axis` (default x);
        // `focal_length` is a 35 mm equivalent, 36 mm wide.
        let fov = self.take_float(p, "fov")?;
        let focal = self.take_string(p, "focal_length")?;
        let axis = self.take_string(p, "fov_axis")?;
        let half_tan = |deg: f64| (deg.to_radians() / 2.0).tan();
        let from_half_tan = |t: f64| 2.0 * t.atan().to_degrees();
        let (key, deg) = match (fov, focal) {
            (Some(_), Some(_)) => {
                return Err(self.err(node, "give fov or focal_length, not both"));
            }
            (None, Some(f)) => {
                let mm = f.trim().trim_end_matches("mm").trim();
                let mm = self.number(node, mm)?;
                if mm <= 0.0 {
                    return Err(self.err(node, format!("focal_length {f} must be positive")));
                }
                ("hfov", from_half_tan(18.0 / mm))
            }
            (fov, None) => {
                let fov = fov.unwrap_or(DEFAULT_HFOV_DEG);
                if !(fov > 0.0 && fov < 180.0) {
                    return Err(self.err(node, format!("fov = {fov} must be in (0, 180)")));
                }
                match axis.as_deref().unwrap_or("x") {
                    "x" => ("hfov", fov),
                    "y" => ("vfov", fov),
                    "smaller" if w <= h => ("hfov", fov),
                    "smaller" => ("vfov", fov),
                    "larger" if w >= h => ("hfov", fov),
                    "larger" => ("vfov", fov),
                    "diagonal" => ("vfov", from_half_tan(half_tan(fov) * h / w.hypot(h))),
                    other => {
                        return Err(self.err(
                            node,
                            format!(
                                "fov_axis `{other}` is not one of x, y, diagonal, smaller, larger"
                            ),
                        ))
                    }
                }
            }
        };
        camera.insert(key.into(), float(deg));
        Ok(())
    }

    /// Translates a BSDF element into a `[[materials]]` entry (once per
    /// element) and returns its name.
    fn material(&mut self, node: Node<'a, 'input>) -> Result<String> {
        let key = node.range().start;
        if let Some(name) = self.material_names.get(&key) {
            return Ok(name.clone());
        }
        let kind = self.required_attr(node, "type")?;
        let (inner, twosided) = if kind == "twosided" {
            let mut bsdfs = node.children().filter(|c| c.is_element());
            let inner = bsdfs
                .next()
                .ok_or_else(|| self.err(node, "twosided needs a BSDF inside"))?;
            if bsdfs.next().is_some() {
                return Err(self.err(
                    node,
                    "a twosided with two BSDFs (one per side) is not supported",
                ));
            }
            let inner = if tag(inner) == "ref" {
                let id = self.required_attr(inner, "id")?;
                *self.ids.get(&id).ok_or_else(|| {
                    self.err(inner, format!("no element with id=\"{id}\" before it"))
                })?
            } else {
                inner
            };
            if tag(inner) != "bsdf" {
                return Err(self.err(inner, "twosided needs a <bsdf> inside"));
            }
            (inner, true)
        } else {
            (node, false)
        };
        let mut table = self.bsdf(inner, twosided)?;
        let name = match self.attr(node, "id")? {
            Some(id) => id,
            None => format!("bsdf-line-{}", self.line(key)),
        };
        if self
            .materials
            .iter()
            .any(|m| m.get("name") == Some(&Value::String(name.clone())))
        {
            return Err(self.err(node, format!("a material named `{name}` exists already")));
        }
        let mut entry = Table::new();
        entry.insert("name".into(), Value::String(name.clone()));
        entry.0.append(&mut table.0);
        self.materials.push(entry);
        self.material_names.insert(key, name.clone());
        Ok(name)
    }

    /// The plsr keys (with `type`) of one BSDF.
    fn bsdf(&mut self, node: Node<'a, 'input>, twosided: bool) -> Result<Table> {
        let kind = self.required_attr(node, "type")?;
        let mut p = self.params(node)?;
        let mut t = Table::new();
        let opaque = !matches!(kind.as_str(), "dielectric" | "roughdielectric");
        if opaque && !twosided {
            self.note(
                node,
                "one-sided BSDF: Mitsuba renders its back black, plsr shades opaque \
                 surfaces from both sides (as with twosided)",
            );
        }
        match kind.as_str() {
            "diffuse" => self.bsdf_diffuse(&mut p, &mut t)?,
            "roughconductor" | "conductor" => self.bsdf_conductor(node, &kind, &mut p, &mut t)?,
            "roughdielectric" | "dielectric" => {
                self.bsdf_dielectric(node, &kind, &mut p, &mut t)?
            }
            "principled" => self.bsdf_principled(node, &mut p, &mut t)?,
            "twosided" => return Err(self.err(node, "a twosided inside a twosided")),
            other => {
                return Err(self.err(
                    node,
                    format!(
                        "the `{other}` BSDF is not supported (supported: diffuse, conductor, \
                         roughconductor, dielectric, roughdielectric, principled, twosided)"
                    ),
                ))
            }
        }
        self.leftovers(&p)?;
        if let Some(c) = node
            .children()
            .find(|c| c.is_element() && c.attribute("name").is_none())
        {
            return Err(self.err(c, "not supported inside a BSDF"));
        }
        Ok(t)
    }

    /// `diffuse`: plsr's diffuse, its reflectance a colour or a bitmap.
    fn bsdf_diffuse(&mut self, p: &mut Params<'a, 'input>, t: &mut Table) -> Result<()> {
        set(t, "type", Value::String("diffuse".into()));
        match self
            .take_colour(p, "reflectance")?
            .unwrap_or(Colour::Rgb([0.5; 3]))
        {
            Colour::Rgb(v) => set(t, "reflectance", vec3(v)),
            Colour::Bitmap(f) => set(t, "base_color_map", Value::String(f)),
        }
        Ok(())
    }

    /// `conductor` and `roughconductor`: Cook–Torrance with a conductor's
    /// Fresnel (a preset metal, or `eta` and `k`).
    fn bsdf_conductor(
        &mut self,
        node: Node<'a, 'input>,
        kind: &str,
        p: &mut Params<'a, 'input>,
        t: &mut Table,
    ) -> Result<()> {
        set(t, "type", Value::String("cook_torrance".into()));
        set(t, "fresnel", Value::String("conductor".into()));
        if kind == "conductor" {
            self.note(
                node,
                "a smooth conductor is rendered as GGX with α = 0.001 (numerically a mirror)",
            );
            set(t, "alpha", float(0.0));
        } else {
            self.roughness(p, t, node)?;
        }
        let eta = self.take_rgb(p, "eta")?;
        let k = self.take_rgb(p, "k")?;
        let preset = self.take_string(p, "material")?;
        match (preset, eta, k) {
            (Some(_), Some(_), _) | (Some(_), _, Some(_)) => {
                return Err(self.err(node, "give `material` or `eta` and `k`, not both"))
            }
            (Some(m), None, None) => {
                if !METAL_NAMES.contains(&m.as_str()) {
                    return Err(self.err(
                        node,
                        format!(
                            "material `{m}`: plsr has the presets {} (or give eta and k)",
                            METAL_NAMES.join(", ")
                        ),
                    ));
                }
                set(t, "metal", Value::String(m));
            }
            (None, None, None) => set(t, "metal", Value::String("none".into())),
            (None, eta, k) => {
                set(t, "eta", vec3(eta.unwrap_or([0.0; 3])));
                set(t, "k", vec3(k.unwrap_or([1.0; 3])));
            }
        }
        if let Some(s) = self.take_rgb(p, "specular_reflectance")? {
            set(t, "specular_reflectance", vec3(s));
        }
        Ok(())
    }

    /// `dielectric` and `roughdielectric`: plsr's dielectric of relative
    /// index `int_ior / ext_ior` (numbers or named materials).
    fn bsdf_dielectric(
        &mut self,
        node: Node<'a, 'input>,
        kind: &str,
        p: &mut Params<'a, 'input>,
        t: &mut Table,
    ) -> Result<()> {
        set(t, "type", Value::String("dielectric".into()));
        let ior = |this: &Self, p: &mut Params<'a, 'input>, name: &str, default: f64| {
            let Some(c) = this.take(p, name) else {
                return Ok(default);
            };
            match tag(c) {
                "float" => this.number(c, &this.required_attr(c, "value")?),
                "string" => {
                    let v = this.required_attr(c, "value")?;
                    NAMED_IORS
                        .iter()
                        .find(|(n, _)| *n == v)
                        .map(|(_, i)| *i)
                        .ok_or_else(|| {
                            this.err(c, format!("`{v}` is not a known material's index"))
                        })
                }
                _ => Err(this.err(c, format!("`{name}` must be a <float> or <string>"))),
            }
        };
        let int_ior = ior(self, p, "int_ior", 1.5046)?;
        let ext_ior = ior(self, p, "ext_ior", 1.000277)?;
        if !(int_ior > 0.0 && ext_ior > 0.0) || int_ior == ext_ior {
            return Err(self.err(
                node,
                format!("int_ior {int_ior} and ext_ior {ext_ior} must be positive and differ"),
            ));
        }
        set(t, "ior", float(int_ior / ext_ior));
        if kind == "roughdielectric" {
            self.roughness(p, t, node)?;
        }
        for s in ["specular_reflectance", "specular_transmittance"] {
            if let Some(v) = self.take_rgb(p, s)? {
                if v != [1.0; 3] {
                    return Err(self.err(node, format!("`{s}` other than 1 is not supported")));
                }
            }
        }
        Ok(())
    }

    /// `principled`: plsr's principled; the lobes plsr does not model must
    /// be 0.
    fn bsdf_principled(
        &mut self,
        node: Node<'a, 'input>,
        p: &mut Params<'a, 'input>,
        t: &mut Table,
    ) -> Result<()> {
        set(t, "type", Value::String("principled".into()));
        match self.take_colour(p, "base_color")? {
            Some(Colour::Rgb(v)) => set(t, "base_color", vec3(v)),
            Some(Colour::Bitmap(f)) => set(t, "base_color_map", Value::String(f)),
            None => {}
        }
        for (name, map) in [("roughness", "roughness_map"), ("metallic", "metallic_map")] {
            match self.take_colour(p, name)? {
                Some(Colour::Rgb([a, b, c])) if a == b && b == c => set(t, name, float(a)),
                Some(Colour::Rgb(_)) => {
                    return Err(self.err(node, format!("`{name}` must be one number")))
                }
                Some(Colour::Bitmap(f)) => {
                    self.note(
                        node,
                        format!("`{name}` texture: plsr reads its red channel, linearly"),
                    );
                    set(t, map, Value::String(f))
                }
                None => {}
            }
        }
        for name in ["anisotropic", "specular", "spec_tint"] {
            if let Some(v) = self.take_float(p, name)? {
                set(t, name, float(v));
            }
        }
        for name in [
            "sheen",
            "sheen_tint",
            "clearcoat",
            "clearcoat_gloss",
            "spec_trans",
            "flatness",
        ] {
            if let Some(v) = self.take_float(p, name)? {
                if v != 0.0 {
                    return Err(self.err(
                        node,
                        format!(
                            "`{name}` = {v}: principled's {name} is not modelled by plsr \
                             (only 0 is accepted)"
                        ),
                    ));
                }
            }
        }
        if let Some(eta) = self.take_float(p, "eta")? {
            // Mitsuba: η given instead of `specular`.
            let s = ((eta - 1.0) / (eta + 1.0)).powi(2) / 0.08;
            if !(0.0..=1.0).contains(&s) {
                return Err(self.err(node, format!("eta = {eta} is outside plsr's range")));
            }
            set(t, "specular", float(s));
        }
        Ok(())
    }

    /// `distribution` and `alpha` / `alpha_u`, `alpha_v` (Mitsuba's default:
    /// Beckmann, α 0.1).
    fn roughness(&self, p: &mut Params<'a, 'input>, t: &mut Table, node: Node) -> Result<()> {
        let d = self
            .take_string(p, "distribution")?
            .unwrap_or_else(|| "beckmann".into());
        if !matches!(d.as_str(), "ggx" | "beckmann") {
            return Err(self.err(node, format!("distribution `{d}` is not ggx or beckmann")));
        }
        t.insert("distribution".into(), Value::String(d));
        let alpha = self.take_float(p, "alpha")?;
        let u = self.take_float(p, "alpha_u")?;
        let v = self.take_float(p, "alpha_v")?;
        match (alpha, u, v) {
            (Some(_), Some(_), _) | (Some(_), _, Some(_)) => {
                return Err(self.err(node, "give alpha or alpha_u with alpha_v, not both"))
            }
            (_, Some(u), Some(v)) => {
                t.insert("alpha_u".into(), float(u));
                t.insert("alpha_v".into(), float(v));
            }
            (_, Some(_), None) | (_, None, Some(_)) => {
                return Err(self.err(node, "alpha_u and alpha_v go together"))
            }
            (a, None, None) => {
                t.insert("alpha".into(), float(a.unwrap_or(0.1)));
            }
        }
        Ok(())
    }

    fn shape(&mut self, node: Node<'a, 'input>) -> Result<()> {
        let kind = self.required_attr(node, "type")?;
        let mut p = self.params(node)?;
        let mut s = Table::new();
        match kind.as_str() {
            "obj" | "ply" => {
                s.insert("type".into(), Value::String(kind.clone()));
                let file = self
                    .take_string(&mut p, "filename")?
                    .ok_or_else(|| self.err(node, "a mesh needs `filename`"))?;
                s.insert("file".into(), Value::String(self.file_name(file)));
                let face_normals = self.take_bool(&mut p, "face_normals")?.unwrap_or(false);
                if face_normals {
                    self.note(
                        node,
                        "face_normals = true: plsr keeps a mesh file's own normals, if it has any",
                    );
                } else {
                    // Mitsuba gives meshes without normals smooth ones.
                    s.insert("smooth_normals".into(), Value::Boolean(true));
                }
                if self.take_bool(&mut p, "flip_normals")? == Some(true) {
                    if kind == "obj" {
                        return Err(self.err(node, "flip_normals is not supported for obj in plsr"));
                    }
                    s.insert("flip_normals".into(), Value::Boolean(true));
                }
                self.take_bool(&mut p, "flip_tex_coords")?;
            }
            "rectangle" | "disk" | "cube" | "sphere" => {
                s.insert("type".into(), Value::String(kind.clone()));
                if self.take_bool(&mut p, "flip_normals")? == Some(true) {
                    s.insert("flip_normals".into(), Value::Boolean(true));
                }
                if kind == "sphere" {
                    if let Some(c) = self.take_point(&mut p, "center")? {
                        s.insert("center".into(), vec3(c));
                    }
                    if let Some(r) = self.take_float(&mut p, "radius")? {
                        s.insert("radius".into(), float(r));
                    }
                }
            }
            other => {
                return Err(self.err(
                    node,
                    format!(
                        "the `{other}` shape is not supported (supported: obj, ply, rectangle, \
                         sphere, disk, cube)"
                    ),
                ))
            }
        }
        if let Some(m) = self.take_transform(&mut p, "to_world")? {
            let rows: Vec<Value> = (0..4).map(|r| vec3_row(m.row(r))).collect();
            s.insert("transform.matrix".into(), Value::Array(rows));
        }
        let mut bsdf = None;
        for c in node.children().filter(|c| c.is_element()) {
            let name = c.attribute("name");
            match (tag(c), name) {
                ("bsdf", _) | ("ref", None) | ("ref", Some("bsdf")) => {
                    if bsdf.is_some() {
                        return Err(self.err(c, "a shape has one BSDF: this is the second"));
                    }
                    let target = if tag(c) == "ref" {
                        let id = self.required_attr(c, "id")?;
                        let t = *self.ids.get(&id).ok_or_else(|| {
                            self.err(c, format!("no element with id=\"{id}\" before it"))
                        })?;
                        if tag(t) != "bsdf" {
                            return Err(self.err(c, format!("id=\"{id}\" is not a BSDF")));
                        }
                        t
                    } else {
                        c
                    };
                    bsdf = Some(self.material(target)?);
                    if let Some(n) = name {
                        p.used.insert(n.to_string());
                    }
                }
                ("emitter", _) => {
                    let ek = self.required_attr(c, "type")?;
                    if ek != "area" {
                        return Err(
                            self.err(c, format!("a shape's emitter must be `area`, not `{ek}`"))
                        );
                    }
                    let mut ep = self.params(c)?;
                    let radiance = self.take_rgb(&mut ep, "radiance")?.unwrap_or([1.0; 3]);
                    self.leftovers(&ep)?;
                    s.insert("emission".into(), vec3(radiance));
                    if let Some(n) = name {
                        p.used.insert(n.to_string());
                    }
                }
                _ => {}
            }
        }
        let material = match bsdf {
            Some(m) => m,
            None => self.default_material(),
        };
        s.insert("material".into(), Value::String(material));
        self.leftovers(&p)?;
        if let Some(c) = node.children().find(|c| {
            c.is_element()
                && c.attribute("name").is_none()
                && !matches!(tag(*c), "bsdf" | "ref" | "emitter")
        }) {
            return Err(self.err(c, "not supported inside a shape"));
        }
        self.shapes.push(s);
        Ok(())
    }

    /// Mitsuba's BSDF for shapes without one: diffuse, 0.5 grey.
    fn default_material(&mut self) -> String {
        let name = "mitsuba-default-diffuse".to_string();
        if !self
            .materials
            .iter()
            .any(|m| m.get("name") == Some(&Value::String(name.clone())))
        {
            let mut m = Table::new();
            m.insert("name".into(), Value::String(name.clone()));
            m.insert("type".into(), Value::String("diffuse".into()));
            m.insert("reflectance".into(), vec3([0.5; 3]));
            self.materials.push(m);
        }
        name
    }

    fn emitter(&mut self, node: Node<'a, 'input>) -> Result<()> {
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
                let intensity = self.take_rgb(&mut p, "intensity")?.unwrap_or([1.0; 3]);
                let mut l = Table::new();
                l.insert("type".into(), Value::String("point".into()));
                l.insert("position".into(), dvec(position));
                l.insert("intensity".into(), vec3(intensity));
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
                    e.insert("file".into(), Value::String(self.file_name(file)));
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
                    e.insert("up".into(), dvec(up.normalize()));
                    e.insert("forward".into(), dvec(forward.normalize()));
                    e.insert("filter".into(), Value::String("bilinear".into()));
                    if let Some(s) = self.take_float(&mut p, "scale")? {
                        e.insert("scale".into(), float(s));
                    }
                } else {
                    let r = self.take_rgb(&mut p, "radiance")?.unwrap_or([1.0; 3]);
                    e.insert("radiance".into(), vec3(r));
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
                        "the `{other}` emitter is not supported (supported: point, envmap, \
                         constant, and area inside a shape)"
                    ),
                ))
            }
        }
        self.leftovers(&p)
    }

    /// The plsr scene as TOML.
    fn finish(&mut self) -> String {
        let mut out = format!(
            "# Translated from Mitsuba 3 XML ({}) by plsr {}.\n",
            self.file.display(),
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
                "resolution".into(),
                Value::Array(vec![Value::Integer(768), Value::Integer(576)]),
            );
            c.insert("position".into(), vec3([0.0; 3]));
            c.insert("look_at".into(), vec3([0.0, 0.0, 1.0]));
            c.insert("up".into(), vec3([0.0, 1.0, 0.0]));
            c.insert("hfov".into(), float(DEFAULT_HFOV_DEG));
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

/// Sets `t[k] = v`.
fn set(t: &mut Table, k: &str, v: Value) {
    t.insert(k.to_string(), v);
}

fn vec3_row(r: DVec4) -> Value {
    Value::Array(r.to_array().iter().map(|&x| float(x)).collect())
}

/// What a sensor's film and sampler set, with Mitsuba's defaults.
struct SensorSettings {
    /// Film width, pixels.
    width: i64,
    /// Film height, pixels.
    height: i64,
    /// The Gaussian pixel filter's σ (pixels), or `None` for a box.
    filter: Option<f64>,
    /// Samples per pixel.
    spp: i64,
    /// The sampler's seed, if given.
    seed: Option<i64>,
}

impl Default for SensorSettings {
    fn default() -> SensorSettings {
        SensorSettings {
            width: 768,
            height: 576,
            filter: Some(0.5), // Mitsuba's default: Gaussian, σ 0.5 px
            spp: 4,
            seed: None,
        }
    }
}
