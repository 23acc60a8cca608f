//! The applications built on the renderer, the paper's pipeline around a
//! render:
//! - [`capture`]: the bracketed photos a 360° camera would take of a
//!   rendered scene;
//! - [`composite`]: virtual objects composited into a photograph
//!   (differential rendering, the exposure fit);
//! - [`fit`]: materials and lights fitted to photographs;
//! - [`exif_exposure`]: a photo's exposure from its EXIF, in a merged
//!   panorama's units;
//! - [`error`]: the applications' error enum;
//! - [`experiment`]: the paper's experiment redone on a generated room.

pub mod capture;
pub mod composite;
pub mod error;
pub mod exif_exposure;
pub mod experiment;
pub mod fit;

pub use error::{Error, Result};
