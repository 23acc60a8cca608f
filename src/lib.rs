//! plsr: a physically based renderer for placing virtual objects into
//! photographs, with parametric light sources (PLS) and HDR-panorama lighting.
//!
//! Module map, dependencies pointing downwards:
//! - [`sys`] (the `plsr-embree-sys` crate): raw Embree 3 bindings;
//! - [`accel`]: the safe Embree layer (device, scene, ray queries);
//! - [`sampler`], [`sampling`]: random streams, warps, discrete distributions;
//! - [`equirect`], [`color`], [`filter`]: the panorama convention, colour
//!   (white balance) and pixel filters;
//! - [`camera`], [`bsdf`], [`light`]: the models, each behind one interface;
//! - [`texture`], [`material`]: image textures and the materials they vary;
//! - [`scene`]: scene files and the built scene;
//! - [`integrator`], [`render`]: the path tracer and the tile scheduler;
//! - [`film`], [`output`]: the image with its AOVs, EXR and PNG output;
//! - [`hdr`]: HDR panoramas from bracketed photos (OpenImageIO shim,
//!   response recovery, streaming merge);
//! - [`capi`]: the C ABI for C and C++ hosts (`include/plsr.h`);
//! - [`bench`](mod@bench), [`cli`]: the `plsr` program.

pub use plsr_embree_sys as sys;

pub mod accel;
pub mod bench;
pub mod bsdf;
pub mod camera;
pub mod capi;
pub mod chi2;
pub mod cli;
pub mod color;
pub mod equirect;
pub mod error;
pub mod film;
pub mod filter;
pub mod hdr;
pub mod integrator;
pub mod light;
pub mod material;
pub mod output;
pub mod pls;
pub mod render;
pub mod sampler;
pub mod sampling;
pub mod scene;
pub mod texture;

pub use error::{Error, Result};
