//! plsr: a physically based renderer for placing virtual objects into
//! photographs, with parametric light sources (PLS) and HDR-panorama lighting.
//!
//! This crate is the library only; the `plsr` program (subcommands,
//! progress bars, benchmarks) is the binary in `src/bin/plsr/`, and
//! `libplsr.so` is this library with its C ABI ([`capi`]).
//!
//! Module map, dependencies pointing downwards (see `docs/architecture.md`):
//! - [`sys`] (the `plsr-embree-sys` crate): raw Embree 3 bindings;
//! - [`error`], [`atomic_write`]: errors, and files replaced all at once;
//! - [`accel`]: the safe Embree layer (device, scene, ray queries);
//! - [`rng`], [`warp`]: random streams; warps, discrete distributions, MIS;
//! - [`equirect`], [`color`], [`filter`]: the panorama convention, colour
//!   (white balance) and pixel filters;
//! - [`hdr`]: HDR panoramas from bracketed photos (OpenImageIO shim,
//!   response recovery, streaming merge);
//! - [`camera`], [`bsdf`], [`light`] (with the PLS model in [`light::pls`]): the
//!   models, each behind one
//!   interface;
//! - [`texture`], [`material`]: image textures and the materials they vary;
//! - [`scene`]: scene files and the built scene;
//! - [`integrator`]: the path tracer and its vectorised kernel;
//! - [`film`]: the image with its AOVs, EXR and PNG output;
//! - [`render`]: the tile scheduler;
//! - [`capture`]: a simulated 360° bracket capture of a rendered scene;
//! - [`capi`]: the C ABI for C and C++ hosts (`include/plsr.h`).

pub use plsr_embree_sys as sys;

pub mod accel;
pub mod atomic_write;
pub mod bsdf;
pub mod camera;
pub mod capi;
pub mod capture;
pub mod color;
pub mod equirect;
pub mod error;
pub mod film;
pub mod filter;
pub mod hdr;
pub mod integrator;
pub mod job;
pub mod light;
pub mod material;
pub mod render;
pub mod rng;
pub mod scene;
pub mod texture;
pub mod warp;

pub use error::{Error, Result};
