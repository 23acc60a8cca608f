//! Denoising through the C ABI: a host's own float buffers
//! ([`plsr_denoise`], as OIDN's filter takes them), a rendered image with
//! its albedo and normal layers ([`plsr_image_denoise`]), and a render
//! that denoises its result ([`plsr_render_denoised`]). Added in 0.5.0.

use super::{
    boundary, handle_ref, new_handle, plsr_result, plsr_scene, slice_arg, slice_mut_arg, write_out,
    FfiError,
};
use crate::image::{job_arg, plsr_image, plsr_progress_fn, plsr_render_settings, render_film};
use plsr::film::denoise::DenoiseSettings;
use plsr::film::Film;
use std::ffi::c_void;

/// How [`plsr_denoise`] filters a host's buffers. Added in 0.5.0.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
#[allow(non_camel_case_types)]
pub struct plsr_denoise_settings {
    /// 1: the colour is HDR (linear radiance, any magnitude); 0: LDR, in
    /// [0, 1].
    pub hdr: u32,
    /// 1: the albedo and normal are noise-free (or prefiltered); 0: they
    /// are noisy, as a render's first hits are.
    pub clean_aux: u32,
    /// 1: clean the albedo and normal with their own networks first (then
    /// `clean_aux` is implied); three networks instead of one.
    pub prefilter: u32,
}

/// The largest image the C ABI denoises, pixels (2^30: a 32768² frame).
const MAX_PIXELS: u64 = 1 << 30;

fn to_pixels(values: &[f32]) -> Vec<[f32; 3]> {
    values.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect()
}

fn denoise_error(e: plsr_denoise::FilterError) -> FfiError {
    FfiError::new(crate::PLSR_ERR_INPUT, format!("cannot denoise: {e}"))
}

/// Runs `f` on a pool of `threads` workers (0: all cores).
fn on_threads<T>(threads: u32, f: impl FnOnce() -> T + Send) -> Result<T, FfiError>
where
    T: Send,
{
    let pool = plsr_base::threads::thread_pool((threads > 0).then_some(threads as usize))?;
    Ok(pool.install(f))
}

/// Denoises a host's image: `color` (and optionally `albedo`, and
/// `normal` with it) are `width·height·3` floats each, RGB (normals XYZ in
/// [−1, 1], any space), row-major from the top row; the result goes to
/// `output` (`width·height·3` floats; it may be `color` itself).
/// `settings` may be `NULL` (HDR, noisy guides, no prefilter). Values that
/// are NaN or infinite are refused (`PLSR_ERR_INPUT`, naming how many
/// pixels have them); images smaller than the network's 16×16 are padded.
/// `threads` workers (0: all cores); the output does not depend on it.
/// Added in 0.5.0.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub extern "C" fn plsr_denoise(
    width: u32,
    height: u32,
    color: *const f32,
    albedo: *const f32,
    normal: *const f32,
    settings: *const plsr_denoise_settings,
    threads: u32,
    output: *mut f32,
) -> plsr_result {
    boundary(|| {
        let pixels = u64::from(width) * u64::from(height);
        if pixels == 0 || pixels > MAX_PIXELS {
            return Err(FfiError::invalid(format!(
                "`width` × `height` = {width} × {height}: must be 1 to 2^30 pixels"
            )));
        }
        let n = pixels as usize * 3;
        if output.is_null() {
            return Err(FfiError::null("output"));
        }
        let s = if settings.is_null() {
            plsr_denoise_settings {
                hdr: 1,
                clean_aux: 0,
                prefilter: 0,
            }
        } else {
            slice_arg(settings, 1, "settings")?[0]
        };
        if !normal.is_null() && albedo.is_null() {
            return Err(FfiError::invalid(
                "`normal` needs `albedo` (the networks take a normal only with an albedo)",
            ));
        }
        // Copied first, so that `output` may be `color`.
        let color = to_pixels(slice_arg(color, n, "color")?);
        let albedo = (!albedo.is_null())
            .then(|| slice_arg(albedo, n, "albedo").map(to_pixels))
            .transpose()?;
        let normal = (!normal.is_null())
            .then(|| slice_arg(normal, n, "normal").map(to_pixels))
            .transpose()?;
        let (w, h) = (width as usize, height as usize);
        let result = on_threads(threads, || {
            let filter = if s.prefilter != 0 {
                plsr_denoise::denoise_prefiltered
            } else {
                plsr_denoise::denoise
            };
            filter(
                plsr_denoise::Image::new(&color, w, h),
                albedo.as_deref().map(|p| plsr_denoise::Image::new(p, w, h)),
                normal.as_deref().map(|p| plsr_denoise::Image::new(p, w, h)),
                &plsr_denoise::Options {
                    hdr: s.hdr != 0,
                    clean_aux: s.clean_aux != 0,
                    input_scale: None,
                },
            )
        })?
        .map_err(denoise_error)?;
        let out = slice_mut_arg(output, n, "output")?;
        for (o, p) in out.chunks_exact_mut(3).zip(&result) {
            o.copy_from_slice(p);
        }
        Ok(())
    })
}

/// Denoises a rendered image guided by its albedo and normal layers, into
/// a new image `*out` (whose EXR keeps the noisy colour as `noisy.R/G/B`).
/// `prefilter` non-zero cleans the guides first. `threads` workers (0:
/// all cores). The guides are the image's first-hit layers
/// (`plsr_render_denoised` traces them through smooth glass). A composite
/// (`plsr_composite`) has no guide layers and is refused. Added in 0.5.0.
#[no_mangle]
pub extern "C" fn plsr_image_denoise(
    image: *const plsr_image,
    prefilter: u32,
    threads: u32,
    out: *mut *mut plsr_image,
) -> plsr_result {
    boundary(|| {
        let img = handle_ref(image, "image")?;
        if out.is_null() {
            return Err(FfiError::null("out"));
        }
        if img.film.spp == 0 {
            return Err(FfiError::invalid(
                "`image` is not a render (a composite has no albedo and normal layers to guide the denoiser)",
            ));
        }
        let mut film = img.film.clone();
        denoise_film(&mut film, prefilter, threads)?;
        write_out(out, new_handle(plsr_image::from_film(film)), "out")
    })
}

fn denoise_film(film: &mut Film, prefilter: u32, threads: u32) -> Result<(), FfiError> {
    let settings = DenoiseSettings {
        prefilter: prefilter != 0,
        ..DenoiseSettings::default()
    };
    on_threads(threads, || film.denoise(&settings))??;
    Ok(())
}

/// Renders `scene` as [`crate::plsr_render_with_settings`] does (with the
/// scene's own settings when `settings` is `NULL`; `sample_start` must be
/// 0), then denoises the
/// image guided by its albedo and normal layers (`prefilter` non-zero:
/// the guides cleaned first). The image's EXR keeps the noisy colour as
/// `noisy.R/G/B`. Added in 0.5.0.
#[no_mangle]
pub extern "C" fn plsr_render_denoised(
    scene: *const plsr_scene,
    settings: *const plsr_render_settings,
    prefilter: u32,
    threads: u32,
    progress: plsr_progress_fn,
    user_data: *mut c_void,
    out: *mut *mut plsr_image,
) -> plsr_result {
    boundary(|| {
        let s = handle_ref(scene, "scene")?;
        if out.is_null() {
            return Err(FfiError::null("out"));
        }
        let job = if settings.is_null() {
            s.scene.default_job()
        } else {
            let r = slice_arg(settings, 1, "settings")?[0];
            if r.sample_start != 0 {
                return Err(FfiError::invalid(format!(
                    "`sample_start` = {}: a part of a render is denoised only once merged; render from sample 0",
                    r.sample_start
                )));
            }
            job_arg(r.spp, r.max_depth, r.seed, r.sample_start)?
        };
        let mut film = render_film(s, &job, threads, progress, user_data)?;
        on_threads(threads, || {
            plsr::integrator::guides::see_through_glass(&s.scene, &job, &mut film)
        })?;
        denoise_film(&mut film, prefilter, threads)?;
        write_out(out, new_handle(plsr_image::from_film(film)), "out")
    })
}
