//! Test helpers shared by the workspace's tests (`use plsr_testkit as
//! common;` in each module that needs them).
//!
//! Not every test uses every helper.
#![allow(dead_code)]

pub mod chi2;
pub mod films;
pub mod scenes;

/// The repository's root: the tests' paths (`assets/…`, `tests/data/…`)
/// are relative to it.
pub const REPO_ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

/// A small valid scene (8×8 pixels, 1 spp, an emitting sphere) for the
/// command-line tests.
pub const SMALL_SCENE: &str = r#"
[render]
spp = 1

[camera]
position = [0, -3, 1]
look_at = [0, 0, 0]
up = [0, 0, 1]
vfov = 40
resolution = [8, 8]

[[shapes]]
type = "sphere"
emission = [1, 1, 1]
"#;
