//! A real Slurm run of `plsr farm slurm`: a single-node cluster (munged,
//! slurmctld and slurmd on this machine, configured in a temporary folder
//! by `scripts/slurm-single-node.sh` and stopped afterwards) runs the 4-task render array and the merge job;
//! the merged image equals the single-machine render, and submitting again
//! after a piece is lost re-runs that piece alone.
//!
//! Needs Debian's `slurm-wlm` and `munge` (`make test-deps` installs them). If
//! they are missing or the daemons do not start, the test fails and says
//! why, with the daemons' logs: it never skips.

use plsr_testkit as common;

use common::films::assert_close;
use plsr::film::Film;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

const SCENE: &str = "tests/data/cornell-64.toml";

/// A single-node Slurm cluster in a temporary folder; dropped, it stops.
struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
}

/// The program `name`, looked up on PATH and in the sbin folders.
fn program(name: &str) -> PathBuf {
    let path = std::env::var("PATH").unwrap_or_default();
    for dir in path
        .split(':')
        .chain(["/usr/sbin", "/sbin", "/usr/bin", "/usr/local/sbin"])
    {
        let p = Path::new(dir).join(name);
        if p.is_file() {
            return p;
        }
    }
    panic!(
        "{name} is not installed: this test runs a real Slurm cluster and needs Debian's \
         slurm-wlm and munge packages (`make test-deps` installs them)"
    );
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| format!("(cannot read {}: {e})", p.display()))
}

impl Cluster {
    /// Starts a cluster with `scripts/slurm-single-node.sh`, the script
    /// docs/farm.md offers users, so that the test keeps it working.
    fn start() -> Cluster {
        program("munged");
        program("slurmctld");
        program("sbatch");
        let dir = tempfile::Builder::new()
            .prefix("plsr-slurm-")
            .tempdir()
            .unwrap()
            .keep();
        let cluster = Cluster {
            conf: dir.join("slurm.conf"),
            dir: dir.clone(),
        };
        let out = Command::new("bash")
            .arg("scripts/slurm-single-node.sh")
            .arg("start")
            .arg(&dir)
            .output()
            .unwrap();
        if !out.status.success() {
            cluster.fail(&format!(
                "scripts/slurm-single-node.sh start failed ({}): {}",
                out.status,
                String::from_utf8_lossy(&out.stderr)
            ));
        }
        let said = String::from_utf8_lossy(&out.stdout);
        assert!(
            said.contains(&format!("export SLURM_CONF={}", cluster.conf.display())),
            "{said}"
        );
        cluster
    }

    /// Runs a Slurm client command against this cluster.
    fn slurm(&self, name: &str, args: &[&str]) -> Output {
        Command::new(program(name))
            .args(args)
            .env("SLURM_CONF", &self.conf)
            .output()
            .unwrap()
    }

    /// Fails the test with `why` and every log of the cluster.
    fn fail(&self, why: &str) -> ! {
        let mut logs = String::new();
        for log in ["munge/munged.log", "slurmctld.log", "slurmd.log"] {
            logs.push_str(&format!("\n--- {log} ---\n{}", read(&self.dir.join(log))));
        }
        if let Ok(entries) = std::fs::read_dir(self.dir.join("out/logs")) {
            for e in entries.flatten() {
                logs.push_str(&format!(
                    "\n--- {} ---\n{}",
                    e.path().display(),
                    read(&e.path())
                ));
            }
        }
        panic!("Slurm: {why}{logs}");
    }

    /// Waits until no job is queued or running.
    fn wait_idle(&self, what: &str) {
        let start = Instant::now();
        loop {
            let out = self.slurm("squeue", &["-h", "-o", "%i %T"]);
            if out.status.success() && out.stdout.iter().all(|b| b.is_ascii_whitespace()) {
                return;
            }
            if start.elapsed() > Duration::from_secs(300) {
                self.fail(&format!(
                    "{what}: jobs still queued after 300 s:\n{}",
                    String::from_utf8_lossy(&out.stdout)
                ));
            }
            std::thread::sleep(Duration::from_millis(250));
        }
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new("bash")
            .arg("scripts/slurm-single-node.sh")
            .arg("stop")
            .arg(&self.dir)
            .output();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Runs `plsr ARGS` with the cluster's configuration; returns (success,
/// stdout + stderr).
fn plsr(cluster: &Cluster, args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(args)
        .env("SLURM_CONF", &cluster.conf)
        .output()
        .unwrap();
    (
        out.status.success(),
        format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ),
    )
}

#[test]
fn a_slurm_array_and_its_merge_give_the_single_machine_render() {
    let cluster = Cluster::start();
    let out = cluster.dir.join("out");
    let out_s = out.to_str().unwrap();
    let scene = std::fs::canonicalize(SCENE).unwrap();
    let scene_s = scene.to_str().unwrap();
    let submit = [
        "farm",
        "slurm",
        scene_s,
        "--parts",
        "4",
        "--spp",
        "16",
        "-o",
        out_s,
        "--cpus-per-task",
        "1",
        "--submit",
    ];
    let (ok, said) = plsr(&cluster, &submit);
    if !ok {
        cluster.fail(&format!("plsr farm slurm --submit failed: {said}"));
    }
    assert!(said.contains("submitted render array job"), "{said}");
    cluster.wait_idle("first run");
    let merged = out.join("image.exr");
    if !merged.is_file() {
        cluster.fail("no merged image after the jobs ended");
    }
    assert!(out.join("image.png").is_file());
    let single = cluster.dir.join("single.exr");
    let (ok, said) = plsr(
        &cluster,
        &[
            "render",
            scene_s,
            "--spp",
            "16",
            "-o",
            single.to_str().unwrap(),
            "-q",
        ],
    );
    assert!(ok, "{said}");
    let single = Film::read_exr(&single).unwrap();
    assert!(single.color.iter().any(|c| c.max_element() > 0.0));
    // Four ranges add their f64 sums in another grouping than one render:
    // equal to float precision.
    assert_close(
        "Slurm merge",
        &single,
        &Film::read_exr(&merged).unwrap(),
        1e-6,
    );

    // A lost piece: submitting again renders it alone, then merges.
    let lost = out.join("parts/samples-000008-000012.exr");
    assert!(lost.is_file());
    std::fs::remove_file(&lost).unwrap();
    std::fs::remove_file(&merged).unwrap();
    let (ok, said) = plsr(&cluster, &submit);
    if !ok {
        cluster.fail(&format!("second plsr farm slurm --submit failed: {said}"));
    }
    assert!(
        said.contains("--array=2)"),
        "only piece 2 is resubmitted: {said}"
    );
    cluster.wait_idle("resubmission");
    if !merged.is_file() {
        cluster.fail("no merged image after the resubmitted jobs ended");
    }
    assert_close(
        "Slurm resubmission",
        &single,
        &Film::read_exr(&merged).unwrap(),
        1e-6,
    );
    // Every piece was rendered once: four render logs, then one more.
    let render_logs = std::fs::read_dir(out.join("logs"))
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with("render-"))
        .count();
    assert_eq!(render_logs, 5);
}
