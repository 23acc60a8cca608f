//! A closed standard output (`plsr info x.exr | head`) ends a command
//! quietly: killed by SIGPIPE as a C program is (status 141 in a shell) or
//! exit 0, never a panic's message and backtrace.

use std::os::unix::process::ExitStatusExt;
use std::process::{Command, Output, Stdio};

/// Runs plsr with `args` whose standard output is a pipe already closed
/// at the other end, so its first write fails.
fn with_closed_stdout(args: &[&str]) -> Output {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(args)
        .env("RUST_BACKTRACE", "1")
        .stdout(writer)
        .stderr(Stdio::piped())
        .output()
        .unwrap()
}

fn assert_quiet(args: &[&str]) {
    let out = with_closed_stdout(args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let by_sigpipe = out.status.signal() == Some(libc::SIGPIPE);
    assert!(
        by_sigpipe || out.status.code() == Some(0),
        "plsr {}: {:?}, {stderr}",
        args.join(" "),
        out.status
    );
    assert!(
        !stderr.contains("panicked") && !stderr.contains("backtrace"),
        "plsr {}: {stderr}",
        args.join(" ")
    );
}

#[test]
fn a_closed_stdout_ends_commands_quietly() {
    assert_quiet(&["info", "tests/data/cornell-64-ref.exr"]);
    assert_quiet(&["info", "tests/data/realworld/hdr/memorial/memorial0061.png"]);
    assert_quiet(&["pls", "check", "assets/lights/paper.toml"]);
    assert_quiet(&[
        "compare",
        "--json",
        "tests/data/cornell-64-ref.exr",
        "tests/data/cornell-64-ref.exr",
    ]);
    assert_quiet(&[
        "import",
        "tests/data/realworld/mitsuba/ours/blendbsdf_rough.xml",
    ]);
    assert_quiet(&["--help"]);
    assert_quiet(&["render", "--help"]);
}
