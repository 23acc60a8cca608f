//! Parametric light sources on their own through the C ABI: validate,
//! transform by a 4×4 matrix, tessellate.

use super::{boundary, plsr_result, slice_arg, slice_mut_arg, write_out, FfiError};
use glam::{Mat4, Vec3};
use plsr::light::pls::{BrightnessMode, Pls, PlsGeometry};

/// One parametric light source `l = (n, g, a, c, b)` (paper section 3;
/// units of the PLS file format: metres, degrees, linear RGB).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
#[allow(non_camel_case_types)]
pub struct plsr_pls_params {
    /// Unit normal: the side the emitter emits towards.
    pub n: [f32; 3],
    /// Start of the symmetry axis (metres).
    pub e1: [f32; 3],
    /// End of the symmetry axis (metres).
    pub e2: [f32; 3],
    /// First inner axis point along `e2 − e1`, in [0, alpha2].
    pub alpha1: f32,
    /// Second inner axis point, in [alpha1, 1].
    pub alpha2: f32,
    /// Half-widths of the four Bézier anchors (metres, ≥ 0).
    pub d: [f32; 4],
    /// Divergence half-angle of the beam, degrees in (0, 90].
    pub a_deg: f32,
    /// Colour, linear RGB, ≥ 0.
    pub c: [f32; 3],
    /// Brightness (≥ 0): radiant intensity along `n` (W/sr) when
    /// `brightness_is_radiance` is 0, else radiance (W/(m²·sr)).
    pub b: f32,
    /// 0: `b` is intensity (the default of plsr); 1: `b` is radiance.
    pub brightness_is_radiance: u32,
}

pub(crate) fn pls_from_params(p: &plsr_pls_params) -> Result<(Pls, BrightnessMode), FfiError> {
    let light = Pls {
        name: Some("params".into()),
        n: Vec3::from(p.n),
        g: PlsGeometry {
            e1: Vec3::from(p.e1),
            e2: Vec3::from(p.e2),
            alpha1: p.alpha1,
            alpha2: p.alpha2,
            d: p.d,
        },
        a_deg: p.a_deg,
        // The C struct predates the soft edge (0.5.0): hard-edged.
        penumbra_deg: 0.0,
        c: Vec3::from(p.c),
        b: p.b,
    };
    light
        .validate(0)
        .map_err(|e| FfiError::invalid(format!("{e}")))?;
    let mode = match p.brightness_is_radiance {
        0 => BrightnessMode::Intensity,
        1 => BrightnessMode::Radiance,
        v => {
            return Err(FfiError::invalid(format!(
                "params.brightness_is_radiance = {v} must be 0 or 1"
            )))
        }
    };
    Ok((light, mode))
}

fn params_from_pls(l: &Pls, brightness_is_radiance: u32) -> plsr_pls_params {
    plsr_pls_params {
        n: l.n.to_array(),
        e1: l.g.e1.to_array(),
        e2: l.g.e2.to_array(),
        alpha1: l.g.alpha1,
        alpha2: l.g.alpha2,
        d: l.g.d,
        a_deg: l.a_deg,
        c: l.c.to_array(),
        b: l.b,
        brightness_is_radiance,
    }
}

/// Checks a light's parameters: `PLSR_OK`, or `PLSR_ERR_INVALID_ARGUMENT`
/// with a message naming the parameter and the fault.
#[no_mangle]
pub extern "C" fn plsr_pls_validate(params: *const plsr_pls_params) -> plsr_result {
    boundary(|| {
        let p = slice_arg(params, 1, "params")?[0];
        pls_from_params(&p).map(|_| ())
    })
}

/// Transforms a light by the affine 4×4 matrix `matrix` (16 floats,
/// row-major, last row `0 0 0 1`) through its parameters (paper eq. 15–21):
/// `n' = normalize(R n)`, `e' = M e`, `d' = s·d`; `a`, `c`, `b` unchanged.
/// Writes the result to `*out` (which may alias `params`).
#[no_mangle]
pub extern "C" fn plsr_pls_transform(
    params: *const plsr_pls_params,
    matrix: *const f32,
    out: *mut plsr_pls_params,
) -> plsr_result {
    boundary(|| {
        let p = slice_arg(params, 1, "params")?[0];
        let m = slice_arg(matrix, 16, "matrix")?;
        if m.iter().any(|x| !x.is_finite()) {
            return Err(FfiError::invalid("`matrix` has a non-finite entry"));
        }
        if m[12] != 0.0 || m[13] != 0.0 || m[14] != 0.0 || m[15] != 1.0 {
            return Err(FfiError::invalid(
                "`matrix` is not affine: its last row must be 0 0 0 1",
            ));
        }
        let mut cols = [0.0f32; 16];
        for r in 0..4 {
            for c in 0..4 {
                cols[c * 4 + r] = m[r * 4 + c];
            }
        }
        let mat = Mat4::from_cols_array(&cols);
        if mat.determinant().abs() < 1e-12 {
            return Err(FfiError::invalid("`matrix` is singular"));
        }
        let (light, _) = pls_from_params(&p)?;
        let t = light.transform(&mat);
        write_out(out, params_from_pls(&t, p.brightness_is_radiance), "out")
    })
}

/// Tessellates a light's outline into `nf` quads (two triangles each where
/// not degenerate), facing `n`.
///
/// Two calls: with `positions` and `indices` `NULL`, writes the counts
/// needed to `*vertex_count` and `*triangle_count`; then with buffers of
/// `3·vertex_count` floats (`positions_len`) and `3·triangle_count`
/// indices (`indices_len`), fills them. Too-small buffers give
/// `PLSR_ERR_INVALID_ARGUMENT` and are left untouched.
#[no_mangle]
pub extern "C" fn plsr_pls_tessellate(
    params: *const plsr_pls_params,
    nf: u32,
    positions: *mut f32,
    positions_len: usize,
    indices: *mut u32,
    indices_len: usize,
    vertex_count: *mut usize,
    triangle_count: *mut usize,
) -> plsr_result {
    boundary(|| {
        let p = slice_arg(params, 1, "params")?[0];
        let nf = plsr::light::pls::check_nf(nf as u64)
            .map_err(|m| FfiError::invalid(format!("`nf` {m}")))?;
        let (light, _) = pls_from_params(&p)?;
        let mesh = light.tessellate(nf);
        let (nv, nt) = (mesh.positions.len(), mesh.triangles.len());
        write_out(vertex_count, nv, "vertex_count")?;
        write_out(triangle_count, nt, "triangle_count")?;
        if positions.is_null() && indices.is_null() {
            return Ok(());
        }
        if positions.is_null() || indices.is_null() {
            return Err(FfiError::null(if positions.is_null() {
                "positions"
            } else {
                "indices"
            }));
        }
        if positions_len < 3 * nv || indices_len < 3 * nt {
            return Err(FfiError::invalid(format!(
                "buffers too small: need {} floats and {} indices, got {positions_len} and {indices_len}",
                3 * nv,
                3 * nt
            )));
        }
        let pos = slice_mut_arg(positions, 3 * nv, "positions")?;
        let idx = slice_mut_arg(indices, 3 * nt, "indices")?;
        for (dst, v) in pos.chunks_exact_mut(3).zip(&mesh.positions) {
            dst.copy_from_slice(&v.to_array());
        }
        for (dst, t) in idx.chunks_exact_mut(3).zip(&mesh.triangles) {
            dst.copy_from_slice(t);
        }
        Ok(())
    })
}
