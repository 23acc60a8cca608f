//! Test helpers shared by the integration tests (`mod common;` in each).
//!
//! Not every test uses every helper.
#![allow(dead_code)]

pub mod chi2;
pub mod films;
pub mod scenes;

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
