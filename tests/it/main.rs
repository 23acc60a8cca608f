//! The renderer's tests, one module per topic: radiometry against analytic
//! answers, chi-square tests of every sampling routine, the vectorised
//! kernel against the general integrator, determinism, scene files.

mod bsdf;
mod calibration;
mod cameras;
mod composite;
mod curves;
mod denoising;
mod determinism;
mod embree_layer;
mod environment;
mod fuzz_parsers;
mod gltf_fixtures;
mod gltf_import;
mod instancing;
mod materials;
mod mitsuba_parity;
mod paired_render;
mod plastic;
mod pls;
mod pls_render;
mod radiometry;
mod regression;
mod sampling_chi2;
mod sdf_grid;
mod surfaces;
mod under_load;
mod vectorised;
