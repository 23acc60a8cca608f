//! The `plsr` program; see `plsr --help`.

use std::process::ExitCode;

fn main() -> ExitCode {
    match plsr::cli::run(std::env::args_os()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("plsr: error: {e}");
            ExitCode::FAILURE
        }
    }
}
