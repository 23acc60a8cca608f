//! Writing output files without ever leaving a partial one behind, and
//! several outputs of one command together or not at all ([`OutputSet`]).
//!
//! Every output is written under a hidden temporary name in its folder,
//! `.STEM.HOST.PID.N.partial.EXT` ([`partial_path`]), and renamed into
//! place when complete. The temporaries this process is writing are
//! registered, so that a signal handler can remove them
//! ([`remove_partial_outputs`]); those of processes that died without
//! cleaning up (`kill -9`, a power cut) are swept the next time an output
//! of the same name is written on the same host ([`sweep_stale_partials`]).

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard};

/// Numbers the temporaries of one process, so that no two share a name.
static PARTIAL_COUNTER: AtomicU64 = AtomicU64::new(0);

/// The temporaries this process is writing now.
static LIVE_PARTIALS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn live_partials() -> MutexGuard<'static, Vec<PathBuf>> {
    // A panic while holding the lock leaves a list that is still valid.
    LIVE_PARTIALS.lock().unwrap_or_else(|e| e.into_inner())
}

/// This machine's name as it appears in temporary names: letters, digits
/// and `-` only, at most 32 of them (`host` where none is known).
fn host_tag() -> &'static str {
    static TAG: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    TAG.get_or_init(|| {
        let name = std::fs::read_to_string("/proc/sys/kernel/hostname")
            .ok()
            .or_else(|| std::env::var("HOSTNAME").ok())
            .unwrap_or_default();
        let tag: String = name
            .trim()
            .chars()
            .filter(|c| c.is_ascii_alphanumeric() || *c == '-')
            .take(32)
            .collect();
        if tag.is_empty() {
            "host".into()
        } else {
            tag
        }
    })
}

/// The temporary name an output `path` is written under before being
/// renamed into place: hidden, in the same folder, with the same extension
/// (OpenImageIO picks the format from it), naming this host and process.
pub fn partial_path(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    let n = PARTIAL_COUNTER.fetch_add(1, Ordering::Relaxed);
    path.with_file_name(format!(
        ".{stem}.{}.{}.{n}.partial{ext}",
        host_tag(),
        std::process::id()
    ))
}

/// Records that this process is writing the temporary `tmp` (before it
/// is created), so that [`remove_partial_outputs`] can remove it.
pub fn register_partial(tmp: &Path) {
    live_partials().push(tmp.to_path_buf());
}

/// Forgets `tmp` once it was renamed into place or removed.
pub fn forget_partial(tmp: &Path) {
    let mut live = live_partials();
    if let Some(i) = live.iter().position(|p| p == tmp) {
        live.swap_remove(i);
    }
}

/// Removes every temporary this process is writing. For a signal
/// handler's thread (`plsr` calls it on SIGINT, SIGTERM and SIGHUP) just
/// before the process ends; the lock stays held, so no new temporary is
/// registered afterwards. Returns how many were removed.
pub fn remove_partial_outputs() -> usize {
    let mut live = live_partials();
    let mut removed = 0;
    for tmp in live.drain(..) {
        if remove_partial(&tmp) {
            removed += 1;
        }
    }
    // Held until the process ends: a writer about to register waits.
    std::mem::forget(live);
    removed
}

/// Removes a temporary output, a file or a staging folder; whether it did.
fn remove_partial(tmp: &Path) -> bool {
    match std::fs::symlink_metadata(tmp) {
        Ok(m) if m.is_dir() => std::fs::remove_dir_all(tmp).is_ok(),
        Ok(_) => std::fs::remove_file(tmp).is_ok(),
        Err(_) => false,
    }
}

/// The process id in a temporary name of `target` written on this host
/// (`.STEM.HOST.PID.N.partial.EXT`), if `name` is one.
fn partial_owner(name: &str, target: &Path) -> Option<u32> {
    let stem = target.file_stem()?.to_string_lossy();
    let ext = target
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    let rest = name
        .strip_prefix(&format!(".{stem}.{}.", host_tag()))?
        .strip_suffix(&format!(".partial{ext}"))?;
    let (pid, n) = rest.split_once('.')?;
    if n.is_empty() || !n.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    pid.parse().ok()
}

/// Whether process `pid` of this host is running (on systems without
/// `/proc`, every process counts as running: nothing is swept).
fn process_is_running(pid: u32) -> bool {
    if !Path::new("/proc/self").exists() {
        return true;
    }
    Path::new("/proc").join(pid.to_string()).exists()
}

/// Removes the temporaries of `target` left by processes of this host that
/// are no longer running (killed while writing it); returns how many. Those
/// of running processes and of other hosts (a shared folder) are kept.
pub fn sweep_stale_partials(target: &Path) -> usize {
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name.to_str().and_then(|n| partial_owner(n, target)) else {
            continue;
        };
        if pid != std::process::id() && !process_is_running(pid) && remove_partial(&entry.path()) {
            removed += 1;
        }
    }
    removed
}

/// Writes `path` by calling `write` on a temporary file in the same folder
/// (opened for reading and writing) and renaming it into place only when
/// `write` succeeded; on failure the temporary file is removed and `path` is
/// untouched.
pub fn write_atomically<E: From<Error>>(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> std::result::Result<(), E>,
) -> std::result::Result<(), E> {
    // A set of one output: staged, then renamed; on failure its drop
    // removes the temporary file.
    let mut outputs = OutputSet::new();
    outputs.stage(path, write)?;
    Ok(outputs.commit()?)
}

/// Bytes free to an unprivileged writer on the file system holding
/// `path`'s folder; `None` where it cannot be asked.
pub fn free_space(path: &Path) -> Option<u64> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        let cdir = std::ffi::CString::new(dir.as_os_str().as_bytes()).ok()?;
        let mut stat = std::mem::MaybeUninit::<libc::statvfs>::uninit();
        // SAFETY: `cdir` is a NUL-terminated path alive for the call and
        // `stat` is writable storage of the struct statvfs fills; it is
        // read only after the call reported success.
        let stat = unsafe {
            if libc::statvfs(cdir.as_ptr(), stat.as_mut_ptr()) != 0 {
                return None;
            }
            stat.assume_init()
        };
        Some((stat.f_bavail as u64).saturating_mul(stat.f_frsize as u64))
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        None
    }
}

/// The message for a failed write of `path` that needs up to `needed`
/// bytes: "no space left on device" when its folder has less free than
/// that (the writing library's own message is often only "could not
/// open"), otherwise `message` with the temporary name `tmp` replaced by
/// `path`.
pub fn write_failure_message(path: &Path, tmp: &Path, needed: u64, message: &str) -> String {
    match free_space(path) {
        Some(free) if free < needed => {
            format!("no space left on device: {free} bytes free, the file needs up to {needed}")
        }
        _ => message.replace(&tmp.display().to_string(), &path.display().to_string()),
    }
}

/// An output named with another format's extension. Its text does not
/// repeat the path; callers put it in front.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WrongExtension {
    /// The format that would be written ("OpenEXR").
    pub format: String,
    /// The extension it needs, without the dot.
    pub wanted: String,
    /// The extension the path has (empty if none).
    pub got: String,
}

impl std::fmt::Display for WrongExtension {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let WrongExtension {
            format,
            wanted,
            got,
        } = self;
        if got.is_empty() {
            write!(
                f,
                "writes {format}; name the file `.{wanted}` (it has no extension)"
            )
        } else {
            write!(
                f,
                "writes {format}; name the file `.{wanted}` (got `.{got}`)"
            )
        }
    }
}

impl std::error::Error for WrongExtension {}

/// Checks that `path` ends in `.extension` (any case), the format
/// `format` that will be written: no file is ever written under the name
/// of another format.
pub fn check_extension(
    path: &Path,
    extension: &str,
    format: &str,
) -> std::result::Result<(), WrongExtension> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    if ext.eq_ignore_ascii_case(extension) {
        Ok(())
    } else {
        Err(WrongExtension {
            format: format.into(),
            wanted: extension.into(),
            got: ext.into(),
        })
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
    /// untouched until [`OutputSet::commit`]. `write` may fail with any
    /// error enum that holds this crate's [`Error`].
    pub fn stage<E: From<Error>>(
        &mut self,
        path: &Path,
        write: impl FnOnce(&mut BufWriter<File>) -> std::result::Result<(), E>,
    ) -> std::result::Result<(), E> {
        sweep_stale_partials(path);
        let tmp = partial_path(path);
        let io_err = |source| Error::Io {
            file: path.to_path_buf(),
            source,
        };
        // Recorded first, so that a failure below (or a signal) still
        // removes it. Opened readable too, so that a writer can fix up what
        // it wrote.
        register_partial(&tmp);
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
        Ok(file.sync_all().map_err(io_err)?)
    }

    /// Stages `bytes` as the future `path` (see [`OutputSet::stage`]).
    pub fn stage_bytes(&mut self, path: &Path, bytes: &[u8]) -> Result<()> {
        self.stage(path, |w| {
            w.write_all(bytes).map_err(|source| Error::Io {
                file: path.to_path_buf(),
                source,
            })
        })
    }

    /// Stages `img` encoded as PNG as the future `path`.
    pub fn stage_png(&mut self, path: &Path, img: &image::RgbImage) -> Result<()> {
        let mut bytes = Vec::new();
        img.write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map_err(|e| Error::Output {
            file: path.to_path_buf(),
            message: e.to_string(),
        })?;
        self.stage_bytes(path, &bytes)
    }

    /// Takes over `tmp`, a complete temporary file written (and registered
    /// with [`register_partial`]) by another writer, to be renamed to
    /// `path` at commit.
    pub fn adopt(&mut self, tmp: PathBuf, path: PathBuf) {
        self.staged.push((tmp, path));
    }

    /// Renames every staged file into place, in the order staged. A target
    /// that is a folder (the one way a rename fails that checking ahead
    /// can see) stops the commit before anything is renamed.
    pub fn commit(mut self) -> Result<()> {
        if let Some((_, path)) = self.staged.iter().find(|(_, p)| p.is_dir()) {
            return Err(Error::Output {
                file: path.clone(),
                message: "is a folder, not a file".into(),
            });
        }
        while !self.staged.is_empty() {
            let (tmp, path) = &self.staged[0];
            if let Err(source) = std::fs::rename(tmp, path) {
                // Those renamed are in place; the rest are removed on drop.
                return Err(Error::Io {
                    file: path.clone(),
                    source,
                });
            }
            forget_partial(tmp);
            self.staged.remove(0);
        }
        Ok(())
    }
}

impl Drop for OutputSet {
    fn drop(&mut self) {
        for (tmp, _) in &self.staged {
            let _ = std::fs::remove_file(tmp);
            forget_partial(tmp);
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
    fn partials_are_named_and_registered() {
        let dir = std::env::temp_dir().join(format!("plsr-live-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("pano.exr");
        let tmp = partial_path(&target);
        let name = tmp.file_name().unwrap().to_str().unwrap().to_owned();
        assert!(
            name.starts_with(".pano.") && name.ends_with(".partial.exr"),
            "{name}"
        );
        assert_eq!(partial_owner(&name, &target), Some(std::process::id()));
        register_partial(&tmp);
        std::fs::write(&tmp, "half a panorama").unwrap();
        // Forgotten ones stay (they were renamed into place).
        let kept = partial_path(&target);
        register_partial(&kept);
        forget_partial(&kept);
        std::fs::write(&kept, "x").unwrap();
        let live = live_partials().clone();
        assert!(live.contains(&tmp) && !live.contains(&kept));
        // What a signal handler removes: this one, by `remove_partial`
        // (calling `remove_partial_outputs` here would lock the list for
        // good; crates/cli/tests/it/bad_output.rs signals a real merge instead).
        forget_partial(&tmp);
        assert!(remove_partial(&tmp));
        assert!(!tmp.exists() && kept.exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn only_stale_partials_of_this_host_are_swept() {
        let dir = std::env::temp_dir().join(format!("plsr-sweep-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("pano.exr");
        let host = host_tag();
        // Linux pids stay below 2^22: 99999999 is never running.
        let dead = dir.join(format!(".pano.{host}.99999999.0.partial.exr"));
        let dead_dir = dir.join(format!(".pano.{host}.99999998.3.partial.exr"));
        let alive = dir.join(format!(".pano.{host}.{}.7.partial.exr", std::process::id()));
        let other_host = dir.join(".pano.elsewhere-0.99999999.0.partial.exr");
        let other_name = dir.join(format!(".panorama.{host}.99999999.0.partial.exr"));
        let not_ours = dir.join(format!(".pano.{host}.99999999.x.partial.exr"));
        for f in [&dead, &alive, &other_host, &other_name, &not_ours] {
            std::fs::write(f, "x").unwrap();
        }
        std::fs::create_dir(&dead_dir).unwrap();
        std::fs::write(dead_dir.join("truth.exr"), "x").unwrap();
        assert_eq!(sweep_stale_partials(&target), 2);
        assert!(!dead.exists() && !dead_dir.exists());
        for f in [&alive, &other_host, &other_name, &not_ours] {
            assert!(f.exists(), "{} was swept", f.display());
        }
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
        set.stage::<Error>(&a, |w| {
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
        set.stage::<Error>(&a, |w| {
            w.write_all(b"new a").unwrap();
            Ok(())
        })
        .unwrap();
        set.stage::<Error>(&b, |w| {
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
