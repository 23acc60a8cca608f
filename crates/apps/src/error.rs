//! The errors of the applications: every library below them, and the
//! applications' own faults.

/// A failure of an application (capture, composite, fit, the experiment).
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad input, an unreadable file, an invalid argument, cancelled work.
    #[error(transparent)]
    Base(#[from] plsr_base::Error),
    /// The renderer failed (a scene, Embree).
    #[error(transparent)]
    Render(#[from] plsr::Error),
    /// The HDR toolkit failed (brackets, a response curve, an image).
    #[error(transparent)]
    Hdr(#[from] plsr_hdr::Error),
    /// An image could not be read or written through OpenImageIO.
    #[error(transparent)]
    Image(#[from] plsr_hdr::oiio::Error),
    /// A metric could not be computed.
    #[error(transparent)]
    Metrics(#[from] plsr_metrics::Error),
}

/// This crate's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
