//! HDR merge of bracketed exposures through the C ABI.

use super::{boundary, path_arg, plsr_result, slice_arg, FfiError};
use plsr_hdr::merge::{merge, MergeOptions};
use plsr_hdr::response::ResponseMethod;
use std::ffi::c_char;

/// How the camera response of a merge is obtained.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum plsr_response {
    /// Recovered by Debevec & Malik 1997 (8-bit inputs).
    PLSR_RESPONSE_DEBEVEC = 0,
    /// Recovered by Robertson et al. 2003.
    PLSR_RESPONSE_ROBERTSON = 1,
    /// Linear data (camera raw, or already linear files).
    PLSR_RESPONSE_LINEAR = 2,
    /// The sRGB transfer function.
    PLSR_RESPONSE_SRGB = 3,
}

/// Merges `count` bracketed photos (paths, any order, any format
/// OpenImageIO reads) into the HDR image `output` (`.exr` or `.hdr`).
///
/// `exposures` is `NULL` to read exposure times from the files' EXIF, or
/// `count` exposure times in seconds, in the order of `inputs`. `response`
/// is a `plsr_response` value. On failure no output file is left behind.
/// May be called from several threads at once (on different outputs).
#[no_mangle]
pub extern "C" fn plsr_hdr_merge(
    inputs: *const *const c_char,
    count: usize,
    exposures: *const f64,
    response: u32,
    output: *const c_char,
) -> plsr_result {
    boundary(|| {
        let paths = slice_arg(inputs, count, "inputs")?
            .iter()
            .enumerate()
            .map(|(i, &p)| path_arg(p, &format!("inputs[{i}]")))
            .collect::<Result<Vec<_>, _>>()?;
        if count < 2 {
            return Err(FfiError::invalid("a merge needs at least two brackets"));
        }
        let exposures = if exposures.is_null() {
            None
        } else {
            let e = slice_arg(exposures, count, "exposures")?.to_vec();
            if let Some(i) = e.iter().position(|t| !(t.is_finite() && *t > 0.0)) {
                return Err(FfiError::invalid(format!(
                    "exposures[{i}] = {} must be a positive number of seconds",
                    e[i]
                )));
            }
            Some(e)
        };
        let response = match response {
            0 => ResponseMethod::Debevec,
            1 => ResponseMethod::Robertson,
            2 => ResponseMethod::Linear,
            3 => ResponseMethod::Srgb,
            v => {
                return Err(FfiError::invalid(format!(
                    "`response` = {v} is not a plsr_response"
                )))
            }
        };
        let output = path_arg(output, "output")?;
        let options = MergeOptions {
            response,
            exposures,
            ..Default::default()
        };
        merge(&paths, &output, &options, &|_, _, _| {})?;
        Ok(())
    })
}
