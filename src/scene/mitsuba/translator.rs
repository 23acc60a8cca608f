//! The translator's state and what every plugin's translation uses: where
//! an element is (for errors and notes), its attributes, and its named
//! parameters taken one by one so that those left over can be refused.

use super::document::{Document, Element};
use super::table::Table;
use crate::error::{Error, Result};
use plsr_base::Vocabulary;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

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

/// A Mitsuba scene being translated into plsr's tables.
pub(super) struct Translator<'a> {
    pub doc: &'a Document,
    /// The folder file names in the translation are relative to, when it
    /// is not the scene's own (then relative names are made absolute).
    pub rebase: Option<PathBuf>,
    /// Every element with an `id`, by id (and the `<alias>`es).
    pub ids: HashMap<String, &'a Element>,
    pub materials: Vec<Table>,
    /// plsr material names, by the BSDF element's key.
    pub material_names: HashMap<usize, String>,
    pub shapes: Vec<Table>,
    pub lights: Vec<Table>,
    pub environment: Option<Table>,
    pub render: Table,
    pub camera: Option<Table>,
    pub film: Table,
    /// Whether the scene's integrator was read.
    pub integrated: bool,
    /// While a `shapegroup`'s shapes are written: the group's name (the
    /// `group` key of its shapes).
    pub group: Option<String>,
    /// The groups written so far (each once, however many instances).
    pub groups_written: HashSet<String>,
    /// `[[instances]]`: a group and its `to_world` each.
    pub instances: Vec<Table>,
    pub notes: Vec<String>,
    noted: HashSet<String>,
}

/// The parameters of one plugin element, consumed one by one so that
/// those left over can be reported.
pub(super) struct Params<'a> {
    pub node: &'a Element,
    /// Named children (`<float name="alpha" …>`), by name.
    pub named: Vec<(String, &'a Element)>,
    pub used: HashSet<String>,
}

impl<'a> Translator<'a> {
    pub fn new(doc: &'a Document, rebase: Option<PathBuf>) -> Translator<'a> {
        Translator {
            doc,
            rebase,
            ids: HashMap::new(),
            materials: Vec::new(),
            material_names: HashMap::new(),
            shapes: Vec::new(),
            lights: Vec::new(),
            environment: None,
            // Mitsuba picks each emitter equally likely; so does the import,
            // so its noise is Mitsuba's too.
            render: Table(vec![(
                "light_picking".to_string(),
                toml::Value::String("uniform".into()),
            )]),
            camera: None,
            film: Table::new(),
            integrated: false,
            group: None,
            groups_written: HashSet::new(),
            instances: Vec::new(),
            notes: Vec::new(),
            noted: HashSet::new(),
        }
    }

    /// The file `node` is in.
    pub fn file_of(&self, node: &Element) -> &'a Path {
        &self.doc.files[node.file]
    }

    /// Where `node` is: its line and its start tag.
    pub fn at(&self, node: &Element) -> String {
        let mut s = format!("line {}, <{}", node.line, node.tag);
        for a in ["type", "name", "id"] {
            if let Some(v) = node.attribute(a) {
                s.push_str(&format!(" {a}=\"{v}\""));
            }
        }
        s.push('>');
        s
    }

    pub fn err(&self, node: &Element, message: impl Into<String>) -> Error {
        Error::input(self.file_of(node), self.at(node), message)
    }

    /// Records an approximation, once per message.
    pub fn note(&mut self, node: &Element, message: impl Into<String>) {
        let message = message.into();
        if self.noted.insert(message.clone()) {
            let at = self.at(node);
            let file = if node.file == 0 {
                String::new()
            } else {
                format!("{}: ", self.file_of(node).display())
            };
            self.notes.push(format!("{file}{at}: {message}"));
        }
    }

    /// Attribute `name` of `node` (its `$name`s replaced when the file was
    /// read).
    pub fn attr(&self, node: &Element, name: &str) -> Result<Option<String>> {
        Ok(node.attribute(name).map(str::to_string))
    }

    /// Collects every element with an `id` (ids are global across includes;
    /// a `<ref>` may come before its target, as in Mitsuba), and the
    /// `<alias id as>` names.
    pub fn collect_ids(&mut self, root: &'a Element) -> Result<()> {
        let all = root.descendants();
        for e in &all {
            if e.tag == "alias" {
                continue;
            }
            if let Some(id) = e.attribute("id") {
                if e.tag == "ref" {
                    continue;
                }
                if let Some(first) = self.ids.insert(id.to_string(), e) {
                    return Err(self.err(
                        e,
                        format!(
                            "id=\"{id}\" is used twice (first {} of {})",
                            self.at(first),
                            self.file_of(first).display()
                        ),
                    ));
                }
            }
        }
        for e in all.iter().filter(|e| e.tag == "alias") {
            let id = self.required_attr(e, "id")?;
            let to = self.required_attr(e, "as")?;
            let target = *self
                .ids
                .get(&id)
                .ok_or_else(|| self.err(e, format!("no element has id=\"{id}\"")))?;
            if self.ids.insert(to.clone(), target).is_some() {
                return Err(self.err(e, format!("id=\"{to}\" exists already")));
            }
        }
        Ok(())
    }

    /// `node`, or the element it refers to if it is a `<ref id>`.
    pub fn deref(&self, node: &'a Element) -> Result<&'a Element> {
        if node.tag != "ref" {
            return Ok(node);
        }
        let id = self.required_attr(node, "id")?;
        let target = *self
            .ids
            .get(&id)
            .ok_or_else(|| self.err(node, format!("no element has id=\"{id}\"")))?;
        if target.tag == "ref" {
            return Err(self.err(node, format!("id=\"{id}\" is a <ref> itself")));
        }
        Ok(target)
    }

    /// A file name given by `node`, as the translated scene must give it:
    /// found as Mitsuba's file resolver finds it (the scene's `<path>`s,
    /// its folder, the element's own file's folder), relative to the
    /// scene's folder, or absolute if the translation goes elsewhere.
    pub fn file_name(&self, node: &Element, name: String) -> String {
        let found = self.doc.resolve(&name, node.file);
        match &self.rebase {
            Some(base) if found.is_relative() => base.join(&found).to_string_lossy().into_owned(),
            _ => found.to_string_lossy().into_owned(),
        }
    }

    /// Reports the first named parameter nobody took.
    pub fn leftovers(&self, p: &Params) -> Result<()> {
        for (name, c) in &p.named {
            if !p.used.contains(name) && !IGNORED.contains(&name.as_str()) {
                let kind = p.node.attribute("type").unwrap_or("");
                return Err(self.err(
                    c,
                    format!(
                        "`{name}` of a `{kind}` {} is not supported by plsr",
                        p.node.tag
                    ),
                ));
            }
        }
        Ok(())
    }
}
