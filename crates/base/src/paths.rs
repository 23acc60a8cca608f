//! Paths between files that name each other: a file written in one folder
//! that names a file elsewhere (a farm plan naming its scene, a fitted
//! scene naming its photos).

use std::path::{Path, PathBuf};

/// `to` as seen from the folder `from`, both absolute and normalised
/// (canonical): `..` for each folder of `from` past their common part,
/// then the rest of `to`. `to` itself when they share nothing but the root.
pub fn relative_between(from: &Path, to: &Path) -> PathBuf {
    let common = from
        .components()
        .zip(to.components())
        .take_while(|(a, b)| a == b)
        .count();
    if common <= 1 {
        return to.to_path_buf();
    }
    let mut rel = PathBuf::new();
    for _ in from.components().skip(common) {
        rel.push("..");
    }
    for c in to.components().skip(common) {
        rel.push(c);
    }
    rel
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_between_folders() {
        let r = |a: &str, b: &str| relative_between(Path::new(a), Path::new(b));
        assert_eq!(r("/a/b/out", "/a/b/photo.exr"), Path::new("../photo.exr"));
        assert_eq!(r("/a/b", "/a/b/c/d.obj"), Path::new("c/d.obj"));
        assert_eq!(r("/a/x/y", "/a/b/c.png"), Path::new("../../b/c.png"));
        assert_eq!(r("/a", "/b/c.png"), Path::new("/b/c.png"));
    }
}
