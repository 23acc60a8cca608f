//! The errors of reading and writing images through OpenImageIO.

use std::path::PathBuf;

/// A failure of this crate: OpenImageIO could not be loaded, or refused to
/// read or write a file (with its own message), or a shared fault.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad input, an unreadable file, an invalid argument.
    #[error(transparent)]
    Base(#[from] plsr_base::Error),
    /// OpenImageIO (through plsr's shim) could not be loaded to read `file`
    /// (an output it cannot write is a [`Error::Write`]).
    #[error("{}: {reason}", file.display())]
    Unavailable {
        /// The image plsr was about to read.
        file: PathBuf,
        /// Why the shim could not be loaded.
        reason: LoadFailure,
    },
    /// OpenImageIO could not read `file`.
    #[error("{}: {message}", file.display())]
    Read {
        /// The image.
        file: PathBuf,
        /// OpenImageIO's message.
        message: String,
    },
    /// OpenImageIO could not write `file`.
    #[error("{}: {message}", file.display())]
    Write {
        /// The output image.
        file: PathBuf,
        /// OpenImageIO's message (a full disk said as such).
        message: String,
    },
}

/// Why the OpenImageIO shim could not be loaded.
#[derive(Debug, Clone, thiserror::Error)]
pub enum LoadFailure {
    /// The embedded library could not be put where `dlopen` maps it from.
    #[error(
        "OpenImageIO could not be loaded ({0}); install it \
         (Debian: apt-get install libopenimageio-dev)"
    )]
    Staging(String),
    /// `dlopen` refused the library (OpenImageIO missing): its message.
    #[error(
        "OpenImageIO could not be loaded ({0}); install it \
         (Debian: apt-get install libopenimageio-dev)"
    )]
    Dlopen(String),
    /// The shim lacks one of its functions.
    #[error("the OpenImageIO shim lacks {name}: {dl_error}")]
    MissingSymbol {
        /// The function's name.
        name: String,
        /// `dlerror`'s message.
        dl_error: String,
    },
}

/// This crate's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
