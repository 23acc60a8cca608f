//! The renderer's errors: the shared vocabulary of [`plsr_base::Error`]
//! (bad input naming file and field, I/O, outputs, invalid arguments,
//! cancellation) and what only the renderer meets: Embree's failures.
//!
//! A module's own checks return small typed faults (a texture that does
//! not decode, a PLY header it cannot read, an exposure out of range);
//! the scene reader puts them into an [`Error`] naming the scene file and
//! the field that named them.

use std::fmt;

/// A failure of the renderer.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad input, an unreadable file, an output that could not be made, an
    /// invalid argument, a cancelled render.
    #[error(transparent)]
    Base(#[from] plsr_base::Error),
    /// Embree reported an error.
    #[error(transparent)]
    Embree(#[from] EmbreeError),
    /// The denoiser refused its input (pixels that are not finite).
    #[error("cannot denoise: {0}")]
    Denoise(#[from] plsr_denoise::FilterError),
}

/// The renderer's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// An error reported by Embree: its error code and message.
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

/// What is wrong with a file of a mesh, image or scene format (PLY, OBJ,
/// MTL, glTF, an environment image): it cannot be read, or its content is
/// not what the format allows (the text says where: the line, the element).
/// The scene reader puts it into an [`Error`] naming the scene file's field.
#[derive(Debug, thiserror::Error)]
pub enum FormatError {
    /// The file could not be read.
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// The content breaks the format, or a limit of plsr's.
    #[error("{0}")]
    Content(String),
}

impl From<String> for FormatError {
    fn from(message: String) -> FormatError {
        FormatError::Content(message)
    }
}

impl From<&str> for FormatError {
    fn from(message: &str) -> FormatError {
        FormatError::Content(message.into())
    }
}
