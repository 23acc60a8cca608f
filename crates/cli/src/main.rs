//! The `plsr` program: the command line over the plsr library. The commands
//! live in the `plsr_cli` library (`src/lib.rs`); this is what only a
//! program does: end cleanly on signals and on a closed pipe, and turn the
//! outcome into an exit status.

use plsr_cli::{run, Outcome};
use std::process::ExitCode;

/// On SIGINT (Ctrl-C), SIGTERM and SIGHUP: removes the temporary files of
/// outputs being written, then ends the process by the same signal, so the
/// shell sees what it sent. Without this the hidden `.partial` files of an
/// interrupted `hdr merge` (hundreds of MB) would stay behind.
fn remove_partial_outputs_on_signals() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        return;
    };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            plsr::atomic_write::remove_partial_outputs();
            // Restores the default action and raises the signal again.
            let _ = signal_hook::low_level::emulate_default_handler(signal);
            std::process::exit(128 + signal);
        }
    });
}

/// A closed standard output or error (`plsr info x.exr | head`) ends the
/// command quietly, as SIGPIPE ends a C program. Rust ignores SIGPIPE, so
/// writing to a closed pipe fails and `println!` panics ("failed printing
/// to stdout: Broken pipe"); for that panic alone this hook removes the
/// outputs not yet in place and ends the process by SIGPIPE's default
/// action (status 141 in a shell), with no message. Every other panic
/// goes to the default hook.
fn end_quietly_on_a_closed_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or("");
        if message.starts_with("failed printing to std")
            && message.contains(&format!("(os error {})", libc::EPIPE))
        {
            plsr::atomic_write::remove_partial_outputs();
            let _ = signal_hook::low_level::emulate_default_handler(libc::SIGPIPE);
            std::process::exit(128 + libc::SIGPIPE);
        }
        default(info);
    }));
}

fn main() -> ExitCode {
    remove_partial_outputs_on_signals();
    end_quietly_on_a_closed_pipe();
    match run(std::env::args_os()) {
        Ok(Outcome::Done) => ExitCode::SUCCESS,
        Ok(Outcome::Usage) => ExitCode::from(2),
        Err(e) => {
            eprintln!("plsr: error: {e}");
            ExitCode::FAILURE
        }
    }
}
