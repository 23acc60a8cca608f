//! plsr: a physically based renderer for placing virtual objects into
//! photographs, with parametric light sources (PLS) and HDR-panorama lighting.
//!
//! This crate is the renderer: the workspace's other crates are below it
//! (`plsr-base`, the building blocks, re-exported here under their old
//! names; `plsr-embree-sys`, re-exported as [`sys`]) or above it
//! (`plsr-hdr`, `plsr-metrics`, `plsr-apps`, the C ABI `plsr-capi`, the
//! program `plsr-cli`); `docs/architecture.md` has the graph.
//!
//! Module map, from the bottom layer up; each module uses only modules on
//! its own layer or below:
//! 0. [`elementary`], [`warp`], [`filter`], [`sampler`], [`prefetch`]:
//!    branch-free elementary functions, warps, pixel filters, the path
//!    tracer's sample streams, cache prefetch hints (and, from
//!    `plsr-base`: [`error`], [`atomic_write`], [`input`], [`rng`],
//!    [`color`], [`threads`], [`memory`], [`text`]);
//! 1. [`accel`] (over [`sys`], the raw Embree 3 bindings), [`equirect`]:
//!    Embree, the panorama convention;
//! 2. [`camera`] (with [`camera_path`]), [`bsdf`], [`texture`],
//!    [`material`], [`light`] (with the parametric light sources in
//!    [`light::pls`]): the models;
//! 3. [`film`]: per-pixel sums, the developed image, EXR and PNG;
//! 4. [`scene`] and [`job`]: the built scene, scene files, what to render;
//! 5. [`integrator`]: the path tracer and its vectorised kernel;
//! 6. [`render`]: a whole image on the thread pool.

pub use plsr_embree_sys as sys;

// The building blocks, under the paths they had before the workspace.
pub use plsr_base::{atomic_write, color, input, memory, rng, text, threads};

pub mod accel;
pub mod bsdf;
pub mod calibrated_camera;
pub mod calibration;
pub mod camera;
pub mod camera_path;
pub mod elementary;
pub mod equirect;
pub mod error;
pub mod film;
pub mod filter;
pub mod integrator;
pub mod job;
pub mod lens_distortion;
pub mod light;
pub mod material;
pub mod prefetch;
pub mod render;
pub mod sampler;
pub mod scene;
pub mod texture;
pub mod warp;

pub use error::{Error, Result};
