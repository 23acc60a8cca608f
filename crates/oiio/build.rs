//! Build script of `plsr-oiio`: the OpenImageIO shim.
//!
//! It compiles the small C++ shim over OpenImageIO (`shim/oiio_shim.cpp`,
//! C ABI in `shim/oiio_shim.h`) into a shared library of its own,
//! `$OUT_DIR/libplsr_oiio.so`, linked against OpenImageIO (found with
//! pkg-config). plsr does not link OpenImageIO itself: this crate embeds
//! the shim and opens it with `dlopen` the first time an image is read or
//! written, so the commands that never touch an image (`plsr --version`,
//! most renders) do not pay for loading OpenImageIO's ~260 libraries.
use std::path::PathBuf;
use std::process::Command;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=shim/oiio_shim.cpp");
    println!("cargo:rerun-if-changed=shim/oiio_shim.h");

    let oiio = match pkg_config::Config::new()
        .atleast_version("2.2")
        // The link lines go to the shim, not to plsr.
        .cargo_metadata(false)
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
        .pic(true)
        .file("shim/oiio_shim.cpp")
        .include("shim")
        .warnings(true);
    for dir in &oiio.include_paths {
        build.include(dir);
    }
    let objects = build.compile_intermediates();

    let out_dir = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let shim = out_dir.join("libplsr_oiio.so");
    let mut link: Command = build.get_compiler().to_command();
    link.arg("-shared")
        .arg("-o")
        .arg(&shim)
        .args(&objects)
        .arg("-Wl,-soname,libplsr_oiio.so")
        .arg("-Wl,--as-needed")
        // Stripped: the library is embedded in every plsr binary.
        .arg("-s");
    for dir in &oiio.link_paths {
        link.arg(format!("-L{}", dir.display()));
    }
    for lib in &oiio.libs {
        link.arg(format!("-l{lib}"));
    }
    let status = link.status().unwrap_or_else(|e| {
        panic!("cannot run the C++ compiler to link the OpenImageIO shim: {e}")
    });
    assert!(
        status.success(),
        "linking the OpenImageIO shim ({}) failed: {status}",
        shim.display()
    );
}
