//! Test scenes written into a temporary folder.

use std::path::{Path, PathBuf};

/// `tests/data/cornell-64.toml` (the Cornell box at 64×64) written to
/// `dir/name` with its mesh by absolute path, its `[camera]` table replaced
/// by `camera` where one is given, and `extra` (e.g. a `[film]` table)
/// appended.
pub fn cornell_64(dir: &Path, name: &str, camera: Option<&str>, extra: &str) -> PathBuf {
    let mut text = std::fs::read_to_string("tests/data/cornell-64.toml").unwrap();
    if let Some(camera) = camera {
        let start = text.find("[camera]").unwrap();
        let end = start + text[start..].find("\n\n").unwrap();
        text = format!("{}{camera}{}", &text[..start], &text[end..]);
    }
    let assets = std::fs::canonicalize("assets").unwrap();
    let text = text.replace(
        "\"../../assets/",
        &format!("\"{}/", assets.to_str().unwrap()),
    );
    let path = dir.join(name);
    std::fs::write(&path, format!("{text}{extra}")).unwrap();
    path
}
