//! The C ABI: what C and C++ hosts (AR runtimes, engines, tools) link.
//!
//! Conventions of every function (the generated header `include/plsr.h`
//! repeats them):
//!
//! - **Handles are opaque** (`plsr_scene`, `plsr_scene_builder`,
//!   `plsr_image`): created by a `*_new`/`*_load`/`*_build`/`plsr_render`
//!   call through an out-pointer, released by the matching `*_free`, which
//!   accepts `NULL`. The library owns what a handle points to; pointers it
//!   returns into a handle (`plsr_image_rgba`) live until that handle is
//!   freed.
//! - **Every fallible call returns a [`plsr_result`]**; `PLSR_OK` is 0. The
//!   message of the last failure on the calling thread is
//!   [`plsr_last_error`]. Out-pointers are written only on success.
//! - **Nothing unwinds into the host**: every entry point runs inside a
//!   panic boundary (`PLSR_ERR_PANIC`); `NULL` pointers, wrong sizes,
//!   invalid UTF-8 paths and handles that are not live (never created,
//!   already freed, or of another type) give error codes, never a crash.
//!   Live handles are tracked in a registry, so a double free or a use after
//!   free is detected unless the address was reused by a new handle.
//! - **Threads**: a `plsr_scene` is immutable once built and may be rendered
//!   from several threads at once; a `plsr_scene_builder` or `plsr_image` must
//!   be used by one thread at a time. No handle may be freed while another
//!   thread uses it. `plsr_last_error` is per thread.
//!
//! Units follow the scene-file format: metres (or any consistent unit),
//! degrees for angles, linear RGB, row-major 4×4 matrices.

mod composite;
mod denoise;
mod fit;
mod hdr;
mod image;
mod pls;
mod scene;

pub use composite::*;
pub use denoise::*;
pub use fit::*;
pub use hdr::*;
pub use image::*;
pub use pls::*;
pub use scene::*;

use std::any::TypeId;
use std::cell::RefCell;
use std::collections::HashMap;
use std::ffi::{c_char, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::Mutex;

/// Result codes of the C API.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum plsr_result {
    /// Success.
    PLSR_OK = 0,
    /// A required pointer argument was `NULL`.
    PLSR_ERR_NULL_ARGUMENT = 1,
    /// An argument is out of range or inconsistent (sizes, values, UTF-8).
    PLSR_ERR_INVALID_ARGUMENT = 2,
    /// A handle that is not live: never created, freed, or of another type.
    PLSR_ERR_INVALID_HANDLE = 3,
    /// Bad input data: a scene, light or image file with a fault (the message
    /// names the file, the field and the fault).
    PLSR_ERR_INPUT = 4,
    /// Reading or writing a file failed.
    PLSR_ERR_IO = 5,
    /// Embree reported an error.
    PLSR_ERR_EMBREE = 6,
    /// The progress callback asked to stop.
    PLSR_ERR_CANCELLED = 7,
    /// An internal error (a caught panic); please report it.
    PLSR_ERR_PANIC = 8,
}

pub use plsr_result::*;

/// A failure on its way to the host: a code and a message.
pub(crate) struct FfiError {
    code: plsr_result,
    message: String,
}

impl FfiError {
    pub(crate) fn new(code: plsr_result, message: impl Into<String>) -> FfiError {
        FfiError {
            code,
            message: message.into(),
        }
    }

    pub(crate) fn invalid(message: impl Into<String>) -> FfiError {
        FfiError::new(PLSR_ERR_INVALID_ARGUMENT, message)
    }

    pub(crate) fn null(name: &str) -> FfiError {
        FfiError::new(PLSR_ERR_NULL_ARGUMENT, format!("`{name}` is NULL"))
    }
}

/// The result code of each kind of failure, whichever crate reported it.
trait ResultCode {
    fn result_code(&self) -> plsr_result;
}

impl ResultCode for plsr_base::Error {
    fn result_code(&self) -> plsr_result {
        match self {
            plsr_base::Error::Input { .. } => PLSR_ERR_INPUT,
            plsr_base::Error::Io { .. } | plsr_base::Error::Output { .. } => PLSR_ERR_IO,
            plsr_base::Error::InvalidArgument(_) => PLSR_ERR_INVALID_ARGUMENT,
            plsr_base::Error::Cancelled => PLSR_ERR_CANCELLED,
        }
    }
}

impl ResultCode for plsr_hdr::oiio::Error {
    fn result_code(&self) -> plsr_result {
        match self {
            plsr_hdr::oiio::Error::Base(e) => e.result_code(),
            plsr_hdr::oiio::Error::Unavailable { .. } | plsr_hdr::oiio::Error::Read { .. } => {
                PLSR_ERR_INPUT
            }
            plsr_hdr::oiio::Error::Write { .. } => PLSR_ERR_IO,
        }
    }
}

impl ResultCode for plsr::Error {
    fn result_code(&self) -> plsr_result {
        match self {
            plsr::Error::Base(e) => e.result_code(),
            plsr::Error::Embree(_) => PLSR_ERR_EMBREE,
            plsr::Error::Denoise(_) => PLSR_ERR_INPUT,
        }
    }
}

impl ResultCode for plsr_hdr::Error {
    fn result_code(&self) -> plsr_result {
        match self {
            plsr_hdr::Error::Base(e) => e.result_code(),
            plsr_hdr::Error::Image(e) => e.result_code(),
        }
    }
}

impl ResultCode for plsr_metrics::Error {
    fn result_code(&self) -> plsr_result {
        match self {
            plsr_metrics::Error::Base(e) => e.result_code(),
            plsr_metrics::Error::Image(e) => e.result_code(),
            plsr_metrics::Error::Weights(_) => PLSR_ERR_INVALID_ARGUMENT,
        }
    }
}

impl ResultCode for plsr_apps::Error {
    fn result_code(&self) -> plsr_result {
        match self {
            plsr_apps::Error::Base(e) => e.result_code(),
            plsr_apps::Error::Render(e) => e.result_code(),
            plsr_apps::Error::Hdr(e) => e.result_code(),
            plsr_apps::Error::Image(e) => e.result_code(),
            plsr_apps::Error::Metrics(e) => e.result_code(),
        }
    }
}

macro_rules! ffi_error_from {
    ($($error:ty),*) => {$(
        impl From<$error> for FfiError {
            fn from(e: $error) -> FfiError {
                FfiError::new(e.result_code(), e.to_string())
            }
        }
    )*};
}

ffi_error_from!(
    plsr_base::Error,
    plsr_hdr::oiio::Error,
    plsr::Error,
    plsr_hdr::Error,
    plsr_metrics::Error,
    plsr_apps::Error
);

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

fn set_last_error(message: &str) {
    let c = CString::new(message.replace('\0', "\u{fffd}")).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = c);
}

/// Runs an entry point's body inside the panic boundary and turns its
/// outcome into a result code, recording the message of a failure.
pub(crate) fn boundary(body: impl FnOnce() -> Result<(), FfiError>) -> plsr_result {
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(Ok(())) => PLSR_OK,
        Ok(Err(e)) => {
            set_last_error(&e.message);
            e.code
        }
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            set_last_error(&format!("internal error: {what}"));
            PLSR_ERR_PANIC
        }
    }
}

/// The message of the last failed call on this thread ("" if none yet).
///
/// The string is owned by the library and valid until the next failing call
/// on the same thread; copy it to keep it.
#[no_mangle]
pub extern "C" fn plsr_last_error() -> *const c_char {
    catch_unwind(|| LAST_ERROR.with(|e| e.borrow().as_ptr())).unwrap_or(c"internal error".as_ptr())
}

/// The library's version, e.g. `"0.1.0"`: a static string, never freed.
#[no_mangle]
pub extern "C" fn plsr_version() -> *const c_char {
    static VERSION: &CStr =
        match CStr::from_bytes_with_nul(concat!(env!("CARGO_PKG_VERSION"), "\0").as_bytes()) {
            Ok(v) => v,
            Err(_) => c"unknown",
        };
    VERSION.as_ptr()
}

// ---- handles ------------------------------------------------------------

/// Live handles: address → type. Every handle passed in is checked here
/// before it is dereferenced.
static LIVE: Mutex<Option<HashMap<usize, TypeId>>> = Mutex::new(None);

fn live() -> std::sync::MutexGuard<'static, Option<HashMap<usize, TypeId>>> {
    // A poisoned lock only means a panic elsewhere while holding it; the map
    // itself stays consistent (single inserts and removes).
    LIVE.lock().unwrap_or_else(|p| p.into_inner())
}

/// Moves `value` to the heap and registers it; returns the handle.
pub(crate) fn new_handle<T: 'static>(value: T) -> *mut T {
    let ptr = Box::into_raw(Box::new(value));
    live()
        .get_or_insert_with(HashMap::new)
        .insert(ptr as usize, TypeId::of::<T>());
    ptr
}

fn check_live<T: 'static>(ptr: *const T, name: &str) -> Result<(), FfiError> {
    if ptr.is_null() {
        return Err(FfiError::null(name));
    }
    match live()
        .as_ref()
        .and_then(|m| m.get(&(ptr as usize)).copied())
    {
        Some(t) if t == TypeId::of::<T>() => Ok(()),
        Some(_) => Err(FfiError::new(
            PLSR_ERR_INVALID_HANDLE,
            format!("`{name}` is a handle of another type"),
        )),
        None => Err(FfiError::new(
            PLSR_ERR_INVALID_HANDLE,
            format!("`{name}` is not a live handle (freed, or never created by plsr)"),
        )),
    }
}

/// Borrows a live handle.
pub(crate) fn handle_ref<'a, T: 'static>(ptr: *const T, name: &str) -> Result<&'a T, FfiError> {
    check_live(ptr, name)?;
    // SAFETY: the registry holds exactly the addresses returned by
    // `new_handle::<T>` and not yet freed, so `ptr` points to a live, aligned
    // `T`. The documented contract forbids freeing it while this call uses it.
    Ok(unsafe { &*ptr })
}

/// Borrows a live handle mutably.
pub(crate) fn handle_mut<'a, T: 'static>(ptr: *mut T, name: &str) -> Result<&'a mut T, FfiError> {
    check_live(ptr, name)?;
    // SAFETY: as in `handle_ref`; builders and images are documented as
    // single-threaded, so no other reference exists during the call.
    Ok(unsafe { &mut *ptr })
}

/// Unregisters and drops a handle; `NULL` is a no-op, a handle that is not
/// live is reported and left alone.
pub(crate) fn free_handle<T: 'static>(ptr: *mut T, name: &str) -> Result<(), FfiError> {
    if ptr.is_null() {
        return Ok(());
    }
    check_live(ptr, name)?;
    if let Some(m) = live().as_mut() {
        m.remove(&(ptr as usize));
    }
    // SAFETY: `ptr` came from `Box::into_raw` in `new_handle::<T>` and was
    // live until the removal above, so it is dropped exactly once.
    drop(unsafe { Box::from_raw(ptr) });
    Ok(())
}

// ---- arguments ----------------------------------------------------------

/// A UTF-8 path from a C string.
pub(crate) fn path_arg(p: *const c_char, name: &str) -> Result<PathBuf, FfiError> {
    Ok(PathBuf::from(str_arg(p, name)?))
}

/// A UTF-8 string from a C string.
pub(crate) fn str_arg<'a>(p: *const c_char, name: &str) -> Result<&'a str, FfiError> {
    if p.is_null() {
        return Err(FfiError::null(name));
    }
    // SAFETY: the caller passes a NUL-terminated string that lives for the
    // call (the documented contract of every `const char *` argument).
    unsafe { CStr::from_ptr(p) }
        .to_str()
        .map_err(|_| FfiError::invalid(format!("`{name}` is not valid UTF-8")))
}

/// A slice of `len` elements at `p`.
pub(crate) fn slice_arg<'a, T>(p: *const T, len: usize, name: &str) -> Result<&'a [T], FfiError> {
    if len == 0 {
        return Ok(&[]);
    }
    if p.is_null() {
        return Err(FfiError::null(name));
    }
    if !(p as usize).is_multiple_of(std::mem::align_of::<T>()) {
        return Err(FfiError::invalid(format!("`{name}` is misaligned")));
    }
    // SAFETY: the caller passes `len` readable elements at `p` (the
    // documented contract); non-null and alignment are checked above.
    Ok(unsafe { std::slice::from_raw_parts(p, len) })
}

/// A writable slice of `len` elements at `p`.
pub(crate) fn slice_mut_arg<'a, T>(
    p: *mut T,
    len: usize,
    name: &str,
) -> Result<&'a mut [T], FfiError> {
    if p.is_null() {
        return Err(FfiError::null(name));
    }
    if !(p as usize).is_multiple_of(std::mem::align_of::<T>()) {
        return Err(FfiError::invalid(format!("`{name}` is misaligned")));
    }
    // SAFETY: the caller passes at least `len` writable elements at `p` (the
    // documented contract, with `len` checked against the buffer size the
    // caller gave); non-null and alignment are checked above.
    Ok(unsafe { std::slice::from_raw_parts_mut(p, len) })
}

/// Three floats at `p` (a `const float[3]` argument).
pub(crate) fn vec3_arg(p: *const f32, name: &str) -> Result<glam::Vec3, FfiError> {
    let s = slice_arg(p, 3, name)?;
    let v = glam::Vec3::new(s[0], s[1], s[2]);
    if !v.is_finite() {
        return Err(FfiError::invalid(format!(
            "`{name}` has a non-finite component"
        )));
    }
    Ok(v)
}

/// Writes `value` through an out-pointer.
pub(crate) fn write_out<T>(out: *mut T, value: T, name: &str) -> Result<(), FfiError> {
    if out.is_null() {
        return Err(FfiError::null(name));
    }
    // SAFETY: `out` is non-null and, by contract, points to writable storage
    // for a `T`.
    unsafe { out.write(value) };
    Ok(())
}

#[cfg(test)]
mod tests;
