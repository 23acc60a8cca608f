//! The properties plsr's fuzz targets check, one module per target, kept
//! apart from libFuzzer so that `cargo test` can replay the inputs fuzzing
//! found (fuzz/regressions/TARGET/, tests/it/fuzz_regressions.rs in
//! plsr-cli) and `fuzz/` can drive the same code with coverage.
//!
//! Each `check` takes one input and panics on a finding: any input must
//! end in a value that holds its invariants, or in an error that is not
//! empty and names the file it is about (docs/fuzzing.md).

pub mod calibration;
pub mod capi_scene;
/// What the targets share: the work folder, its fixtures, clean errors.
pub mod common;
pub mod farm_plan;
pub mod gltf;
pub mod image;
pub mod mitsuba_serialized;
pub mod mitsuba_xml;
pub mod obj_mtl;
pub mod pls;
pub mod ply;
pub mod response_csv;
pub mod scene_json;
pub mod scene_toml;

/// The targets, by name (the files of fuzz/fuzz_targets/).
pub const TARGETS: &[&str] = &[
    "calibration",
    "capi_scene",
    "farm_plan",
    "gltf",
    "image",
    "mitsuba_serialized",
    "mitsuba_xml",
    "obj_mtl",
    "pls",
    "ply",
    "response_csv",
    "scene_json",
    "scene_toml",
];

/// Runs target `name`'s check on `data`; `false` for an unknown name.
pub fn check(name: &str, data: &[u8]) -> bool {
    match name {
        "calibration" => calibration::check(data),
        "capi_scene" => capi_scene::check(data),
        "farm_plan" => farm_plan::check(data),
        "gltf" => gltf::check(data),
        "image" => image::check(data),
        "mitsuba_serialized" => mitsuba_serialized::check(data),
        "mitsuba_xml" => mitsuba_xml::check(data),
        "obj_mtl" => obj_mtl::check(data),
        "pls" => pls::check(data),
        "ply" => ply::check(data),
        "response_csv" => response_csv::check(data),
        "scene_json" => scene_json::check(data),
        "scene_toml" => scene_toml::check(data),
        _ => return false,
    }
    true
}
