//! Rendering a whole image: tiles spread over a rayon pool, progress and
//! cancellation, each tile folded into the film's sums as it finishes.

use crate::error::{Error, Result};
use crate::film::{Film, FilmSums};
use crate::integrator::gradient::{gradient_tile, GradientMap, TileGradient};
use crate::integrator::{
    continue_tile, render_tile, render_tile_pair, Isa, RayStats, SoaScene, Tile,
};
pub use crate::job::RenderJob;
use crate::scene::Scene;
pub use crate::threads::thread_pool;
use plsr_base::Vocabulary;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// Default tile edge in pixels: 32×32 = 1024 paths per wavefront, enough
/// to amortise the vectorised kernel's per-pass costs (5 % faster than
/// 16×16 on `plsr bench`; the general integrator does not mind), while a
/// 512×512 image still has 256 tiles to spread over the threads.
pub const DEFAULT_TILE_SIZE: u32 = 32;

/// The largest tile edge, pixels (a tile's buffers grow with its area).
pub const MAX_TILE_SIZE: u32 = 4096;

/// How to run a render (what to render is the [`RenderJob`]); no option
/// changes the image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderOptions {
    /// Worker threads; `None` uses every core.
    pub threads: Option<usize>,
    /// Tile edge in pixels.
    pub tile_size: u32,
    /// Use the vectorised kernel (see [`SoaScene`]); it gives the same
    /// image as the general integrator, faster. `false` forces the general
    /// integrator (the reference).
    pub vectorised: bool,
    /// Instruction set of the vectorised kernel; `None` picks the best the
    /// CPU has. Every choice gives the same image (for tests and timing);
    /// one the CPU lacks is an error, whether or not the kernel would run.
    pub isa: Option<Isa>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            threads: None,
            tile_size: DEFAULT_TILE_SIZE,
            vectorised: true,
            isa: None,
        }
    }
}

/// What a render did and how fast.
#[derive(Debug, Clone, Copy, Default)]
pub struct RenderStats {
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Camera samples taken (pixels × spp).
    pub samples: u64,
    /// Rays traced.
    pub rays: RayStats,
    /// Worker threads used.
    pub threads: usize,
    /// The instruction set of the vectorised kernel, if it rendered the
    /// image (`None`: the general integrator did).
    pub vectorised: Option<Isa>,
}

impl RenderStats {
    /// Millions of camera samples per second.
    pub fn msamples_per_s(&self) -> f64 {
        self.samples as f64 / self.seconds / 1e6
    }

    /// Millions of rays per second.
    pub fn mrays_per_s(&self) -> f64 {
        self.rays.total() as f64 / self.seconds / 1e6
    }

    /// Fraction of the workers' time (wall time × threads) spent inside
    /// Embree's queries; the rest is shading, bookkeeping and idling.
    pub fn trace_share(&self) -> f64 {
        self.rays.trace_nanos as f64 * 1e-9 / (self.seconds * self.threads as f64)
    }

    /// Millions of camera samples per second the same rays would allow if
    /// everything but Embree's queries took no time: the ceiling of any
    /// integrator that traces these rays.
    /// NaN when nothing was traced.
    pub fn trace_bound_msamples_per_s(&self) -> f64 {
        if self.rays.trace_nanos == 0 {
            return f64::NAN;
        }
        let trace_wall = self.rays.trace_nanos as f64 * 1e-9 / self.threads as f64;
        self.samples as f64 / trace_wall / 1e6
    }
}

/// The tiles covering a `width × height` image, in scanline order.
pub fn tiles(width: u32, height: u32, size: u32) -> Vec<Tile> {
    let size = size.max(1);
    let mut out = Vec::new();
    for y0 in (0..height).step_by(size as usize) {
        for x0 in (0..width).step_by(size as usize) {
            out.push(Tile {
                x0,
                y0,
                width: size.min(width - x0),
                height: size.min(height - y0),
            });
        }
    }
    out
}

/// Working memory of one pixel of a tile in flight (bytes): its sums and
/// the wavefront's path state (ray, throughput, vertex, random state).
const PATH_STATE_BYTES: u64 = 256;

/// Bytes a render of a `width × height` image needs at its peak: the
/// film's per-pixel sums, the developed film (ten float channels and
/// three colour layers), the OpenEXR encoder's copy of every channel, and
/// the tiles in flight, one per thread.
pub fn memory_needed(width: u32, height: u32, tile_size: u32, threads: usize) -> u64 {
    let pixels = width as u64 * height as u64;
    let sums = std::mem::size_of::<crate::film::PixelSums>() as u64;
    let film = 4 * 3 * 4 + 3 * 4;
    // The image's 16 channels of 4 bytes, and the sums a render keeps
    // beside them: seven 64-bit sums, three counts and seven 32-bit sums,
    // with a 64-bit scratch copy while they are cut into words.
    let exr = 16 * 4 + 7 * 8 + 3 * 4 + 7 * 4 + 8;
    let tile = (tile_size as u64 * tile_size as u64).min(pixels);
    pixels * (sums + film + exr) + tile * (sums + PATH_STATE_BYTES) * threads as u64
}

/// A render that would need more memory than the machine has free. Its
/// text does not name the option or field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error(
    "{width}×{height} pixels need about {} of memory to render, more than the {} available \
     (render a smaller image, or pieces of it)",
    crate::memory::human_bytes(*needed),
    crate::memory::human_bytes(*available)
)]
pub struct NotEnoughMemory {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Bytes the render needs, estimated.
    pub needed: u64,
    /// Bytes free.
    pub available: u64,
}

/// Checks that a render of `scene` with `options` fits in the memory this
/// machine has free; the message gives both. Passes where the machine does
/// not say (non-Linux).
pub fn check_memory(
    scene: &Scene,
    options: &RenderOptions,
) -> std::result::Result<(), NotEnoughMemory> {
    let cam = scene.camera();
    let threads = options
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let needed = memory_needed(cam.width(), cam.height(), options.tile_size, threads);
    match crate::memory::available_bytes() {
        Some(available) if needed > available => Err(NotEnoughMemory {
            width: cam.width(),
            height: cam.height(),
            needed,
            available,
        }),
        _ => Ok(()),
    }
}

/// Renders `job` of the scene into a developed film (means, variances and
/// AOVs). `progress(done_tiles, total_tiles)` is called from worker threads
/// after each tile; returning `false` cancels the render.
pub fn render(
    scene: &Scene,
    job: &RenderJob,
    options: &RenderOptions,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<(Film, RenderStats)> {
    let (sums, stats) = render_sums(scene, job, options, progress)?;
    Ok((sums.develop(job.spp), stats))
}

/// Renders `job` of the scene into per-pixel sums and counts, which merge
/// with other pieces of the same image ([`FilmSums::merge`]); see
/// [`render`].
pub fn render_sums(
    scene: &Scene,
    job: &RenderJob,
    options: &RenderOptions,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<(FilmSums, RenderStats)> {
    render_window_sums(scene, job, options, None, progress)
}

/// [`render_sums`] of the pixels of `window` only (the whole image for
/// `None`): the others keep no samples. Each pixel's sums are those of the
/// whole image's render, bit for bit, so windows stitch exactly.
pub fn render_window_sums(
    scene: &Scene,
    job: &RenderJob,
    options: &RenderOptions,
    window: Option<Tile>,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<(FilmSums, RenderStats)> {
    let (sums, _, stats) = render_tiles(scene, job, options, window, None, progress)?;
    Ok((sums, stats))
}

/// Resumes a render: adds the samples of `job` (which must start where
/// `previous` ends) to `previous`, the sums of the samples before them over
/// the whole image (or the scene's crop window), each pixel's samples one
/// by one in sample order as one render adds them
/// ([`crate::integrator::continue_tile`]): the sums are bit for bit those
/// of one render of all the samples. The stats count the new samples.
pub fn continue_sums(
    scene: &Scene,
    job: &RenderJob,
    options: &RenderOptions,
    previous: &FilmSums,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<(FilmSums, RenderStats)> {
    continue_window_sums(scene, job, options, None, previous, progress)
}

/// [`continue_sums`] of the pixels of `window` only (the whole image, or
/// the scene's crop window, for `None`): a resumed part of a window.
pub fn continue_window_sums(
    scene: &Scene,
    job: &RenderJob,
    options: &RenderOptions,
    window: Option<Tile>,
    previous: &FilmSums,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<(FilmSums, RenderStats)> {
    let cam = scene.camera();
    if (previous.width(), previous.height()) != (cam.width(), cam.height())
        || previous.settings() != *scene.film()
    {
        return Err(Error::invalid_argument(format!(
            "cannot resume a {}×{} render as the {}×{} image of another film",
            previous.width(),
            previous.height(),
            cam.width(),
            cam.height()
        )));
    }
    let (sums, _, stats) = render_tiles(
        scene,
        job,
        options,
        window,
        Some(Previous::Sums(previous)),
        progress,
    )?;
    Ok((sums, stats))
}

/// Compositing's pair of renders of the whole image: `job` with the
/// virtual objects and without them, each film's sums bit for bit those
/// of [`render_sums`] with `hide_virtual` false and true, in one
/// wavefront that traces a path once until it meets a virtual object
/// ([`crate::integrator::render_tile_pair`]). The stats count both
/// renders' samples and rays.
pub fn render_pair_sums(
    scene: &Scene,
    job: &RenderJob,
    options: &RenderOptions,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<(FilmSums, FilmSums, RenderStats)> {
    if job.hide_virtual {
        return Err(Error::invalid_argument(
            "a paired render shows the virtual objects in its first film (hide_virtual is false)",
        ));
    }
    let (with, without, stats) =
        render_tiles(scene, job, options, None, Some(Previous::Paired), progress)?;
    let without = without.expect("a paired render returns both films");
    Ok((with, without, stats))
}

/// What [`render_tiles`] does besides rendering the job's samples afresh.
#[derive(Clone, Copy)]
enum Previous<'a> {
    /// Render the film without the virtual objects too
    /// ([`render_pair_sums`]).
    Paired,
    /// Add the samples to these sums ([`continue_sums`]).
    Sums(&'a FilmSums),
}

/// [`render_window_sums`]; with [`Previous::Paired`] the film without the
/// virtual objects too ([`render_pair_sums`]); with [`Previous::Sums`],
/// continuing those sums ([`continue_sums`]).
fn render_tiles(
    scene: &Scene,
    job: &RenderJob,
    options: &RenderOptions,
    window: Option<Tile>,
    previous: Option<Previous>,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<(FilmSums, Option<FilmSums>, RenderStats)> {
    let paired = matches!(previous, Some(Previous::Paired));
    let start_sums = match previous {
        Some(Previous::Sums(sums)) => Some(sums),
        _ => None,
    };
    job.validate()
        .map_err(|e| Error::invalid_argument(format!("render: {e}")))?;
    if options.tile_size == 0 || options.tile_size > MAX_TILE_SIZE {
        return Err(Error::invalid_argument(format!(
            "tile size {} must be in [1, {MAX_TILE_SIZE}] pixels",
            options.tile_size
        )));
    }
    let cam = scene.camera();
    let (width, height) = (cam.width(), cam.height());
    // The whole image, or the scene's crop window.
    let window = window.unwrap_or(match scene.film().crop {
        Some(c) => Tile {
            x0: c.x0,
            y0: c.y0,
            width: c.width,
            height: c.height,
        },
        None => Tile {
            x0: 0,
            y0: 0,
            width,
            height,
        },
    });
    if window.width == 0
        || window.height == 0
        || window.x0.saturating_add(window.width) > width
        || window.y0.saturating_add(window.height) > height
    {
        return Err(Error::invalid_argument(format!(
            "window {}×{} at ({}, {}) does not lie inside the {width}×{height} image",
            window.width, window.height, window.x0, window.y0
        )));
    }
    let tiles: Vec<Tile> = tiles(window.width, window.height, options.tile_size)
        .into_iter()
        .map(|t| Tile {
            x0: t.x0 + window.x0,
            y0: t.y0 + window.y0,
            ..t
        })
        .collect();
    let isa = match options.isa {
        Some(isa) if !isa.is_available() => {
            return Err(Error::invalid_argument(format!(
                "this CPU cannot run the {} kernel",
                isa.name()
            )))
        }
        Some(isa) => isa,
        None => Isa::best(),
    };
    let kernel = options.vectorised.then(|| SoaScene::new(scene)).flatten();
    check_memory(scene, options)
        .map_err(|m| Error::invalid_argument(format!("camera.resolution: {m}")))?;
    let pool = thread_pool(options.threads)?;
    let done = AtomicUsize::new(0);
    let cancelled = AtomicBool::new(false);
    let first_sample = start_sums.map_or(job.sample_start, |s| s.sample_start());
    let new_film = || FilmSums::new(width, height, first_sample, *scene.film());
    let film = Mutex::new(new_film());
    let film_o = Mutex::new(paired.then(new_film));
    let rays = Mutex::new(RayStats::default());
    let start = Instant::now();
    pool.install(|| {
        tiles.par_iter().for_each(|&tile| {
            if cancelled.load(Ordering::Relaxed) {
                return;
            }
            let kernel = kernel.as_ref().map(|k| (k, isa));
            let r = if paired {
                let (r, pixels_o) = render_tile_pair(scene, job, kernel, tile);
                if let Some(film_o) = film_o.lock().unwrap_or_else(|e| e.into_inner()).as_mut() {
                    film_o.add_tile(r.tile, &pixels_o);
                }
                r
            } else if let Some(sums) = start_sums {
                continue_tile(scene, job, kernel, tile, sums.tile_pixels(tile))
            } else {
                render_tile(scene, job, kernel, tile)
            };
            // Each tile covers its own pixels, so the order in which tiles
            // are folded in does not change the sums.
            film.lock()
                .unwrap_or_else(|e| e.into_inner())
                .add_tile(r.tile, &r.pixels);
            rays.lock().unwrap_or_else(|e| e.into_inner()).add(&r.rays);
            let n = done.fetch_add(1, Ordering::Relaxed) + 1;
            if !progress(n, tiles.len()) {
                cancelled.store(true, Ordering::Relaxed);
            }
        })
    });
    if cancelled.load(Ordering::Relaxed) {
        return Err(Error::cancelled());
    }
    let seconds = start.elapsed().as_secs_f64();
    let renders = if paired { 2 } else { 1 };
    let stats = RenderStats {
        seconds,
        samples: renders * window.width as u64 * window.height as u64 * job.spp as u64,
        rays: rays.into_inner().unwrap_or_else(|e| e.into_inner()),
        threads: pool.current_num_threads(),
        vectorised: kernel.is_some().then_some(isa),
    };
    let film = film.into_inner().unwrap_or_else(|e| e.into_inner());
    let film_o = film_o.into_inner().unwrap_or_else(|e| e.into_inner());
    Ok((film, film_o, stats))
}

/// What a gradient pass ([`render_gradient`]) returns.
#[derive(Debug, Clone)]
pub struct GradientResult {
    /// The radiance sums of the paths traced (no AOVs); with `all_paths`,
    /// the same sums the general integrator gives for the job.
    pub sums: FilmSums,
    /// `Σ_p adjoint_p · ∂I_p/∂θ` per slot of the [`GradientMap`].
    pub gradient: Vec<f64>,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// Estimates `Σ_p adjoint_p · ∂I_p/∂θ` for every slot of `map` over the
/// image of `job` (see [`crate::integrator::gradient`]): `adjoint` holds
/// the loss's derivative with respect to each pixel's recorded value,
/// row-major over the camera's image. The tiles' gradients are added in
/// tile order, so the result does not depend on the thread count.
pub fn render_gradient(
    scene: &Scene,
    job: &RenderJob,
    options: &RenderOptions,
    map: &GradientMap,
    adjoint: &[glam::Vec3],
    all_paths: bool,
) -> Result<GradientResult> {
    job.validate()
        .map_err(|e| Error::invalid_argument(format!("render: {e}")))?;
    let cam = scene.camera();
    let (width, height) = (cam.width(), cam.height());
    if adjoint.len() != width as usize * height as usize {
        return Err(Error::invalid_argument(format!(
            "the adjoint image has {} pixels, the camera {width}×{height}",
            adjoint.len()
        )));
    }
    if map.materials.len() != scene.materials().len()
        || map.lights.len() != scene.lights().lights.len()
    {
        return Err(Error::invalid_argument(
            "the gradient map was made for another scene",
        ));
    }
    if let Some(m) = scene.materials().iter().find(|m| m.textures.terminator()) {
        return Err(Error::invalid_argument(format!(
            "material `{}`: normal_shadowing is not differentiated (fit without it)",
            m.name
        )));
    }
    if let Some(m) = scene.materials().iter().find(|m| m.composite.is_some()) {
        return Err(Error::invalid_argument(format!(
            "material `{}`: blends, masks and two-faced materials are not differentiated \
             (fit a scene without them)",
            m.name
        )));
    }
    check_memory(scene, options)
        .map_err(|m| Error::invalid_argument(format!("camera.resolution: {m}")))?;
    let tiles = tiles(width, height, options.tile_size.max(1));
    let pool = thread_pool(options.threads)?;
    let start = Instant::now();
    let results: Vec<TileGradient> = pool.install(|| {
        tiles
            .par_iter()
            .map(|&tile| gradient_tile(scene, job, map, adjoint, tile, all_paths))
            .collect()
    });
    let mut sums = FilmSums::new(width, height, job.sample_start, *scene.film());
    let mut gradient = vec![0.0f64; map.len];
    for r in &results {
        sums.add_tile(r.tile, &r.pixels);
        for (g, t) in gradient.iter_mut().zip(&r.gradient) {
            *g += t;
        }
    }
    Ok(GradientResult {
        sums,
        gradient,
        seconds: start.elapsed().as_secs_f64(),
    })
}
