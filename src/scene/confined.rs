//! The one rule for files a scene file names (a glTF's buffers and images,
//! an OBJ's MTL libraries and textures): they resolve inside the folder of
//! the file that names them, after symbolic links are followed, and are
//! regular files. Absolute paths, `..` escapes, links out of the folder,
//! folders, devices and FIFOs are refused, so that a downloaded asset
//! cannot make plsr read, say, `/etc/passwd` or `/dev/zero` as its data.
//! See `docs/errors.md`.

use std::path::{Component, Path, PathBuf};

/// `name` (a relative path, already decoded from any URI escapes) resolved
/// inside the canonical folder `folder`, symbolic links followed, naming a
/// regular file; or why not, in words that follow the name in an error.
/// `owner` says whose files these are (`"a glTF's"`, `"an OBJ's"`).
pub(crate) fn confined_path(
    folder: &Path,
    name: &str,
    owner: &str,
) -> std::result::Result<PathBuf, String> {
    let relative = Path::new(name);
    if name.is_empty() {
        return Err("is empty".into());
    }
    let drive =
        name.len() >= 2 && name.as_bytes()[1] == b':' && name.as_bytes()[0].is_ascii_alphabetic();
    if relative.has_root() || name.starts_with('\\') || drive {
        return Err(format!(
            "is an absolute path: {owner} files must be inside its folder (copy the file there and \
             name it relative to it)"
        ));
    }
    if relative.components().any(|c| c == Component::ParentDir) {
        return Err(format!(
            "climbs out with `..`: {owner} files must be inside its folder"
        ));
    }
    let joined = folder.join(relative);
    let resolved = joined.canonicalize().map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => format!("not found ({})", joined.display()),
        _ => format!("cannot be opened ({}): {e}", joined.display()),
    })?;
    if !resolved.starts_with(folder) {
        return Err(format!(
            "is a link to {}, outside {owner} folder",
            resolved.display()
        ));
    }
    let meta = std::fs::metadata(&resolved).map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err("is not a regular file (a folder, device or FIFO)".into());
    }
    Ok(resolved)
}

#[cfg(test)]
mod tests {
    use super::confined_path;

    #[test]
    fn names_outside_the_folder_are_refused_before_anything_is_read() {
        let dir = tempfile::tempdir().unwrap();
        let folder = dir.path().canonicalize().unwrap();
        std::fs::create_dir(folder.join("tex")).unwrap();
        std::fs::write(folder.join("tex/a.png"), b"x").unwrap();
        assert_eq!(
            confined_path(&folder, "tex/a.png", "an OBJ's").unwrap(),
            folder.join("tex/a.png")
        );
        for (name, fault) in [
            ("/etc/passwd", "absolute path"),
            ("C:\\textures\\a.png", "absolute path"),
            ("\\\\server\\share\\a.png", "absolute path"),
            ("../a.png", "climbs out"),
            ("tex/../../a.png", "climbs out"),
            ("tex", "not a regular file"),
            ("gone.png", "not found"),
            ("", "is empty"),
        ] {
            let e = confined_path(&folder, name, "an OBJ's").unwrap_err();
            assert!(e.contains(fault), "{name}: {e}");
        }
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink("/etc/hostname", folder.join("link.png")).unwrap();
            let e = confined_path(&folder, "link.png", "an OBJ's").unwrap_err();
            assert!(e.contains("outside an OBJ's folder"), "{e}");
            std::os::unix::fs::symlink("/dev/zero", folder.join("zero.bin")).unwrap();
            let e = confined_path(&folder, "zero.bin", "an OBJ's").unwrap_err();
            assert!(e.contains("outside"), "{e}");
        }
    }
}
