//! The shared vocabulary of plsr's errors: every failure names what it was
//! working on. Each library crate above this one has its own error enum
//! holding this one (`#[from]`) beside its own faults; [`Vocabulary`] gives
//! those enums the same constructors.

use std::fmt;
use std::path::PathBuf;

/// A failure every crate can meet: bad input, a file that cannot be read
/// or written, an invalid argument, cancelled work.
#[derive(Debug)]
pub enum Error {
    /// Bad input: the file, the field (a path such as `shapes[2].transform.scale`,
    /// empty when the fault is not in one field) and what is wrong.
    Input {
        /// The offending file.
        file: PathBuf,
        /// The field, as a dotted path; empty if none applies.
        field: String,
        /// What is wrong with it.
        message: String,
    },
    /// A file could not be read or written.
    Io {
        /// The file.
        file: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// An output could not be produced.
    Output {
        /// The output file.
        file: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A value passed through the API is invalid; the message is a whole
    /// sentence (shown as it is, without a prefix naming the variant).
    InvalidArgument(String),
    /// Long work (a render, a fit) was cancelled by its progress callback.
    Cancelled,
}

impl Error {
    /// An [`Error::Input`] for `file`, `field`, `message`.
    pub fn input(
        file: impl Into<PathBuf>,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Error {
        Error::Input {
            file: file.into(),
            field: field.into(),
            message: message.into(),
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Input {
                file,
                field,
                message,
            } => {
                if field.is_empty() {
                    write!(f, "{}: {message}", file.display())
                } else {
                    write!(f, "{}: {field}: {message}", file.display())
                }
            }
            Error::Io { file, source } => write!(f, "{}: {source}", file.display()),
            Error::Output { file, message } => write!(f, "{}: {message}", file.display()),
            Error::InvalidArgument(m) => write!(f, "{m}"),
            Error::Cancelled => write!(f, "render cancelled"),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

/// plsr's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The constructors of [`Error`] on any error enum that holds it, so that a
/// crate's own enum is built as `Error::input(file, field, message)` like
/// the vocabulary itself.
pub trait Vocabulary: From<Error> {
    /// Bad input: `file`, `field` (dotted path, or empty), what is wrong.
    fn input(
        file: impl Into<PathBuf>,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        Error::input(file, field, message).into()
    }
    /// `file` could not be read or written.
    fn io(file: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            file: file.into(),
            source,
        }
        .into()
    }
    /// The output `file` could not be produced.
    fn output(file: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Error::Output {
            file: file.into(),
            message: message.into(),
        }
        .into()
    }
    /// A value passed through the API or on the command line is invalid.
    fn invalid_argument(message: impl Into<String>) -> Self {
        Error::InvalidArgument(message.into()).into()
    }
    /// Long work was cancelled by its progress callback.
    fn cancelled() -> Self {
        Error::Cancelled.into()
    }
}

impl<E: From<Error>> Vocabulary for E {}
