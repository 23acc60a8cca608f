//! Writing output files without ever leaving a partial one behind, and
//! several outputs of one command together or not at all ([`OutputSet`]).

use crate::error::{Error, Result};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// The temporary name `path` is written under before being renamed into place.
fn temporary_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.partial", std::process::id()))
}

/// Writes `path` by calling `write` on a temporary file in the same folder
/// (opened for reading and writing) and renaming it into place only when
/// `write` succeeded; on failure the temporary file is removed and `path` is
/// untouched.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<()>,
) -> Result<()> {
    // A set of one output: staged, then renamed; on failure its drop
    // removes the temporary file.
    let mut outputs = OutputSet::new();
    outputs.stage(path, write)?;
    outputs.commit()
}

/// Checks that `path` ends in `.extension` (any case), the format
/// `format` that will be written: no file is ever written under the name
/// of another format. The message does not repeat the path.
pub fn check_extension(
    path: &Path,
    extension: &str,
    format: &str,
) -> std::result::Result<(), String> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    if ext.eq_ignore_ascii_case(extension) {
        Ok(())
    } else {
        Err(format!(
            "writes {format}; name the file `.{extension}` (got `.{ext}`)"
        ))
    }
}

/// `path` with its folder's links resolved (and the file's own, where it
/// exists); `None` where the folder does not exist.
fn resolved(path: &Path) -> Option<PathBuf> {
    if let Ok(p) = std::fs::canonicalize(path) {
        return Some(p);
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    Some(std::fs::canonicalize(dir).ok()?.join(path.file_name()?))
}

/// Whether `a` and `b` name the same file once links are resolved (an
/// output that would replace an input).
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (resolved(a), resolved(b)) {
        (Some(a), Some(b)) => a == b,
        _ => false,
    }
}

/// The outputs of one command, written to temporary files first and
/// renamed into place together by [`OutputSet::commit`], after every one
/// was written: a failure while writing any of them leaves every target
/// untouched. Dropped uncommitted, it removes its temporary files.
#[derive(Debug, Default)]
pub struct OutputSet {
    /// (temporary file, target) of each staged output.
    staged: Vec<(PathBuf, PathBuf)>,
}

impl OutputSet {
    /// An empty set.
    pub fn new() -> OutputSet {
        OutputSet::default()
    }

    /// Writes the future `path` by calling `write` on a temporary file in
    /// the same folder (opened for reading and writing); `path` itself is
    /// untouched until [`OutputSet::commit`].
    pub fn stage(
        &mut self,
        path: &Path,
        write: impl FnOnce(&mut BufWriter<File>) -> Result<()>,
    ) -> Result<()> {
        let tmp = temporary_path(path);
        let io_err = |source| Error::Io {
            file: path.to_path_buf(),
            source,
        };
        // Recorded first, so that a failure below still removes it. Opened
        // readable too, so that a writer can fix up what it wrote.
        self.staged.push((tmp.clone(), path.to_path_buf()));
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(&tmp)
            .map_err(io_err)?;
        let mut w = BufWriter::new(file);
        write(&mut w)?;
        let file = w.into_inner().map_err(|e| io_err(e.into_error()))?;
        file.sync_all().map_err(io_err)
    }

    /// Renames every staged file into place, in the order staged.
    pub fn commit(mut self) -> Result<()> {
        while !self.staged.is_empty() {
            let (tmp, path) = &self.staged[0];
            if let Err(source) = std::fs::rename(tmp, path) {
                // Those renamed are in place; the rest are removed on drop.
                return Err(Error::Io {
                    file: path.clone(),
                    source,
                });
            }
            self.staged.remove(0);
        }
        Ok(())
    }
}

impl Drop for OutputSet {
    fn drop(&mut self) {
        for (tmp, _) in &self.staged {
            let _ = std::fs::remove_file(tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn same_file_sees_through_links_and_relative_paths() {
        let dir = std::env::temp_dir().join(format!("plsr-same-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let f = dir.join("scene.toml");
        std::fs::write(&f, "x").unwrap();
        assert!(same_file(&f, &dir.join("sub/../scene.toml")));
        #[cfg(unix)]
        {
            let link = dir.join("link.toml");
            let _ = std::fs::remove_file(&link);
            std::os::unix::fs::symlink(&f, &link).unwrap();
            assert!(same_file(&f, &link));
        }
        assert!(!same_file(&f, &dir.join("other.exr")));
        assert!(same_file(&dir.join("new.exr"), &dir.join("sub/../new.exr")));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn outputs_are_committed_together_or_not_at_all() {
        let dir = std::env::temp_dir().join(format!("plsr-outputs-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (a, b) = (dir.join("a.txt"), dir.join("b.txt"));
        std::fs::write(&a, "old a").unwrap();
        // The second output fails: neither target changes, no temporary stays.
        let mut set = OutputSet::new();
        set.stage(&a, |w| {
            w.write_all(b"new a").unwrap();
            Ok(())
        })
        .unwrap();
        let failed = set.stage(&b, |_| Err(Error::InvalidArgument("cannot write b".into())));
        assert!(failed.is_err());
        drop(set);
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "old a");
        assert!(!b.exists());
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert_eq!(left.len(), 1, "only a.txt remains");
        // Both succeed: both are replaced at commit, not before.
        let mut set = OutputSet::new();
        set.stage(&a, |w| {
            w.write_all(b"new a").unwrap();
            Ok(())
        })
        .unwrap();
        set.stage(&b, |w| {
            w.write_all(b"new b").unwrap();
            Ok(())
        })
        .unwrap();
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "old a");
        set.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "new a");
        assert_eq!(std::fs::read_to_string(&b).unwrap(), "new b");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
