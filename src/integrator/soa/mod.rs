//! The vectorised wavefront that renders every scene. Every BSDF model is
//! shaded in a branch-free loop of its own over structure-of-arrays lanes
//! ([`LaneBsdf`]): Lambert surfaces (their colour textured or not),
//! rough Cook–Torrance surfaces (GGX or Beckmann, isotropic or not, with a
//! conductor's, Schlick's or a dielectric coating's Fresnel term, their
//! roughness mapped or not), principled surfaces (Mitsuba's mode or the
//! energy-conserving one; base colour, roughness and metallic mapped or
//! not), Blinn–Phong surfaces (their colour mapped or not), rough
//! dielectrics (GGX or Beckmann) and smooth dielectrics; a map's values are
//! looked up per lane ([`mapped_params`]), and every kind takes vertex
//! normals and normal maps. They are lit by point lights, emissive meshes
//! (area lights), parametric lights (emitting triangles with a cone, picked
//! only where their cone reaches) and an environment (an
//! importance-sampled panorama or a constant sky; its samples and the
//! lookups of rays that leave the scene are taken for all lanes at once,
//! with the batched lookups the general integrator uses); virtual objects
//! (compositing) included: the job's ray mask on every ray, and their
//! coverage counted in the matte; a composite's renders with and without
//! them are made at once, a path forking where it meets one (`paired.rs`).
//!
//! It computes what the general integrator ([`super::render_tile`])
//! computes, in the same floating-point operations in the same order, with
//! the same random numbers; Rust never contracts `a·b + c` into a fused
//! multiply-add, so every lane rounds exactly as the scalar code does and
//! the images are bit-identical (tested in `tests/it/vectorised.rs`). One
//! assumption lies outside plsr: that Embree returns the same hit for the
//! same ray whether it traces it alone (the general integrator's
//! `rtcIntersect1M`) or in a packet of a structure-of-arrays stream (the
//! kernel's `rtcIntersectNp`); Embree does not promise it, and every test
//! confirms it. What
//! differs is the layout: the paths of a tile live in structure-of-arrays
//! lanes ([`RayBatch`] and the arrays of [`SoaLanes`]), and one bounce of
//! all of them is a single loop without branches (`shade_lane` per lane),
//! which the compiler turns into AVX-512 or AVX2 code, picked at run time.
//! Rays go to Embree as SoA streams (`rtcIntersectNp`, `rtcOccludedNp`).
//!
//! [`SoaScene::new`] prepares any scene for it; the general integrator
//! stays as the reference (`plsr render --scalar`), and renders a scene
//! only where a material is one no pass shades (none is today).

// Lane loops index a dozen arrays by lane; iterator chains would hide that.
#![allow(clippy::needless_range_loop)]

use super::spawn::{ray_epsilon, shadow_segment, spawn_origin};
use super::steps::{
    camera_sample, emission_weight, environment_weight, roulette, roulette_spins,
    shading_normal_towards, sides_agree, PrevVertex, RayStats, SurfacePoint,
};
use crate::accel::{gather_lanes, RayBatch, INVALID_ID, REAL_MASK};
use crate::bsdf::albedo::EnergyTables;
use crate::bsdf::models::KnownAlbedos;
use crate::bsdf::{
    lambert_eval, lambert_pdf, lambert_sample, BlinnPhongParams, Bsdf, BsdfSample,
    CookTorranceParams, DielectricParams, Distribution, Fresnel, Microfacet, PrincipledParams,
};
use crate::camera::{Camera, PinholeCamera};
use crate::film::{PixelSums, Tile};
use crate::filter::PixelFilter;
use crate::job::RenderJob;
use crate::light::pls::SoftEdge;
use crate::light::{point_light_sample, Cone, Light, LightSample, TrianglePoint};
use crate::prefetch::prefetch;
use crate::sampler::{PathSampler, SampleStream};
use crate::scene::Scene;
use crate::warp::{power_heuristic, Frame};
use glam::{Vec2, Vec3};
use std::marker::PhantomData;
use std::time::Instant;

mod blinn_phong;
mod bounce;
mod camera_rays;
mod chunk;
mod cook_torrance;
mod dielectric;
mod distribution;
mod isa;
mod lambert;
mod lane_bsdf;
mod lanes;
mod lights;
mod paired;
mod passes;
mod principled;
mod shade;
mod smooth_dielectric;
mod tables;

// Every stage sees every other stage's items: the kernel is one
// algorithm filed by stage, not a set of independent modules.
use blinn_phong::*;
use bounce::*;
use camera_rays::*;
use chunk::*;
use cook_torrance::*;
use dielectric::*;
use distribution::*;
use isa::*;
use lambert::*;
use lane_bsdf::*;
use lanes::*;
use lights::*;
use paired::*;
use passes::*;
use principled::*;
use shade::*;
use smooth_dielectric::*;
use tables::*;

pub use isa::{trace_pass, Isa};
pub use lanes::{SoaLanes, TilePass};
pub use paired::{PairPass, PairedLanes};
pub use tables::SoaScene;
