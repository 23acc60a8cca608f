//! The files a command reads: each is checked to be a regular file before
//! it is opened, so that a folder, a FIFO or a device named as an input
//! gets a clear message instead of "not found" or a read that never ends.

use std::path::Path;

/// Why a path named as an input is not a readable regular file. Its text
/// does not repeat the path; callers put it in front.
#[derive(Debug)]
pub enum NotAFile {
    /// The path names a folder.
    Folder,
    /// The path names a FIFO, a socket or a device.
    Special,
    /// Nothing exists at the path.
    NotFound,
    /// The path's metadata cannot be read (permissions, a broken link, …).
    Unreadable(std::io::Error),
}

impl std::fmt::Display for NotAFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NotAFile::Folder => f.write_str("is a folder, not a file"),
            NotAFile::Special => f.write_str("is not a regular file (a FIFO, socket or device)"),
            NotAFile::NotFound => f.write_str("not found"),
            NotAFile::Unreadable(e) => write!(f, "cannot be read: {e}"),
        }
    }
}

impl std::error::Error for NotAFile {}

/// Checks that `path` names an existing regular file (after following
/// links).
pub fn check_regular_file(path: &Path) -> std::result::Result<(), NotAFile> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => Ok(()),
        Ok(m) if m.is_dir() => Err(NotAFile::Folder),
        Ok(_) => Err(NotAFile::Special),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err(NotAFile::NotFound),
        Err(e) => Err(NotAFile::Unreadable(e)),
    }
}

/// [`check_regular_file`] as a plsr error: a path that does not exist or
/// cannot be read is an I/O error (as opening it would give), a folder or a
/// special file is an input error naming it.
pub fn check_input_file(path: &Path) -> crate::error::Result<()> {
    match std::fs::metadata(path) {
        Err(source) => Err(crate::error::Error::Io {
            file: path.to_path_buf(),
            source,
        }),
        Ok(_) => check_regular_file(path)
            .map_err(|m| crate::error::Error::input(path, "", m.to_string())),
    }
}

/// Reads a text file that should be UTF-8 but may come from older tools
/// in Latin-1 (ISO 8859-1): valid UTF-8 is kept, anything else is decoded
/// byte for byte as Latin-1, so that an accented comment never stops a load.
pub fn read_text_lenient(path: &Path) -> std::io::Result<String> {
    let bytes = std::fs::read(path)?;
    Ok(match String::from_utf8(bytes) {
        Ok(s) => s,
        Err(e) => e.into_bytes().iter().map(|&b| b as char).collect(),
    })
}

/// Fixed-length arrays in input files, read strictly: the `toml` crate
/// reads `[1, 2, 3, 4]` into a `[f32; 3]` by dropping the last number, so
/// every fixed-length field of plsr's files goes through these instead
/// (`#[serde(deserialize_with = "crate::input::exact::array")]`).
pub mod exact {
    use serde::de::{Deserialize, Deserializer, Error, SeqAccess, Visitor};
    use std::marker::PhantomData;

    /// Exactly `N` values.
    pub fn array<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
    where
        D: Deserializer<'de>,
        T: Deserialize<'de>,
    {
        Ok(Exact::<T, N>::deserialize(d)?.0)
    }

    /// An optional array of exactly `N` values (with `default`: absent is
    /// `None`).
    pub fn option<'de, D, T, const N: usize>(d: D) -> Result<Option<[T; N]>, D::Error>
    where
        D: Deserializer<'de>,
        T: Deserialize<'de>,
    {
        Ok(Option::<Exact<T, N>>::deserialize(d)?.map(|e| e.0))
    }

    /// An optional `R × C` matrix, row by row.
    pub fn option_matrix<'de, D, const R: usize, const C: usize>(
        d: D,
    ) -> Result<Option<[[f32; C]; R]>, D::Error>
    where
        D: Deserializer<'de>,
    {
        let rows = Option::<Exact<Exact<f32, C>, R>>::deserialize(d)?;
        Ok(rows.map(|rows| rows.0.map(|row| row.0)))
    }

    /// `N` values, no more and no fewer.
    struct Exact<T, const N: usize>([T; N]);

    impl<'de, T: Deserialize<'de>, const N: usize> Deserialize<'de> for Exact<T, N> {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            d.deserialize_seq(ExactVisitor::<T, N>(PhantomData))
        }
    }

    struct ExactVisitor<T, const N: usize>(PhantomData<T>);

    impl<'de, T: Deserialize<'de>, const N: usize> Visitor<'de> for ExactVisitor<T, N> {
        type Value = Exact<T, N>;

        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            // serde's own words for a fixed-size array.
            write!(f, "an array of length {N}")
        }

        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
            let mut values = Vec::with_capacity(N);
            while let Some(v) = seq.next_element::<T>()? {
                values.push(v);
            }
            let n = values.len();
            values
                .try_into()
                .map(Exact)
                .map_err(|_| A::Error::invalid_length(n, &self))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_of_path_get_their_own_message() {
        let dir = std::env::temp_dir().join(format!("plsr-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("a.txt");
        std::fs::write(&file, "x").unwrap();
        assert!(check_regular_file(&file).is_ok());
        let folder = check_regular_file(&dir).unwrap_err();
        assert!(matches!(folder, NotAFile::Folder));
        assert_eq!(folder.to_string(), "is a folder, not a file");
        let missing = check_regular_file(&dir.join("missing")).unwrap_err();
        assert!(matches!(missing, NotAFile::NotFound));
        assert_eq!(missing.to_string(), "not found");
        #[cfg(unix)]
        {
            let device = check_regular_file(Path::new("/dev/null")).unwrap_err();
            assert!(matches!(device, NotAFile::Special));
            assert!(device.to_string().contains("not a regular file"));
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn arrays_of_the_wrong_length_are_refused() {
        #[derive(serde::Deserialize, Debug)]
        struct T {
            #[serde(deserialize_with = "exact::array")]
            a: [f32; 3],
            #[serde(default, deserialize_with = "exact::option")]
            b: Option<[f32; 3]>,
            #[serde(default, deserialize_with = "exact::option_matrix")]
            m: Option<[[f32; 2]; 2]>,
        }
        let t: T = toml::from_str("a = [1, 2, 3]\nm = [[1, 2], [3, 4]]").unwrap();
        assert_eq!(
            (t.a, t.b, t.m),
            ([1.0, 2.0, 3.0], None, Some([[1.0, 2.0], [3.0, 4.0]]))
        );
        for bad in [
            "a = [1, 2, 3, 4]",
            "a = [1, 2]",
            "a = [1, 2, 3]\nb = [1, 2, 3, 4]",
            "a = [1, 2, 3]\nm = [[1, 2, 3], [3, 4]]",
            "a = [1, 2, 3]\nm = [[1, 2]]",
        ] {
            let e = toml::from_str::<T>(bad).unwrap_err().to_string();
            assert!(e.contains("invalid length"), "{bad}: {e}");
        }
    }

    #[test]
    fn latin1_text_is_decoded_byte_for_byte() {
        let dir = std::env::temp_dir().join(format!("plsr-latin1-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("a.obj");
        std::fs::write(&file, b"# caf\xe9\nv 1 2 3\n").unwrap();
        assert_eq!(read_text_lenient(&file).unwrap(), "# café\nv 1 2 3\n");
        std::fs::write(&file, "# café\n").unwrap();
        assert_eq!(read_text_lenient(&file).unwrap(), "# café\n");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
