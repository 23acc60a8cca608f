//! A Mitsuba scene's XML as Mitsuba's parser reads it, before any plugin is
//! looked at: the files it includes, the folders it searches, its
//! parameters.
//!
//! [`Document::load`] reads the scene file and every file it includes into
//! one tree of [`Element`]s, each knowing its file and line, and carries out
//! the structural tags as Mitsuba 3 does:
//! - `<default name value>` defines the parameter `$name` unless it is
//!   already defined (by an earlier `<default>` or on the command line,
//!   `-D name=value`, which therefore wins);
//! - `$name` in any attribute is replaced by the parameter's value, the
//!   longest name first (`$spp2` before `$spp`), `\$` standing for a literal
//!   `$`; a `$name` without a value is an error;
//! - `<path value>` adds a folder to the front of the search list for file
//!   names (relative to the file it is in, else searched for itself);
//! - `<include filename>` reads another file (searched from the including
//!   file's folder, then the search list) and puts its elements in place of
//!   the tag: a `<scene>`'s children, or the single object it holds.
//!
//! Limits, each an error naming the file and line: includes nested more
//! than 15 deep (Mitsuba's limit) or in a loop (the chain is named),
//! elements nested more than [`MAX_NESTING`] deep, an attribute longer than
//! [`MAX_VALUE_BYTES`] after substitution and more than
//! [`MAX_EXPANDED_BYTES`] of substituted text in all (chained `<default>`s
//! can double a value at each step), and a file larger than
//! [`MAX_FILE_BYTES`].

use crate::error::{Error, Result};
use plsr_base::Vocabulary;
use std::path::{Component, Path, PathBuf};

/// Mitsuba's limit on nested `<include>`s.
const MAX_INCLUDE_DEPTH: usize = 15;
/// The deepest nesting of elements read (Mitsuba's scenes nest a handful).
pub const MAX_NESTING: usize = 200;
/// The longest attribute value after `$name` substitution, bytes.
pub const MAX_VALUE_BYTES: usize = 16 << 20;
/// The most text substitutions may produce in a whole scene, bytes.
pub const MAX_EXPANDED_BYTES: usize = 256 << 20;
/// The largest XML file read, bytes.
pub const MAX_FILE_BYTES: u64 = 256 << 20;

/// One XML element, its `$name`s replaced, with where it came from.
#[derive(Debug)]
pub(super) struct Element {
    /// The tag (`shape`, `float`, …).
    pub tag: String,
    /// The attributes in file order.
    attributes: Vec<(String, String)>,
    /// Its child elements (comments and text dropped).
    pub children: Vec<Element>,
    /// The file it is in (an index into [`Document::files`]).
    pub file: usize,
    /// Its line in that file (from 1).
    pub line: u32,
    /// A number no other element of the document has.
    pub key: usize,
}

impl Element {
    /// The attribute `name`'s value.
    pub fn attribute(&self, name: &str) -> Option<&str> {
        self.attributes
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    /// Every element below this one, depth first, this one included.
    pub fn descendants(&self) -> Vec<&Element> {
        let mut out = Vec::new();
        let mut stack = vec![self];
        while let Some(e) = stack.pop() {
            out.push(e);
            stack.extend(e.children.iter().rev());
        }
        out
    }
}

/// A parameter (`-D name=value` or `<default>`) and whether a `$name` used it.
#[derive(Debug, Clone)]
struct Parameter {
    name: String,
    value: String,
    from_command_line: bool,
    used: bool,
}

/// A Mitsuba scene's elements, its files and the folders its file names are
/// searched in.
#[derive(Debug)]
pub(super) struct Document {
    /// The `<scene>`.
    pub root: Element,
    /// The scene file and every file it included, as named to the user.
    pub files: Vec<PathBuf>,
    /// The scene file's folder.
    base: PathBuf,
    /// Each file's folder, relative to `base` (or absolute).
    folders: Vec<PathBuf>,
    /// Folders searched for file names, first match wins: each `<path>`
    /// (the latest first), relative to `base` unless absolute.
    search: Vec<PathBuf>,
    /// What the user should know (a `-D` nothing used).
    pub notes: Vec<String>,
}

/// What [`Document::load`] is building.
struct Loader<'p> {
    files: Vec<PathBuf>,
    /// The canonical path of each file in `files`.
    canonical: Vec<PathBuf>,
    /// The scene file's folder.
    base: PathBuf,
    /// Each file's folder relative to `base` (or absolute).
    folders: Vec<PathBuf>,
    search: Vec<PathBuf>,
    parameters: &'p mut Vec<Parameter>,
    expanded: usize,
    next_key: usize,
}

impl Document {
    /// Reads the scene `path` (whose text is `text`) and its includes, with
    /// the command line's parameters `defines` (`-D name=value`); a `-D`
    /// that no `$name` used is noted.
    pub fn load(path: &Path, text: &str, defines: &[(String, String)]) -> Result<Document> {
        let mut parameters: Vec<Parameter> = Vec::new();
        for (name, value) in defines {
            if !is_parameter_name(name) {
                return Err(Error::invalid_argument(format!(
                    "-D {name}={value}: a parameter's name is letters, digits and `_`"
                )));
            }
            parameters.retain(|p| p.name != *name);
            parameters.push(Parameter {
                name: name.clone(),
                value: value.clone(),
                from_command_line: true,
                used: false,
            });
        }
        let base = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .to_path_buf();
        let canonical = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
        let mut loader = Loader {
            files: vec![path.to_path_buf()],
            canonical: vec![canonical],
            base: base.clone(),
            folders: vec![PathBuf::new()],
            search: Vec::new(),
            parameters: &mut parameters,
            expanded: 0,
            next_key: 0,
        };
        let mut roots = loader.parse_file(0, text, &[0])?;
        let root = roots
            .pop()
            .ok_or_else(|| Error::input(path, "", "the file holds no <scene> element"))?;
        if root.tag != "scene" {
            return Err(Error::input(
                path,
                "",
                format!(
                    "unsupported scene format: XML whose root element is <{}>, not a \
                     Mitsuba 3 <scene>; plsr reads TOML scene files, JSON with the same \
                     schema, or Mitsuba 3 XML (see docs/scene-format.md)",
                    root.tag
                ),
            ));
        }
        let Loader {
            files,
            search,
            folders,
            ..
        } = loader;
        // Mitsuba warns of parameters nothing used; so does plsr.
        let known: Vec<&str> = parameters
            .iter()
            .filter(|q| !q.from_command_line)
            .map(|q| q.name.as_str())
            .collect();
        let notes = parameters
            .iter()
            .filter(|p| p.from_command_line && !p.used)
            .map(|p| {
                format!(
                    "-D {}={}: the scene has no `${}`, so it changes nothing (its <default> \
                     parameters: {})",
                    p.name,
                    p.value,
                    p.name,
                    if known.is_empty() {
                        "none".to_string()
                    } else {
                        known.join(", ")
                    }
                )
            })
            .collect();
        Ok(Document {
            root,
            files,
            base,
            folders,
            search,
            notes,
        })
    }

    /// The file `name` given by an element of file `file`, as Mitsuba's file
    /// resolver finds it: absolute names as they are; relative ones in the
    /// first search folder that has them, else in the scene's folder, else
    /// in the element's own file's folder. The path is relative to the
    /// scene file's folder unless a folder on the way was absolute.
    pub fn resolve(&self, name: &str, file: usize) -> PathBuf {
        let name_path = Path::new(name);
        if name_path.is_absolute() {
            return name_path.to_path_buf();
        }
        let own = self.folders[file].clone();
        let candidates = self
            .search
            .iter()
            .cloned()
            .chain([PathBuf::new(), own.clone()]);
        for folder in candidates {
            let rel = join_lexically(&folder, name_path);
            if self.base.join(&rel).exists() {
                return rel;
            }
        }
        join_lexically(&own, name_path)
    }
}

impl Document {
    /// A path relative to the scene's folder (as [`Document::resolve`]
    /// gives it) as the process can open it.
    pub fn base_path(&self, resolved: &str) -> PathBuf {
        shown_path(&self.base, Path::new(resolved))
    }
}

impl Loader<'_> {
    /// Parses file `index` (whose text is `text`; `chain` the files that
    /// included it, outermost first) and returns its elements: the root's
    /// children for an included `<scene>`, else the root itself.
    pub(super) fn parse_file(
        &mut self,
        index: usize,
        text: &str,
        chain: &[usize],
    ) -> Result<Vec<Element>> {
        let path = self.files[index].clone();
        // XML allows nothing before its declaration; be lenient with a byte
        // order mark and blank lines, and count the lines skipped.
        let body = text.strip_prefix('\u{feff}').unwrap_or(text);
        let trimmed = body.trim_start();
        let skipped = body[..body.len() - trimmed.len()].matches('\n').count() as u32;
        check_nesting(trimmed).map_err(|line| {
            Error::input(
                &path,
                format!("line {}", line + skipped),
                format!("elements nested more than {MAX_NESTING} deep"),
            )
        })?;
        let doc = roxmltree::Document::parse(trimmed).map_err(|e| {
            Error::input(
                &path,
                "",
                format!("not well-formed XML (a Mitsuba 3 scene was expected): {e}"),
            )
        })?;
        let lines = LineIndex::new(trimmed, skipped);
        let root = doc.root_element();
        let at = |node: roxmltree::Node| lines.line(node.range().start);
        if root.tag_name().name() == "scene" {
            if let Some(v) = root.attribute("version") {
                if !(v.starts_with("3.") || v.starts_with("2.")) {
                    return Err(Error::input(
                        &path,
                        format!("line {}, <scene version=\"{v}\">", at(root)),
                        "plsr reads Mitsuba 2 and 3 scenes (version 2.x or 3.x); upgrade \
                         older ones with Mitsuba 3 (`mitsuba.xml.upgrade`?) or by hand",
                    ));
                }
            }
            if index == 0 {
                let mut scene = self.element(index, root, &lines)?;
                scene.children = self.children(index, root, &lines, chain, true)?;
                return Ok(vec![scene]);
            }
            return self.children(index, root, &lines, chain, true);
        }
        if index == 0 {
            // Not a scene: the caller names the fault.
            return Ok(vec![self.element(index, root, &lines)?]);
        }
        let mut object = self.element(index, root, &lines)?;
        object.children = self.children(index, root, &lines, chain, false)?;
        Ok(vec![object])
    }

    /// `node` without its children, its attributes substituted.
    pub(super) fn element(
        &mut self,
        file: usize,
        node: roxmltree::Node,
        lines: &LineIndex,
    ) -> Result<Element> {
        let line = lines.line(node.range().start);
        let mut attributes = Vec::new();
        for a in node.attributes() {
            let value = self.substitute(file, line, node.tag_name().name(), a.value())?;
            attributes.push((a.name().to_string(), value));
        }
        self.next_key += 1;
        Ok(Element {
            tag: node.tag_name().name().to_string(),
            attributes,
            children: Vec::new(),
            file,
            line,
            key: self.next_key,
        })
    }

    /// The child elements of `node`, with the structural tags carried out
    /// (`in_root`: `node` is a file's `<scene>`, where `<path>` may be).
    pub(super) fn children(
        &mut self,
        file: usize,
        node: roxmltree::Node,
        lines: &LineIndex,
        chain: &[usize],
        in_root: bool,
    ) -> Result<Vec<Element>> {
        let mut out = Vec::new();
        for c in node.children().filter(|c| c.is_element()) {
            let mut e = self.element(file, c, lines)?;
            let where_ = |e: &Element| format!("line {}, <{}>", e.line, e.tag);
            match e.tag.as_str() {
                "default" => {
                    let name = e.attribute("name").unwrap_or_default().to_string();
                    let value = e.attribute("value").map(str::to_string).ok_or_else(|| {
                        Error::input(&self.files[file], where_(&e), "`value` is required")
                    })?;
                    if !is_parameter_name(&name) {
                        return Err(Error::input(
                            &self.files[file],
                            where_(&e),
                            format!(
                                "name=\"{name}\": a parameter's name is letters, digits \
                                 and `_`"
                            ),
                        ));
                    }
                    if !self.parameters.iter().any(|p| p.name == name) {
                        self.parameters.push(Parameter {
                            name,
                            value,
                            from_command_line: false,
                            used: false,
                        });
                    }
                }
                "path" => {
                    if !in_root {
                        return Err(Error::input(
                            &self.files[file],
                            where_(&e),
                            "<path> belongs directly inside the <scene>",
                        ));
                    }
                    self.add_search_folder(file, &e)?;
                }
                "include" => {
                    let mut included = self.include(file, &e, chain)?;
                    if let (Some(name), [object]) = (e.attribute("name"), included.as_mut_slice()) {
                        // `<include name="bsdf" …>` names the object it brings.
                        if object.attribute("name").is_none() {
                            object.attributes.push(("name".into(), name.to_string()));
                        }
                    }
                    out.append(&mut included);
                }
                _ => {
                    e.children = self.children(file, c, lines, chain, false)?;
                    out.push(e);
                }
            }
        }
        Ok(out)
    }

    /// Where a name given in file `file` is looked for, in order: the
    /// file's own folder, the search list, the scene's folder.
    fn search_order(&self, file: usize) -> impl Iterator<Item = PathBuf> + '_ {
        std::iter::once(self.folders[file].clone())
            .chain(self.search.iter().cloned())
            .chain(std::iter::once(PathBuf::new()))
    }

    /// `<path value>`: the folder, relative to the file it is in, else
    /// searched for, goes to the front of the search list.
    pub(super) fn add_search_folder(&mut self, file: usize, e: &Element) -> Result<()> {
        let at = format!("line {}, <path>", e.line);
        let value = e
            .attribute("value")
            .ok_or_else(|| Error::input(&self.files[file], &at, "`value` is required"))?;
        let v = Path::new(value);
        let found = if v.is_absolute() {
            Some(v.to_path_buf()).filter(|p| p.is_dir())
        } else {
            self.search_order(file)
                .map(|f| join_lexically(&f, v))
                .find(|rel| self.base.join(rel).is_dir())
        };
        let folder = found.ok_or_else(|| {
            Error::input(
                &self.files[file],
                &at,
                format!(
                    "the folder \"{value}\" does not exist (relative to {})",
                    display_folder(&shown_path(&self.base, &self.folders[file]))
                ),
            )
        })?;
        self.search.insert(0, folder);
        Ok(())
    }

    /// `<include filename>`: the included file's elements.
    pub(super) fn include(
        &mut self,
        file: usize,
        e: &Element,
        chain: &[usize],
    ) -> Result<Vec<Element>> {
        let at = format!("line {}, <include>", e.line);
        let here = &self.files[file];
        let name = e
            .attribute("filename")
            .ok_or_else(|| Error::input(here, &at, "`filename` is required"))?;
        if chain.len() > MAX_INCLUDE_DEPTH {
            return Err(Error::input(
                here,
                &at,
                format!("includes nested more than {MAX_INCLUDE_DEPTH} deep (Mitsuba's limit)"),
            ));
        }
        let name_path = Path::new(name);
        let rel = if name_path.is_absolute() {
            name_path.to_path_buf()
        } else {
            self.search_order(file)
                .map(|f| join_lexically(&f, name_path))
                .find(|rel| self.base.join(rel).is_file())
                .ok_or_else(|| {
                    Error::input(
                        here,
                        &at,
                        format!(
                            "the included file \"{name}\" was not found (searched in {})",
                            self.search_order(file)
                                .map(|f| display_folder(&shown_path(&self.base, &f)))
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    )
                })?
        };
        let full = shown_path(&self.base, &rel);
        let shown = full;
        let canonical =
            std::fs::canonicalize(&shown).map_err(|source| Error::io(&shown, source))?;
        if let Some(first) = chain.iter().position(|&f| self.canonical[f] == canonical) {
            let mut names: Vec<String> = chain[first..]
                .iter()
                .map(|&f| self.files[f].display().to_string())
                .collect();
            names.push(shown.display().to_string());
            return Err(Error::input(
                here,
                &at,
                format!("an include loop: {}", names.join(" → ")),
            ));
        }
        crate::input::check_input_file(&shown)?;
        let size = std::fs::metadata(&shown)
            .map_err(|source| Error::io(&shown, source))?
            .len();
        if size > MAX_FILE_BYTES {
            return Err(Error::input(
                &shown,
                "",
                format!("{size} bytes: larger than plsr reads as a scene ({MAX_FILE_BYTES})"),
            ));
        }
        let text =
            crate::input::read_text_lenient(&shown).map_err(|source| Error::io(&shown, source))?;
        let index = self.files.len();
        self.files.push(shown);
        self.canonical.push(canonical);
        self.folders
            .push(rel.parent().map(Path::to_path_buf).unwrap_or_default());
        let mut inner = chain.to_vec();
        inner.push(index);
        self.parse_file(index, &text, &inner)
    }

    /// `value` (an attribute of a `<tag>` at `line` of `file`) with every
    /// `$name` replaced by its parameter, the longest names first.
    pub(super) fn substitute(
        &mut self,
        file: usize,
        line: u32,
        tag: &str,
        value: &str,
    ) -> Result<String> {
        if !value.contains('$') {
            return Ok(value.to_string());
        }
        let at = || format!("line {line}, <{tag}>");
        let mut out = String::new();
        let mut rest = value;
        while let Some(i) = rest.find('$') {
            let escaped = rest[..i].ends_with('\\');
            out.push_str(&rest[..i - usize::from(escaped)]);
            let after = &rest[i + 1..];
            if escaped {
                out.push('$');
                rest = after;
                continue;
            }
            let len = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            let word = &after[..len];
            // The longest parameter whose name starts the word.
            let best = self
                .parameters
                .iter_mut()
                .filter(|p| word.starts_with(p.name.as_str()))
                .max_by_key(|p| p.name.len());
            let Some(p) = best else {
                return Err(Error::input(
                    &self.files[file],
                    at(),
                    format!(
                        "`${word}` has no value: give it a <default name=\"{word}\" \
                         value=\"…\"/> before this line, or `-D {word}=…`"
                    ),
                ));
            };
            p.used = true;
            if out.len() + p.value.len() > MAX_VALUE_BYTES
                || self.expanded + p.value.len() > MAX_EXPANDED_BYTES
            {
                return Err(Error::input(
                    &self.files[file],
                    at(),
                    format!(
                        "substituting `${}` makes the value longer than plsr accepts \
                         ({MAX_VALUE_BYTES} bytes per value, {MAX_EXPANDED_BYTES} in all): \
                         are <default>s defined through each other?",
                        p.name
                    ),
                ));
            }
            self.expanded += p.value.len();
            out.push_str(&p.value);
            rest = &after[p.name.len()..];
        }
        out.push_str(rest);
        Ok(out)
    }
}

/// Whether `name` can be a parameter's name.
fn is_parameter_name(name: &str) -> bool {
    !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// `folder/name` with `.` dropped and `..` taking back a named folder
/// (lexically: the scene's own notation, not the file system's).
fn join_lexically(folder: &Path, name: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in folder.components().chain(name.components()) {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                let last_is_named =
                    matches!(out.components().next_back(), Some(Component::Normal(_)));
                if last_is_named {
                    out.pop();
                } else {
                    out.push("..");
                }
            }
            other => out.push(other.as_os_str()),
        }
    }
    out
}

/// `rel` (relative to the scene's folder `base`, or absolute) as messages
/// show it: without a leading `./`.
fn shown_path(base: &Path, rel: &Path) -> PathBuf {
    if base == Path::new(".") {
        rel.to_path_buf()
    } else {
        base.join(rel)
    }
}

/// A folder as messages show it.
fn display_folder(p: &Path) -> String {
    if p.as_os_str().is_empty() {
        ".".into()
    } else {
        p.display().to_string()
    }
}

/// The deepest nesting of `text`'s elements, without building a tree (so
/// that a hostile file cannot exhaust the stack of what reads the tree):
/// `Err(line)` where it passes [`MAX_NESTING`].
fn check_nesting(text: &str) -> std::result::Result<(), u32> {
    let bytes = text.as_bytes();
    let mut depth = 0usize;
    let mut line = 1u32;
    let mut i = 0;
    while i < bytes.len() {
        match bytes[i] {
            b'\n' => line += 1,
            b'<' => {
                let rest = &bytes[i..];
                let skip_to = |end: &[u8]| {
                    rest.windows(end.len())
                        .position(|w| w == end)
                        .map(|p| p + end.len())
                        .unwrap_or(rest.len())
                };
                let n = if rest.starts_with(b"<!--") {
                    skip_to(b"-->")
                } else if rest.starts_with(b"<![CDATA[") {
                    skip_to(b"]]>")
                } else if rest.starts_with(b"<?") {
                    skip_to(b"?>")
                } else if rest.starts_with(b"<!") {
                    skip_to(b">")
                } else if rest.starts_with(b"</") {
                    depth = depth.saturating_sub(1);
                    skip_to(b">")
                } else {
                    let n = tag_end(rest);
                    if !(n >= 2 && rest[n - 2] == b'/') {
                        depth += 1;
                        if depth > MAX_NESTING {
                            return Err(line);
                        }
                    }
                    n
                };
                line += rest[..n].iter().filter(|&&b| b == b'\n').count() as u32;
                i += n;
                continue;
            }
            _ => {}
        }
        i += 1;
    }
    Ok(())
}

/// The length of the start tag at the front of `rest` (up to its `>`,
/// outside quoted attribute values).
fn tag_end(rest: &[u8]) -> usize {
    let mut quote = None;
    for (i, &b) in rest.iter().enumerate() {
        match (quote, b) {
            (None, b'"' | b'\'') => quote = Some(b),
            (Some(q), _) if b == q => quote = None,
            (None, b'>') => return i + 1,
            _ => {}
        }
    }
    rest.len()
}

/// Byte offsets to line numbers of one file's text.
struct LineIndex {
    starts: Vec<usize>,
    skipped: u32,
}

impl LineIndex {
    pub(super) fn new(text: &str, skipped: u32) -> LineIndex {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        LineIndex { starts, skipped }
    }

    pub(super) fn line(&self, at: usize) -> u32 {
        let i = self.starts.partition_point(|&s| s <= at);
        i as u32 + self.skipped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    pub(super) fn paths_join_lexically() {
        let j = |a: &str, b: &str| join_lexically(Path::new(a), Path::new(b));
        assert_eq!(j("", "x.ply"), PathBuf::from("x.ply"));
        assert_eq!(
            j("../../common", "meshes/a.ply"),
            PathBuf::from("../../common/meshes/a.ply")
        );
        assert_eq!(j("include", "../x"), PathBuf::from("x"));
        assert_eq!(j("a/./b", "../../../c"), PathBuf::from("../c"));
        assert_eq!(j("/abs/dir", "../f"), PathBuf::from("/abs/f"));
    }

    #[test]
    pub(super) fn nesting_is_measured_without_a_tree() {
        assert_eq!(check_nesting("<a><b/><c x='>'>t</c></a>"), Ok(()));
        let deep = "<a>".repeat(MAX_NESTING + 1);
        assert_eq!(check_nesting(&deep), Err(1));
        let fine = format!(
            "{}{}",
            "<a>".repeat(MAX_NESTING),
            "</a>".repeat(MAX_NESTING)
        );
        assert_eq!(check_nesting(&fine), Ok(()));
        assert_eq!(check_nesting("<!-- <a><a><a> -->\n<b/>"), Ok(()));
    }

    #[test]
    pub(super) fn lines_are_counted_from_one_after_skipped_blank_lines() {
        let l = LineIndex::new("ab\ncd\n", 2);
        assert_eq!(l.line(0), 3);
        assert_eq!(l.line(3), 4);
    }
}
