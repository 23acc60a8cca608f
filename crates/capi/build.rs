//! Build script of `plsr-capi`: gives the C ABI's shared library its
//! soname, `libplsr.so.MAJOR` (the crate's major version). A host linked
//! against this build records that name and loads any later build of the
//! same major version (the C ABI only grows within one); `make install`
//! links it to the real file `libplsr.so.X.Y.Z`.

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let major =
        std::env::var("CARGO_PKG_VERSION_MAJOR").expect("cargo sets CARGO_PKG_VERSION_MAJOR");
    println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,libplsr.so.{major}");
}
