//! The `plsr` program's tests, one module per topic: each command run as a
//! user runs it (bad input, bad options, outputs that must not be lost),
//! the HDR, metrics, compositing and farm commands end to end, and the C
//! ABI from real C and C++ hosts against what `cargo test` built.

/// The tests name the repository's files relative to its root
/// (`assets/…`, `tests/data/…`), as a user at the top of a checkout would;
/// cargo starts them in this crate's folder, so the process moves to the
/// root before any test runs (one `.init_array` entry, run by the loader).
#[used]
#[link_section = ".init_array"]
static RUN_FROM_THE_REPOSITORY_ROOT: extern "C" fn() = run_from_the_repository_root;

extern "C" fn run_from_the_repository_root() {
    if let Err(e) = std::env::set_current_dir(plsr_testkit::REPO_ROOT) {
        eprintln!(
            "cannot enter the repository's root {}: {e}",
            plsr_testkit::REPO_ROOT
        );
        std::process::abort();
    }
}

mod bad_input;
mod bad_meshes;
mod bad_options;
mod bad_output;
mod bench_peers;
mod c_hosts;
mod composite;
mod farm;
mod gradients;
mod hdr;
mod hdr_capture;
mod metrics;
mod mitsuba_import;
mod pls_cli;
mod slurm;
mod tonemap;
