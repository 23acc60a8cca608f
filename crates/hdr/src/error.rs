//! The errors of the HDR toolkit.

/// A failure of the HDR toolkit: an image OpenImageIO could not read or
/// write, one of its own parse faults, or a shared fault (bad brackets, an
/// unreadable file, an invalid option).
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad input, an unreadable file, an invalid argument.
    #[error(transparent)]
    Base(#[from] plsr_base::Error),
    /// OpenImageIO could not be loaded, or could not read or write an image.
    #[error(transparent)]
    Image(#[from] plsr_oiio::Error),
}

/// An exposure time that could not be parsed (`1/30`, `0.5`, `15` are
/// valid).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BadExposure {
    /// The text is not a number or a fraction.
    #[error("{0:?} is not a number")]
    NotANumber(String),
    /// The number is zero, negative or not finite.
    #[error("{0:?} is not a positive exposure time")]
    NotPositive(String),
}

/// A response method's name that is not one of plsr's.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("unknown response method {0:?} (expected debevec, robertson, linear or srgb)")]
pub struct UnknownResponseMethod(pub String);

/// Why no exposures could be planned for an image.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NoExposurePlan {
    /// Every pixel is black.
    #[error("the image has no light (every pixel is black): nothing to expose for")]
    NoLight,
}

/// This crate's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
