//! Pieces of a render (`plsr render --samples` / `--crop`) and `plsr
//! merge`: merged sample ranges give the image of one render of their
//! union, stitched windows the full image bit for bit, and bad sets of
//! parts are refused with the file named and no output written.

use plsr_testkit as common;

use common::films::assert_close;
use plsr::film::Film;
use std::path::{Path, PathBuf};
use std::process::Command;

const SCENE: &str = "tests/data/cornell-64.toml";

/// Runs `plsr ARGS` and returns (success, stderr).
fn plsr(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

/// `plsr merge` takes no `--quiet`.
fn merge(parts: &[&Path], out: &Path) -> (bool, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_plsr"));
    cmd.arg("merge");
    for p in parts {
        cmd.arg(p);
    }
    let out = cmd.arg("-o").arg(out).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

/// Renders a part of the test scene with `extra` arguments into `dir/name`.
fn part(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let path = dir.join(name);
    let mut args = vec![
        "render",
        SCENE,
        "-o",
        path.to_str().unwrap(),
        "--max-depth",
        "3",
    ];
    args.extend_from_slice(extra);
    let (ok, err) = plsr(&args);
    assert!(ok, "{name}: {err}");
    path
}

#[test]
fn sample_ranges_merge_into_the_render_of_their_union() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let whole = part(d, "whole.exr", &["--spp", "16"]);
    // Uneven ranges, given to merge out of order.
    let parts = [
        part(d, "c.exr", &["--samples", "8..9"]),
        part(d, "a.exr", &["--samples", "0..3"]),
        part(d, "d.exr", &["--samples", "9..16"]),
        part(d, "b.exr", &["--samples", "3..8"]),
    ];
    let merged = d.join("merged.exr");
    let refs: Vec<&Path> = parts.iter().map(|p| p.as_path()).collect();
    let (ok, err) = merge(&refs, &merged);
    assert!(ok, "{err}");
    let (w, m) = (
        Film::read_exr(&whole).unwrap(),
        Film::read_exr(&merged).unwrap(),
    );
    assert!(w.color.iter().any(|c| c.max_element() > 0.0));
    // The sums add in another grouping than one render's, so the means may
    // differ in the last bits of their f64 sums: ulp-level.
    assert_close("4 sample ranges", &w, &m, 1e-6);
    // One part of the whole range is the render itself, bit for bit.
    let all = part(d, "all.exr", &["--samples", "0..16"]);
    let one = d.join("one.exr");
    assert!(merge(&[&all], &one).0);
    assert_close("one part", &w, &Film::read_exr(&one).unwrap(), 0.0);
}

#[test]
fn windows_stitch_into_the_full_image_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let whole = part(d, "whole.exr", &["--spp", "5"]);
    let parts = [
        part(d, "a.exr", &["--spp", "5", "--crop", "0,0,40,25"]),
        part(d, "b.exr", &["--spp", "5", "--crop", "40,0,64,25"]),
        part(d, "c.exr", &["--spp", "5", "--crop", "0,25,30,64"]),
        part(d, "d.exr", &["--spp", "5", "--crop", "30,25,64,64"]),
    ];
    let merged = d.join("merged.exr");
    let refs: Vec<&Path> = parts.iter().map(|p| p.as_path()).collect();
    let (ok, err) = merge(&refs, &merged);
    assert!(ok, "{err}");
    assert_close(
        "4 windows",
        &Film::read_exr(&whole).unwrap(),
        &Film::read_exr(&merged).unwrap(),
        0.0,
    );
    // Windows and sample ranges together.
    let mixed = [
        part(d, "e.exr", &["--samples", "0..2", "--crop", "0,0,64,30"]),
        part(d, "f.exr", &["--samples", "2..5", "--crop", "0,0,64,30"]),
        part(d, "g.exr", &["--samples", "0..4", "--crop", "0,30,64,64"]),
        part(d, "h.exr", &["--samples", "4..5", "--crop", "0,30,64,64"]),
    ];
    let refs: Vec<&Path> = mixed.iter().map(|p| p.as_path()).collect();
    assert!(merge(&refs, &merged).0);
    assert_close(
        "windows × ranges",
        &Film::read_exr(&whole).unwrap(),
        &Film::read_exr(&merged).unwrap(),
        1e-6,
    );
}

#[test]
fn bad_sets_of_parts_are_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = part(d, "a.exr", &["--samples", "0..4"]);
    let b = part(d, "b.exr", &["--samples", "4..8"]);
    let other_seed = part(d, "seed.exr", &["--samples", "4..8", "--seed", "7"]);
    let gap = part(d, "gap.exr", &["--samples", "6..8"]);
    let overlap = part(d, "overlap.exr", &["--samples", "2..8"]);
    let window = part(
        d,
        "window.exr",
        &["--samples", "0..8", "--crop", "0,0,64,32"],
    );
    let plain = d.join("plain.exr");
    assert!(
        plsr(&[
            "render",
            SCENE,
            "-o",
            plain.to_str().unwrap(),
            "--spp",
            "2",
            "--no-resume-data"
        ])
        .0
    );
    let truncated = d.join("truncated.exr");
    let bytes = std::fs::read(&b).unwrap();
    std::fs::write(&truncated, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let out = d.join("out.exr");
    for (what, parts, file, says) in [
        (
            "another seed",
            vec![&a, &other_seed],
            &other_seed,
            "scene hash",
        ),
        ("a gap", vec![&a, &gap], &gap, "samples 4..6 are missing"),
        (
            "an overlap",
            vec![&a, &overlap],
            &overlap,
            "overlap samples 0..4",
        ),
        (
            "a truncated part",
            vec![&a, &truncated],
            &truncated,
            // Its header claims more samples than the file holds, which
            // is found before any pixel is read.
            "cannot be in a file of",
        ),
        (
            "a render without its sums",
            vec![&a, &plain],
            &plain,
            "no render sums",
        ),
        (
            "a missing window",
            vec![&window],
            &window,
            "no part covers pixel (0, 32)",
        ),
    ] {
        let refs: Vec<&Path> = parts.iter().map(|p| p.as_path()).collect();
        let (ok, err) = merge(&refs, &out);
        assert!(!ok, "{what}: merged");
        let name = file.file_name().unwrap().to_str().unwrap();
        assert!(
            err.contains(says) && (what == "a missing window" || err.contains(name)),
            "{what}: {err}"
        );
        assert!(!out.exists(), "{what}: left an output");
    }
    // The good pair merges.
    assert!(merge(&[&a, &b], &out).0);
    // Bad options.
    for (args, says) in [
        (vec!["--samples", "5..5"], "START must be below END"),
        (vec!["--samples", "x..4"], "not a sample index"),
        (
            vec!["--samples", "0..4", "--spp", "4"],
            "cannot be used with",
        ),
        (vec!["--crop", "0,0,65,10"], "reaches past the 64×64 image"),
        (vec!["--crop", "3,0,3,10"], "empty"),
        (vec!["--crop", "1,2,3"], "expected the corners X0,Y0,X1,Y1"),
        // An origin and a size: the corners are said.
        (
            vec!["--crop", "10,5,30x20"],
            "by their corners X0,Y0,X1,Y1 in plsr: --crop 10,5,40,25",
        ),
    ] {
        let o = d.join("bad.exr");
        let mut full = vec!["render", SCENE, "-o", o.to_str().unwrap()];
        full.extend(args.iter().copied());
        let (ok, err) = plsr(&full);
        assert!(!ok && err.contains(says), "{args:?}: {err}");
        assert!(!o.exists());
    }
}

/// The test scene in `dir` with `camera` in place of its `[camera]` table.
fn scene_with_camera(dir: &Path, camera: &str) -> PathBuf {
    common::scenes::cornell_64(dir, "scene.toml", Some(camera), "")
}

/// A camera at `position` (x, z) looking into the box.
fn static_camera(x: f32, z: f32) -> String {
    format!(
        "[camera]\nposition = [{x}, 273, {z}]\nlook_at = [278, 273, 0]\nup = [0, 1, 0]\n\
         vfov = 37\nresolution = [64, 64]"
    )
}

/// Three keys: frame 0 at x 278, frame 4 at x 378 (z −800 throughout),
/// frame 6 at z −700.
const PATH_CAMERA: &str = "[camera]\nup = [0, 1, 0]\nvfov = 37\nresolution = [64, 64]\n\
    [[camera.path]]\nframe = 0\nposition = [278, 273, -800]\nlook_at = [278, 273, 0]\n\
    [[camera.path]]\nframe = 4\nposition = [378, 273, -800]\nlook_at = [278, 273, 0]\n\
    [[camera.path]]\nframe = 6\nposition = [378, 273, -700]\nlook_at = [278, 273, 0]";

#[test]
fn frames_follow_the_camera_path() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let anim = scene_with_camera(d, PATH_CAMERA);
    let pattern = d.join("frame-{frame}.exr");
    let (ok, err) = plsr(&[
        "render",
        anim.to_str().unwrap(),
        "-o",
        pattern.to_str().unwrap(),
        "--frames",
        "0..=6",
        "--spp",
        "2",
    ]);
    assert!(ok, "{err}");
    // Keys and the frames between are the poses of static cameras there,
    // bit for bit (the interpolated positions are exact in f32 here).
    let sub = tempfile::tempdir().unwrap();
    for (frame, x, z) in [
        (0, 278.0, -800.0),
        (2, 328.0, -800.0),
        (4, 378.0, -800.0),
        (5, 378.0, -750.0),
        (6, 378.0, -700.0),
    ] {
        let still = scene_with_camera(sub.path(), &static_camera(x, z));
        let out = sub.path().join("still.exr");
        let (ok, err) = plsr(&[
            "render",
            still.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--spp",
            "2",
        ]);
        assert!(ok, "{err}");
        let framed = d.join(format!("frame-{frame:04}.exr"));
        assert_close(
            &format!("frame {frame}"),
            &Film::read_exr(&out).unwrap(),
            &Film::read_exr(&framed).unwrap(),
            0.0,
        );
    }
    assert!(!d.join("frame-0007.exr").exists());
    // Frames differ from each other.
    assert_ne!(
        Film::read_exr(&d.join("frame-0000.exr")).unwrap().color,
        Film::read_exr(&d.join("frame-0006.exr")).unwrap().color
    );
    // Bad frames and paths.
    let one = d.join("one.exr");
    let anim_s = anim.to_str().unwrap();
    for (args, says) in [
        (
            vec!["--frame", "7"],
            "the camera path runs from frame 0 to 6",
        ),
        (vec!["--frames", "0..3"], "the name must contain {frame}"),
        (vec!["--frames", "4..4"], "no frames"),
        (vec!["--frames", "a..4"], "not a frame number"),
    ] {
        let mut full = vec!["render", anim_s, "-o", one.to_str().unwrap()];
        full.extend(args.iter().copied());
        let (ok, err) = plsr(&full);
        assert!(!ok && err.contains(says), "{args:?}: {err}");
        assert!(!one.exists());
    }
    let (ok, err) = plsr(&["render", SCENE, "-o", one.to_str().unwrap(), "--frame", "0"]);
    assert!(!ok && err.contains("has no camera path"), "{err}");
    let bad = scene_with_camera(d, &PATH_CAMERA.replace("frame = 4", "frame = 0"));
    let (ok, err) = plsr(&["render", bad.to_str().unwrap(), "-o", one.to_str().unwrap()]);
    assert!(
        !ok && err.contains("camera.path[1].frame") && err.contains("frames must increase"),
        "{err}"
    );
}

/// Runs the plsr command line `command` (its first word `plsr`) with the
/// pods' `mount` mapped to the local `root`, and `env`.
fn run_as_pod(
    command: &[String],
    mount: &str,
    root: &Path,
    env: &[(&str, String)],
) -> (bool, String) {
    assert_eq!(command[0], "plsr");
    let args: Vec<String> = command[1..]
        .iter()
        .map(|a| a.replace(mount, root.to_str().unwrap()))
        .collect();
    let out = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(&args)
        .envs(env.iter().map(|(k, v)| (k, v)))
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

/// Writes the Kubernetes files of a small job (2 parts of 6 spp, and
/// `extra` options) into a new volume; returns the volume, its canonical
/// root, the scene and the output folder.
fn k8s_files(extra: &[&str]) -> (tempfile::TempDir, PathBuf, PathBuf, PathBuf) {
    let volume = tempfile::tempdir().unwrap();
    let root = std::fs::canonicalize(volume.path()).unwrap();
    let anim = scene_with_camera(&root, PATH_CAMERA);
    let out = root.join("renders/shot");
    let mut args = vec![
        "farm",
        "k8s",
        anim.to_str().unwrap(),
        "--parts",
        "2",
        "--spp",
        "6",
        "-o",
        out.to_str().unwrap(),
        "--image",
        "registry.example.com/plsr:0.2",
        "--claim",
        "render-data",
        "--volume-root",
        root.to_str().unwrap(),
    ];
    args.extend(extra);
    let (ok, err) = plsr(&args);
    assert!(ok, "{err}");
    (volume, root, anim, out)
}

/// Runs `run-k8s.sh` against a stub `kubectl` that reports every Job in
/// the state `job_state` (a condition type) and one failed pod with a log;
/// returns (success, stderr, the stub's log of its calls).
fn run_k8s_with_stub(out: &Path, job_state: &str, timeout: &str) -> (bool, String, String) {
    let bin = out.join("stub-bin");
    std::fs::create_dir_all(&bin).unwrap();
    let calls = out.join("kubectl-calls.txt");
    let stub = format!(
        r#"#!/bin/sh
echo "$*" >> '{calls}'
case "$*" in
    "get job "*) printf '{job_state} ' ;;
    "get pods "*) printf 'plsr-shot-render-0-abcde' ;;
    "logs plsr-shot-render-0-abcde "*) echo "plsr: error: out of memory (stub log)" ;;
esac
exit 0
"#,
        calls = calls.display()
    );
    let kubectl = bin.join("kubectl");
    std::fs::write(&kubectl, stub).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&kubectl, std::fs::Permissions::from_mode(0o755)).unwrap();
    let path = format!("{}:{}", bin.display(), std::env::var("PATH").unwrap());
    let run = std::process::Command::new("sh")
        .arg(out.join("run-k8s.sh"))
        .env("PATH", path)
        .env("PLSR_POLL_SECONDS", "0")
        .env("PLSR_TIMEOUT", timeout)
        .output()
        .unwrap();
    (
        run.status.success(),
        String::from_utf8_lossy(&run.stderr).into_owned(),
        std::fs::read_to_string(&calls).unwrap_or_default(),
    )
}

/// A failed render Job ends `run-k8s.sh` at once, with status 1 and the
/// failed pod's log, and no merge is applied; a complete one goes on to
/// the merge; a Job that never ends is given up after the timeout.
#[test]
fn run_k8s_stops_on_a_failed_job_and_shows_its_pods_logs() {
    let (_volume, _, _, out) = k8s_files(&[]);
    let (ok, stderr, calls) = run_k8s_with_stub(&out, "Failed", "168h");
    assert!(!ok, "{stderr}");
    assert!(
        stderr.contains("job plsr-shot-render failed")
            && stderr.contains("--- pod plsr-shot-render-0-abcde")
            && stderr.contains("out of memory (stub log)"),
        "{stderr}"
    );
    assert!(!calls.contains("merge-job.yaml"), "{calls}");

    std::fs::remove_file(out.join("kubectl-calls.txt")).unwrap();
    let (ok, stderr, calls) = run_k8s_with_stub(&out, "Complete", "168h");
    assert!(ok, "{stderr}");
    assert!(calls.contains("merge-job.yaml"), "{calls}");
    assert!(calls.contains("get job plsr-shot-merge"), "{calls}");

    // Neither condition: the wait ends at the timeout, not in a week.
    let (ok, stderr, _) = run_k8s_with_stub(&out, "Suspended", "1s");
    assert!(!ok, "{stderr}");
    assert!(
        stderr.contains("neither completed nor failed within 1s"),
        "{stderr}"
    );
}

#[test]
fn kubernetes_manifests_are_indexed_jobs_whose_pods_render_the_pieces() {
    let (_volume, root, anim, out) = k8s_files(&[
        "--frames", "3..5", "--mount", "/mnt/vol", "--cpus", "2", "--memory", "2Gi",
    ]);
    let yaml = |name: &str| -> serde_yaml::Value {
        serde_yaml::from_str(&std::fs::read_to_string(out.join(name)).unwrap()).unwrap()
    };
    let render = yaml("render-job.yaml");
    let merge = yaml("merge-job.yaml");
    let s = |v: &serde_yaml::Value| v.as_str().unwrap().to_string();
    let command = |job: &serde_yaml::Value| -> Vec<String> {
        job["spec"]["template"]["spec"]["containers"][0]["command"]
            .as_sequence()
            .unwrap()
            .iter()
            .map(s)
            .collect()
    };
    for job in [&render, &merge] {
        assert_eq!(s(&job["apiVersion"]), "batch/v1");
        assert_eq!(s(&job["kind"]), "Job");
        let pod = &job["spec"]["template"]["spec"];
        assert_eq!(s(&pod["restartPolicy"]), "Never");
        let c = &pod["containers"][0];
        assert_eq!(s(&c["image"]), "registry.example.com/plsr:0.2");
        assert_eq!(s(&c["volumeMounts"][0]["mountPath"]), "/mnt/vol");
        assert_eq!(s(&c["resources"]["requests"]["memory"]), "2Gi");
        assert_eq!(s(&c["resources"]["requests"]["cpu"]), "2");
        let volume = &pod["volumes"][0];
        assert_eq!(volume["name"], c["volumeMounts"][0]["name"]);
        assert_eq!(
            s(&volume["persistentVolumeClaim"]["claimName"]),
            "render-data"
        );
    }
    assert_eq!(s(&render["metadata"]["name"]), "plsr-shot-render");
    assert_eq!(s(&merge["metadata"]["name"]), "plsr-shot-merge");
    // Frames 3 and 4, two parts each.
    assert_eq!(s(&render["spec"]["completionMode"]), "Indexed");
    assert_eq!(render["spec"]["completions"].as_u64(), Some(4));
    assert_eq!(render["spec"]["parallelism"].as_u64(), Some(4));
    let render_cmd = command(&render);
    assert_eq!(
        render_cmd,
        [
            "plsr",
            "farm",
            "piece",
            "/mnt/vol/renders/shot/farm.toml",
            "--threads",
            "2"
        ]
    );
    assert_eq!(
        command(&merge),
        ["plsr", "farm", "merge", "/mnt/vol/renders/shot/farm.toml"]
    );
    let script = std::fs::read_to_string(out.join("run-k8s.sh")).unwrap();
    let order: Vec<usize> = [
        "apply -f ",
        "wait_for_job plsr-shot-render",
        "merge-job.yaml",
        "wait_for_job plsr-shot-merge",
    ]
    .iter()
    .map(|w| {
        script
            .find(w)
            .unwrap_or_else(|| panic!("{w} not in {script}"))
    })
    .collect();
    assert!(order.windows(2).all(|w| w[0] < w[1]), "{script}");

    // The pods, run here with the volume at its local path: merging before
    // every piece is there is refused, naming what is missing.
    let merge_cmd = command(&merge);
    let pod = |i: u32| {
        let (ok, err) = run_as_pod(
            &render_cmd,
            "/mnt/vol",
            &root,
            &[("JOB_COMPLETION_INDEX", i.to_string())],
        );
        assert!(ok, "pod {i}: {err}");
    };
    for i in [0, 2, 3] {
        pod(i);
    }
    let (ok, err) = run_as_pod(&merge_cmd, "/mnt/vol", &root, &[]);
    assert!(
        !ok && err.contains("1 of 4 pieces are missing or stale (1)"),
        "{err}"
    );
    assert!(!out.join("image-0003.exr").exists());
    pod(1);
    let (ok, err) = run_as_pod(&merge_cmd, "/mnt/vol", &root, &[]);
    assert!(ok, "{err}");
    let single = root.join("single.exr");
    assert!(
        plsr(&[
            "render",
            anim.to_str().unwrap(),
            "--frame",
            "4",
            "--spp",
            "6",
            "-o",
            single.to_str().unwrap()
        ])
        .0
    );
    assert_close(
        "frame 4 from pods",
        &Film::read_exr(&single).unwrap(),
        &Film::read_exr(&out.join("image-0004.exr")).unwrap(),
        1e-6,
    );
    assert!(out.join("image-0003.png").is_file());
    let (ok, err) = run_as_pod(
        &render_cmd,
        "/mnt/vol",
        &root,
        &[("JOB_COMPLETION_INDEX", "4".into())],
    );
    assert!(!ok && err.contains("has pieces 0 to 3"), "{err}");
}

#[test]
fn bad_farm_requests_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("out");
    let o = out.to_str().unwrap();
    let (ok, err) = plsr(&["farm", "slurm", SCENE, "--parts", "0", "-o", o]);
    assert!(
        !ok && err.contains("--parts: must be between 1 and spp"),
        "{err}"
    );
    let (ok, err) = plsr(&[
        "farm", "slurm", SCENE, "--parts", "9", "--spp", "8", "-o", o,
    ]);
    assert!(
        !ok && err.contains("each part renders at least one sample"),
        "{err}"
    );
    let (ok, err) = plsr(&[
        "farm", "slurm", SCENE, "--parts", "2", "--frames", "0..2", "-o", o,
    ]);
    assert!(!ok && err.contains("has no camera path"), "{err}");
    assert!(!out.exists(), "a refused plan makes no folder");
    // The plan would replace the scene (a scene named farm.toml, OUTDIR its
    // folder): refused, the scene untouched.
    let own = d.join("own");
    std::fs::create_dir(&own).unwrap();
    let scene_text = std::fs::read_to_string(SCENE).unwrap().replace(
        "\"../../assets/",
        &format!("\"{}/", std::fs::canonicalize("assets").unwrap().display()),
    );
    std::fs::write(own.join("farm.toml"), &scene_text).unwrap();
    let (ok, err) = plsr(&[
        "farm",
        "slurm",
        own.join("farm.toml").to_str().unwrap(),
        "--parts",
        "2",
        "-o",
        own.to_str().unwrap(),
    ]);
    assert!(!ok && err.contains("which the scene reads"), "{err}");
    assert_eq!(
        std::fs::read_to_string(own.join("farm.toml")).unwrap(),
        scene_text
    );
    assert!(!own.join("render.sbatch").exists());
    // The pods see only the volume: a scene outside it is refused.
    let root = d.join("volume");
    std::fs::create_dir(&root).unwrap();
    let (ok, err) = plsr(&[
        "farm",
        "k8s",
        SCENE,
        "--parts",
        "2",
        "-o",
        root.join("o").to_str().unwrap(),
        "--image",
        "i",
        "--claim",
        "c",
        "--volume-root",
        root.to_str().unwrap(),
    ]);
    assert!(!ok && err.contains("is not inside --volume-root"), "{err}");
    let (ok, err) = plsr(&[
        "farm",
        "piece",
        d.join("nothing.toml").to_str().unwrap(),
        "0",
    ]);
    assert!(!ok && err.contains("nothing.toml"), "{err}");
    // A plan, then a piece without an index outside a batch system.
    assert!(plsr(&["farm", "slurm", SCENE, "--parts", "2", "--spp", "2", "-o", o]).0);
    let out = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(["farm", "piece", out.join("farm.toml").to_str().unwrap()])
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("no piece index"),
        "{err}"
    );
    // A piece that fails (its scene gone) leaves no empty `parts/` behind.
    let plan = d.join("out").join("farm.toml");
    let text = std::fs::read_to_string(&plan).unwrap();
    let broken: String = text
        .lines()
        .map(|l| {
            if l.starts_with("scene = ") {
                "scene = \"missing.toml\"".to_string()
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(&plan, broken).unwrap();
    let (ok, err) = plsr(&["farm", "piece", plan.to_str().unwrap(), "0"]);
    assert!(!ok && err.contains("missing.toml"), "{err}");
    assert!(!d.join("out").join("parts").exists(), "{err}");
}

/// `--resume` continues any render: the samples it adds are accumulated
/// onto the file's exact sums as one render accumulates them, so that the
/// resumed file is byte for byte the file one render of all the samples
/// writes (denoised too); files it cannot continue are refused and kept.
#[test]
fn resume_continues_any_render_into_the_file_of_one_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("resumed.exr");
    let o = out.to_str().unwrap();
    let render = |o: &str, extra: &[&str]| {
        let mut args = vec!["render", SCENE, "-o", o, "--max-depth", "3"];
        args.extend_from_slice(extra);
        plsr(&args)
    };
    // A plain render of 4 samples, resumed to 16.
    let (ok, err) = render(o, &["--spp", "4"]);
    assert!(ok, "{err}");
    let (ok, err) = render(o, &["--resume", "--spp", "16"]);
    assert!(ok && err.contains("12 new samples, 16 in all"), "{err}");
    let whole = part(d, "whole.exr", &["--spp", "16"]);
    assert_eq!(
        std::fs::read(&out).unwrap(),
        std::fs::read(&whole).unwrap(),
        "the resumed file differs from one render's"
    );
    // Nothing left to do, but the PNG asked for is written.
    let png = d.join("resumed.png");
    let (ok, err) = render(
        o,
        &["--resume", "--spp", "16", "--png", png.to_str().unwrap()],
    );
    assert!(ok && err.contains("holds 16 samples already"), "{err}");
    assert!(png.exists(), "{err}");
    // A merged image keeps the merged sums, and resumes too.
    let (p0, p1, merged) = (d.join("p0.exr"), d.join("p1.exr"), d.join("merged.exr"));
    assert!(render(p0.to_str().unwrap(), &["--samples", "0..3"]).0);
    assert!(render(p1.to_str().unwrap(), &["--samples", "3..8"]).0);
    let (ok, err) = merge(&[&p0, &p1], &merged);
    assert!(ok, "{err}");
    let (ok, err) = render(merged.to_str().unwrap(), &["--resume", "--spp", "16"]);
    assert!(ok && err.contains("8 new samples, 16 in all"), "{err}");
    assert_close(
        "merged, then resumed",
        &Film::read_exr(&whole).unwrap(),
        &Film::read_exr(&merged).unwrap(),
        1e-6,
    );
    // A part of samples 0..N (as older versions wrote) continues too.
    let old_part = part(d, "old-part.exr", &["--samples", "0..4"]);
    let (ok, err) = render(old_part.to_str().unwrap(), &["--resume", "--spp", "16"]);
    assert!(ok, "{err}");
    assert_eq!(
        std::fs::read(&old_part).unwrap(),
        std::fs::read(&whole).unwrap()
    );
    // Denoised: the merged sums denoised with the guides of all samples.
    let denoised = d.join("denoised.exr");
    let dn = denoised.to_str().unwrap();
    assert!(render(dn, &["--spp", "4", "--denoise"]).0);
    let (ok, err) = render(dn, &["--resume", "--spp", "16", "--denoise"]);
    assert!(ok, "{err}");
    let denoised_whole = part(d, "denoised-whole.exr", &["--spp", "16", "--denoise"]);
    assert_eq!(
        std::fs::read(&denoised).unwrap(),
        std::fs::read(&denoised_whole).unwrap(),
        "the resumed denoised file differs from one render's"
    );
    // Refused, the file left as it was: a render without its sums, a part
    // that is not samples 0..N of the whole image, other settings.
    let small = part(d, "small.exr", &["--spp", "4", "--no-resume-data"]);
    let later = part(d, "later.exr", &["--samples", "4..8"]);
    let before = std::fs::read(&out).unwrap();
    for (file, extra, says) in [
        (&small, vec!["--spp", "8"], "no render sums"),
        (
            &later,
            vec!["--spp", "16"],
            "this file holds samples 4..8 of the window 0,0,64,64 (X0,Y0,X1,Y1) of a 64×64 image",
        ),
        (
            &out,
            vec!["--spp", "32", "--seed", "9"],
            "it was rendered otherwise: seed 0 in the file, 9 now",
        ),
        (
            &out,
            vec!["--spp", "32", "--rr-depth", "2"],
            "rr_depth 4 in the file, 2 now",
        ),
        (
            &out,
            vec!["--spp", "32", "--resolution", "32,32"],
            "plsrPartImage: the file is a 64×64 image, this render 32×32",
        ),
    ] {
        let kept = std::fs::read(file).unwrap();
        let mut args = vec!["--resume"];
        args.extend_from_slice(&extra);
        let (ok, err) = render(file.to_str().unwrap(), &args);
        let name = file.file_name().unwrap().to_str().unwrap();
        assert!(!ok && err.contains(name) && err.contains(says), "{err}");
        assert_eq!(std::fs::read(file).unwrap(), kept, "{name} was changed");
    }
    assert_eq!(std::fs::read(&out).unwrap(), before);
    // A scene file changed since (if only by a comment) is said as such.
    let edited = common::scenes::cornell_64(d, "edited.toml", None, "");
    let e = edited.to_str().unwrap();
    let eo = d.join("edited.exr");
    assert!(plsr(&["render", e, "-o", eo.to_str().unwrap(), "--spp", "2"]).0);
    let text = std::fs::read_to_string(&edited).unwrap();
    std::fs::write(&edited, text + "\n# a comment\n").unwrap();
    let (ok, err) = plsr(&[
        "render",
        e,
        "-o",
        eo.to_str().unwrap(),
        "--spp",
        "4",
        "--resume",
    ]);
    assert!(
        !ok && err.contains("edited.exr")
            && err.contains("the scene file or a file it reads has changed since"),
        "{err}"
    );
}

/// Resuming works frame by frame along a camera path, and on a film with
/// a crop window (whose render keeps the window's sums, and whose parts
/// merge into the window).
#[test]
fn frames_and_film_crop_windows_resume_into_one_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let anim = scene_with_camera(d, PATH_CAMERA);
    let run = |pattern: &str, extra: &[&str]| {
        let mut args = vec![
            "render",
            anim.to_str().unwrap(),
            "-o",
            pattern,
            "--frames",
            "3..5",
            "--max-depth",
            "3",
        ];
        args.extend_from_slice(extra);
        let (ok, err) = plsr(&args);
        assert!(ok, "{err}");
        err
    };
    let resumed = d.join("r-{frame}.exr");
    let one = d.join("o-{frame}.exr");
    run(resumed.to_str().unwrap(), &["--spp", "3"]);
    let err = run(resumed.to_str().unwrap(), &["--spp", "7", "--resume"]);
    assert_eq!(err.matches("4 new samples, 7 in all").count(), 2, "{err}");
    run(one.to_str().unwrap(), &["--spp", "7"]);
    for f in ["0003", "0004"] {
        let name = |p: &str| d.join(format!("{p}-{f}.exr"));
        assert_eq!(
            std::fs::read(name("r")).unwrap(),
            std::fs::read(name("o")).unwrap(),
            "frame {f}"
        );
    }

    let cropped =
        common::scenes::cornell_64(d, "crop.toml", None, "\n[film]\ncrop = [8, 4, 40, 60]\n");
    let c = cropped.to_str().unwrap();
    let out = d.join("crop.exr");
    let o = out.to_str().unwrap();
    assert!(plsr(&["render", c, "-o", o, "--spp", "3"]).0);
    let (ok, err) = plsr(&["render", c, "-o", o, "--spp", "7", "--resume"]);
    assert!(ok, "{err}");
    let once = d.join("crop-once.exr");
    assert!(plsr(&["render", c, "-o", once.to_str().unwrap(), "--spp", "7"]).0);
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&once).unwrap());
    let image = Film::read_exr(&out).unwrap();
    assert_eq!((image.width, image.height), (32, 56));
    // A --crop part resumes too, into the part of all its samples.
    let (cp, cp_once) = (d.join("cp.exr"), d.join("cp-once.exr"));
    let crop_part = |p: &Path, extra: &[&str]| {
        let mut args = vec![
            "render",
            c,
            "-o",
            p.to_str().unwrap(),
            "--crop",
            "10,8,30,40",
        ];
        args.extend_from_slice(extra);
        let (ok, err) = plsr(&args);
        assert!(ok, "{err}");
        err
    };
    crop_part(&cp, &["--spp", "3"]);
    let err = crop_part(&cp, &["--spp", "7", "--resume"]);
    assert!(err.contains("4 new samples, 7 in all"), "{err}");
    crop_part(&cp_once, &["--spp", "7"]);
    assert_eq!(
        std::fs::read(&cp).unwrap(),
        std::fs::read(&cp_once).unwrap()
    );
    // Its parts hold the window and merge into it.
    let (a, b, merged) = (d.join("ca.exr"), d.join("cb.exr"), d.join("cm.exr"));
    for (p, range) in [(&a, "0..3"), (&b, "3..7")] {
        let (ok, err) = plsr(&["render", c, "-o", p.to_str().unwrap(), "--samples", range]);
        assert!(ok, "{err}");
    }
    let (ok, err) = merge(&[&a, &b], &merged);
    assert!(ok, "{err}");
    assert_close(
        "merged window",
        &image,
        &Film::read_exr(&merged).unwrap(),
        1e-6,
    );
}

/// A render keeps its sums in a file under twice the size of the image
/// alone (`--no-resume-data`; 1.77× here), not the 5 times of an
/// uncompressed part of the same samples.
#[test]
fn the_sums_a_render_keeps_cost_less_than_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let size =
        |name: &str, extra: &[&str]| std::fs::metadata(part(d, name, extra)).unwrap().len() as f64;
    let image = size("image.exr", &["--spp", "16", "--no-resume-data"]);
    let with_sums = size("sums.exr", &["--spp", "16"]);
    let part = size("part.exr", &["--samples", "0..16"]);
    let (ratio, part_ratio) = (with_sums / image, part / image);
    eprintln!(
        "image {image} B, with sums {with_sums} B ({ratio:.2}×), part {part} B ({part_ratio:.2}×)"
    );
    assert!(ratio < 2.0, "the sums made the file {ratio:.2}× larger");
    assert!(part_ratio > 4.0, "{part_ratio:.2}");
}

/// Runs `plsr ARGS`, which must succeed; returns stdout and stderr.
fn run(args: &[&str]) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args(args)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{args:?}: {text}");
    text
}

/// `farm status` tells pieces that are missing from pieces that are stale
/// (rendered before the scene changed), and a merged image that is current
/// from one that is not.
#[test]
fn status_tells_stale_pieces_and_images_from_missing_ones() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = common::scenes::cornell_64(d, "scene.toml", None, "");
    let out = d.join("farm");
    let plan = out.join("farm.toml");
    let p = plan.to_str().unwrap();
    run(&[
        "farm",
        "slurm",
        scene.to_str().unwrap(),
        "--parts",
        "3",
        "--spp",
        "6",
        "-o",
        out.to_str().unwrap(),
    ]);
    run(&["farm", "piece", p, "0"]);
    run(&["farm", "piece", p, "1"]);
    let s = run(&["farm", "status", p]);
    assert!(s.contains("2 of 3 pieces done; missing: 2\n"), "{s}");
    run(&["farm", "piece", p, "2"]);
    run(&["farm", "merge", p]);
    let s = run(&["farm", "status", p]);
    assert!(
        s.contains("3 of 3 pieces done\n") && s.contains("1 of 1 merged images written\n"),
        "{s}"
    );
    // The scene changes (by a comment): every piece and the image are stale.
    let text = std::fs::read_to_string(&scene).unwrap();
    std::fs::write(&scene, text + "\n# changed\n").unwrap();
    let s = run(&["farm", "status", p]);
    assert!(
        s.contains("0 of 3 pieces done; stale (rendered before the scene or its settings changed")
            && s.contains("): 0-2")
            && s.contains("0 of 1 merged images written; stale")
            && s.contains("image.exr"),
        "{s}"
    );
}

/// A Mitsuba scene's `-D` parameters go into the plan: every piece reads
/// the scene with them (here `spp`, which sets the plan's samples), status
/// finds the parts done, and the merge is the image of 8 samples.
#[test]
fn a_plan_keeps_a_mitsuba_scenes_d_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let plsr = |args: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_plsr"))
            .args(args)
            .output()
            .unwrap();
        let text =
            String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
        (o.status.success(), text)
    };
    let scene = "tests/data/realworld/mitsuba/docs/scenes/variants_cbox_rgb.xml";
    let out_s = out.display().to_string();
    let (ok, e) = plsr(&[
        "farm", "slurm", scene, "-D", "spp=8", "--parts", "2", "-o", &out_s,
    ]);
    assert!(ok, "{e}");
    let plan = std::fs::read_to_string(out.join("farm.toml")).unwrap();
    assert!(
        plan.contains("defines = [[\"spp\", \"8\"]]") && plan.contains("spp = 8"),
        "{plan}"
    );
    let plan_s = out.join("farm.toml").display().to_string();
    for i in ["0", "1"] {
        let (ok, e) = plsr(&["farm", "piece", &plan_s, i]);
        assert!(ok, "{e}");
    }
    let (ok, e) = plsr(&["farm", "status", &plan_s]);
    assert!(ok && e.contains("2 of 2 pieces done"), "{e}");
    let (ok, e) = plsr(&["farm", "merge", &plan_s]);
    assert!(ok, "{e}");
    let film = Film::read_exr(&out.join("image.exr")).unwrap();
    assert_eq!(film.spp, 8);
    // Denoised after the exact merge: the noisy colour is the merge's.
    let (ok, e) = plsr(&["farm", "merge", &plan_s, "--denoise"]);
    assert!(ok && e.contains("at 8 spp, denoised"), "{e}");
    let denoised = Film::read_exr(&out.join("image.exr")).unwrap();
    assert_eq!(denoised.noisy.as_ref(), Some(&film.color));
    assert_ne!(denoised.color, film.color);
}

/// `--samples` takes `START..=LAST` as `--frames` does.
#[test]
fn samples_take_an_inclusive_range_too() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = part(d, "a.exr", &["--samples", "2..=5"]);
    let b = part(d, "b.exr", &["--samples", "2..6"]);
    assert_eq!(std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
}

/// A plan can set the seed and the image size (`farm slurm --seed
/// --resolution`), as `plsr render` does: its merge is the render of the
/// scene with them, and status finds its pieces done.
#[test]
fn a_plan_sets_the_seed_and_resolution() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("farm");
    run(&[
        "farm",
        "slurm",
        SCENE,
        "--parts",
        "2",
        "--spp",
        "6",
        "--seed",
        "5",
        "--resolution",
        "40,30",
        "-o",
        out.to_str().unwrap(),
    ]);
    let plan = out.join("farm.toml");
    let text = std::fs::read_to_string(&plan).unwrap();
    assert!(
        text.contains("seed = 5") && text.contains("resolution = [40, 30]"),
        "{text}"
    );
    let p = plan.to_str().unwrap();
    run(&["farm", "piece", p, "0"]);
    run(&["farm", "piece", p, "1"]);
    assert!(run(&["farm", "status", p]).contains("2 of 2 pieces done"));
    run(&["farm", "merge", p]);
    let one = d.join("one.exr");
    run(&[
        "render",
        SCENE,
        "-o",
        one.to_str().unwrap(),
        "--spp",
        "6",
        "--seed",
        "5",
        "--resolution",
        "40,30",
    ]);
    let merged = Film::read_exr(&out.join("image.exr")).unwrap();
    assert_eq!((merged.width, merged.height), (40, 30));
    assert_close(
        "farm with seed and size",
        &Film::read_exr(&one).unwrap(),
        &merged,
        1e-6,
    );
    // A size out of range is refused before anything is written.
    let bad = d.join("bad");
    let o = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .args([
            "farm",
            "slurm",
            SCENE,
            "--parts",
            "2",
            "--resolution",
            "0,30",
            "-o",
        ])
        .arg(&bad)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("--resolution 0,30"),
        "{err}"
    );
    assert!(!bad.exists());
}
