//! Isolated runs (`isolation = "round"`): each round of timed samples in a fresh process.
//!
//! The parent holds the results folder's lock, writes `meta.toml` and the header of runs.csv,
//! then starts one child per round. A child resumes from runs.csv like any resumed run, takes
//! that round's samples, appends their rows and exits; the parent rereads runs.csv between
//! rounds, so it alone decides when the run is over. The child reports each sample on stdout
//! (one line, for the parent's progress display); its errors go to the inherited stderr.

use super::plan::{ExperimentPlan, StatsSettings};
use super::progress::Progress;
use super::results::{read_runs, RunRow};
use super::run::{self, predictions_path, RunError, RunOptions, RunOutcome, Todo, SAMPLE};
use serde::{Deserialize, Serialize};
use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// The hidden subcommand a round's process runs: `raysched round-child JOB`, JOB being a
/// [`RoundJob`] as JSON.
pub const ROUND_CHILD_COMMAND: &str = "round-child";

/// A child's last line: the prefix, then its untimed renders (warm-ups and inner probes).
const UNTIMED: &str = "untimed\t";

/// What a round's process is started with.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RoundJob {
    /// The experiment file.
    pub experiment: PathBuf,
    /// Its hash as the parent planned it: a file edited during the run is refused.
    pub file_hash: String,
    /// The results root (the parent's `--out`).
    pub out: PathBuf,
    /// The round to measure.
    pub round: u64,
    /// The parent's statistics settings (the file's, with the command line's overrides).
    pub stats: StatsSettings,
}

/// Run `plan` with a fresh process of `exe` per round, or in this process where the plan asks
/// for that or holds a GPU source (opening the device per round would cost more than a
/// round of samples measures).
pub fn run_experiment_isolated(
    plan: &ExperimentPlan,
    opts: &RunOptions,
    exe: &Path,
) -> Result<RunOutcome, RunError> {
    if plan.stats.isolation == super::config::Isolation::None
        || plan.gpu.is_some()
        || opts.child_round.is_some()
    {
        return run::run_experiment(plan, opts);
    }
    let dir = opts.out.join(&plan.name);
    let _lock = super::lock::ResultsLock::acquire(&dir)?;
    let runs_path = dir.join("runs.csv");
    let (runs, old_rows) = run::open_results(plan, &dir, opts.fresh)?;
    run::validate_old_rows(plan, &runs, &old_rows)?;
    drop(runs);
    let skipped = old_rows.len();
    let todo_of = |rows: &[RunRow]| {
        let mut todo = Todo::of(plan, rows, None);
        todo.update_done(plan);
        todo
    };
    let mut rows = old_rows;
    let mut todo = todo_of(&rows);
    let pred_path = predictions_path(&dir);
    if plan.predict {
        let p = run::predictions(plan, &todo)?;
        let text = serde_json::to_string(&p).map_err(|e| run::io_err(&pred_path, e))?;
        crate::util::fs::write_atomic(&pred_path, text.as_bytes())?;
    }
    let mut progress = Progress::new(opts.quiet, todo.upper_bound_now(plan));
    let (mut measured, mut untimed) = (0u64, 0usize);
    let mut round = 0u64;
    while !todo.round_order(plan, round).is_empty() {
        progress.set_bound(todo.upper_bound_now(plan) + measured);
        let job = RoundJob {
            experiment: plan.file.clone(),
            file_hash: plan.file_hash.clone(),
            out: opts.out.clone(),
            round,
            stats: plan.stats,
        };
        let before = measured;
        run_child(exe, &job, &mut |line| {
            if let Some(label) = line.strip_prefix(SAMPLE) {
                progress.set_message(label.to_string());
                progress.inc();
                measured += 1;
            } else if let Some(n) = line.strip_prefix(UNTIMED) {
                untimed += n.trim().parse::<usize>().unwrap_or(0);
            }
        })
        .map_err(|e| RunError::Child(format!("{}: round {round}: {e}", plan.file.display())))?;
        if measured == before {
            return Err(RunError::Child(format!(
                "{}: round {round}: its process measured nothing",
                plan.file.display()
            )));
        }
        round += 1;
        // The child appended its round: the parent alone decides from the file what is left.
        rows = read_runs(&runs_path)?.0;
        todo = todo_of(&rows);
    }
    if plan.predict {
        let _ = std::fs::remove_file(&pred_path);
    }
    let new = rows.len() - skipped;
    progress.finish(new);
    Ok(RunOutcome {
        dir,
        measured: new,
        skipped,
        untimed,
        mismatches: rows
            .iter()
            .filter(|r| !r.identical && r.agrees != Some(true))
            .count(),
        other_launches: todo.other_launches,
    })
}

/// Start `exe round-child JOB`, pass each line it prints to `line`, wait for it.
fn run_child(exe: &Path, job: &RoundJob, line: &mut dyn FnMut(&str)) -> Result<(), String> {
    let arg = serde_json::to_string(job).map_err(|e| e.to_string())?;
    let mut child = Command::new(exe)
        .arg(ROUND_CHILD_COMMAND)
        .arg(arg)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| format!("starting {}: {e}", exe.display()))?;
    // Held open until the child has ended: when this process dies, the child sees its stdin
    // close and stops ([`child_main`]), so a killed run leaves no orphan appending rows.
    let _stdin = child.stdin.take();
    let stdout = child.stdout.take().expect("piped");
    for l in std::io::BufReader::new(stdout).lines() {
        match l {
            Ok(l) => line(&l),
            Err(_) => break,
        }
    }
    let status = child.wait().map_err(|e| e.to_string())?;
    if status.success() {
        Ok(())
    } else {
        Err(format!(
            "its process failed ({status}; its message is above)"
        ))
    }
}

/// A round's process: plan `job.experiment` again, check it is the parent's, measure round
/// `job.round` into the parent's runs.csv.
pub fn child_main(job: &RoundJob) -> Result<(), RunError> {
    // The parent never writes to stdin: end of file means it is gone (killed), and with it
    // the lock on the folder; this process must not go on appending rows.
    std::thread::spawn(|| {
        let mut byte = [0u8; 1];
        let _ = std::io::Read::read(&mut std::io::stdin(), &mut byte);
        std::process::exit(3);
    });
    let mut plan = super::load_plan(&job.experiment).map_err(|e| RunError::Child(e.to_string()))?;
    if plan.file_hash != job.file_hash {
        return Err(RunError::Refused(format!(
            "{}: changed while it was being measured (hash {} → {})",
            job.experiment.display(),
            job.file_hash,
            plan.file_hash
        )));
    }
    plan.stats = job.stats;
    let opts = RunOptions {
        out: job.out.clone(),
        fresh: false,
        quiet: true,
        child_round: Some(job.round),
    };
    let outcome = run::run_experiment(&plan, &opts)?;
    println!("{UNTIMED}{}", outcome.untimed);
    Ok(())
}
