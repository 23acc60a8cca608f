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

mod bsdf;
mod conductors;
mod document;
mod emitter;
mod params;
mod scene;
mod sensor;
mod shape;
pub mod spectrum;
mod table;
mod texture;
mod translator;

pub use document::{MAX_EXPANDED_BYTES, MAX_FILE_BYTES, MAX_NESTING, MAX_VALUE_BYTES};

use crate::error::{Error, Result};
use document::Document;
use plsr_base::Vocabulary;
use std::path::{Path, PathBuf};
use translator::Translator;

/// A translated scene: plsr's TOML, and what was approximated.
#[derive(Debug, Clone)]
pub struct Translation {
    /// The scene in plsr's format (paths as the XML gave them, relative to
    /// the XML file's folder).
    pub toml: String,
    /// One line per approximation, naming the element and its line.
    pub notes: Vec<String>,
    /// The files the scene included (`<include>`), which it is made of
    /// as much as of the scene file.
    pub included: Vec<PathBuf>,
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

/// How a Mitsuba scene is read: what `mitsuba`'s command line would add.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Options {
    /// Parameters, as `mitsuba -D name=value` gives them: they take the
    /// place of the scene's `<default>` of the same name, and each must be
    /// used by some `$name`.
    pub defines: Vec<(String, String)>,
    /// `--anim-time SECONDS`: when the scene is a glTF file rendered on its
    /// own, the time its animations are shown at (0 when `None`); refused
    /// for other scenes (a scene file's `gltf` shape has its own `time`).
    pub time: Option<f32>,
}

/// Translates the Mitsuba 3 scene `text` (read from `path`, which errors
/// name) into plsr's scene format. File names are relative to the scene's
/// folder.
pub fn translate(path: &Path, text: &str) -> Result<Translation> {
    translate_with(path, text, &Options::default())
}

/// [`translate`] with the command line's `options`.
pub fn translate_with(path: &Path, text: &str, options: &Options) -> Result<Translation> {
    translate_into(path, text, options, None)
}

/// [`translate_with`] for a scene file to be written into the folder
/// `out_dir`: relative file names are rewritten to name the same files
/// from there (absolute if `out_dir` is another folder).
pub fn translate_for(
    path: &Path,
    text: &str,
    options: &Options,
    out_dir: &Path,
) -> Result<Translation> {
    let here = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let same = match (std::fs::canonicalize(here), std::fs::canonicalize(out_dir)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    if same {
        return translate_into(path, text, options, None);
    }
    let base =
        std::fs::canonicalize(here).map_err(|source| Error::io(here.to_path_buf(), source))?;
    translate_into(path, text, options, Some(base))
}

fn translate_into(
    path: &Path,
    text: &str,
    options: &Options,
    rebase: Option<PathBuf>,
) -> Result<Translation> {
    let doc = Document::load(path, text, &options.defines)?;
    let mut t = Translator::new(&doc, rebase);
    t.notes = doc.notes.clone();
    t.collect_ids(&doc.root)?;
    t.scene(&doc.root)?;
    Ok(Translation {
        toml: t.finish(),
        notes: std::mem::take(&mut t.notes),
        included: doc.files[1..].to_vec(),
    })
}
