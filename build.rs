//! Top-level build script of plsr.
//!
//! Embree is linked by the `plsr-embree-sys` crate. This script is where the
//! OpenImageIO C++ shim (HDR merge) and the generated C header will be built;
//! for now it only declares what it depends on.
fn main() {
    println!("cargo:rerun-if-changed=build.rs");
}
