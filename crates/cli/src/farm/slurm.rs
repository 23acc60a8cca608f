//! `plsr farm slurm`: the plan as a Slurm job array (`render.sbatch`, task
//! `i` renders piece `i` from `$SLURM_ARRAY_TASK_ID`) and a merge job
//! (`merge.sbatch`) submitted with `--dependency=afterok` on the array.

use super::plan::{index_list, DoneCheck, FarmPlan};
use super::{make_plan, shell_quote, this_program, PlanArgs};
use crate::error::{Error, Result};
use plsr::atomic_write::OutputSet;
use plsr_base::Vocabulary;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Arguments of `plsr farm slurm`.
#[derive(Debug, clap::Args)]
pub struct SlurmArgs {
    #[command(flatten)]
    pub plan: PlanArgs,
    /// Submit the jobs with sbatch: the array for the pieces not done yet
    /// (all of them the first time) and the merge after it.
    #[arg(long)]
    pub submit: bool,
    /// CPUs per array task (sbatch --cpus-per-task); each piece renders
    /// on that many threads.
    #[arg(long)]
    pub cpus_per_task: Option<u32>,
    /// Memory per task (sbatch --mem, e.g. 4G).
    #[arg(long)]
    pub mem: Option<String>,
    /// Time limit per task (sbatch --time, e.g. 1:00:00).
    #[arg(long)]
    pub time: Option<String>,
    /// Partition (sbatch --partition).
    #[arg(long)]
    pub partition: Option<String>,
    /// At most this many array tasks at once (sbatch --array=…%N).
    #[arg(long)]
    pub max_running: Option<u32>,
    /// More sbatch options for both jobs, each as one `#SBATCH` line
    /// (e.g. --sbatch-option=--account=render).
    #[arg(long, value_name = "OPTION", allow_hyphen_values = true)]
    pub sbatch_option: Vec<String>,
    /// The plsr program the jobs run (default: this one; it must be at the
    /// same path on every node).
    #[arg(long)]
    pub plsr: Option<PathBuf>,
}

/// The batch scripts' names in the output folder.
pub const RENDER_SCRIPT: &str = "render.sbatch";
/// See [`RENDER_SCRIPT`].
pub const MERGE_SCRIPT: &str = "merge.sbatch";

/// Runs `plsr farm slurm`.
pub fn run(a: &SlurmArgs) -> Result<()> {
    if a.cpus_per_task == Some(0) {
        return Err(Error::invalid_argument(
            "--cpus-per-task must be at least 1",
        ));
    }
    if a.max_running == Some(0) {
        return Err(Error::invalid_argument("--max-running must be at least 1"));
    }
    for o in &a.sbatch_option {
        if !o.starts_with('-') || o.contains('\n') {
            return Err(Error::invalid_argument(format!(
                "--sbatch-option {o:?}: expected one sbatch option such as --account=NAME"
            )));
        }
    }
    let (plan, dir, plan_file) = make_plan(&a.plan, &[RENDER_SCRIPT, MERGE_SCRIPT])?;
    let program = match &a.plsr {
        Some(p) => p.clone(),
        None => this_program()?,
    };
    std::fs::create_dir_all(dir.join("logs"))
        .map_err(|source| Error::io(dir.join("logs"), source))?;
    let mut outputs = OutputSet::new();
    let render = dir.join(RENDER_SCRIPT);
    let merge = dir.join(MERGE_SCRIPT);
    outputs.stage_bytes(
        &render,
        render_script(a, &plan, &dir, &plan_file, &program).as_bytes(),
    )?;
    outputs.stage_bytes(
        &merge,
        merge_script(a, &dir, &plan_file, &program).as_bytes(),
    )?;
    outputs.commit()?;
    let pieces = plan.piece_count();
    let quiet = a.plan.quiet;
    if !quiet {
        crate::note!(
            "wrote {} ({} pieces: {} frame{} × {} parts of {}, {} spp in all) and {}",
            render.display(),
            pieces,
            plan.frame_list().len(),
            if plan.frame_list().len() == 1 {
                ""
            } else {
                "s"
            },
            plan.parts,
            plan.part_spp(),
            plan.spp,
            merge.display()
        );
    }
    if !a.submit {
        if !quiet {
            crate::note!(
            "submit with: plsr farm slurm … --submit, or\n  \
             id=$(sbatch --parsable {}) && sbatch --dependency=afterok:$id --kill-on-invalid-dep=yes {}",
            shell_quote(&render.to_string_lossy()),
            shell_quote(&merge.to_string_lossy())
        );
        }
        return Ok(());
    }
    let missing = DoneCheck::new(&plan, &dir)?.missing(&plan, &dir);
    let mut merge_args = vec!["--parsable".to_string()];
    if missing.is_empty() {
        if !quiet {
            crate::note!("every piece is done: submitting the merge alone");
        }
    } else {
        let throttle = a.max_running.map(|n| format!("%{n}")).unwrap_or_default();
        let array = format!("--array={}{throttle}", index_list(&missing));
        if missing.len() < pieces as usize && !quiet {
            crate::note!(
                "{} of {pieces} pieces are done: submitting the other {} ({array})",
                pieces as usize - missing.len(),
                missing.len()
            );
        }
        let id = sbatch(&["--parsable".into(), array, render.to_string_lossy().into()])?;
        println!("submitted render array job {id}");
        merge_args.push(format!("--dependency=afterok:{id}"));
        merge_args.push("--kill-on-invalid-dep=yes".into());
    }
    merge_args.push(merge.to_string_lossy().into());
    let id = sbatch(&merge_args)?;
    println!("submitted merge job {id}");
    Ok(())
}

/// Runs sbatch with `args`; returns the job id it prints (`--parsable`).
fn sbatch(args: &[String]) -> Result<String> {
    let out = Command::new("sbatch").args(args).output().map_err(|e| {
        Error::invalid_argument(format!(
            "cannot run sbatch ({e}): is Slurm's client (Debian: slurm-client) installed and on PATH?"
        ))
    })?;
    if !out.status.success() {
        return Err(Error::invalid_argument(format!(
            "sbatch {} failed ({}): {}",
            args.join(" "),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    // `--parsable` prints "ID" or "ID;CLUSTER".
    let id = text.trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() || !id.bytes().all(|b| b.is_ascii_digit()) {
        return Err(Error::invalid_argument(format!(
            "sbatch printed {text:?}, not a job id"
        )));
    }
    Ok(id)
}

/// The `#SBATCH` lines both jobs share.
fn common_directives(a: &SlurmArgs, out: &mut String) {
    if let Some(p) = &a.partition {
        out.push_str(&format!("#SBATCH --partition={p}\n"));
    }
    if let Some(t) = &a.time {
        out.push_str(&format!("#SBATCH --time={t}\n"));
    }
    for o in &a.sbatch_option {
        out.push_str(&format!("#SBATCH {o}\n"));
    }
}

/// The array job's script.
fn render_script(
    a: &SlurmArgs,
    plan: &FarmPlan,
    dir: &Path,
    plan_file: &Path,
    program: &Path,
) -> String {
    let mut s = format!(
        "#!/bin/bash\n\
         # Written by `plsr farm slurm` (docs/farm.md). Array task i renders piece i of\n\
         # {plan}: frame (i / parts) and its sample range (i % parts).\n\
         # `plsr farm slurm … --submit` submits it for the pieces not done yet and the\n\
         # merge after it; by hand: sbatch --array=0-{last} {this}\n\
         #SBATCH --job-name=plsr-render\n\
         #SBATCH --array=0-{last}\n\
         #SBATCH --output={logs}/render-%A_%a.log\n",
        plan = plan_file.display(),
        last = plan.piece_count() - 1,
        this = dir.join(RENDER_SCRIPT).display(),
        logs = dir.join("logs").display(),
    );
    if let Some(c) = a.cpus_per_task {
        s.push_str(&format!("#SBATCH --cpus-per-task={c}\n"));
    }
    if let Some(m) = &a.mem {
        s.push_str(&format!("#SBATCH --mem={m}\n"));
    }
    common_directives(a, &mut s);
    s.push_str(&format!(
        "set -euo pipefail\n\
         exec {program} farm piece {plan} \"$SLURM_ARRAY_TASK_ID\" \
         ${{SLURM_CPUS_PER_TASK:+--threads \"$SLURM_CPUS_PER_TASK\"}}\n",
        program = shell_quote(&program.to_string_lossy()),
        plan = shell_quote(&plan_file.to_string_lossy()),
    ));
    s
}

/// The merge job's script.
fn merge_script(a: &SlurmArgs, dir: &Path, plan_file: &Path, program: &Path) -> String {
    let mut s = format!(
        "#!/bin/bash\n\
         # Written by `plsr farm slurm` (docs/farm.md): merges the pieces of\n\
         # {plan} once the render array has succeeded (--dependency=afterok).\n\
         #SBATCH --job-name=plsr-merge\n\
         #SBATCH --output={logs}/merge-%j.log\n",
        plan = plan_file.display(),
        logs = dir.join("logs").display(),
    );
    common_directives(a, &mut s);
    s.push_str(&format!(
        "set -euo pipefail\nexec {} farm merge {}\n",
        shell_quote(&program.to_string_lossy()),
        shell_quote(&plan_file.to_string_lossy()),
    ));
    s
}
