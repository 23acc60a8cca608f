//! The C ABI of compositing: a host that has a camera frame gets the frame
//! back with the scene's virtual objects in it.

use super::image::plsr_image;
use super::{
    boundary, handle_ref, new_handle, plsr_result, plsr_scene, slice_arg, write_out, FfiError,
};
use plsr::render::RenderOptions;
use plsr_apps::composite::{composite_built, CompositeOptions, Mode, Photo, Retrace, Transfer};

/// How to composite, for [`plsr_composite`]. Added in 0.4.0.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
#[allow(non_camel_case_types)]
pub struct plsr_composite_settings {
    /// 0: differential (the objects; their shadows scale the photo's
    /// colour, the light they reflect is added); 1: superimpose (the
    /// objects pasted over the photo); 2: additive (Debevec's original
    /// differential, clamped at 0).
    pub mode: u32,
    /// How the photo's 8-bit values map to linear radiance: 0 sRGB, 1 linear.
    pub response: u32,
    /// `k` in photo ≈ k · render; 0: fit it.
    pub exposure: f32,
    /// Samples per pixel of each of the two renders; 0: the scene's.
    pub spp: u32,
    /// Worker threads; 0: all cores.
    pub threads: u32,
}

/// Composites the virtual meshes of `scene` (shapes loaded with `virtual =
/// true`) into a photo given as `width × height` interleaved 8-bit RGB
/// values (row-major from the top; its size must be the camera's), into
/// `*out`: the composite in the photo's linear radiance (RGB) with the
/// matte as alpha. `*exposure_out` (may be `NULL`) receives the exposure
/// used. Added in 0.4.0.
#[no_mangle]
pub extern "C" fn plsr_composite(
    scene: *const plsr_scene,
    photo_rgb: *const u8,
    width: u32,
    height: u32,
    settings: *const plsr_composite_settings,
    out: *mut *mut plsr_image,
    exposure_out: *mut f32,
) -> plsr_result {
    boundary(|| {
        let s = handle_ref(scene, "scene")?;
        let c = slice_arg(settings, 1, "settings")?[0];
        if out.is_null() {
            return Err(FfiError::null("out"));
        }
        let n = (width as usize)
            .checked_mul(height as usize)
            .and_then(|n| n.checked_mul(3))
            .ok_or_else(|| FfiError::invalid(format!("{width}×{height}: too large")))?;
        if n == 0 {
            return Err(FfiError::invalid("`width` and `height` must be at least 1"));
        }
        let rgb = slice_arg(photo_rgb, n, "photo_rgb")?;
        let mode = match c.mode {
            0 => Mode::Differential,
            1 => Mode::Superimpose,
            2 => Mode::Additive,
            m => return Err(FfiError::invalid(format!("`mode` {m}: 0, 1 or 2"))),
        };
        let transfer = match c.response {
            0 => Transfer::Srgb,
            1 => Transfer::Linear,
            r => {
                return Err(FfiError::invalid(format!(
                    "`response` {r}: 0 (sRGB) or 1 (linear)"
                )))
            }
        };
        let exposure = if c.exposure == 0.0 {
            None
        } else if c.exposure.is_finite() && c.exposure > 0.0 {
            Some(c.exposure)
        } else {
            return Err(FfiError::invalid(format!(
                "`exposure` {}: a positive number, or 0 to fit it",
                c.exposure
            )));
        };
        let photo = Photo::from_rgb8(width, height, rgb, transfer)?;
        let options = CompositeOptions {
            mode,
            spp: (c.spp > 0).then_some(c.spp),
            seed: None,
            render: RenderOptions {
                threads: (c.threads > 0).then_some(c.threads as usize),
                ..Default::default()
            },
            denoise: None,
            retrace: Retrace::Touched,
        };
        let (result, _) = composite_built(&s.scene, &photo, exposure, &options, &|_, _| true)?;
        if !exposure_out.is_null() {
            write_out(exposure_out, result.k, "exposure_out")?;
        }
        let image = plsr_image::from_composite(&result);
        write_out(out, new_handle(image), "out")
    })
}
