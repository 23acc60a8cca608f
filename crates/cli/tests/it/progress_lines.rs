//! Progress seen from a log (stderr not a terminal): plain lines with the
//! elapsed time, the counts and the ETA, no bar and no carriage returns;
//! `PLSR_PROGRESS=none` silences them, `--quiet` them and the summary.

use std::process::Command;

/// Renders the small Cornell box with `args` and the environment `env`;
/// returns stderr.
fn render(dir: &std::path::Path, args: &[&str], env: &[(&str, &str)]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(["render", "tests/data/cornell-64.toml", "--spp", "16", "-o"])
        .arg(dir.join("c.exr"))
        .args(args)
        .envs(env.iter().copied())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{stderr}");
    stderr
}

#[test]
fn a_log_gets_progress_lines_and_quiet_or_none_silences_them() {
    let dir = tempfile::tempdir().unwrap();
    // A line at every update (the default is one every 10 s).
    let every = ("PLSR_PROGRESS_SECONDS", "0");
    let log = render(dir.path(), &[], &[every]);
    let progress: Vec<&str> = log.lines().filter(|l| l.contains("tiles (eta")).collect();
    assert!(!progress.is_empty(), "{log}");
    for line in &progress {
        assert!(line.starts_with("[00:00:"), "{line}");
        assert!(!line.contains('░') && !line.contains('█'), "{line}");
    }
    assert!(!log.contains('\r'), "{log:?}");
    assert!(log.contains("rendered 64×64"), "{log}");
    // Silenced.
    let quiet = render(dir.path(), &["--quiet"], &[every]);
    assert!(quiet.is_empty(), "--quiet printed: {quiet}");
    let none = render(dir.path(), &[], &[every, ("PLSR_PROGRESS", "none")]);
    assert!(!none.contains("tiles (eta"), "{none}");
    assert!(none.contains("rendered 64×64"), "{none}");
    // The default interval prints nothing for work this short.
    let default = render(dir.path(), &[], &[]);
    assert!(!default.contains("tiles (eta"), "{default}");
    // No line is printed twice in a row.
    for pair in progress.windows(2) {
        assert_ne!(pair[0], pair[1], "{log}");
    }
    // Settings that cannot be followed are said once, and the default kept.
    for (env, says) in [
        (
            ("PLSR_PROGRESS", "verbose"),
            "PLSR_PROGRESS=verbose: expected bar, lines or none (using lines)",
        ),
        (
            ("PLSR_PROGRESS", "bar"),
            "PLSR_PROGRESS=bar: stderr is not a terminal",
        ),
        (
            ("PLSR_PROGRESS_SECONDS", "abc"),
            "PLSR_PROGRESS_SECONDS=abc: expected a number of seconds (using 10)",
        ),
    ] {
        let log = render(dir.path(), &[], &[env]);
        assert_eq!(log.matches(says).count(), 1, "{log}");
        assert!(log.contains("rendered 64×64"), "{log}");
    }
}
