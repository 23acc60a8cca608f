//! The C ABI's tests that call it from Rust (unit tests: the crate is a
//! `cdylib` and `staticlib`, which integration tests cannot link).

mod calls;
mod header;

use std::path::Path;

/// The repository's root, which the tests' paths are relative to.
fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}
