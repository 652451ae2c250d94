//! The measurement loop: rounds of one sample per open configuration, in a seeded shuffled
//! order, until each configuration's CI target or budget is reached; each row appended whole
//! as soon as it is measured.

use super::meta::{self, Meta};
use super::plan::{ExperimentPlan, Launch, RunConfig, Sources};
use super::progress::Progress;
use super::results::{timeline_path, ResultsError, RunRow, RunsFile};
use super::stats::{median, relative_half_width, shuffle};
use crate::core::metrics::{RunStats, WorkerStats};
use crate::core::render::{render_serial, Image};
use crate::core::tracer::Tracer;
use crate::sched::{render_scene, RenderOn, SchedError, SchedulerSpec};
use crate::studies::model::advise::Probed;
use crate::studies::model::Prediction;
use crate::util::fs::{write_atomic, WriteError};
use crate::util::hash::hex;
use crate::util::text::slug;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

mod measure;
mod predict;
mod rounds;
mod session;
pub(super) use measure::SAMPLE;
use measure::*;
pub use measure::{inner_count, timeline_text};
use predict::*;
pub(super) use predict::{predictions, predictions_path};
pub(super) use rounds::Todo;
use rounds::*;
pub use rounds::{MAX_INNER, MIN_ADAPTIVE_RUNS};
use session::*;

/// Where and how [`run_experiment`] writes.
pub struct RunOptions {
    /// Results root; the experiment writes to `out/<name>/`.
    pub out: PathBuf,
    /// Discard old results (runs.csv, timelines, plots) instead of resuming.
    pub fresh: bool,
    /// Hide the progress bar.
    pub quiet: bool,
    /// Set in a round's own process ([`super::isolate`]): measure this round only; the parent
    /// holds the folder's lock and wrote `meta.toml` and the header.
    pub child_round: Option<u64>,
}

/// What a run did.
#[derive(Debug)]
pub struct RunOutcome {
    /// The experiment's results folder, `out/<name>/`.
    pub dir: PathBuf,
    /// Timed samples measured by this run (rows appended).
    pub measured: usize,
    /// Rows already in runs.csv, not measured again.
    pub skipped: usize,
    /// Untimed renders: warm-ups and the probes that size short samples.
    pub untimed: usize,
    /// Rows (old and new) whose image differs from the serial baseline's.
    pub mismatches: usize,
    /// Configurations that belong to other `mpirun` launches (not measured here).
    pub other_launches: usize,
}

/// Runs the MPI rows of one `mpirun` launch (implemented by `crate::mpi::experiment` on rank
/// 0); the runner stays free of MPI.
pub trait Remote {
    /// The launch whose MPI configurations this remote measures.
    fn launch(&self) -> &Launch;
    /// One timed run of `spec` on the launch's ranks; only the scheduler's wall time is timed.
    fn measure(
        &mut self,
        plan: &ExperimentPlan,
        c: &RunConfig,
        spec: &SchedulerSpec,
    ) -> Result<(Image, RunStats), RunError>;
}

/// Why a run stopped.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Refusals that `--fresh` fixes (changed experiment file, edited scene, foreign CSV).
    #[error("{0}")]
    Refused(String),
    /// Reading or writing runs.csv failed.
    #[error(transparent)]
    Results(#[from] ResultsError),
    /// A scheduler run failed.
    #[error("{config}: {source}")]
    Sched {
        /// The configuration's id and label.
        config: String,
        /// The scheduler's error.
        #[source]
        source: SchedError,
    },
    /// Writing an output file (meta, image, timeline) or creating a folder failed.
    #[error("{path}: {msg}")]
    Io {
        /// The file or folder.
        path: String,
        /// The error's text.
        msg: String,
    },
    /// The MPI side failed (a rank lost, a scene that did not build on a rank).
    #[error("{0}")]
    Mpi(String),
    /// Another run holds the results folder's lock.
    #[error(transparent)]
    Locked(#[from] super::lock::LockError),
    /// A round's own process could not start, failed, or could not plan the experiment.
    #[error("{0}")]
    Child(String),
}

pub(super) fn io_err(path: &Path, e: impl std::fmt::Display) -> RunError {
    RunError::Io {
        path: path.display().to_string(),
        msg: e.to_string(),
    }
}

impl From<WriteError> for RunError {
    fn from(e: WriteError) -> Self {
        io_err(&e.path, e.io)
    }
}

/// How a refusal to resume ends: both ways out, `--out` keeping the old folder as it is.
const KEEP_OR_FRESH: &str =
    "rerun with --out DIR to keep this folder as it is, or with --fresh to start it over";

/// Check (or start) `meta.toml` and append this start to its history. An existing one must
/// have been measured by this machine and build; what it says about the earlier rows is kept
/// as written. The experiment file may have changed (a grown grid resumes): its new hash and
/// any scene it adds are recorded. Every refusal comes before the file is written.
fn prepare_meta(
    plan: &ExperimentPlan,
    dir: &Path,
    fresh: bool,
    rows_before: usize,
) -> Result<Meta, RunError> {
    let path = dir.join("meta.toml");
    let runs = dir.join("runs.csv");
    let mut start = meta::Start::now(rows_before, plan.stats);
    start.experiment_hash = Some(plan.file_hash.clone());
    let resuming = !fresh && runs.exists() && rows_before > 0;
    let mut meta = if resuming {
        let old: Option<Meta> = std::fs::read_to_string(&path)
            .ok()
            .and_then(|t| toml::from_str(&t).ok());
        let Some(old) = old else {
            return Err(RunError::Refused(format!(
                "{}: missing or unreadable beside {}; {KEEP_OR_FRESH}",
                path.display(),
                runs.display()
            )));
        };
        let mut diffs = meta::resume_conflict(&old, &start);
        if let (Some(a), Some(b)) = (&old.gpu, plan.gpu.as_ref().map(|g| &g.info)) {
            if a != b {
                diffs.push(format!(
                    "GPU {} ({}) → {} ({})",
                    a.name, a.driver, b.name, b.driver
                ));
            }
        }
        if !diffs.is_empty() {
            return Err(RunError::Refused(format!(
                "{}: its {rows_before} rows were measured elsewhere ({}); resuming would mix them: {KEEP_OR_FRESH}",
                runs.display(),
                diffs.join(", ")
            )));
        }
        let mut scenes = old.scenes;
        for s in meta::collect(plan).scenes {
            if !scenes.iter().any(|o| o.file == s.file && o.hash == s.hash) {
                scenes.push(s);
            }
        }
        Meta {
            resumed: Some(start.time.clone()),
            experiment_file: plan.file.display().to_string(),
            experiment_hash: plan.file_hash.clone(),
            scenes,
            gpu: old
                .gpu
                .or_else(|| plan.gpu.as_ref().map(|g| g.info.clone())),
            configs: plan.configs.iter().map(|c| c.id.clone()).collect(),
            ..old
        }
    } else {
        meta::collect(plan)
    };
    meta.history.push(start);
    let text = toml::to_string(&meta).map_err(|e| io_err(&path, e))?;
    write_atomic(&path, text.as_bytes())?;
    Ok(meta)
}

/// What the serial baseline of one (scene, tracer) measured so far.
#[derive(Default)]
struct SerialInfo {
    walls: Vec<f64>,
    hash: Option<String>,
    /// Its image, kept (or read back from `images/`) where GPU rows are compared with it.
    image: Option<Image>,
}

/// Measure `plan` into `out/<name>/`, resuming what runs.csv already holds, outside any
/// `mpirun` launch: configurations of an `[mpi]` launch are left out.
pub fn run_experiment(plan: &ExperimentPlan, opts: &RunOptions) -> Result<RunOutcome, RunError> {
    run_experiment_with(plan, opts, None)
}

/// [`run_experiment`] inside an `mpirun` launch: `remote` measures the MPI rows of its launch;
/// configurations of other launches are left for them (their rows may already be in runs.csv).
///
/// Rounds: each round takes one timed sample of every configuration not yet done, serial
/// baselines first, each group in an order shuffled with the experiment's seed and the round,
/// so drift and a neighbour's load hit every configuration alike, and sample k of a
/// configuration pairs with sample k of its baseline (the speedup intervals rest on the
/// pairs). A configuration is done after `min_runs` samples once its median's CI reaches the
/// target, or when its runs or seconds are spent; a baseline runs on while any of its
/// configurations does.
pub fn run_experiment_with(
    plan: &ExperimentPlan,
    opts: &RunOptions,
    remote: Option<&mut dyn Remote>,
) -> Result<RunOutcome, RunError> {
    let launch = remote.as_ref().map(|r| r.launch().clone());
    let dir = opts.out.join(&plan.name);
    let child = opts.child_round;
    let _lock = match child {
        None => Some(super::lock::ResultsLock::acquire(&dir)?),
        Some(_) => None,
    };
    let fresh = opts.fresh && child.is_none();
    let (runs, old_rows) = match child {
        None => open_results(plan, &dir, fresh)?,
        Some(_) => RunsFile::open(&dir.join("runs.csv"), false)?,
    };
    let serial = check_old_rows(plan, &runs.path, &old_rows)?;
    let mut todo = Todo::of(plan, &old_rows, launch.as_ref());
    todo.update_done(plan);
    let predictions = match child {
        Some(_) => read_predictions(plan, &dir)?,
        None if plan.predict => predictions(plan, &todo)?,
        None => HashMap::new(),
    };
    let mut session = Session {
        plan,
        dir,
        runs,
        serial,
        progress: Progress::new(opts.quiet, todo.upper_bound(plan)),
        remote,
        mismatches: old_rows
            .iter()
            .filter(|r| !r.identical && r.agrees != Some(true))
            .count(),
        measured: 0,
        untimed: 0,
        predictions,
        probe_s: None,
        child: child.is_some(),
    };
    let skipped = old_rows.len();
    let mut round = child.unwrap_or(0);
    loop {
        todo.update_done(plan);
        let order = todo.round_order(plan, round);
        if order.is_empty() {
            break;
        }
        if let (Some(_), Some(&first)) = (child, order.first()) {
            session.warm_process(&todo.states[first])?;
        }
        // Once per round, 0.2 % of a round of `quick` (see `speed::STEPS`).
        session.probe_s = Some(super::speed::probe_s());
        for i in order {
            session.sample(&mut todo.states[i])?;
            session
                .progress
                .set_bound(todo.upper_bound_now(plan) + session.measured as u64);
        }
        round += 1;
        if child.is_some() {
            break;
        }
    }
    session.progress.finish(session.measured);
    Ok(RunOutcome {
        dir: session.dir,
        measured: session.measured,
        skipped,
        mismatches: session.mismatches,
        other_launches: todo.other_launches,
        untimed: session.untimed,
    })
}

/// The results folder ready for this start and its runs.csv open for appending: the folders
/// made, `meta.toml` checked (or started) against the rows already there, before the file is
/// changed, with this start appended to its history.
pub(super) fn open_results(
    plan: &ExperimentPlan,
    dir: &Path,
    fresh: bool,
) -> Result<(RunsFile, Vec<RunRow>), RunError> {
    prepare_dir(plan, dir, fresh)?;
    let old = RunsFile::read(&dir.join("runs.csv"), fresh)?;
    // The rows are checked before meta.toml is touched: a refused resume changes nothing.
    check_old_rows(plan, &dir.join("runs.csv"), &old.rows)?;
    prepare_meta(plan, dir, fresh, old.rows.len())?;
    Ok(old.open()?)
}

/// The results folder with its `images/` (and `timelines/`); `fresh` clears old timelines and
/// plots, which would otherwise outlive the rows they came from.
fn prepare_dir(plan: &ExperimentPlan, dir: &Path, fresh: bool) -> Result<(), RunError> {
    if fresh {
        for sub in ["timelines", "plots"] {
            let _ = std::fs::remove_dir_all(dir.join(sub));
        }
    }
    std::fs::create_dir_all(dir.join("images")).map_err(|e| io_err(dir, e))?;
    if plan.timeline {
        std::fs::create_dir_all(dir.join("timelines")).map_err(|e| io_err(dir, e))?;
    }
    Ok(())
}

/// Resume: old rows must still be valid measurements of this plan's scenes as they are now.
pub(super) fn validate_old_rows(
    plan: &ExperimentPlan,
    runs: &RunsFile,
    old_rows: &[RunRow],
) -> Result<(), RunError> {
    check_old_rows(plan, &runs.path, old_rows).map(drop)
}

/// [`validate_old_rows`], returning what the serial baselines measured so far. A row of a
/// configuration the plan still has must match its scene's hash. A row of one it lacks is a
/// grid value since removed, kept and not measured again, unless its scene file is still in
/// the plan at other settings or content (spp, size, an edit): those rows no longer describe
/// the scene as planned, and the resume is refused.
fn check_old_rows(
    plan: &ExperimentPlan,
    runs: &Path,
    old_rows: &[RunRow],
) -> Result<HashMap<usize, SerialInfo>, RunError> {
    let by_id: HashMap<&str, &RunConfig> =
        plan.configs.iter().map(|c| (c.id.as_str(), c)).collect();
    let changed = |r: &RunRow, what: String| {
        RunError::Refused(format!(
            "{}: scene {} {what} since these rows were measured; {KEEP_OR_FRESH}",
            runs.display(),
            r.scene_file
        ))
    };
    let mut serial: HashMap<usize, SerialInfo> = HashMap::new();
    for r in old_rows {
        let Some(c) = by_id.get(r.config.as_str()) else {
            let same_file: Vec<&crate::core::scene::Scene> = plan
                .scenes
                .iter()
                .filter(|s| s.file == r.scene_file)
                .map(|s| s.scene.as_ref())
                .collect();
            let settings = |s: &crate::core::scene::Scene| {
                (s.width(), s.height(), s.settings.spp, s.settings.max_depth)
            };
            let row_settings = (r.width, r.height, r.spp, r.max_depth);
            let kept = same_file.is_empty()
                || same_file
                    .iter()
                    .any(|s| hex(s.hash) == r.scene_hash && settings(s) == row_settings);
            if kept {
                continue;
            }
            let s = same_file
                .iter()
                .find(|s| hex(s.hash) == r.scene_hash)
                .unwrap_or(&same_file[0]);
            let (w, h, spp, depth) = settings(s);
            let what = if spp != r.spp {
                format!("spp changed ({} → {spp})", r.spp)
            } else if (w, h) != (r.width, r.height) {
                format!("size changed ({}×{} → {w}×{h})", r.width, r.height)
            } else if depth != r.max_depth {
                format!("max_depth changed ({} → {depth})", r.max_depth)
            } else {
                format!("changed (hash {} → {})", r.scene_hash, hex(s.hash))
            };
            return Err(changed(r, what));
        };
        let now = hex(plan.scene_of(c).scene.hash);
        if r.scene_hash != now {
            return Err(changed(
                r,
                format!("changed (hash {} → {now})", r.scene_hash),
            ));
        }
        if c.spec.is_none() {
            let s = serial.entry(c.baseline).or_default();
            s.walls.push(r.wall_s);
            if r.repetition == 0 {
                s.hash = Some(r.image_hash.clone());
            }
        }
    }
    Ok(serial)
}
