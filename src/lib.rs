//! plsr: a physically based renderer for placing virtual objects into
//! photographs, with parametric light sources (PLS) and HDR-panorama lighting.
//!
//! This crate is the library only; the `plsr` program (subcommands,
//! progress bars, benchmarks) is the binary in `src/bin/plsr/`, and
//! `libplsr.so` is this library with its C ABI ([`capi`]).
//!
//! Module map, from the bottom layer up; each module uses only modules on
//! its own layer or below (see `docs/architecture.md`):
//! 0. [`error`], [`atomic_write`], [`rng`], [`warp`], [`color`], [`filter`],
//!    [`job`]: errors, files replaced all at once, random streams, warps,
//!    colour, pixel filters, and what to render ([`job::RenderJob`]);
//! 1. [`accel`] (over [`sys`], the raw Embree 3 bindings), [`equirect`],
//!    [`threads`]: Embree, the panorama convention, worker threads;
//! 2. [`hdr`]: images through OpenImageIO, camera responses, bracket merging;
//! 3. [`camera`], [`bsdf`], [`texture`], [`material`], [`light`] (with the
//!    parametric light sources in [`light::pls`]): the models;
//! 4. [`film`]: per-pixel sums, the developed image, EXR and PNG;
//! 5. [`scene`]: the built scene and scene files;
//! 6. [`integrator`]: the path tracer and its vectorised kernel;
//! 7. [`render`]: a whole image on the thread pool;
//! 8. [`capture`], [`composite`], [`fit`], [`metrics`], [`capi`]: a
//!    simulated 360° bracket capture; virtual objects composited into
//!    photos; materials and lights fitted to photos; image quality metrics
//!    (CW-SSIM, LPIPS, FLIP, SSIM, PSNR, RMSE); the C ABI for C and C++ hosts
//!    (`include/plsr.h`);
//! 9. [`experiment`]: the paper's experiment redone on a generated room.

pub use plsr_embree_sys as sys;

pub mod accel;
pub mod atomic_write;
pub mod bsdf;
pub mod camera;
pub mod camera_path;
pub mod capi;
pub mod capture;
pub mod color;
pub mod composite;
pub mod elementary;
pub mod equirect;
pub mod error;
pub mod experiment;
pub mod film;
pub mod filter;
pub mod fit;
pub mod hdr;
pub mod input;
pub mod integrator;
pub mod job;
pub mod light;
pub mod material;
pub mod memory;
pub mod metrics;
pub mod prefetch;
pub mod render;
pub mod rng;
pub mod sampler;
pub mod scene;
pub mod text;
pub mod texture;
pub mod threads;
pub mod warp;

pub use error::{Error, Result};
