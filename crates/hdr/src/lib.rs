//! HDR panoramas from bracketed exposures.
//!
//! - [`error`]: the toolkit's error enum and its parse faults;
//! - [`oiio`]: reading and writing images through OpenImageIO (C++ shim);
//! - [`response`]: camera response curves (Debevec–Malik, Robertson, linear,
//!   sRGB), saved as CSV and plotted as PNG;
//! - [`levels`]: the black (pedestal) and white (clip) levels of a camera,
//!   found from its brackets;
//! - [`merge`]: the streaming merge of brackets into one float/half EXR, with
//!   optional median-threshold-bitmap alignment ([`align`]);
//! - [`deghost`]: leaving out brackets where something moved between them;
//! - [`reference`]: how close a merge is to a reference map (log2-RMSE
//!   overall, in the highlights and in the shadows);
//! - [`synth`]: synthetic HDR scenes and simulated brackets for tests and the
//!   benchmark;
//!
//! The simulated 360° capture of a rendered scene is [`plsr_apps::capture`]
//! (it renders, so it sits above the renderer); the `plsr hdr` commands and
//! `plsr bench hdr` are in the program.
//!
//! See docs/hdr.md.

pub mod align;
pub mod deghost;
pub mod error;
pub mod levels;
pub mod merge;
pub use plsr_oiio as oiio;
pub mod reference;
pub mod response;
pub mod synth;

pub use error::{Error, Result};
