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

/// Makes a test binary start in the repository's root, before any test
/// runs: the tests name the repository's files relative to it (`assets/…`,
/// `tests/data/…`), as a user at the top of a checkout would, while cargo
/// starts a crate's tests in that crate's folder. One `.init_array` entry,
/// run by the loader; call it once at the top of a test binary's `main.rs`.
#[macro_export]
macro_rules! run_from_the_repository_root {
    () => {
        #[used]
        #[link_section = ".init_array"]
        static RUN_FROM_THE_REPOSITORY_ROOT: extern "C" fn() = run_from_the_repository_root;

        extern "C" fn run_from_the_repository_root() {
            if let Err(e) = std::env::set_current_dir($crate::REPO_ROOT) {
                eprintln!(
                    "cannot enter the repository's root {}: {e}",
                    $crate::REPO_ROOT
                );
                std::process::abort();
            }
        }
    };
}
