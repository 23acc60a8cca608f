//! `plsr bench peers` end to end, with a stand-in for Mitsuba 3: a script
//! given as `--python` that answers each job as `scripts/bench_peers_mitsuba.py`
//! would (a black image and a fixed time), so the benchmark's own logic —
//! one peer process per scene, bracketed by plsr's timings — is tested on
//! machines without Mitsuba.

#[cfg(unix)]
use std::process::Command;

/// The stand-in's render time for every scene, seconds.
#[cfg(unix)]
const PEER_SECONDS: f64 = 0.5;

/// Parses `1.234 (1.200 / 1.270)` into its three numbers.
#[cfg(unix)]
fn bracketed(cell: &str) -> Option<(f64, f64, f64)> {
    let (mean, rest) = cell.trim().split_once(" (")?;
    let (before, after) = rest.strip_suffix(')')?.split_once(" / ")?;
    Some((
        mean.parse().ok()?,
        before.parse().ok()?,
        after.parse().ok()?,
    ))
}

#[cfg(unix)]
#[test]
fn each_scene_gets_its_own_peer_run_bracketed_by_plsr_timings() {
    // Under the build's own temporary folder: the stand-in is executed,
    // and /tmp may be mounted without execution.
    let dir = tempfile::tempdir_in(env!("CARGO_TARGET_TMPDIR")).unwrap();
    let log = dir.path().join("peer-jobs.log");
    let arg_log = dir.path().join("peer-args.log");
    let peer = dir.path().join("fake-python");
    // Called as `fake-python scripts/bench_peers_mitsuba.py JOBS.json
    // --repeats N`: logs the job and its arguments, writes one black frame
    // where the job says, prints the result line.
    let script = format!(
        r#"#!/bin/sh
jobs="$2"
cat "$jobs" >> "{log}"
echo >> "{log}"
echo "$3 $4" >> "{arg_log}"
name=$(grep -o '"name":"[^"]*"' "$jobs" | head -n 1 | cut -d'"' -f4)
image=$(grep -o '"image":"[^"]*"' "$jobs" | head -n 1 | cut -d'"' -f4)
case "$name" in
  cornell) bytes=$((512 * 512 * 12)) ;;
  pls-room) bytes=$((640 * 480 * 12)) ;;
  *) echo "unknown scene $name" >&2; exit 1 ;;
esac
head -c "$bytes" /dev/zero > "$image"
echo '{{"mitsuba_version":"stand-in","variant":"test","scenes":[{{"name":"'"$name"'","seconds":{PEER_SECONDS}}}]}}'
"#,
        log = log.display(),
        arg_log = arg_log.display()
    );
    std::fs::write(&peer, script).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&peer, std::fs::Permissions::from_mode(0o755)).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(["bench", "peers", "--scenes", "cornell,pls-room"])
        .args(["--spp", "2", "--reference-spp", "4", "--threads", "2"])
        .args(["--seeds", "3"])
        .arg("--python")
        .arg(&peer)
        .arg("--peers-dir")
        .arg(dir.path().join("work"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stdout}\n{stderr}");

    // One peer process per scene, each given that scene alone, in order.
    let jobs = std::fs::read_to_string(&log).unwrap();
    let jobs: Vec<&str> = jobs.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(jobs.len(), 2, "{jobs:?}");
    for (job, name) in jobs.iter().zip(["cornell", "pls-room"]) {
        assert_eq!(job.matches("\"name\":").count(), 1, "{job}");
        assert!(job.contains(&format!("\"name\":\"{name}\"")), "{job}");
    }

    // `--seeds 3`: plsr and Mitsuba render each scene three times, and the
    // tables say that each relMSE is the mean over three renders.
    let args = std::fs::read_to_string(&arg_log).unwrap();
    assert_eq!(args, "--repeats 3\n--repeats 3\n", "{args}");
    assert_eq!(stdout.matches("(best of 3 renders)").count(), 2, "{stdout}");
    assert!(stdout.contains("2 spp, 3 seeds each"), "{stdout}");
    assert!(stdout.contains("the mean over 3 renders"), "{stdout}");

    // plsr timed again after each peer run, and the table's plsr figure is
    // the rate of the mean of its two times; the peer's is its own time.
    assert_eq!(stdout.matches("plsr after Mitsuba").count(), 2, "{stdout}");
    for (name, (w, h)) in [("cornell", (512u64, 512u64)), ("pls-room", (640, 480))] {
        let row = stdout
            .lines()
            .find(|l| l.starts_with(&format!("| {name} ")) && l.contains(" / "))
            .unwrap_or_else(|| panic!("no bracketed row for {name}:\n{stdout}"));
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        let (mean, before, after) =
            bracketed(cells[2]).unwrap_or_else(|| panic!("bad plsr cell in {row}"));
        // Rates r = s / t, and t = (t_before + t_after) / 2.
        let expected = 2.0 / (1.0 / before + 1.0 / after);
        assert!(
            (mean - expected).abs() <= 0.002 * expected + 0.0015,
            "{row}: {mean} is not the rate of the mean time of {before} and {after}"
        );
        let peer_rate: f64 = cells[3].parse().unwrap();
        let samples = (w * h * 2) as f64;
        let want = samples / PEER_SECONDS / 1e6;
        assert!(
            (peer_rate - want).abs() < 0.002,
            "{row}: peer {peer_rate}, want {want}"
        );
        let ratio: f64 = cells[4].trim_end_matches('×').parse().unwrap();
        assert!((ratio - mean / peer_rate).abs() < 0.01, "{row}");
    }
}

/// Run from outside the repository, `plsr bench` works from the repository
/// above the program (and says so); a program outside any repository says
/// what it needs instead of failing on a missing `assets/…` file.
#[cfg(unix)]
#[test]
fn bench_finds_the_repository_from_anywhere_or_says_it_needs_it() {
    let elsewhere = tempfile::tempdir().unwrap();
    // A size the hdr suite refuses: the run ends right after finding the
    // repository.
    let out = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .current_dir(elsewhere.path())
        .args(["bench", "hdr", "--hdr-size", "8,8"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("working from the repository at"),
        "{stderr}"
    );
    assert!(
        stderr.contains("--hdr-size 8,8: at least 16 pixels a side"),
        "{stderr}"
    );
    // A copy of the program outside any repository.
    let copy = elsewhere.path().join("plsr");
    std::fs::copy(env!("CARGO_BIN_EXE_plsr"), &copy).unwrap();
    let out = Command::new(&copy)
        .current_dir(elsewhere.path())
        .args(["bench", "pls"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("uses the scenes and assets of plsr's repository"),
        "{stderr}"
    );
}
