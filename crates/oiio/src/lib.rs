//! Safe Rust over the OpenImageIO C++ shim (`shim/oiio_shim.{h,cpp}`).
//!
//! Reading: [`ImageReader`] opens any format OpenImageIO reads (JPEG, PNG,
//! TIFF 8/16-bit, OpenEXR, Radiance HDR, camera raw through libraw, …),
//! reports the size, channels and source bit depth, the EXIF exposure
//! metadata, and reads row ranges converted to `u8`, `u16` or `f32` (so large
//! images can be streamed). Writing: [`ImageWriter`] streams rows into any
//! format OpenImageIO writes (OpenEXR float or half, Radiance HDR, 8/16-bit
//! TIFF/PNG/JPEG) with header attributes, through a temporary file in the
//! same folder that is renamed into place only when the file is complete.
//!
//! Every failure is an [`Error`] naming the file and carrying OpenImageIO's
//! own message ([`error`]); the shim catches every C++ exception, none reaches Rust.
//! This module holds all of plsr's `unsafe` code for OpenImageIO.
//!
//! Two common cases skip OpenImageIO, whose loading costs about 0.3 s:
//! 8/16-bit PNGs without alpha are read by [`png_reader`], and OpenEXR
//! files up to [`exr_writer::MAX_BYTES`] with plsr's attributes are written
//! by [`exr_writer`]; both give what OpenImageIO gives.

pub mod error;
pub mod exr_writer;
pub mod png_reader;

pub use error::{Error, LoadFailure, Result};
use plsr_base::Vocabulary;
use std::ffi::{c_char, c_int, CStr, CString};
use std::path::{Path, PathBuf};
use std::ptr::NonNull;

/// Raw declarations of the shim (imports, not part of plsr's own C API),
/// and the loader that opens it.
///
/// The shim is a shared library of its own (`libplsr_oiio.so`, built by
/// `build.rs` and linked against OpenImageIO), embedded in plsr's code and
/// opened with `dlopen` the first time an image is read or written: plsr
/// itself does not link OpenImageIO, so the commands that never touch an
/// image start without loading its ~260 libraries.
///
/// cbindgen:ignore
mod ffi {
    use crate::LoadFailure;
    use std::ffi::{c_char, c_float, c_int, c_void, CStr};
    use std::sync::OnceLock;

    pub const OK: c_int = 0;
    pub const U8: c_int = 0;
    pub const U16: c_int = 1;
    pub const HALF: c_int = 2;
    pub const F32: c_int = 3;

    #[repr(C)]
    pub struct Input {
        _private: [u8; 0],
    }
    #[repr(C)]
    pub struct Output {
        _private: [u8; 0],
    }

    #[repr(C)]
    #[derive(Default)]
    pub struct Spec {
        pub width: c_int,
        pub height: c_int,
        pub channels: c_int,
        pub format: c_int,
        pub bits: c_int,
    }

    #[repr(C)]
    pub struct Attr {
        pub name: *const c_char,
        pub kind: c_int,
        pub f: c_float,
        pub i: c_int,
        pub s: *const c_char,
    }

    pub type OpenFn = unsafe extern "C" fn(
        path: *const c_char,
        out: *mut *mut Input,
        spec: *mut Spec,
        err: *mut c_char,
        err_len: usize,
    ) -> c_int;
    pub type GetFloatFn =
        unsafe extern "C" fn(in_: *const Input, name: *const c_char, value: *mut f32) -> c_int;
    pub type GetStringFn = unsafe extern "C" fn(
        in_: *const Input,
        name: *const c_char,
        buf: *mut c_char,
        buf_len: usize,
    ) -> c_int;
    pub type ReadRowsFn = unsafe extern "C" fn(
        in_: *mut Input,
        ybegin: c_int,
        yend: c_int,
        type_: c_int,
        data: *mut c_void,
        data_len: usize,
        err: *mut c_char,
        err_len: usize,
    ) -> c_int;
    pub type CloseFn = unsafe extern "C" fn(in_: *mut Input);
    pub type CreateFn = unsafe extern "C" fn(
        path: *const c_char,
        width: c_int,
        height: c_int,
        channels: c_int,
        type_: c_int,
        attrs: *const Attr,
        n_attrs: usize,
        out: *mut *mut Output,
        err: *mut c_char,
        err_len: usize,
    ) -> c_int;
    pub type WriteRowsFn = unsafe extern "C" fn(
        out: *mut Output,
        ybegin: c_int,
        yend: c_int,
        type_: c_int,
        data: *const c_void,
        data_len: usize,
        err: *mut c_char,
        err_len: usize,
    ) -> c_int;
    pub type FinishFn =
        unsafe extern "C" fn(out: *mut Output, err: *mut c_char, err_len: usize) -> c_int;
    pub type AbortFn = unsafe extern "C" fn(out: *mut Output);

    /// The shim's entry points (`shim/oiio_shim.h`), looked up in the
    /// loaded library.
    pub struct Api {
        pub open: OpenFn,
        pub get_float: GetFloatFn,
        pub get_string: GetStringFn,
        pub read_rows: ReadRowsFn,
        pub close: CloseFn,
        pub create: CreateFn,
        pub write_rows: WriteRowsFn,
        pub finish: FinishFn,
        pub abort: AbortFn,
    }

    /// The shim library, as `build.rs` linked it.
    static SHIM: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/libplsr_oiio.so"));

    static API: OnceLock<Result<Api, LoadFailure>> = OnceLock::new();

    /// The shim's entry points, loading it (and with it OpenImageIO) on
    /// first use; the error says why it could not be loaded.
    pub fn api() -> Result<&'static Api, &'static LoadFailure> {
        API.get_or_init(load).as_ref()
    }

    /// The entry points of the shim already loaded: every handle came from
    /// [`api`], so a call on a handle finds them.
    pub fn loaded() -> &'static Api {
        match API.get() {
            Some(Ok(api)) => api,
            _ => unreachable!("an OpenImageIO handle exists only once the shim is loaded"),
        }
    }

    /// The last `dlerror` message.
    fn dl_error() -> String {
        // SAFETY: dlerror returns NULL or a NUL-terminated string valid until
        // the next dl call on this thread; it is copied at once.
        let e = unsafe { libc::dlerror() };
        if e.is_null() {
            "unknown dlopen error".into()
        } else {
            // SAFETY: non-null, NUL-terminated (see above).
            unsafe { CStr::from_ptr(e) }.to_string_lossy().into_owned()
        }
    }

    /// Opens the embedded library: from an anonymous in-memory file
    /// (`memfd_create`), or where that is unavailable from a temporary file
    /// removed again once it is mapped.
    fn open_library() -> Result<*mut c_void, LoadFailure> {
        use std::io::Write;
        use std::os::fd::FromRawFd;
        let flags = libc::RTLD_NOW | libc::RTLD_LOCAL;
        // SAFETY: the name is a NUL-terminated literal; the returned
        // descriptor, when valid, is owned by the File made from it.
        let fd = unsafe { libc::memfd_create(c"plsr-oiio-shim".as_ptr(), libc::MFD_CLOEXEC) };
        if fd >= 0 {
            // SAFETY: `fd` is a fresh descriptor nobody else owns.
            let mut file = unsafe { std::fs::File::from_raw_fd(fd) };
            file.write_all(SHIM).map_err(|e| {
                LoadFailure::Staging(format!("cannot write the OpenImageIO shim to memory: {e}"))
            })?;
            let path = std::ffi::CString::new(format!("/proc/self/fd/{fd}"))
                .expect("no NUL in a formatted path");
            // SAFETY: a NUL-terminated path; the descriptor stays open (the
            // File lives) until dlopen has mapped the library.
            let handle = unsafe { libc::dlopen(path.as_ptr(), flags) };
            drop(file);
            if !handle.is_null() {
                return Ok(handle);
            }
            let why = dl_error();
            // /proc not mounted: fall back to a file. Anything else (a
            // missing OpenImageIO) would fail there too.
            if !why.contains("/proc/self/fd") {
                return Err(LoadFailure::Dlopen(why));
            }
        }
        let dir = std::env::temp_dir();
        let path = dir.join(format!(
            ".plsr-oiio-shim.{}.{:?}.so",
            std::process::id(),
            std::thread::current().id()
        ));
        let write = || -> std::io::Result<()> {
            let mut f = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)?;
            f.write_all(SHIM)
        };
        if let Err(e) = write() {
            let _ = std::fs::remove_file(&path);
            return Err(LoadFailure::Staging(format!(
                "cannot write the OpenImageIO shim to {}: {e}",
                path.display()
            )));
        }
        let cpath = std::ffi::CString::new(path.as_os_str().as_encoded_bytes()).map_err(|_| {
            LoadFailure::Staging(format!("{}: the path contains a NUL byte", path.display()))
        })?;
        // SAFETY: a NUL-terminated path to a complete library file.
        let handle = unsafe { libc::dlopen(cpath.as_ptr(), flags) };
        let result = if handle.is_null() {
            Err(LoadFailure::Dlopen(dl_error()))
        } else {
            Ok(handle)
        };
        let _ = std::fs::remove_file(&path);
        result
    }

    fn load() -> Result<Api, LoadFailure> {
        let lib = open_library()?;
        let symbol = |name: &CStr| -> Result<*mut c_void, LoadFailure> {
            // SAFETY: `lib` is a live handle from dlopen (never closed) and
            // `name` a NUL-terminated symbol name.
            let p = unsafe { libc::dlsym(lib, name.as_ptr()) };
            if p.is_null() {
                Err(LoadFailure::MissingSymbol {
                    name: name.to_string_lossy().into_owned(),
                    dl_error: dl_error(),
                })
            } else {
                Ok(p)
            }
        };
        // SAFETY (each transmute): the symbol is the shim's function of that
        // name, defined in shim/oiio_shim.cpp with exactly the C signature of
        // the field it is stored in, and the library stays loaded for the
        // life of the process.
        macro_rules! function {
            ($name:literal, $type:ty) => {
                // SAFETY: see above: the shim's function of that name, of
                // exactly this signature, in a library loaded for good.
                unsafe { std::mem::transmute::<*mut c_void, $type>(symbol($name)?) }
            };
        }
        Ok(Api {
            open: function!(c"plsr_oiio_open", OpenFn),
            get_float: function!(c"plsr_oiio_get_float", GetFloatFn),
            get_string: function!(c"plsr_oiio_get_string", GetStringFn),
            read_rows: function!(c"plsr_oiio_read_rows", ReadRowsFn),
            close: function!(c"plsr_oiio_close", CloseFn),
            create: function!(c"plsr_oiio_create", CreateFn),
            write_rows: function!(c"plsr_oiio_write_rows", WriteRowsFn),
            finish: function!(c"plsr_oiio_finish", FinishFn),
            abort: function!(c"plsr_oiio_abort", AbortFn),
        })
    }
}

/// Size of the buffer OpenImageIO's error messages are copied into, in bytes.
const ERR_LEN: usize = 2048;

/// The error message the shim left in `buf`.
fn message(buf: &[c_char; ERR_LEN]) -> String {
    // SAFETY: the shim always NUL-terminates within ERR_LEN bytes when it
    // writes a message, and the buffer starts zeroed, so there is a NUL inside.
    let s = unsafe { CStr::from_ptr(buf.as_ptr()) }
        .to_string_lossy()
        .trim()
        .to_string();
    if s.is_empty() {
        "OpenImageIO reported an error without a message".into()
    } else {
        s
    }
}

fn c_path(path: &Path) -> Result<CString> {
    use std::os::unix::ffi::OsStrExt;
    CString::new(path.as_os_str().as_bytes())
        .map_err(|_| Error::input(path, "", "the path contains a NUL byte"))
}

/// A pixel type of a file or of a buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PixelType {
    /// 8-bit unsigned integer (values 0–255 stand for 0–1).
    U8,
    /// 16-bit unsigned integer (values 0–65535 stand for 0–1).
    U16,
    /// 16-bit float (OpenEXR half).
    Half,
    /// 32-bit float.
    F32,
    /// Anything else OpenImageIO reads (read it converted to `f32`).
    Other,
}

impl PixelType {
    fn code(self) -> c_int {
        match self {
            PixelType::U8 => ffi::U8,
            PixelType::U16 => ffi::U16,
            PixelType::Half => ffi::HALF,
            PixelType::F32 | PixelType::Other => ffi::F32,
        }
    }

    fn from_code(code: c_int) -> PixelType {
        match code {
            ffi::U8 => PixelType::U8,
            ffi::U16 => PixelType::U16,
            ffi::HALF => PixelType::Half,
            ffi::F32 => PixelType::F32,
            _ => PixelType::Other,
        }
    }

    /// Whether values are integers with a fixed clip level (U8, U16).
    pub fn is_integer(self) -> bool {
        matches!(self, PixelType::U8 | PixelType::U16)
    }
}

/// Element types rows can be read into or written from: `u8`, `u16`, `f32`.
pub trait Sample: Copy + Default + Send + Sync + 'static + private::Sealed {
    /// The matching [`PixelType`].
    const TYPE: PixelType;
}
impl Sample for u8 {
    const TYPE: PixelType = PixelType::U8;
}
impl Sample for u16 {
    const TYPE: PixelType = PixelType::U16;
}
impl Sample for f32 {
    const TYPE: PixelType = PixelType::F32;
}
/// Conversions between sample types, as OpenImageIO converts them
/// (integers span 0–1 over their full range, scaled by the reciprocal of
/// their largest value).
pub(crate) mod private {
    pub trait Sealed: Sized {
        fn from_u8(v: u8) -> Self;
        fn from_u16(v: u16) -> Self;
        fn to_f32(self) -> f32;
    }
    impl Sealed for u8 {
        fn from_u8(v: u8) -> Self {
            v
        }
        fn from_u16(v: u16) -> Self {
            ((u32::from(v) * 255 + 32767) / 65535) as u8
        }
        fn to_f32(self) -> f32 {
            f32::from(self) * (1.0 / 255.0)
        }
    }
    impl Sealed for u16 {
        fn from_u8(v: u8) -> Self {
            u16::from(v) * 257
        }
        fn from_u16(v: u16) -> Self {
            v
        }
        fn to_f32(self) -> f32 {
            f32::from(self) * (1.0 / 65535.0)
        }
    }
    impl Sealed for f32 {
        fn from_u8(v: u8) -> Self {
            v.to_f32()
        }
        fn from_u16(v: u16) -> Self {
            v.to_f32()
        }
        fn to_f32(self) -> f32 {
            self
        }
    }
}

/// Size, channels and depth of an image file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ImageInfo {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Channels per pixel (interleaved).
    pub channels: usize,
    /// The file's pixel type.
    pub format: PixelType,
    /// Significant bits per sample as the file states them (e.g. 12 for some
    /// camera raw files stored in 16 bits); otherwise the size of `format`.
    pub bits: u32,
}

/// Exposure metadata from a file's EXIF block; `None` where absent.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Exif {
    /// Exposure time in seconds (`ExposureTime`).
    pub exposure_time: Option<f64>,
    /// Aperture f-number (`FNumber`).
    pub f_number: Option<f64>,
    /// ISO sensitivity (`Exif:ISOSpeedRatings` or `Exif:PhotographicSensitivity`).
    pub iso: Option<f64>,
}

/// An image file open for reading (first subimage, full resolution).
#[derive(Debug)]
pub struct ImageReader {
    source: Source,
    info: ImageInfo,
    path: PathBuf,
}

/// What reads an [`ImageReader`]'s file.
#[derive(Debug)]
enum Source {
    /// OpenImageIO, through the shim.
    Oiio(NonNull<ffi::Input>),
    /// plsr's own PNG reader.
    Png(Box<png_reader::PngRows>),
}

// SAFETY: an OpenImageIO ImageInput may be used from any thread as long as
// calls do not overlap; `ImageReader` is not `Sync` and every call takes
// `&mut self` or only reads the immutable spec, so moving it is sound.
unsafe impl Send for ImageReader {}

impl ImageReader {
    /// Opens `path`. Errors name the file and carry OpenImageIO's message.
    pub fn open(path: &Path) -> Result<ImageReader> {
        plsr_base::input::check_input_file(path)?;
        if png_reader::is_png(path) {
            if let Some(png) = png_reader::PngRows::open(path)? {
                return Ok(ImageReader {
                    info: png.info().clone(),
                    source: Source::Png(Box::new(png)),
                    path: path.to_path_buf(),
                });
            }
        }
        Self::open_with_oiio(path)
    }

    /// Opens `path` with OpenImageIO, whatever its format. An OpenEXR
    /// header whose sizes the file cannot hold is refused first
    /// ([`plsr_base::exr_header::header_fault`]): OpenImageIO would size
    /// its buffers from it.
    fn open_with_oiio(path: &Path) -> Result<ImageReader> {
        if plsr_base::exr_header::is_exr(path) {
            use plsr_base::Vocabulary;
            let fault =
                plsr_base::exr_header::header_fault(path).map_err(|e| Error::io(path, e))?;
            if let Some(fault) = fault {
                return Err(Error::input(path, "dataWindow", fault));
            }
        }
        let cpath = c_path(path)?;
        let mut handle: *mut ffi::Input = std::ptr::null_mut();
        let mut spec = ffi::Spec::default();
        let mut err = [0 as c_char; ERR_LEN];
        let api = ffi::api().map_err(|why| Error::Unavailable {
            file: path.to_path_buf(),
            reason: why.clone(),
        })?;
        // SAFETY: all pointers are valid for the duration of the call: the
        // path is a NUL-terminated CString, `handle` and `spec` are local
        // out-parameters, and `err` holds ERR_LEN bytes as stated.
        let status = unsafe {
            (api.open)(
                cpath.as_ptr(),
                &mut handle,
                &mut spec,
                err.as_mut_ptr(),
                ERR_LEN,
            )
        };
        if status != ffi::OK {
            return Err(Error::Read {
                file: path.to_path_buf(),
                message: message(&err),
            });
        }
        let handle = NonNull::new(handle).ok_or_else(|| Error::Read {
            file: path.to_path_buf(),
            message: "OpenImageIO returned no image".into(),
        })?;
        let format = PixelType::from_code(spec.format);
        Ok(ImageReader {
            source: Source::Oiio(handle),
            info: ImageInfo {
                width: spec.width.max(0) as usize,
                height: spec.height.max(0) as usize,
                channels: spec.channels.max(0) as usize,
                format,
                bits: spec.bits.max(0) as u32,
            },
            path: path.to_path_buf(),
        })
    }

    /// The image's size, channels and depth.
    pub fn info(&self) -> &ImageInfo {
        &self.info
    }

    /// The file this reader reads.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// A numeric metadata attribute (OpenImageIO name, e.g. `"ExposureTime"`).
    pub fn float_attribute(&self, name: &str) -> Option<f64> {
        let handle = match &self.source {
            Source::Oiio(handle) => handle,
            // PNG text chunks are strings, as OpenImageIO reports them.
            Source::Png(_) => return None,
        };
        let cname = CString::new(name).ok()?;
        let mut v = 0f32;
        // SAFETY: the handle is live (owned by self), the name is a valid C
        // string, and `v` is a valid out-parameter; the shim never throws.
        let found = unsafe { (ffi::loaded().get_float)(handle.as_ptr(), cname.as_ptr(), &mut v) };
        (found == 1 && v.is_finite()).then_some(v as f64)
    }

    /// A string metadata attribute, truncated to 64 KiB.
    pub fn string_attribute(&self, name: &str) -> Option<String> {
        let handle = match &self.source {
            Source::Oiio(handle) => handle,
            Source::Png(png) => return png.text(name).map(str::to_owned),
        };
        let cname = CString::new(name).ok()?;
        let mut buf = vec![0 as c_char; 65536];
        // SAFETY: the handle is live, the name is a valid C string, and `buf`
        // holds `buf.len()` bytes; the shim NUL-terminates within them.
        let found = unsafe {
            (ffi::loaded().get_string)(handle.as_ptr(), cname.as_ptr(), buf.as_mut_ptr(), buf.len())
        };
        if found != 1 {
            return None;
        }
        // SAFETY: the shim wrote a NUL-terminated string into `buf`.
        Some(
            unsafe { CStr::from_ptr(buf.as_ptr()) }
                .to_string_lossy()
                .into_owned(),
        )
    }

    /// Exposure time, f-number and ISO from the EXIF metadata; values that
    /// are absent, non-positive or non-finite are `None`.
    pub fn exif(&self) -> Exif {
        let positive = |name: &str| self.float_attribute(name).filter(|v| *v > 0.0);
        Exif {
            exposure_time: positive("ExposureTime").or_else(|| positive("Exif:ExposureTime")),
            f_number: positive("FNumber").or_else(|| positive("Exif:FNumber")),
            iso: positive("Exif:ISOSpeedRatings")
                .or_else(|| positive("Exif:PhotographicSensitivity")),
        }
    }

    /// Reads rows `y0..y1` (all channels, interleaved) converted to `T` into
    /// `out`, which must hold exactly `(y1 - y0) · width · channels` values.
    /// Integer types span their full range for 0–1 (u8: 255, u16: 65535).
    pub fn read_rows<T: Sample>(&mut self, y0: usize, y1: usize, out: &mut [T]) -> Result<()> {
        let need = y1.saturating_sub(y0) * self.info.width * self.info.channels;
        if y0 > y1 || y1 > self.info.height || out.len() != need {
            return Err(Error::invalid_argument(format!(
                "{}: rows {y0}..{y1} with a buffer of {} values (image {}×{}×{})",
                self.path.display(),
                out.len(),
                self.info.width,
                self.info.height,
                self.info.channels
            )));
        }
        let handle = match &mut self.source {
            Source::Oiio(handle) => *handle,
            Source::Png(png) => return png.read_rows(y0, y1, out),
        };
        let mut err = [0 as c_char; ERR_LEN];
        // SAFETY: the handle is live and used by one thread at a time (&mut
        // self); `out` is a valid writable buffer of exactly
        // `size_of_val(out)` bytes, which the shim checks against the rows
        // requested; `err` holds ERR_LEN bytes.
        let status = unsafe {
            (ffi::loaded().read_rows)(
                handle.as_ptr(),
                y0 as c_int,
                y1 as c_int,
                T::TYPE.code(),
                out.as_mut_ptr().cast(),
                std::mem::size_of_val(out),
                err.as_mut_ptr(),
                ERR_LEN,
            )
        };
        if status != ffi::OK {
            return Err(Error::Read {
                file: self.path.clone(),
                message: message(&err),
            });
        }
        Ok(())
    }

    /// Reads the whole image converted to `T` (see [`ImageReader::read_rows`]).
    /// An image whose header asks for more memory than the machine has
    /// free is refused before anything is allocated.
    pub fn read_all<T: Sample>(&mut self) -> Result<Vec<T>> {
        let (w, h, c) = (self.info.width, self.info.height, self.info.channels);
        let bytes = w
            .checked_mul(h)
            .and_then(|n| n.checked_mul(c))
            .and_then(|n| n.checked_mul(std::mem::size_of::<T>()))
            .map_or(u64::MAX, |b| b as u64);
        if let Some(free) = plsr_base::memory::available_bytes().filter(|&free| bytes > free) {
            return Err(Error::Read {
                file: self.path.clone(),
                message: format!(
                    "the header says {w}×{h} pixels of {c} channel(s): {} in memory, more \
                     than the {} free (a damaged or hostile header?)",
                    plsr_base::memory::human_bytes(bytes),
                    plsr_base::memory::human_bytes(free)
                ),
            });
        }
        let mut v = vec![T::default(); w * h * c];
        let h = self.info.height;
        self.read_rows(0, h, &mut v)?;
        Ok(v)
    }
}

impl Drop for ImageReader {
    fn drop(&mut self) {
        if let Source::Oiio(handle) = self.source {
            // SAFETY: the handle came from plsr_oiio_open and is closed
            // exactly once, here; the shim never throws.
            unsafe { (ffi::loaded().close)(handle.as_ptr()) }
        }
    }
}

/// File extensions of the camera raw formats OpenImageIO reads through
/// LibRaw (Adobe DNG and the common makers' own), lower case.
pub const CAMERA_RAW_EXTENSIONS: [&str; 22] = [
    "dng", "cr2", "cr3", "crw", "nef", "nrw", "arw", "srf", "sr2", "raf", "orf", "rw2", "rwl",
    "pef", "srw", "3fr", "fff", "iiq", "mos", "mrw", "x3f", "erf",
];

/// Whether `path` names a camera raw file (by its extension, as
/// OpenImageIO chooses its reader). [`ImageReader`] reads those as linear
/// 16-bit RGB with sRGB primaries: LibRaw subtracts the black level the
/// file gives, scales to its white level, applies its as-shot white
/// balance and demosaics; clipped highlights stay at 65535.
pub fn is_camera_raw(path: &Path) -> bool {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .is_some_and(|e| CAMERA_RAW_EXTENSIONS.contains(&e.as_str()))
}

/// Reads a whole image as `f32` (integer types scaled to 0–1).
pub fn read_image_f32(path: &Path) -> Result<(ImageInfo, Vec<f32>)> {
    let mut r = ImageReader::open(path)?;
    let data = r.read_all::<f32>()?;
    Ok((r.info().clone(), data))
}

/// A value of a header attribute to write.
#[derive(Debug, Clone, PartialEq)]
pub enum AttrValue {
    /// A float (e.g. `ExposureTime` in seconds).
    Float(f32),
    /// An integer (e.g. `Exif:ISOSpeedRatings`).
    Int(i32),
    /// A string.
    Str(String),
}

/// A named header attribute (OpenImageIO naming: `ExposureTime`,
/// `compression`, `plsr:response`, …).
pub type Attribute = (String, AttrValue);

/// The uncompressed size of an image (bytes), what its file needs at most
/// (give or take a header).
fn raw_size(width: usize, height: usize, channels: usize, stored: PixelType) -> u64 {
    let bytes = match stored {
        PixelType::U8 => 1,
        PixelType::U16 | PixelType::Half => 2,
        PixelType::F32 | PixelType::Other => 4,
    };
    (width * height * channels * bytes + (1 << 16)) as u64
}

/// What both writers do first: refuse an empty or oversized image, sweep
/// the temporaries a killed run left beside `path`, and name this one's;
/// returns it and the bytes the file needs at most.
fn begin_output(
    path: &Path,
    width: usize,
    height: usize,
    channels: usize,
    stored: PixelType,
) -> Result<(PathBuf, u64)> {
    check_size(path, width, height, channels)?;
    plsr_base::atomic_write::sweep_stale_partials(path);
    Ok((
        plsr_base::atomic_write::partial_path(path),
        raw_size(width, height, channels, stored),
    ))
}

/// Refuses an empty image, or one too large for OpenImageIO's sizes.
fn check_size(path: &Path, width: usize, height: usize, channels: usize) -> Result<()> {
    let out_err = |message: &str| Error::Write {
        file: path.to_path_buf(),
        message: message.into(),
    };
    if width == 0 || height == 0 || channels == 0 {
        return Err(out_err("empty image"));
    }
    if [width, height, channels]
        .iter()
        .any(|&d| d > i32::MAX as usize)
    {
        return Err(out_err("image too large"));
    }
    Ok(())
}

/// Removes an unfinished temporary output and forgets it.
fn discard(tmp: &Path) {
    let _ = std::fs::remove_file(tmp);
    plsr_base::atomic_write::forget_partial(tmp);
}

/// An image being written row by row; call [`ImageWriter::finish`] to close
/// it and move it into place. Dropped unfinished, it leaves no file behind.
#[derive(Debug)]
pub struct ImageWriter {
    /// `None` once finished.
    sink: Option<Sink>,
    path: PathBuf,
    tmp: PathBuf,
    width: usize,
    height: usize,
    channels: usize,
    /// Bytes the file needs at most.
    needed: u64,
}

/// What writes an [`ImageWriter`]'s file.
#[derive(Debug)]
enum Sink {
    /// OpenImageIO, through the shim.
    Oiio(NonNull<ffi::Output>),
    /// plsr's own OpenEXR writer, and the temporary file it will fill.
    Exr(Box<exr_writer::ExrBuffer>, std::fs::File),
}

// SAFETY: an OpenImageIO ImageOutput may be driven from any one thread at a
// time; every call takes `&mut self` or `self`, and the type is not `Sync`.
unsafe impl Send for ImageWriter {}

impl ImageWriter {
    /// Creates `path` (format by extension) of `width`×`height`×`channels`,
    /// stored as `stored`, with header `attributes`.
    pub fn create(
        path: &Path,
        width: usize,
        height: usize,
        channels: usize,
        stored: PixelType,
        attributes: &[Attribute],
    ) -> Result<ImageWriter> {
        let out_err = |message: String| Error::Write {
            file: path.to_path_buf(),
            message,
        };
        if let Some(buffer) =
            exr_writer::ExrBuffer::new(path, width, height, channels, stored, attributes)
        {
            let (tmp, needed) = begin_output(path, width, height, channels, stored)?;
            plsr_base::atomic_write::register_partial(&tmp);
            // Read as well as written: the header is sorted in place.
            let file = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(true)
                .open(&tmp)
                .map_err(|e| {
                    discard(&tmp);
                    out_err(plsr_base::atomic_write::write_failure_message(
                        path,
                        &tmp,
                        needed,
                        &e.to_string(),
                    ))
                })?;
            return Ok(ImageWriter {
                sink: Some(Sink::Exr(Box::new(buffer), file)),
                path: path.to_path_buf(),
                tmp,
                width,
                height,
                channels,
                needed,
            });
        }
        Self::create_with_oiio(path, width, height, channels, stored, attributes)
    }

    /// [`ImageWriter::create`] with OpenImageIO, whatever the format.
    fn create_with_oiio(
        path: &Path,
        width: usize,
        height: usize,
        channels: usize,
        stored: PixelType,
        attributes: &[Attribute],
    ) -> Result<ImageWriter> {
        let out_err = |message: String| Error::Write {
            file: path.to_path_buf(),
            message,
        };
        let (tmp, needed) = begin_output(path, width, height, channels, stored)?;
        let ctmp = c_path(&tmp)?;
        plsr_base::atomic_write::register_partial(&tmp);
        // Keep the CStrings alive while the Attr array points into them.
        let mut strings = Vec::new();
        for (name, value) in attributes {
            let n = CString::new(name.as_str())
                .map_err(|_| out_err(format!("attribute name {name:?} contains NUL")))?;
            let s = match value {
                AttrValue::Str(s) => Some(
                    CString::new(s.as_str())
                        .map_err(|_| out_err(format!("attribute {name} contains NUL")))?,
                ),
                _ => None,
            };
            strings.push((n, s));
        }
        let attrs: Vec<ffi::Attr> = attributes
            .iter()
            .zip(&strings)
            .map(|((_, value), (n, s))| ffi::Attr {
                name: n.as_ptr(),
                kind: match value {
                    AttrValue::Float(_) => 0,
                    AttrValue::Int(_) => 1,
                    AttrValue::Str(_) => 2,
                },
                f: if let AttrValue::Float(f) = value {
                    *f
                } else {
                    0.0
                },
                i: if let AttrValue::Int(i) = value { *i } else { 0 },
                s: s.as_ref().map_or(std::ptr::null(), |s| s.as_ptr()),
            })
            .collect();
        let mut handle: *mut ffi::Output = std::ptr::null_mut();
        let mut err = [0 as c_char; ERR_LEN];
        let api = match ffi::api() {
            Ok(api) => api,
            Err(why) => {
                discard(&tmp);
                // An output that cannot be written (as before the typed
                // errors: the C ABI reports it as an I/O failure).
                return Err(out_err(why.to_string()));
            }
        };
        // SAFETY: the path and every attribute name/string are NUL-terminated
        // CStrings alive until after the call (`ctmp`, `strings`); `attrs`
        // holds `attrs.len()` elements; `handle` and `err` are valid
        // out-parameters (err of ERR_LEN bytes).
        let status = unsafe {
            (api.create)(
                ctmp.as_ptr(),
                width as c_int,
                height as c_int,
                channels as c_int,
                stored.code(),
                attrs.as_ptr(),
                attrs.len(),
                &mut handle,
                err.as_mut_ptr(),
                ERR_LEN,
            )
        };
        if status != ffi::OK {
            discard(&tmp);
            return Err(out_err(plsr_base::atomic_write::write_failure_message(
                path,
                &tmp,
                needed,
                &message(&err),
            )));
        }
        let Some(handle) = NonNull::new(handle) else {
            discard(&tmp);
            return Err(out_err("OpenImageIO returned no writer".into()));
        };
        Ok(ImageWriter {
            sink: Some(Sink::Oiio(handle)),
            path: path.to_path_buf(),
            tmp,
            width,
            height,
            channels,
            needed,
        })
    }

    /// Writes rows `y0..y1` from `data` (interleaved, exactly
    /// `(y1 - y0) · width · channels` values); rows go in increasing order.
    pub fn write_rows<T: Sample>(&mut self, y0: usize, y1: usize, data: &[T]) -> Result<()> {
        let need = y1.saturating_sub(y0) * self.width * self.channels;
        if y0 > y1 || y1 > self.height || data.len() != need {
            return Err(Error::invalid_argument(format!(
                "{}: rows {y0}..{y1} with {} values",
                self.path.display(),
                data.len()
            )));
        }
        let handle = match &mut self.sink {
            None => {
                return Err(Error::Write {
                    file: self.path.clone(),
                    message: "writer already closed".into(),
                })
            }
            Some(Sink::Exr(buffer, _)) => {
                buffer.write_rows(y0, data);
                return Ok(());
            }
            Some(Sink::Oiio(handle)) => *handle,
        };
        let mut err = [0 as c_char; ERR_LEN];
        // SAFETY: the handle is live (Some) and used by one thread (&mut
        // self); `data` is a readable buffer of size_of_val(data) bytes that
        // the shim checks against the rows; `err` holds ERR_LEN bytes.
        let status = unsafe {
            (ffi::loaded().write_rows)(
                handle.as_ptr(),
                y0 as c_int,
                y1 as c_int,
                T::TYPE.code(),
                data.as_ptr().cast(),
                std::mem::size_of_val(data),
                err.as_mut_ptr(),
                ERR_LEN,
            )
        };
        if status != ffi::OK {
            return Err(Error::Write {
                file: self.path.clone(),
                message: self.failure(&message(&err)),
            });
        }
        Ok(())
    }

    /// The message for a failed write: a full disk said as such, the
    /// temporary name replaced by the output's.
    fn failure(&self, message: &str) -> String {
        plsr_base::atomic_write::write_failure_message(&self.path, &self.tmp, self.needed, message)
    }

    /// Closes the file and renames it into place.
    pub fn finish(self) -> Result<()> {
        let mut outputs = plsr_base::atomic_write::OutputSet::new();
        self.finish_into(&mut outputs)?;
        Ok(outputs.commit()?)
    }

    /// Closes the file and hands it to `outputs`, to be renamed into place
    /// with the command's other outputs (or removed with them).
    pub fn finish_into(mut self, outputs: &mut plsr_base::atomic_write::OutputSet) -> Result<()> {
        let handle = match self.sink.take() {
            None => {
                return Err(Error::Write {
                    file: self.path.clone(),
                    message: "writer already closed".into(),
                })
            }
            Some(Sink::Exr(buffer, mut file)) => {
                if let Err(message) = buffer.write(&mut file) {
                    drop(file);
                    discard(&self.tmp);
                    return Err(Error::Write {
                        file: self.path.clone(),
                        message: self.failure(&message),
                    });
                }
                outputs.adopt(self.tmp.clone(), self.path.clone());
                return Ok(());
            }
            Some(Sink::Oiio(handle)) => handle,
        };
        let mut err = [0 as c_char; ERR_LEN];
        // SAFETY: the handle came from plsr_oiio_create and is finished once
        // (taken out of self, so Drop will not abort it); the shim frees it
        // on success and on failure; `err` holds ERR_LEN bytes.
        let status = unsafe { (ffi::loaded().finish)(handle.as_ptr(), err.as_mut_ptr(), ERR_LEN) };
        if status != ffi::OK {
            discard(&self.tmp);
            return Err(Error::Write {
                file: self.path.clone(),
                message: self.failure(&message(&err)),
            });
        }
        outputs.adopt(self.tmp.clone(), self.path.clone());
        Ok(())
    }
}

impl Drop for ImageWriter {
    fn drop(&mut self) {
        match self.sink.take() {
            None => {}
            Some(Sink::Exr(_, file)) => {
                drop(file);
                discard(&self.tmp);
            }
            Some(Sink::Oiio(handle)) => {
                // SAFETY: the handle is live and released exactly once, here.
                unsafe { (ffi::loaded().abort)(handle.as_ptr()) };
                discard(&self.tmp);
            }
        }
    }
}

/// Writes a whole image in one call (see [`ImageWriter`]).
pub fn write_image<T: Sample>(
    path: &Path,
    width: usize,
    height: usize,
    channels: usize,
    stored: PixelType,
    attributes: &[Attribute],
    data: &[T],
) -> Result<()> {
    let mut w = ImageWriter::create(path, width, height, channels, stored, attributes)?;
    w.write_rows(0, height, data)?;
    w.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_round_trip_with_attributes() {
        let dir = std::env::temp_dir().join(format!("plsr-oiio-unit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("t.exr");
        let data: Vec<f32> = (0..4 * 3 * 3).map(|i| i as f32 * 0.5).collect();
        let attrs = vec![
            ("plsr:note".to_string(), AttrValue::Str("hello".into())),
            ("ExposureTime".to_string(), AttrValue::Float(0.25)),
        ];
        write_image(&p, 4, 3, 3, PixelType::F32, &attrs, &data).unwrap();
        let mut r = ImageReader::open(&p).unwrap();
        assert_eq!(r.info().format, PixelType::F32);
        assert_eq!(r.string_attribute("plsr:note").as_deref(), Some("hello"));
        assert_eq!(r.exif().exposure_time, Some(0.25));
        assert_eq!(r.read_all::<f32>().unwrap(), data);
        // Unfinished writers leave nothing.
        let q = dir.join("u.exr");
        drop(ImageWriter::create(&q, 4, 3, 3, PixelType::Half, &[]).unwrap());
        assert!(std::fs::read_dir(&dir).unwrap().count() == 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn missing_file_is_an_error_with_oiio_message() {
        let e = ImageReader::open(Path::new("/nonexistent/x.png")).unwrap_err();
        let s = e.to_string();
        assert!(s.contains("/nonexistent/x.png"), "{s}");
        assert!(s.len() > "/nonexistent/x.png: ".len(), "{s}");
    }
}
