//! `plsr import`: a Mitsuba 3 XML scene translated into plsr's scene
//! format (TOML), checked by building it, written or printed.

use crate::error::{Error, Result};
use plsr::atomic_write::{check_extension, same_file, write_atomically};
use plsr_base::Vocabulary;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Arguments of `plsr import`.
#[derive(Debug, clap::Args)]
pub struct ImportArgs {
    /// The Mitsuba 3 scene (XML).
    #[arg(value_name = "SCENE.xml")]
    pub input: PathBuf,
    /// The plsr scene file to write (TOML); printed if not given. File
    /// names in it are rewritten to name the same files from its folder.
    #[arg(short, long, value_name = "OUT.toml")]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub params: crate::scene_params::SceneParams,
}

/// Runs `plsr import`.
pub fn run(a: &ImportArgs) -> Result<()> {
    plsr::input::check_input_file(&a.input)?;
    let bytes = std::fs::read(&a.input).map_err(|source| Error::io(a.input.clone(), source))?;
    if !plsr::scene::mitsuba::looks_like_xml(&a.input, &bytes) {
        return Err(Error::input(
            &a.input,
            "",
            "not XML: `plsr import` translates Mitsuba 3 scenes (.xml)",
        ));
    }
    let text = String::from_utf8(bytes).map_err(|_| {
        Error::input(
            &a.input,
            "",
            "not UTF-8 text (a Mitsuba 3 XML scene was expected)",
        )
    })?;
    // Building the scene checks everything the translation names (meshes,
    // textures, values) before anything is written.
    let contents = plsr::scene::file::load_contents_with(&a.input, &a.params.options())?;
    let translation = match &a.output {
        Some(out) => {
            check_extension(out, "toml", "a plsr scene (TOML)")
                .map_err(|m| Error::invalid_argument(format!("-o {}: {m}", out.display())))?;
            if same_file(out, &a.input) || contents.inputs.iter().any(|i| same_file(out, i)) {
                return Err(Error::invalid_argument(format!(
                    "-o {}: would replace the scene or a file it reads",
                    out.display()
                )));
            }
            let dir = match out.parent() {
                Some(d) if !d.as_os_str().is_empty() => d,
                _ => Path::new("."),
            };
            plsr::scene::mitsuba::translate_for(&a.input, &text, &a.params.options(), dir)?
        }
        None => plsr::scene::mitsuba::translate_with(&a.input, &text, &a.params.options())?,
    };
    for n in &translation.notes {
        eprintln!("note: {n}");
    }
    match &a.output {
        Some(out) => {
            write_atomically(out, |w| {
                w.write_all(translation.toml.as_bytes())
                    .map_err(|source| Error::io(out.clone(), source))
            })?;
            eprintln!("wrote {}", out.display());
        }
        None => print!("{}", translation.toml),
    }
    Ok(())
}
