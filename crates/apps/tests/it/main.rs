//! The applications' tests: the paper's experiment, its fixtures and its
//! pipeline run small.

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

mod paper_experiment;
