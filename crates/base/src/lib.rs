//! plsr's building blocks, below everything else in the workspace: the
//! error type every crate reports through, files replaced all at once,
//! checks of a user's input files, random streams, colour, the worker
//! threads, the machine's free memory, a bitmap font for plot labels and
//! OpenEXR headers written in a fixed order.
//!
//! Nothing here knows about scenes, images or Embree.

pub mod atomic_write;
pub mod color;
pub mod error;
pub mod exr_header;
pub mod input;
pub mod memory;
pub mod paths;
pub mod rng;
pub mod text;
pub mod threads;

pub use error::{Error, Result, Vocabulary};
