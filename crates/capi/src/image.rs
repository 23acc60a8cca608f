//! Rendering through the C ABI, and the rendered image.

use super::{
    boundary, free_handle, handle_ref, new_handle, path_arg, plsr_result, plsr_scene, slice_arg,
    write_out, FfiError,
};
use plsr::film::{Film, ToneMap};
use plsr::job::{JobError, RenderJob};
use plsr::render::{render, RenderOptions};
use std::ffi::c_void;
use std::sync::Mutex;

/// A rendered image (opaque): RGBA floats plus the film's layers.
#[allow(non_camel_case_types)]
pub struct plsr_image {
    pub(crate) film: Film,
    rgba: Vec<f32>,
}

/// Progress callback: `done` of `total` tiles are finished. Return `true` to
/// go on, `false` to cancel the render (it then fails with
/// `PLSR_ERR_CANCELLED`). Called from the rendering threads, never two
/// calls at a time.
#[allow(non_camel_case_types)]
pub type plsr_progress_fn =
    Option<extern "C" fn(user_data: *mut c_void, done: u32, total: u32) -> bool>;

/// The host's user data, handed back to its callback.
struct UserData(*mut c_void);
// SAFETY: the pointer is only passed back to the host's callback, whose calls
// are serialised by a mutex; the host documents what it points to as usable
// from the rendering threads (the API's contract).
unsafe impl Send for UserData {}
// SAFETY: as above.
unsafe impl Sync for UserData {}

/// What to render of a scene, for [`plsr_render_with_settings`].
#[repr(C)]
#[derive(Debug, Clone, Copy)]
#[allow(non_camel_case_types)]
pub struct plsr_render_settings {
    /// Samples per pixel, 1 to 2^24.
    pub spp: u32,
    /// Maximum number of scattering events, 1 to 1024.
    pub max_depth: u32,
    /// Seed of the random numbers.
    pub seed: u64,
    /// Index of the first sample: the render takes samples
    /// `[sample_start, sample_start + spp)` of every pixel.
    pub sample_start: u32,
}

/// A checked [`RenderJob`] from the C ABI's numbers; errors name the field.
pub(crate) fn job_arg(
    spp: u32,
    max_depth: u32,
    seed: u64,
    sample_start: u32,
) -> Result<RenderJob, FfiError> {
    // The C ABI, like scene files, asks for at least one scattering event.
    if max_depth == 0 {
        return Err(FfiError::invalid(format!(
            "`max_depth` = {max_depth} must be in [1, 1024]"
        )));
    }
    let job = RenderJob {
        spp,
        sample_start,
        max_depth,
        seed,
        hide_virtual: false,
        ..Default::default()
    };
    job.validate().map_err(|e| {
        FfiError::invalid(match e {
            JobError::Spp(_) => format!("`spp` = {spp} must be in [1, 2^24]"),
            JobError::MaxDepth(_) => format!("`max_depth` = {max_depth} must be in [1, 1024]"),
            JobError::SampleRangeOverflows => {
                format!("`sample_start` + `spp` = {sample_start} + {spp} overflows 32 bits")
            }
            // The C ABI keeps the default roulette depth.
            JobError::RrDepth(v) => format!("`rr_depth` = {v} must be in [0, 1024]"),
        })
    })?;
    Ok(job)
}

/// Renders `scene` with the render settings it was loaded or built with,
/// with `threads` worker threads (0: all cores), into `*out`. `progress`
/// may be `NULL`. The same scene, seed and spp give the same image whatever
/// the thread count.
#[no_mangle]
pub extern "C" fn plsr_render(
    scene: *const plsr_scene,
    threads: u32,
    progress: plsr_progress_fn,
    user_data: *mut c_void,
    out: *mut *mut plsr_image,
) -> plsr_result {
    boundary(|| {
        let s = handle_ref(scene, "scene")?;
        let job = s.scene.default_job();
        render_into(s, &job, threads, progress, user_data, out)
    })
}

/// Renders `scene` with other render settings than it was built with
/// (spp, depth, seed, first sample), without rebuilding it; otherwise as
/// [`plsr_render`]. Added in 0.3.0.
#[no_mangle]
pub extern "C" fn plsr_render_with_settings(
    scene: *const plsr_scene,
    settings: *const plsr_render_settings,
    threads: u32,
    progress: plsr_progress_fn,
    user_data: *mut c_void,
    out: *mut *mut plsr_image,
) -> plsr_result {
    boundary(|| {
        let s = handle_ref(scene, "scene")?;
        let r = slice_arg(settings, 1, "settings")?[0];
        let job = job_arg(r.spp, r.max_depth, r.seed, r.sample_start)?;
        render_into(s, &job, threads, progress, user_data, out)
    })
}

/// The body of the render entry points.
fn render_into(
    s: &plsr_scene,
    job: &RenderJob,
    threads: u32,
    progress: plsr_progress_fn,
    user_data: *mut c_void,
    out: *mut *mut plsr_image,
) -> Result<(), FfiError> {
    if out.is_null() {
        return Err(FfiError::null("out"));
    }
    let film = render_film(s, job, threads, progress, user_data)?;
    write_out(out, new_handle(plsr_image::from_film(film)), "out")
}

/// Renders `job` of `s`, reporting progress to the host's callback.
pub(crate) fn render_film(
    s: &plsr_scene,
    job: &RenderJob,
    threads: u32,
    progress: plsr_progress_fn,
    user_data: *mut c_void,
) -> Result<Film, FfiError> {
    let options = RenderOptions {
        threads: (threads > 0).then_some(threads as usize),
        ..Default::default()
    };
    let user = Mutex::new(UserData(user_data));
    let callback = |done: usize, total: usize| -> bool {
        match progress {
            None => true,
            Some(f) => {
                let guard = user.lock().unwrap_or_else(|p| p.into_inner());
                f(guard.0, done as u32, total as u32)
            }
        }
    };
    let (film, _) = render(&s.scene, job, &options, &callback)?;
    Ok(film)
}

impl plsr_image {
    /// An image of a film: its colour and coverage as RGBA.
    pub(crate) fn from_film(film: Film) -> plsr_image {
        let rgba = film
            .color
            .iter()
            .zip(&film.alpha)
            .flat_map(|(c, a)| [c.x, c.y, c.z, *a])
            .collect();
        plsr_image { film, rgba }
    }

    /// A composite as an image: the composite as colour, the matte as alpha.
    pub(crate) fn from_composite(c: &plsr_apps::composite::Composite) -> plsr_image {
        let mut film = Film::new(c.width, c.height);
        film.color = c.color.clone();
        film.alpha = c.matte.clone();
        plsr_image::from_film(film)
    }
}

/// Width and height of an image, pixels.
#[no_mangle]
pub extern "C" fn plsr_image_size(
    image: *const plsr_image,
    width: *mut u32,
    height: *mut u32,
) -> plsr_result {
    boundary(|| {
        let img = handle_ref(image, "image")?;
        if width.is_null() || height.is_null() {
            return Err(FfiError::null(if width.is_null() {
                "width"
            } else {
                "height"
            }));
        }
        write_out(width, img.film.width, "width")?;
        write_out(height, img.film.height, "height")
    })
}

/// The image's pixels: `width·height·4` floats, linear RGB radiance and
/// coverage alpha, row-major from the top row. Owned by the image, valid
/// until `plsr_image_free`; `NULL` if `image` is not a live image.
#[no_mangle]
pub extern "C" fn plsr_image_rgba(image: *const plsr_image) -> *const f32 {
    let mut ptr = std::ptr::null();
    let _ = boundary(|| {
        ptr = handle_ref(image, "image")?.rgba.as_ptr();
        Ok(())
    });
    ptr
}

/// Writes the image as OpenEXR (RGBA plus the layers: variance, albedo,
/// normal, depth, object id), through a temporary file then a rename.
/// `path` must end in `.exr` (`PLSR_ERR_INVALID_ARGUMENT` otherwise).
#[no_mangle]
pub extern "C" fn plsr_image_save_exr(
    image: *const plsr_image,
    path: *const std::ffi::c_char,
) -> plsr_result {
    boundary(|| {
        let img = handle_ref(image, "image")?;
        let path = path_arg(path, "path")?;
        plsr_base::atomic_write::check_extension(&path, "exr", "OpenEXR")
            .map_err(|m| FfiError::invalid(format!("`path` {}: {m}", path.display())))?;
        Ok(img.film.write_exr(&path)?)
    })
}

/// Writes the image as an 8-bit sRGB PNG after an exposure of `exposure_ev`
/// stops (0: none), clamped; `filmic` non-zero uses the filmic curve.
/// `path` must end in `.png` (`PLSR_ERR_INVALID_ARGUMENT` otherwise).
#[no_mangle]
pub extern "C" fn plsr_image_save_png(
    image: *const plsr_image,
    path: *const std::ffi::c_char,
    exposure_ev: f32,
    filmic: u32,
) -> plsr_result {
    boundary(|| {
        let img = handle_ref(image, "image")?;
        let path = path_arg(path, "path")?;
        plsr_base::atomic_write::check_extension(&path, "png", "PNG")
            .map_err(|m| FfiError::invalid(format!("`path` {}: {m}", path.display())))?;
        plsr::film::check_exposure_stops(exposure_ev)
            .map_err(|m| FfiError::invalid(format!("`exposure_ev` {m}")))?;
        let tone = ToneMap {
            exposure: exposure_ev,
            filmic: filmic != 0,
        };
        Ok(img.film.write_png(&path, tone)?)
    })
}

/// Releases an image; `NULL` is a no-op.
#[no_mangle]
pub extern "C" fn plsr_image_free(image: *mut plsr_image) -> plsr_result {
    boundary(|| free_handle(image, "image"))
}
