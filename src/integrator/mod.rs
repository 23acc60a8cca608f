//! The unidirectional path tracer.
//!
//! Per camera sample: next-event estimation at every scattering vertex (one
//! light picked by power, one point on it), BSDF sampling to continue the
//! path, multiple importance sampling of the two strategies with the power
//! heuristic (Veach 1997), and Russian roulette by throughput (times `η²`
//! of the refractions so far) from [`RenderJob::rr_depth`] scattering events
//! on (4 by default).
//! `max_depth` counts scattering events, as pbrt's `maxdepth` does: a path of
//! `max_depth = 1` is direct lighting only.
//!
//! The work is organised as a small wavefront per image tile: all paths of
//! one sample pass over a tile advance together, so their rays go to Embree in
//! batches: camera rays as a coherent stream, then each bounce's continuation
//! rays and shadow rays as streams. Every path draws from its own random
//! stream ([`PathSampler::for_sample`]) and every pixel adds its samples in sample
//! order, so an image is bit-identical whatever the number of threads.
//!
//! Every scene whose materials the kernel has passes for (all models but
//! `plastic`, `rough_plastic`, `thin_dielectric`, `principled_thin` and
//! `principled` with more than its two lobes, which the general integrator
//! renders)
//! runs on a vectorised version of the same wavefront ([`soa`]): structure-of-arrays lanes, compiled for AVX-512, AVX2 and
//! the baseline and picked at run time ([`Isa`]), each material kind
//! shaded in a branch-free loop of its own. It performs the same
//! floating-point operations in the same order with the same random
//! numbers, so it renders the same image bit for bit;
//! `RenderOptions::vectorised` (`plsr render --scalar`) turns it off,
//! leaving the general integrator as the reference.
//!
//! The files: this one picks the integrator for a tile ([`render_tile`]);
//! `general.rs` is the general wavefront, [`soa`] the kernel, `steps.rs`
//! the steps both take alike (the camera sample, the shading point, the
//! MIS weights, Russian roulette), `spawn.rs` where rays start and end, and
//! [`gradient`] the differentiable mode, [`guides`] the denoiser's guides
//! behind glass. The general integrator and the
//! kernel do not import each other.

mod general;
pub mod gradient;
pub mod guides;
pub mod soa;
mod spawn;
mod split_lobes;
mod steps;

pub use soa::{Isa, SoaScene};
pub use steps::RayStats;

pub use crate::film::{PixelSums, Tile};
use crate::job::RenderJob;
use crate::scene::Scene;

/// The result of rendering one tile.
#[derive(Debug, Clone)]
pub struct TileResult {
    /// The tile.
    pub tile: Tile,
    /// Per-pixel sums, row-major within the tile.
    pub pixels: Vec<PixelSums>,
    /// Rays traced.
    pub rays: RayStats,
}

/// Renders the job's samples of every pixel of `tile`; with `kernel` (the
/// scene's [`SoaScene`] and an instruction set), by the vectorised
/// kernel, which gives the same image.
pub fn render_tile(
    scene: &Scene,
    job: &RenderJob,
    kernel: Option<(&SoaScene, Isa)>,
    tile: Tile,
) -> TileResult {
    trace_tile(scene, job, kernel, tile, empty_sums(job, tile))
}

/// [`render_tile`] continuing `previous`, the tile's sums of the samples
/// before the job's (row-major within the tile): each pixel's new samples
/// are added to them one by one in sample order, as one render of all the
/// samples adds them, so that the sums are bit for bit those of that one
/// render (a resumed render, not a merge of two). The object id stays that
/// of the earlier samples.
pub fn continue_tile(
    scene: &Scene,
    job: &RenderJob,
    kernel: Option<(&SoaScene, Isa)>,
    tile: Tile,
    mut previous: Vec<PixelSums>,
) -> TileResult {
    assert_eq!(previous.len(), (tile.width * tile.height) as usize);
    let ids: Vec<f32> = previous.iter().map(|p| p.object_id).collect();
    let had: Vec<bool> = previous.iter().map(|p| p.samples > 0).collect();
    for p in &mut previous {
        p.samples = p.samples.saturating_add(job.spp);
    }
    let mut result = trace_tile(scene, job, kernel, tile, previous);
    for ((p, id), had) in result.pixels.iter_mut().zip(ids).zip(had) {
        if had {
            p.object_id = id;
        }
    }
    result
}

/// Adds the job's samples of `tile` to `pixels` (whose counts already
/// include them).
fn trace_tile(
    scene: &Scene,
    job: &RenderJob,
    kernel: Option<(&SoaScene, Isa)>,
    tile: Tile,
    mut pixels: Vec<PixelSums>,
) -> TileResult {
    let mut rays = RayStats::default();
    match kernel {
        Some((kernel, isa)) => kernel_passes(
            scene,
            job,
            (kernel, isa),
            tile,
            &mut pixels,
            &mut rays,
            None,
        ),
        None => general::render_samples(scene, job, tile, &mut pixels, &mut rays),
    }
    TileResult { tile, pixels, rays }
}

/// A tile's sums before its first sample.
fn empty_sums(job: &RenderJob, tile: Tile) -> Vec<PixelSums> {
    let empty = PixelSums {
        samples: job.spp,
        ..Default::default()
    };
    vec![empty; (tile.width * tile.height) as usize]
}

/// The job's samples of `tile` by the vectorised kernel, one pass per
/// sample in order; with `pixels_o`, paired (see [`render_tile_pair`]).
fn kernel_passes(
    scene: &Scene,
    job: &RenderJob,
    (kernel, isa): (&SoaScene, Isa),
    tile: Tile,
    pixels: &mut [PixelSums],
    rays: &mut RayStats,
    mut pixels_o: Option<&mut [PixelSums]>,
) {
    let samples = job.samples();
    let first_sample = samples.start;
    let mut lanes = soa::SoaLanes::default();
    let mut paired = soa::PairedLanes::default();
    for s in samples {
        let pass = soa::TilePass {
            kernel,
            scene,
            job,
            tile,
            sample: s,
            first: s == first_sample,
        };
        let pair = pixels_o.as_deref_mut().map(|pixels| soa::PairPass {
            lanes: &mut paired,
            pixels,
        });
        soa::trace_pass(isa, &pass, &mut lanes, pixels, rays, pair);
    }
}

/// Renders compositing's pair of renders of `tile`: the job with the
/// virtual objects (the result's `pixels`) and without them (the second
/// value), each pixel's sums bit for bit those of [`render_tile`] with
/// `hide_virtual` false and true. With `kernel`, in one wavefront whose
/// paths are traced once until they meet a virtual object (see
/// `soa/paired.rs`; `rays` counts both renders' rays, `forked`,
/// `o_rays` and `shadow_again` what the pair cost); without, as two renders.
///
/// # Panics
/// If the job hides the virtual objects.
pub fn render_tile_pair(
    scene: &Scene,
    job: &RenderJob,
    kernel: Option<(&SoaScene, Isa)>,
    tile: Tile,
) -> (TileResult, Vec<PixelSums>) {
    assert!(
        !job.hide_virtual,
        "a paired render's job shows the virtual objects"
    );
    let Some((kernel, isa)) = kernel else {
        let hidden = RenderJob {
            hide_virtual: true,
            ..*job
        };
        let mut with = render_tile(scene, job, None, tile);
        let without = render_tile(scene, &hidden, None, tile);
        with.rays.add(&without.rays);
        return (with, without.pixels);
    };
    let (mut pixels, mut pixels_o) = (empty_sums(job, tile), empty_sums(job, tile));
    let mut rays = RayStats::default();
    kernel_passes(
        scene,
        job,
        (kernel, isa),
        tile,
        &mut pixels,
        &mut rays,
        Some(&mut pixels_o),
    );
    (TileResult { tile, pixels, rays }, pixels_o)
}
