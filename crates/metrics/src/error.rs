//! The errors of the image metrics.

/// A failure of the metrics: images that cannot be compared (sizes,
/// channels, masks), an image that cannot be read, or LPIPS weights that
/// do not parse.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad input, an unreadable file, an invalid argument.
    #[error(transparent)]
    Base(#[from] plsr_base::Error),
    /// OpenImageIO could not be loaded, or could not read an image.
    #[error(transparent)]
    Image(#[from] plsr_hdr::oiio::Error),
    /// The LPIPS network's weights (built into plsr) do not parse.
    #[error("LPIPS weights: {0}")]
    Weights(#[from] BadWeights),
}

/// What is wrong with an LPIPS weights file (`PLSRLPIPS1`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BadWeights {
    /// The file ends inside a record.
    #[error("truncated")]
    Truncated,
    /// The file does not start with `PLSRLPIPS1`.
    #[error("not a PLSRLPIPS1 file")]
    NotLpips,
    /// A tensor's name is not UTF-8.
    #[error("a name is not UTF-8")]
    NameNotUtf8,
    /// A tensor the network needs is missing.
    #[error("{0} is missing")]
    Missing(String),
    /// A convolution's weights have the wrong shape.
    #[error("conv{layer} has the wrong shape {dims:?}")]
    ConvShape {
        /// The layer, from 1.
        layer: usize,
        /// The dimensions found.
        dims: Vec<usize>,
    },
    /// A linear layer's weights do not match its convolution's channels.
    #[error("lin{layer} has {weights} weights for {channels} channels")]
    LinearShape {
        /// The layer, from 1.
        layer: usize,
        /// The weights found.
        weights: usize,
        /// The channels of the convolution.
        channels: usize,
    },
}

/// This crate's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
