//! The C ABI of differentiable rendering: a host that runs its own
//! optimiser selects parameters of a scene, reads and sets their values,
//! and asks for the gradient of a render (or of the squared error against
//! a target image) with respect to them.

use super::{
    boundary, free_handle, handle_mut, handle_ref, new_handle, plsr_result, plsr_scene, slice_arg,
    slice_mut_arg, str_arg, write_out, FfiError,
};
use glam::Vec3;
use plsr::job::RenderJob;
use plsr::render::{render_gradient, RenderOptions};
use plsr_apps::fit::params::{apply, gradient_map, select, Parameter};
use plsr_apps::fit::squared_error_gradient;
use std::ffi::{c_char, CString};

/// Parameters of a scene selected for fitting (opaque): their names,
/// values, bounds and gradient slots. One thread at a time. Added in 0.5.0.
#[allow(non_camel_case_types)]
pub struct plsr_parameters {
    params: Vec<Parameter>,
    names: Vec<CString>,
    len: usize,
}

/// How to estimate a gradient. Added in 0.5.0.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
#[allow(non_camel_case_types)]
pub struct plsr_gradient_settings {
    /// Samples per pixel (of the primal render and of the gradient pass each).
    pub spp: u32,
    /// Seed; the gradient pass uses `seed + 1`.
    pub seed: u64,
    /// Worker threads; 0: all cores.
    pub threads: u32,
    /// 1: hide the scene's virtual shapes (fitting the real surfaces to a
    /// photo of them); 0: render everything.
    pub hide_virtual: u32,
}

impl plsr_gradient_settings {
    fn job(&self, scene: &plsr::scene::Scene, seed: u64) -> Result<RenderJob, FfiError> {
        let job = RenderJob {
            spp: self.spp,
            seed,
            hide_virtual: self.hide_virtual != 0,
            ..scene.default_job()
        };
        job.validate()
            .map_err(|e| FfiError::invalid(format!("settings: {e}")))?;
        Ok(job)
    }

    fn options(&self) -> RenderOptions {
        RenderOptions {
            threads: (self.threads > 0).then_some(self.threads as usize),
            ..RenderOptions::default()
        }
    }
}

/// Selects the parameters of `scene` that `patterns` name (`count` C
/// strings such as `"wall.reflectance"`, `"*.roughness"`, `"lamp.b"`; with
/// `count` 0, the default: every real surface's colour, roughness, metallic
/// and anisotropic) into `*out`. An environment's `scale` is relative to
/// the scene as loaded (1). Added in 0.5.0.
#[no_mangle]
pub extern "C" fn plsr_parameters_select(
    scene: *const plsr_scene,
    patterns: *const *const c_char,
    count: usize,
    out: *mut *mut plsr_parameters,
) -> plsr_result {
    boundary(|| {
        let s = handle_ref(scene, "scene")?;
        if out.is_null() {
            return Err(FfiError::null("out"));
        }
        let ptrs = slice_arg(patterns, count, "patterns")?;
        let patterns = ptrs
            .iter()
            .enumerate()
            .map(|(i, p)| str_arg(*p, &format!("patterns[{i}]")).map(str::to_string))
            .collect::<Result<Vec<_>, _>>()?;
        let params = select(&s.scene, &patterns, 1.0)?;
        let names = params
            .iter()
            .map(|p| CString::new(p.name.replace('\0', "?")).unwrap_or_default())
            .collect();
        let len = params.iter().map(|p| p.value.len()).sum();
        write_out(
            out,
            new_handle(plsr_parameters { params, names, len }),
            "out",
        )
    })
}

/// Frees a parameter set (`NULL` is ignored). Added in 0.5.0.
#[no_mangle]
pub extern "C" fn plsr_parameters_free(params: *mut plsr_parameters) -> plsr_result {
    boundary(|| {
        if params.is_null() {
            return Ok(());
        }
        free_handle(params, "params")
    })
}

/// The number of parameters (`*count`) and of floats they hold together
/// (`*len`: a colour has three), which is the length of every values,
/// bounds and gradient array. Either pointer may be `NULL`. Added in 0.5.0.
#[no_mangle]
pub extern "C" fn plsr_parameters_size(
    params: *const plsr_parameters,
    count: *mut usize,
    len: *mut usize,
) -> plsr_result {
    boundary(|| {
        let p = handle_ref(params, "params")?;
        if !count.is_null() {
            write_out(count, p.params.len(), "count")?;
        }
        if !len.is_null() {
            write_out(len, p.len, "len")?;
        }
        Ok(())
    })
}

/// Parameter `index`: its name (`OWNER.FIELD`, owned by `params`, valid
/// until it is freed), its first float in the arrays (`*first`) and its
/// number of floats (`*size`, 1 or 3). Any out-pointer may be `NULL`.
/// Added in 0.5.0.
#[no_mangle]
pub extern "C" fn plsr_parameters_get(
    params: *const plsr_parameters,
    index: usize,
    name: *mut *const c_char,
    first: *mut usize,
    size: *mut usize,
) -> plsr_result {
    boundary(|| {
        let p = handle_ref(params, "params")?;
        let Some(param) = p.params.get(index) else {
            return Err(FfiError::invalid(format!(
                "`index` {index}: there are {} parameters",
                p.params.len()
            )));
        };
        if !name.is_null() {
            write_out(name, p.names[index].as_ptr(), "name")?;
        }
        if !first.is_null() {
            write_out(first, param.slot as usize, "first")?;
        }
        if !size.is_null() {
            write_out(size, param.value.len(), "size")?;
        }
        Ok(())
    })
}

/// Copies the current values (`values`) and bounds (`lower`, `upper`) into
/// arrays of `len` floats (from [`plsr_parameters_size`]); any array may
/// be `NULL`. Added in 0.5.0.
#[no_mangle]
pub extern "C" fn plsr_parameters_values(
    params: *const plsr_parameters,
    values: *mut f32,
    lower: *mut f32,
    upper: *mut f32,
    len: usize,
) -> plsr_result {
    boundary(|| {
        let p = handle_ref(params, "params")?;
        check_len(p, len)?;
        for (out, name) in [(values, "values"), (lower, "lower"), (upper, "upper")] {
            if out.is_null() {
                continue;
            }
            let dst = slice_mut_arg(out, len, name)?;
            for param in &p.params {
                for k in 0..param.value.len() {
                    dst[param.slot as usize + k] = match name {
                        "values" => param.value[k],
                        "lower" => param.bounds.0,
                        _ => param.bounds.1,
                    };
                }
            }
        }
        Ok(())
    })
}

fn check_len(p: &plsr_parameters, len: usize) -> Result<(), FfiError> {
    if len != p.len {
        return Err(FfiError::invalid(format!(
            "`len` {len}: the parameters hold {} floats",
            p.len
        )));
    }
    Ok(())
}

/// Sets the parameters of `scene` to `values` (`len` floats, laid out as
/// [`plsr_parameters_get`] says). Values outside a parameter's bounds are
/// refused, and nothing changes. Not while the scene is being rendered.
/// Added in 0.5.0.
#[no_mangle]
pub extern "C" fn plsr_parameters_set(
    scene: *mut plsr_scene,
    params: *mut plsr_parameters,
    values: *const f32,
    len: usize,
) -> plsr_result {
    boundary(|| {
        let s = handle_mut(scene, "scene")?;
        let p = handle_mut(params, "params")?;
        check_len(p, len)?;
        let v = slice_arg(values, len, "values")?;
        for param in &p.params {
            let (lo, hi) = param.bounds;
            for k in 0..param.value.len() {
                let x = v[param.slot as usize + k];
                if !(x >= lo && x <= hi) {
                    return Err(FfiError::invalid(format!(
                        "values[{}] = {x} for {} must be in [{lo}, {hi}]",
                        param.slot as usize + k,
                        param.name
                    )));
                }
            }
        }
        for param in &mut p.params {
            let first = param.slot as usize;
            let new = v[first..first + param.value.len()].to_vec();
            apply(&mut s.scene, param, &new)?;
            param.value = new;
        }
        Ok(())
    })
}

/// The gradient of `Σ_p adjoint_p · I_p` over the scene's render `I` with
/// respect to the parameters, into `gradient` (`len` floats): `adjoint`
/// holds `width × height` interleaved RGB floats (row-major from the top;
/// the camera's size), the derivative of the host's loss with respect to
/// each pixel's value. Uses `settings.seed` for its paths. Added in 0.5.0.
#[no_mangle]
pub extern "C" fn plsr_render_gradient(
    scene: *const plsr_scene,
    params: *const plsr_parameters,
    adjoint: *const f32,
    width: u32,
    height: u32,
    settings: *const plsr_gradient_settings,
    gradient: *mut f32,
    len: usize,
) -> plsr_result {
    boundary(|| {
        let s = handle_ref(scene, "scene")?;
        let p = handle_ref(params, "params")?;
        let c = slice_arg(settings, 1, "settings")?[0];
        check_len(p, len)?;
        let n = image_size(s, width, height)?;
        let a = slice_arg(adjoint, 3 * n, "adjoint")?;
        let adjoint: Vec<Vec3> = a.chunks_exact(3).map(Vec3::from_slice).collect();
        let job = c.job(&s.scene, c.seed)?;
        let map = gradient_map(&s.scene, &p.params);
        let r = render_gradient(&s.scene, &job, &c.options(), &map, &adjoint, false)?;
        write_gradient(gradient, len, &r.gradient)
    })
}

/// The mean squared error between the scene's render and `target`
/// (`width × height` interleaved linear RGB floats, the camera's size) over
/// the pixels where `mask` (one byte per pixel; `NULL`: every pixel) is not
/// 0, into `*loss`, and its gradient into `gradient` (`len` floats). The
/// render uses `settings.seed`, the gradient `settings.seed + 1`, so that
/// the gradient is unbiased. Added in 0.5.0.
#[no_mangle]
pub extern "C" fn plsr_loss_gradient(
    scene: *const plsr_scene,
    params: *const plsr_parameters,
    target: *const f32,
    mask: *const u8,
    width: u32,
    height: u32,
    settings: *const plsr_gradient_settings,
    loss: *mut f64,
    gradient: *mut f32,
    len: usize,
) -> plsr_result {
    boundary(|| {
        let s = handle_ref(scene, "scene")?;
        let p = handle_ref(params, "params")?;
        let c = slice_arg(settings, 1, "settings")?[0];
        check_len(p, len)?;
        if loss.is_null() {
            return Err(FfiError::null("loss"));
        }
        let n = image_size(s, width, height)?;
        let t = slice_arg(target, 3 * n, "target")?;
        let target: Vec<Vec3> = t.chunks_exact(3).map(Vec3::from_slice).collect();
        if let Some(i) = target.iter().position(|v| !v.is_finite()) {
            return Err(FfiError::invalid(format!(
                "`target` pixel {i} is not finite"
            )));
        }
        let mask: Vec<bool> = if mask.is_null() {
            vec![true; n]
        } else {
            slice_arg(mask, n, "mask")?
                .iter()
                .map(|m| *m != 0)
                .collect()
        };
        let pixels = mask.iter().filter(|m| **m).count();
        if pixels == 0 {
            return Err(FfiError::invalid("`mask` selects no pixel"));
        }
        let primal = c.job(&s.scene, c.seed)?;
        let gradient_job = c.job(&s.scene, c.seed.wrapping_add(1))?;
        let map = gradient_map(&s.scene, &p.params);
        let (l, g) = squared_error_gradient(
            &s.scene,
            &map,
            &target,
            &mask,
            (&primal, &gradient_job),
            &c.options(),
            3.0 * pixels as f64,
        )?;
        write_gradient(gradient, len, &g)?;
        write_out(loss, l, "loss")
    })
}

/// Copies a gradient into the host's array of `len` floats.
fn write_gradient(out: *mut f32, len: usize, gradient: &[f64]) -> Result<(), FfiError> {
    let out = slice_mut_arg(out, len, "gradient")?;
    for (o, g) in out.iter_mut().zip(gradient) {
        *o = *g as f32;
    }
    Ok(())
}

/// The number of pixels of the camera, checking `width × height` against it.
fn image_size(s: &plsr_scene, width: u32, height: u32) -> Result<usize, FfiError> {
    let cam = s.scene.camera();
    if (width, height) != (cam.width(), cam.height()) {
        return Err(FfiError::invalid(format!(
            "the image is {width}×{height} but the camera renders {}×{}",
            cam.width(),
            cam.height()
        )));
    }
    Ok(width as usize * height as usize)
}
