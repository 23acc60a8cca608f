//! Writing a fitted scene: the scene file with the fitted values in place
//! and everything else (comments, order, formatting) kept, through
//! `toml_edit` (TOML) or as re-serialised JSON; PLS lights whose `b` or `c`
//! were fitted get a fitted copy of their PLS file beside the scene.

use super::params::{Owner, Parameter};
use crate::error::{Error, Result};
use plsr::scene::Scene;
use plsr_base::Vocabulary;
use serde_json::Value as Json;
use std::path::{Path, PathBuf};

/// A list of edits: `(where, new value)`.
type Edits = Vec<(Vec<Seg>, NewValue)>;

/// One step into a document: a key or an array index.
#[derive(Debug, Clone, PartialEq)]
enum Seg {
    Key(String),
    Index(usize),
}

/// A value to write.
#[derive(Debug, Clone, PartialEq)]
enum NewValue {
    Number(f64),
    List(Vec<f64>),
    Text(String),
    /// The key is removed (a circle light whose outline was fitted).
    Remove,
}

/// Rounds a fitted number for the file: 6 significant digits.
fn round(v: f32) -> f64 {
    let v = v as f64;
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let digits = 6 - v.abs().log10().ceil() as i32;
    let scale = 10f64.powi(digits);
    (v * scale).round() / scale
}

fn new_value(values: &[f32]) -> NewValue {
    match values {
        [v] => NewValue::Number(round(*v)),
        many => NewValue::List(many.iter().map(|v| round(*v)).collect()),
    }
}

/// The file a scene file or PLS file is, parsed as JSON values (TOML
/// converted) for finding entries by name.
fn parse(path: &Path, text: &str) -> Result<Json> {
    let json = is_json(path);
    if json {
        serde_json::from_str(text).map_err(|e| Error::input(path, "", e.to_string()))
    } else {
        toml::from_str(text).map_err(|e| Error::input(path, "", e.message().to_string()))
    }
}

fn is_json(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
}

/// Index of the entry of array `key` whose `name` is `name`.
fn find_named(doc: &Json, key: &str, name: &str) -> Option<usize> {
    doc.get(key)?
        .as_array()?
        .iter()
        .position(|e| e.get("name").and_then(Json::as_str) == Some(name))
}

/// Applies `edits` to a document's text, keeping everything else: TOML
/// through `toml_edit`, JSON re-serialised (pretty).
fn edit(path: &Path, text: &str, edits: &[(Vec<Seg>, NewValue)]) -> Result<String> {
    if is_json(path) {
        let mut doc = parse(path, text)?;
        for (segs, value) in edits {
            if *value == NewValue::Remove {
                let Some((Seg::Key(last), parents)) = segs.split_last() else {
                    continue;
                };
                let mut node = Some(&mut doc);
                for s in parents {
                    node = node.and_then(|n| match s {
                        Seg::Key(k) => n.get_mut(k),
                        Seg::Index(i) => n.get_mut(*i),
                    });
                }
                if let Some(Json::Object(m)) = node {
                    m.remove(last);
                }
                continue;
            }
            let mut node = &mut doc;
            for s in segs {
                node = match s {
                    Seg::Key(k) => {
                        if !node.is_object() {
                            *node = Json::Object(Default::default());
                        }
                        node.as_object_mut()
                            .expect("made an object")
                            .entry(k.clone())
                            .or_insert(Json::Null)
                    }
                    Seg::Index(i) => match node.get_mut(*i) {
                        Some(n) => n,
                        None => return Err(Error::input(path, "", format!("no entry {i}"))),
                    },
                };
            }
            *node = match value {
                NewValue::Number(v) => serde_json::json!(v),
                NewValue::List(t) => serde_json::json!(t),
                NewValue::Text(s) => Json::String(s.clone()),
                NewValue::Remove => unreachable!("handled above"),
            };
        }
        let mut out = serde_json::to_string_pretty(&doc)
            .map_err(|e| Error::input(path, "", e.to_string()))?;
        out.push('\n');
        return Ok(out);
    }
    let mut doc: toml_edit::DocumentMut = text
        .parse()
        .map_err(|e: toml_edit::TomlError| Error::input(path, "", e.message().to_string()))?;
    for (segs, value) in edits {
        set_in_table(doc.as_table_mut(), segs, value)
            .map_err(|m| Error::input(path, field_name(segs), m.to_string()))?;
    }
    Ok(doc.to_string())
}

/// The dotted field of a path (`materials[2].roughness`).
fn field_name(segs: &[Seg]) -> String {
    let mut out = String::new();
    for s in segs {
        match s {
            Seg::Key(k) => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(k);
            }
            Seg::Index(i) => out.push_str(&format!("[{i}]")),
        }
    }
    out
}

/// The TOML value of a fitted value, keeping `old`'s comments and spacing.
fn toml_value(value: &NewValue, old: Option<&toml_edit::Value>) -> toml_edit::Value {
    let mut v = match value {
        NewValue::Number(x) => toml_edit::Value::from(*x),
        NewValue::List(t) => toml_edit::Value::Array(t.iter().copied().collect()),
        NewValue::Text(s) => toml_edit::Value::from(s.as_str()),
        NewValue::Remove => unreachable!("removals do not reach toml_value"),
    };
    if let Some(old) = old {
        *v.decor_mut() = old.decor().clone();
    }
    v
}

/// Why a fitted value could not be set at its path in the scene file. Its
/// text follows the path.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NotSettable {
    /// An array of tables has no entry of this index.
    #[error("has no entry {0}")]
    NoEntry(usize),
    /// The path stops at an array of tables.
    #[error("is an array of tables")]
    ArrayOfTables,
    /// An array has no inline table at this index.
    #[error("has no table at {0}")]
    NoTableAt(usize),
    /// The path stops at an array.
    #[error("is an array")]
    Array,
    /// The path goes through a value that is not a table.
    #[error("is not a table")]
    NotATable,
    /// The path goes through a key that is not an inline table.
    #[error("`{0}` is not an inline table")]
    NotInline(String),
    /// The path does not end in a field.
    #[error("is not a field")]
    NotAField,
}

fn set_in_table(
    t: &mut toml_edit::Table,
    segs: &[Seg],
    value: &NewValue,
) -> std::result::Result<(), NotSettable> {
    match segs {
        [Seg::Key(k)] if *value == NewValue::Remove => {
            t.remove(k);
            Ok(())
        }
        [Seg::Key(k)] => {
            let old = t.get(k).and_then(toml_edit::Item::as_value).cloned();
            t.insert(k, toml_edit::Item::Value(toml_value(value, old.as_ref())));
            Ok(())
        }
        [Seg::Key(k), rest @ ..] => {
            if !t.contains_key(k) {
                t.insert(k, toml_edit::table());
            }
            match t.get_mut(k) {
                Some(toml_edit::Item::Table(sub)) => set_in_table(sub, rest, value),
                Some(toml_edit::Item::ArrayOfTables(a)) => match rest {
                    [Seg::Index(i), rest @ ..] => match a.get_mut(*i) {
                        Some(sub) => set_in_table(sub, rest, value),
                        None => Err(NotSettable::NoEntry(*i)),
                    },
                    _ => Err(NotSettable::ArrayOfTables),
                },
                Some(toml_edit::Item::Value(toml_edit::Value::InlineTable(it))) => {
                    set_in_inline(it, rest, value)
                }
                Some(toml_edit::Item::Value(toml_edit::Value::Array(arr))) => match rest {
                    [Seg::Index(i), rest @ ..] => match arr.get_mut(*i) {
                        Some(toml_edit::Value::InlineTable(it)) => set_in_inline(it, rest, value),
                        _ => Err(NotSettable::NoTableAt(*i)),
                    },
                    _ => Err(NotSettable::Array),
                },
                _ => Err(NotSettable::NotATable),
            }
        }
        _ => Err(NotSettable::NotAField),
    }
}

fn set_in_inline(
    t: &mut toml_edit::InlineTable,
    segs: &[Seg],
    value: &NewValue,
) -> std::result::Result<(), NotSettable> {
    match segs {
        [Seg::Key(k)] if *value == NewValue::Remove => {
            t.remove(k);
            Ok(())
        }
        [Seg::Key(k)] => {
            let old = t.get(k).cloned();
            t.insert(k, toml_value(value, old.as_ref()));
            Ok(())
        }
        [Seg::Key(k), rest @ ..] => match t.get_mut(k) {
            Some(toml_edit::Value::InlineTable(sub)) => set_in_inline(sub, rest, value),
            _ => Err(NotSettable::NotInline(k.clone())),
        },
        _ => Err(NotSettable::NotAField),
    }
}

/// A fitted scene, ready to be written: the scene file's new text and the
/// fitted PLS files it now names.
#[derive(Debug, Clone, PartialEq)]
pub struct FittedFiles {
    /// The fitted scene file's text.
    pub scene: String,
    /// `(path, text)` of each fitted PLS file.
    pub pls: Vec<(PathBuf, String)>,
}

/// The path `original` (relative to the scene's folder) as the fitted scene
/// in `out_dir` should name it: unchanged when both scenes are in one
/// folder or it is absolute, else relative to `out_dir` (absolute where
/// the two share nothing but the root). `out_dir` need not exist yet.
fn path_from(out_dir: &Path, scene_dir: &Path, original: &str) -> Option<String> {
    if Path::new(original).is_absolute() {
        return None;
    }
    let out_abs = absolute_dir(out_dir)?;
    let scene_abs = std::fs::canonicalize(scene_dir).ok()?;
    if out_abs == scene_abs {
        return None;
    }
    let target = std::fs::canonicalize(scene_abs.join(original))
        .unwrap_or_else(|_| scene_abs.join(original));
    let rel = plsr_base::paths::relative_between(&out_abs, &target);
    Some(rel.to_string_lossy().replace('\\', "/"))
}

/// `dir` made absolute through its nearest existing ancestor (symbolic
/// links resolved there), the rest appended as given.
fn absolute_dir(dir: &Path) -> Option<PathBuf> {
    let mut existing = dir.to_path_buf();
    let mut rest = Vec::new();
    loop {
        if let Ok(abs) = std::fs::canonicalize(&existing) {
            let mut out = abs;
            for part in rest.iter().rev() {
                out.push(part);
            }
            return Some(out);
        }
        rest.push(existing.file_name()?.to_os_string());
        existing = match existing.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
    }
}

/// The fitted scene: `scene_path`'s text with every parameter's value in
/// its field, the relative paths it names rewritten relative to `out`'s
/// folder when that is another, and PLS files with fitted `b` or `c` copied beside `out`
/// (`OUT-STEM.pls-N.EXT`) with the fitted values.
pub fn fitted_files(
    scene_path: &Path,
    scene: &Scene,
    params: &[Parameter],
    out: &Path,
) -> Result<FittedFiles> {
    let text = std::fs::read_to_string(scene_path)
        .map_err(|source| Error::io(scene_path.to_path_buf(), source))?;
    let doc = parse(scene_path, &text)?;
    let scene_dir = scene_path.parent().unwrap_or(Path::new("."));
    let out_dir = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut edits: Edits = Vec::new();
    let key = |k: &str| Seg::Key(k.to_string());
    // PLS files: table index → (its file, its edits).
    let mut pls_edits: Vec<(usize, Edits)> = Vec::new();
    for p in params {
        let value = new_value(&p.value);
        match &p.owner {
            Owner::Material(i) => {
                let name = &scene.materials()[*i].name;
                let k = find_named(&doc, "materials", name).ok_or_else(|| {
                    Error::input(
                        scene_path,
                        "materials",
                        format!("no material named `{name}`"),
                    )
                })?;
                edits.push((vec![key("materials"), Seg::Index(k), key(p.field)], value));
            }
            Owner::PointLight(i) => {
                edits.push((vec![key("lights"), Seg::Index(*i), key(p.field)], value));
            }
            Owner::Shape(mesh) => {
                let k = scene.meshes()[*mesh].object_id as usize;
                edits.push((vec![key("shapes"), Seg::Index(k), key(p.field)], value));
            }
            Owner::Environment => edits.push((vec![key("environment"), key("scale")], value)),
            Owner::Pls { table, light, .. } => {
                let e = match pls_edits.iter_mut().find(|(t, _)| t == table) {
                    Some(e) => e,
                    None => {
                        pls_edits.push((*table, Vec::new()));
                        pls_edits.last_mut().expect("just pushed")
                    }
                };
                let mut segs = vec![key("lights"), Seg::Index(*light)];
                segs.extend(p.field.split('.').map(key));
                e.1.push((segs, value));
            }
        }
    }
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "fitted".into());
    let mut pls = Vec::new();
    for (table, e) in &pls_edits {
        let file = doc
            .get("pls")
            .and_then(|a| a.get(table))
            .and_then(|t| t.get("file"))
            .and_then(Json::as_str)
            .ok_or_else(|| Error::input(scene_path, format!("pls[{table}].file"), "is missing"))?;
        let src = scene_dir.join(file);
        let src_text =
            std::fs::read_to_string(&src).map_err(|source| Error::io(src.clone(), source))?;
        let ext = src
            .extension()
            .map(|e| e.to_string_lossy().into_owned())
            .unwrap_or_else(|| "toml".into());
        let name = format!("{stem}.pls-{table}.{ext}");
        // A light given as a `circle` keeps it (its radius; its axis ends
        // follow `n`); one given by its outline gets `e1`, `e2`, `d`. A
        // circle whose shape was fitted (the edits then hold `alpha1`) is
        // no circle any more: it gets the explicit outline instead.
        let src_doc = parse(&src, &src_text)?;
        let shaped = |k: usize| {
            e.iter().any(|(segs, _)| {
                matches!(segs.as_slice(), [_, Seg::Index(j), Seg::Key(f)] if *j == k && f == "alpha1")
            })
        };
        let is_circle = |k: usize| {
            !shaped(k)
                && src_doc
                    .get("lights")
                    .and_then(|l| l.get(k))
                    .and_then(|l| l.get("circle"))
                    .is_some()
        };
        let mut e: Edits = e
            .iter()
            .filter(|(segs, _)| match segs.as_slice() {
                [_, Seg::Index(k), Seg::Key(f)] if f == "e1" || f == "e2" || f == "d" => {
                    !is_circle(*k)
                }
                [_, Seg::Index(k), Seg::Key(f), _] if f == "circle" => is_circle(*k),
                _ => true,
            })
            .cloned()
            .collect();
        for k in 0..src_doc
            .get("lights")
            .and_then(Json::as_array)
            .map_or(0, Vec::len)
        {
            if shaped(k) {
                e.push((
                    vec![key("lights"), Seg::Index(k), key("circle")],
                    NewValue::Remove,
                ));
            }
        }
        let fitted = edit(&src, &src_text, &e)?;
        pls.push((out_dir.join(&name), fitted));
        edits.push((
            vec![key("pls"), Seg::Index(*table), key("file")],
            NewValue::Text(name),
        ));
    }
    // Other relative paths keep naming the same files from the new folder.
    let fitted_pls: Vec<usize> = pls_edits.iter().map(|(t, _)| *t).collect();
    for (segs, original) in relative_paths(&doc) {
        if matches!(segs.as_slice(), [Seg::Key(k), Seg::Index(t), _] if k == "pls" && fitted_pls.contains(t))
        {
            continue;
        }
        if let Some(p) = path_from(out_dir, scene_dir, &original) {
            edits.push((segs, NewValue::Text(p)));
        }
    }
    Ok(FittedFiles {
        scene: edit(scene_path, &text, &edits)?,
        pls,
    })
}

/// The fields of a scene file that name other files: every `file` key,
/// and `photo.response` / `views[i].photo.response` when a CSV.
fn relative_paths(doc: &Json) -> Vec<(Vec<Seg>, String)> {
    let mut out = Vec::new();
    fn walk(v: &Json, at: &mut Vec<Seg>, out: &mut Vec<(Vec<Seg>, String)>) {
        match v {
            Json::Object(m) => {
                for (k, x) in m {
                    at.push(Seg::Key(k.clone()));
                    match x {
                        Json::String(s)
                            if k == "file"
                                || k == "mtl"
                                || k.ends_with("_map")
                                || (k == "response"
                                    && s.to_ascii_lowercase().ends_with(".csv")) =>
                        {
                            out.push((at.clone(), s.clone()))
                        }
                        _ => walk(x, at, out),
                    }
                    at.pop();
                }
            }
            Json::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    at.push(Seg::Index(i));
                    walk(x, at, out);
                    at.pop();
                }
            }
            _ => {}
        }
    }
    walk(doc, &mut Vec::new(), &mut out);
    out
}

/// The scene file's `environment.scale` (1 when absent).
pub fn environment_scale(scene_path: &Path) -> Result<f32> {
    let text = std::fs::read_to_string(scene_path)
        .map_err(|source| Error::io(scene_path.to_path_buf(), source))?;
    let doc = parse(scene_path, &text)?;
    Ok(doc
        .get("environment")
        .and_then(|e| e.get("scale"))
        .and_then(Json::as_f64)
        .unwrap_or(1.0) as f32)
}
