//! plsr under load and faults: a process killed at any moment, two writers
//! of one file. Whatever happens, an output is either the complete old file
//! or the complete new one, never a mixture, and the next run succeeds.

use plsr::film::Film;
use std::path::Path;
use std::process::{Command, Stdio};

const SCENE: &str = "tests/data/cornell-64.toml";

fn plsr() -> Command {
    Command::new(env!("CARGO_BIN_EXE_plsr"))
}

/// Whether a hidden temporary of an output (`.NAME.partial…`) is left in
/// `dir` or below.
fn partials_in(dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.to_string_lossy().contains(".partial") {
                found.push(p.display().to_string());
            }
        }
    }
    found
}

#[test]
fn two_renders_of_one_output_leave_one_whole_image() {
    let dir = tempfile::tempdir().unwrap();
    let render = |seed: &str, out: &Path| {
        plsr()
            .args(["render", SCENE, "--quiet", "--spp", "48", "--threads", "1"])
            .args(["--seed", seed, "-o"])
            .arg(out)
            .spawn()
            .unwrap()
    };
    // The two images alone, then both at once into one file, three times.
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.exr"));
    assert!(render("1", &a).wait().unwrap().success());
    assert!(render("2", &b).wait().unwrap().success());
    let (a, b) = (Film::read_exr(&a).unwrap(), Film::read_exr(&b).unwrap());
    assert_ne!(a.color, b.color);
    let shared = dir.path().join("shared.exr");
    for _ in 0..3 {
        let (mut one, mut two) = (render("1", &shared), render("2", &shared));
        assert!(one.wait().unwrap().success());
        assert!(two.wait().unwrap().success());
        let image = Film::read_exr(&shared).expect("the shared output is a whole EXR");
        assert!(
            image.color == a.color || image.color == b.color,
            "the output mixes the two renders"
        );
    }
    assert_eq!(partials_in(dir.path()), Vec::<String>::new());
}

#[test]
fn a_piece_killed_twenty_times_then_resumed_gives_the_image_of_an_unbroken_run() {
    let root = tempfile::tempdir().unwrap();
    let plan = |name: &str| {
        let out = root.path().join(name);
        let status = plsr()
            .args([
                "farm", "slurm", SCENE, "--quiet", "--parts", "2", "--spp", "96",
            ])
            .arg("-o")
            .arg(&out)
            .status()
            .unwrap();
        assert!(status.success());
        out
    };
    let piece = |out: &Path, index: &str| {
        plsr()
            .args(["farm", "piece", "--quiet", "--threads", "2"])
            .arg(out.join("farm.toml"))
            .arg(index)
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let merge = |out: &Path| {
        let o = plsr()
            .args(["farm", "merge"])
            .arg(out.join("farm.toml"))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        Film::read_exr(&out.join("image.exr")).unwrap()
    };
    // The reference: both pieces rendered without a fault.
    let clean = plan("clean");
    let started = std::time::Instant::now();
    assert!(piece(&clean, "0").wait().unwrap().success());
    let run_time = started.elapsed();
    assert!(piece(&clean, "1").wait().unwrap().success());
    let reference = merge(&clean);

    // Piece 0 is killed (SIGKILL: no clean-up at all) at 20 moments spread
    // evenly over the time an unbroken run took, from before it has read
    // the plan to about when it writes its part; each run starts again
    // from what the last one left.
    let broken = plan("broken");
    let mut finished_early = 0;
    for k in 0..20u64 {
        let mut child = piece(&broken, "0");
        std::thread::sleep(run_time.mul_f64((k as f64 + 0.5) / 20.0));
        if child.try_wait().unwrap().is_some() {
            finished_early += 1;
        }
        let _ = child.kill();
        let status = child.wait().unwrap();
        assert!(
            status.success() || status.code().is_none(),
            "the piece failed on its own after a kill: {status:?}"
        );
        // The part is absent or whole, never torn.
        let part = broken.join("parts");
        if let Ok(entries) = std::fs::read_dir(&part) {
            for e in entries {
                let p = e.unwrap().path();
                if p.extension().is_some_and(|x| x == "exr")
                    && !p.to_string_lossy().contains(".partial")
                {
                    plsr::film::part::Part::read_exr(&p)
                        .unwrap_or_else(|e| panic!("a torn part after kill {k}: {e}"));
                }
            }
        }
    }
    eprintln!("{finished_early} of 20 kills came after the piece had ended");
    assert!(
        finished_early < 15,
        "too few kills landed while the piece was running"
    );
    // The next runs succeed, and the merge is the unbroken run's image.
    for index in ["0", "1"] {
        let o = piece(&broken, index).wait_with_output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let image = merge(&broken);
    assert_eq!(image.color, reference.color, "the resumed render differs");
    assert_eq!(partials_in(&broken), Vec::<String>::new());
}
