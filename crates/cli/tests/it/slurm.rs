//! A real Slurm run of `plsr farm slurm`: a single-node cluster (munged,
//! slurmctld and slurmd on this machine, configured in a temporary folder
//! and stopped afterwards) runs the 4-task render array and the merge job;
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
    munged_pid: PathBuf,
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

/// A TCP port nobody listens on now.
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| format!("(cannot read {}: {e})", p.display()))
}

impl Cluster {
    fn start() -> Cluster {
        let (munged, slurmctld, slurmd) =
            (program("munged"), program("slurmctld"), program("slurmd"));
        program("sbatch");
        let dir = tempfile::Builder::new()
            .prefix("plsr-slurm-")
            .tempdir()
            .unwrap()
            .keep();
        let d = |name: &str| dir.join(name);
        for sub in ["state", "spool", "munge", "munge-key"] {
            std::fs::create_dir_all(d(sub)).unwrap();
        }
        // munged wants its socket's folders searchable by everyone, and its
        // key in a folder of its owner's alone.
        use std::os::unix::fs::PermissionsExt;
        let mode = |p: PathBuf, m: u32| {
            std::fs::set_permissions(p, std::fs::Permissions::from_mode(m)).unwrap()
        };
        mode(dir.clone(), 0o755);
        mode(d("munge"), 0o755);
        mode(d("munge-key"), 0o700);
        // Munge's shared key: 1 KiB of random bytes, readable by its owner only.
        let key = d("munge-key/munge.key");
        let mut bytes = vec![0u8; 1024];
        std::fs::File::open("/dev/urandom")
            .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut bytes))
            .unwrap();
        std::fs::write(&key, &bytes).unwrap();
        std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o400)).unwrap();
        let socket = d("munge/munge.socket");
        let cluster = Cluster {
            conf: d("slurm.conf"),
            munged_pid: d("munge/munged.pid"),
            dir: dir.clone(),
        };
        let out = Command::new(&munged)
            .arg("--key-file")
            .arg(&key)
            .arg("--socket")
            .arg(&socket)
            .arg("--pid-file")
            .arg(&cluster.munged_pid)
            .arg("--log-file")
            .arg(d("munge/munged.log"))
            .arg("--seed-file")
            .arg(d("munge/munged.seed"))
            .output()
            .unwrap();
        if !out.status.success() {
            cluster.fail(&format!(
                "munged did not start: {}",
                String::from_utf8_lossy(&out.stderr)
            ));
        }
        // The short host name, as slurmd finds its own node by it.
        let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
            .expect("the host name (/proc/sys/kernel/hostname)")
            .trim()
            .split('.')
            .next()
            .unwrap()
            .to_string();
        let user = String::from_utf8(Command::new("id").arg("-un").output().unwrap().stdout)
            .unwrap()
            .trim()
            .to_string();
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let conf = format!(
            "ClusterName=plsrtest\n\
             SlurmctldHost={host}(127.0.0.1)\n\
             SlurmUser={user}\n\
             SlurmctldPort={ctld}\n\
             SlurmdPort={slurmd_port}\n\
             AuthType=auth/munge\n\
             AuthInfo=socket={socket}\n\
             CredType=cred/munge\n\
             StateSaveLocation={state}\n\
             SlurmdSpoolDir={spool}\n\
             SlurmctldPidFile={dir}/slurmctld.pid\n\
             SlurmdPidFile={dir}/slurmd.pid\n\
             SlurmctldLogFile={dir}/slurmctld.log\n\
             SlurmdLogFile={dir}/slurmd.log\n\
             ProctrackType=proctrack/linuxproc\n\
             TaskPlugin=task/none\n\
             SelectType=select/cons_tres\n\
             SelectTypeParameters=CR_CPU\n\
             ReturnToService=2\n\
             MpiDefault=none\n\
             JobAcctGatherType=jobacct_gather/none\n\
             SchedulerParameters=sched_interval=1\n\
             NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN\n\
             PartitionName=debug Nodes={host} Default=YES MaxTime=INFINITE State=UP\n",
            ctld = free_port(),
            slurmd_port = free_port(),
            socket = socket.display(),
            state = d("state").display(),
            spool = d("spool").display(),
            dir = dir.display(),
        );
        std::fs::write(&cluster.conf, conf).unwrap();
        for (daemon, args) in [(&slurmctld, vec!["-i"]), (&slurmd, vec![])] {
            let out = Command::new(daemon)
                .args(args)
                .env("SLURM_CONF", &cluster.conf)
                .output()
                .unwrap();
            if !out.status.success() {
                cluster.fail(&format!(
                    "{} did not start ({}): {}",
                    daemon.display(),
                    out.status,
                    String::from_utf8_lossy(&out.stderr)
                ));
            }
        }
        // Ready when the node is idle.
        let start = Instant::now();
        loop {
            let out = cluster.slurm("sinfo", &["-h", "-o", "%t"]);
            let state = String::from_utf8_lossy(&out.stdout).trim().to_string();
            if out.status.success() && state == "idle" {
                break;
            }
            if start.elapsed() > Duration::from_secs(60) {
                cluster.fail(&format!(
                    "the node did not become idle in 60 s (sinfo: {state:?}, {})",
                    String::from_utf8_lossy(&out.stderr).trim()
                ));
            }
            std::thread::sleep(Duration::from_millis(250));
        }
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
        let _ = self.slurm("scontrol", &["shutdown"]);
        std::thread::sleep(Duration::from_millis(500));
        for pid_file in [
            self.dir.join("slurmctld.pid"),
            self.dir.join("slurmd.pid"),
            self.munged_pid.clone(),
        ] {
            if let Ok(pid) = std::fs::read_to_string(&pid_file) {
                let _ = Command::new("kill").arg(pid.trim()).output();
            }
        }
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
