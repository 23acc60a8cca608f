//! The program's error: whatever any library reported, printed once at the
//! edge as `plsr: error: …` (see `main`).

/// A failure of a `plsr` command.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad input, an unreadable file, an invalid option, cancelled work.
    #[error(transparent)]
    Base(#[from] plsr_base::Error),
    /// The renderer failed (a scene, Embree).
    #[error(transparent)]
    Render(#[from] plsr::Error),
    /// The HDR toolkit failed.
    #[error(transparent)]
    Hdr(#[from] plsr_hdr::Error),
    /// An image could not be read or written through OpenImageIO.
    #[error(transparent)]
    Image(#[from] plsr_hdr::oiio::Error),
    /// A metric could not be computed.
    #[error(transparent)]
    Metrics(#[from] plsr_metrics::Error),
    /// An application (composite, fit, capture, the experiment) failed.
    #[error(transparent)]
    Apps(#[from] plsr_apps::Error),
}

/// The program's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
