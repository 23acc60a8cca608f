//! The `plsr` program's tests, one module per topic: each command run as a
//! user runs it (bad input, bad options, outputs that must not be lost),
//! the HDR, metrics, compositing and farm commands end to end, and the C
//! ABI from real C and C++ hosts against what `cargo test` built.

plsr_testkit::run_from_the_repository_root!();

/// Runs `plsr ARGS`: (success, stdout, stderr).
pub(crate) fn plsr(args: &[&str]) -> (bool, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

mod bad_input;
mod bad_meshes;
mod bad_options;
mod bad_output;
mod bench_peers;
mod c_hosts;
mod calibration;
mod closed_stdout;
mod composite;
mod denoising;
mod exif_exposure;
mod farm;
mod fuzz_plans;
mod fuzz_regressions;
mod gradients;
mod hdr;
mod hdr_capture;
mod hdr_memorial;
mod hdr_raw;
mod metrics;
mod mitsuba_import;
mod mitsuba_structure;
mod pls_cli;
mod progress_lines;
mod slurm;
mod tonemap;
mod under_faults;
