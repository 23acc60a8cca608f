//! plsr's error type: every failure names what it was working on.

use std::fmt;
use std::path::PathBuf;

/// Any error plsr reports.
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
    /// Embree reported an error.
    Embree(EmbreeError),
    /// A value passed through the API is invalid.
    InvalidArgument(String),
    /// The render was cancelled by its progress callback.
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
            Error::Embree(e) => write!(f, "{e}"),
            Error::InvalidArgument(m) => write!(f, "invalid argument: {m}"),
            Error::Cancelled => write!(f, "render cancelled"),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Io { source, .. } => Some(source),
            Error::Embree(e) => Some(e),
            _ => None,
        }
    }
}

impl From<EmbreeError> for Error {
    fn from(e: EmbreeError) -> Error {
        Error::Embree(e)
    }
}

/// An error reported by Embree: its error code and message. Defined here,
/// below the renderer that calls Embree, so that [`Error`] can carry it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EmbreeError {
    /// Embree's `RTCError` code (1 = unknown, 2 = invalid argument, 3 = invalid
    /// operation, 4 = out of memory, 5 = unsupported CPU, 6 = cancelled).
    pub code: u32,
    /// Embree's message, or a description of the failing call.
    pub message: String,
}

impl fmt::Display for EmbreeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self.code {
            1 => "unknown error",
            2 => "invalid argument",
            3 => "invalid operation",
            4 => "out of memory",
            5 => "unsupported CPU",
            6 => "cancelled",
            _ => "error",
        };
        write!(f, "Embree {name}: {}", self.message)
    }
}

impl std::error::Error for EmbreeError {}

/// plsr's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
