//! Top-level build script of plsr.
//!
//! Embree is linked by the `plsr-embree-sys` crate. This script compiles the
//! small C++ shim over OpenImageIO (`shim/oiio_shim.cpp`, C ABI in
//! `shim/oiio_shim.h`) used by the HDR merge, and links OpenImageIO, found with
//! pkg-config.
fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=shim/oiio_shim.cpp");
    println!("cargo:rerun-if-changed=shim/oiio_shim.h");

    let oiio = match pkg_config::Config::new()
        .atleast_version("2.2")
        .probe("OpenImageIO")
    {
        Ok(lib) => lib,
        Err(e) => {
            eprintln!(
                "plsr needs OpenImageIO (2.2 or newer) and its pkg-config file \
                 OpenImageIO.pc; on Debian/Ubuntu install the package \
                 libopenimageio-dev (apt-get install libopenimageio-dev).\n\
                 pkg-config said: {e}"
            );
            panic!(
                "OpenImageIO not found by pkg-config: install the Debian package \
                 libopenimageio-dev"
            );
        }
    };

    let mut build = cc::Build::new();
    build
        .cpp(true)
        .std("c++17")
        .file("shim/oiio_shim.cpp")
        .include("shim")
        .warnings(true);
    for dir in &oiio.include_paths {
        build.include(dir);
    }
    build.compile("plsr_oiio_shim");
    // pkg-config already printed the link lines for OpenImageIO; the shim is
    // C++, so the C++ runtime is linked by cc.
}
