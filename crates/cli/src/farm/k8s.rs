//! `plsr farm k8s`: the plan as a Kubernetes Indexed Job (pod `i` renders
//! piece `i` from `$JOB_COMPLETION_INDEX`) and a merge Job, both with the
//! scene and the output folder on one persistent volume claim, plus
//! `run-k8s.sh`, which applies the first, waits for it and applies the
//! second (Kubernetes has no dependencies between Jobs).

use super::plan::{relative_path, FarmPlan};
use super::{make_plan, shell_quote, PlanArgs};
use crate::error::{Error, Result};
use plsr::atomic_write::OutputSet;
use plsr_base::Vocabulary;
use std::path::{Component, Path, PathBuf};

/// Arguments of `plsr farm k8s`.
#[derive(Debug, clap::Args)]
pub struct K8sArgs {
    #[command(flatten)]
    pub plan: PlanArgs,
    /// The container image with plsr (on its PATH, or see --plsr).
    #[arg(long)]
    pub image: String,
    /// The PersistentVolumeClaim holding the scene and the output folder.
    #[arg(long)]
    pub claim: String,
    /// The local folder that is the claim's root (e.g. where its NFS share
    /// is mounted here); the scene and OUTDIR must lie inside it.
    #[arg(long, default_value = ".")]
    pub volume_root: PathBuf,
    /// Where the pods mount the claim.
    #[arg(long, default_value = "/data")]
    pub mount: String,
    /// Pods at once (default: every piece).
    #[arg(long)]
    pub parallelism: Option<u32>,
    /// CPUs each pod requests (and renders on); default: none requested.
    #[arg(long)]
    pub cpus: Option<u32>,
    /// Memory each pod requests and is limited to (e.g. 4Gi).
    #[arg(long)]
    pub memory: Option<String>,
    /// Retries of each piece before the Job fails (its backoffLimit is
    /// this times the pieces).
    #[arg(long, default_value_t = 2)]
    pub retries: u32,
    /// The Jobs' names: NAME-render and NAME-merge (default: plsr- and
    /// the output folder's name).
    #[arg(long)]
    pub job_name: Option<String>,
    /// The plsr program in the image.
    #[arg(long, default_value = "plsr")]
    pub plsr: String,
    /// The namespace of the Jobs (default: kubectl's current one).
    #[arg(long)]
    pub namespace: Option<String>,
}

/// The files written beside the plan.
pub const RENDER_JOB: &str = "render-job.yaml";
/// See [`RENDER_JOB`].
pub const MERGE_JOB: &str = "merge-job.yaml";
/// See [`RENDER_JOB`].
pub const RUN_SCRIPT: &str = "run-k8s.sh";

/// Runs `plsr farm k8s`.
pub fn run(a: &K8sArgs) -> Result<()> {
    if !a.mount.starts_with('/') {
        return Err(Error::invalid_argument(format!(
            "--mount {}: must be an absolute path in the pods",
            a.mount
        )));
    }
    if a.parallelism == Some(0) || a.cpus == Some(0) {
        return Err(Error::invalid_argument(
            "--parallelism and --cpus must be at least 1",
        ));
    }
    for (flag, v) in [("--image", &a.image), ("--claim", &a.claim)] {
        if v.trim().is_empty() {
            return Err(Error::invalid_argument(format!("{flag} must not be empty")));
        }
    }
    let name = match &a.job_name {
        Some(n) => {
            if dns_label(n) != *n {
                return Err(Error::invalid_argument(format!(
                    "--job-name {n:?}: must be lowercase letters, digits and '-', \
                     start and end with a letter or digit, at most {MAX_NAME} characters"
                )));
            }
            n.clone()
        }
        None => {
            let base = a
                .plan
                .output_dir
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            dns_label(&format!("plsr-{base}"))
        }
    };
    // Where the scene and the output folder are inside the volume: checked
    // before the plan is written.
    let root = std::fs::canonicalize(&a.volume_root)
        .map_err(|source| Error::io(a.volume_root.clone(), source))?;
    inside(&root, &a.plan.scene, "the scene")?;
    let (plan, dir, plan_file) = make_plan(&a.plan, &[RENDER_JOB, MERGE_JOB, RUN_SCRIPT])?;
    let in_pod = |p: &Path| -> Result<String> {
        let rel = inside(&root, p, "OUTDIR")?;
        Ok(format!(
            "{}/{}",
            a.mount.trim_end_matches('/'),
            rel.to_string_lossy()
        ))
    };
    if plan.piece_count() > MAX_COMPLETIONS {
        return Err(Error::invalid_argument(format!(
            "{} pieces: Kubernetes refuses Indexed Jobs of more than {MAX_COMPLETIONS} completions",
            plan.piece_count()
        )));
    }
    let plan_in_pod = in_pod(&plan_file)?;
    let render = render_job(a, &name, &plan, &plan_in_pod);
    let merge = merge_job(a, &name, &plan_in_pod);
    let mut outputs = OutputSet::new();
    let files = [
        (dir.join(RENDER_JOB), render),
        (dir.join(MERGE_JOB), merge),
        (dir.join(RUN_SCRIPT), run_script(a, &name, &dir)),
    ];
    for (path, text) in &files {
        outputs.stage_bytes(path, text.as_bytes())?;
    }
    outputs.commit()?;
    set_executable(&files[2].0)?;
    if a.plan.quiet {
        return Ok(());
    }
    crate::note!(
        "wrote {} ({} pieces), {} and {}; run: sh {}",
        files[0].0.display(),
        plan.piece_count(),
        files[1].0.display(),
        files[2].0.display(),
        shell_quote(&files[2].0.to_string_lossy())
    );
    Ok(())
}

/// The most completions Kubernetes allows an Indexed Job.
const MAX_COMPLETIONS: u32 = 100_000;

/// The longest Job name: pods of an Indexed Job are named NAME-INDEX-xxxxx
/// within 63 characters.
const MAX_NAME: usize = 40;

/// `s` as a DNS label: lowercase letters, digits and '-', trimmed to
/// [`MAX_NAME`] characters.
fn dns_label(s: &str) -> String {
    let mapped: String = s
        .to_lowercase()
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect();
    let mut out = String::new();
    for c in mapped.chars() {
        if !(c == '-' && (out.is_empty() || out.ends_with('-'))) {
            out.push(c);
        }
    }
    out.truncate(MAX_NAME);
    let out = out.trim_end_matches('-').to_string();
    if out.is_empty() {
        "plsr".into()
    } else {
        out
    }
}

/// `path` relative to the volume's `root`, which it must lie in.
fn inside(root: &Path, path: &Path, what: &str) -> Result<PathBuf> {
    let abs =
        std::fs::canonicalize(path).map_err(|source| Error::io(path.to_path_buf(), source))?;
    let rel = relative_path(root, &abs)?;
    if rel.is_absolute() || rel.components().next() == Some(Component::ParentDir) {
        return Err(Error::invalid_argument(format!(
            "{what} {} is not inside --volume-root {}: the pods see only the volume",
            path.display(),
            root.display()
        )));
    }
    Ok(rel)
}

/// A YAML string (JSON's quoting is YAML's double-quoted style).
fn q(s: &str) -> String {
    serde_json::to_string(s).expect("a string serialises")
}

/// The pod template both Jobs share, indented for `spec.template`.
fn pod_template(a: &K8sArgs, role: &str, command: &[String]) -> String {
    let mut s = format!(
        "  template:\n\
         \x20   metadata:\n\
         \x20     labels:\n\
         \x20       app.kubernetes.io/name: plsr\n\
         \x20       app.kubernetes.io/component: {role}\n\
         \x20   spec:\n\
         \x20     restartPolicy: Never\n\
         \x20     containers:\n\
         \x20       - name: plsr\n\
         \x20         image: {image}\n\
         \x20         command: [{command}]\n",
        image = q(&a.image),
        command = command.iter().map(|c| q(c)).collect::<Vec<_>>().join(", "),
    );
    if a.cpus.is_some() || a.memory.is_some() {
        s.push_str("          resources:\n            requests:\n");
        if let Some(c) = a.cpus {
            s.push_str(&format!("              cpu: {}\n", q(&c.to_string())));
        }
        if let Some(m) = &a.memory {
            s.push_str(&format!("              memory: {}\n", q(m)));
            s.push_str(&format!(
                "            limits:\n              memory: {}\n",
                q(m)
            ));
        }
    }
    s.push_str(&format!(
        "          volumeMounts:\n\
         \x20           - name: scene-and-output\n\
         \x20             mountPath: {mount}\n\
         \x20     volumes:\n\
         \x20       - name: scene-and-output\n\
         \x20         persistentVolumeClaim:\n\
         \x20           claimName: {claim}\n",
        mount = q(&a.mount),
        claim = q(&a.claim),
    ));
    s
}

/// The Job's metadata.
fn metadata(a: &K8sArgs, name: &str) -> String {
    let mut s = format!("metadata:\n  name: {}\n", q(name));
    if let Some(ns) = &a.namespace {
        s.push_str(&format!("  namespace: {}\n", q(ns)));
    }
    s.push_str("  labels:\n    app.kubernetes.io/name: plsr\n");
    s
}

/// The Indexed Job rendering the pieces.
fn render_job(a: &K8sArgs, name: &str, plan: &FarmPlan, plan_in_pod: &str) -> String {
    let pieces = plan.piece_count();
    let mut command = vec![
        a.plsr.clone(),
        "farm".into(),
        "piece".into(),
        plan_in_pod.to_string(),
    ];
    if let Some(c) = a.cpus {
        command.extend(["--threads".into(), c.to_string()]);
    }
    format!(
        "# Written by `plsr farm k8s` (docs/farm.md): pod i renders piece i of the plan\n\
         # (index from $JOB_COMPLETION_INDEX); pieces already rendered return at once.\n\
         apiVersion: batch/v1\n\
         kind: Job\n\
         {meta}\
         spec:\n\
         \x20 completionMode: Indexed\n\
         \x20 completions: {pieces}\n\
         \x20 parallelism: {parallelism}\n\
         \x20 backoffLimit: {backoff}\n\
         {template}",
        meta = metadata(a, &format!("{name}-render")),
        parallelism = a.parallelism.unwrap_or(pieces).min(pieces),
        backoff = (a.retries as u64 * pieces as u64).min(i32::MAX as u64),
        template = pod_template(a, "render", &command),
    )
}

/// The Job merging them.
fn merge_job(a: &K8sArgs, name: &str, plan_in_pod: &str) -> String {
    let command = vec![
        a.plsr.clone(),
        "farm".into(),
        "merge".into(),
        plan_in_pod.to_string(),
    ];
    format!(
        "# Written by `plsr farm k8s` (docs/farm.md): merges the pieces once the render\n\
         # Job is complete (run-k8s.sh applies it then).\n\
         apiVersion: batch/v1\n\
         kind: Job\n\
         {meta}\
         spec:\n\
         \x20 completions: 1\n\
         \x20 backoffLimit: {backoff}\n\
         {template}",
        meta = metadata(a, &format!("{name}-merge")),
        backoff = a.retries,
        template = pod_template(a, "merge", &command),
    )
}

/// The script that runs both Jobs in order. It waits for each Job to
/// complete or fail (`kubectl wait` alone waits for one condition, so a
/// failed Job would hold it until its timeout); a failure prints the logs
/// of the Job's failed pods and exits with status 1.
fn run_script(a: &K8sArgs, name: &str, dir: &Path) -> String {
    let ns = a
        .namespace
        .as_ref()
        .map(|n| format!(" --namespace {}", shell_quote(n)))
        .unwrap_or_default();
    let file = |f: &str| shell_quote(&dir.join(f).to_string_lossy());
    format!(
        r#"#!/bin/sh
# Written by `plsr farm k8s` (docs/farm.md): renders the pieces, waits for
# them, merges. Run it again after a failure: the Jobs are replaced and
# only the pieces not rendered yet are rendered.
# PLSR_TIMEOUT: how long to wait for each Job (seconds, or with s, m, h or
# d; default 168h). PLSR_POLL_SECONDS: how often to look (default 10).
set -eu

timeout_seconds() {{
    t="${{PLSR_TIMEOUT:-168h}}"
    case "$t" in
        *d) echo $(( ${{t%d}} * 86400 )) ;;
        *h) echo $(( ${{t%h}} * 3600 )) ;;
        *m) echo $(( ${{t%m}} * 60 )) ;;
        *s) echo "${{t%s}}" ;;
        *) echo "$t" ;;
    esac
}}

# Waits until Job $1 is complete; if it fails or the timeout passes, prints
# the logs of its failed pods and exits 1.
wait_for_job() {{
    deadline=$(( $(date +%s) + $(timeout_seconds) ))
    while :; do
        state=$(kubectl{ns} get job "$1" -o 'jsonpath={{range .status.conditions[?(@.status=="True")]}}{{.type}} {{end}}')
        case " $state " in
            *" Complete "*) return 0 ;;
            *" Failed "*)
                echo "run-k8s.sh: job $1 failed; the logs of its failed pods follow" >&2
                for pod in $(kubectl{ns} get pods -l job-name="$1" --field-selector=status.phase=Failed -o 'jsonpath={{.items[*].metadata.name}}'); do
                    echo "--- pod $pod" >&2
                    kubectl{ns} logs "$pod" --all-containers --tail=200 >&2 || true
                done
                exit 1 ;;
        esac
        if [ "$(date +%s)" -ge "$deadline" ]; then
            echo "run-k8s.sh: job $1 neither completed nor failed within ${{PLSR_TIMEOUT:-168h}}" >&2
            exit 1
        fi
        sleep "${{PLSR_POLL_SECONDS:-10}}"
    done
}}

kubectl{ns} delete job {name}-render {name}-merge --ignore-not-found
kubectl{ns} apply -f {render}
wait_for_job {name}-render
kubectl{ns} apply -f {merge}
wait_for_job {name}-merge
echo "run-k8s.sh: rendered and merged"
"#,
        render = file(RENDER_JOB),
        merge = file(MERGE_JOB),
    )
}

/// Makes the run script executable (rwxr-xr-x).
fn set_executable(path: &Path) -> Result<()> {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755))
        .map_err(|source| Error::io(path.to_path_buf(), source))
}
