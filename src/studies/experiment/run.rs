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

/// One configuration's samples so far and whether it needs more.
struct ConfigState<'p> {
    config: &'p RunConfig,
    /// Wall times by repetition, in repetition order.
    walls: Vec<f64>,
    /// The next repetition's index.
    next_rep: u32,
    /// Seconds of timed renders spent (inner renders included).
    timed_s: f64,
    /// Renders per timed sample, once known.
    inner: Option<u32>,
    done: bool,
}

impl ConfigState<'_> {
    /// Enough samples by its own criteria (runs, budget, CI target).
    fn own_criteria_met(&self, plan: &ExperimentPlan) -> bool {
        let st = &plan.stats;
        let n = self.walls.len() as u32;
        if n < st.min_runs {
            return false;
        }
        if st.fixed() || n >= st.max_runs || self.timed_s >= st.budget_s {
            return true;
        }
        // The summary's own seed, so a configuration stopped here shows the same interval there.
        let seed = super::summary::seed_of(&self.config.id);
        n >= MIN_ADAPTIVE_RUNS && relative_half_width(&self.walls, seed) <= st.ci_target
    }
}

/// The fewest samples whose bootstrap interval the stopping rule trusts: with fewer, the
/// percentile interval of a median is the whole sample range or a single value.
pub const MIN_ADAPTIVE_RUNS: u32 = 5;

/// The most renders inside one timed sample.
pub const MAX_INNER: u32 = 1000;

/// What this launch measures.
pub(super) struct Todo<'p> {
    states: Vec<ConfigState<'p>>,
    /// Configurations that belong to other `mpirun` launches.
    pub(super) other_launches: usize,
}

impl<'p> Todo<'p> {
    pub(super) fn of(
        plan: &'p ExperimentPlan,
        old_rows: &[RunRow],
        launch: Option<&Launch>,
    ) -> Self {
        let mine = |c: &&RunConfig| c.in_launch(launch);
        let other_launches = plan.configs.iter().filter(|c| !mine(c)).count();
        let mut by_id: HashMap<&str, Vec<&RunRow>> = HashMap::new();
        for r in old_rows {
            by_id.entry(r.config.as_str()).or_default().push(r);
        }
        let states = plan
            .configs
            .iter()
            .filter(mine)
            .map(|c| {
                let mut rows = by_id.remove(c.id.as_str()).unwrap_or_default();
                rows.sort_by_key(|r| r.repetition);
                ConfigState {
                    config: c,
                    walls: rows.iter().map(|r| r.wall_s).collect(),
                    next_rep: rows.last().map_or(0, |r| r.repetition + 1),
                    timed_s: rows.iter().map(|r| r.wall_s * f64::from(r.inner)).sum(),
                    inner: rows.first().map(|r| r.inner),
                    done: false,
                }
            })
            .collect();
        Self {
            states,
            other_launches,
        }
    }

    /// Mark what is done: a configuration by its own criteria, a serial baseline once every
    /// configuration compared with it is done too (or its runs are spent).
    pub(super) fn update_done(&mut self, plan: &ExperimentPlan) {
        for s in &mut self.states {
            s.done = s.own_criteria_met(plan);
        }
        let open: Vec<usize> = self
            .states
            .iter()
            .filter(|s| s.config.spec.is_some() && !s.done)
            .map(|s| s.config.baseline)
            .collect();
        for s in &mut self.states {
            if s.config.spec.is_none()
                && s.done
                && open.contains(&s.config.baseline)
                && (s.walls.len() as u32) < plan.stats.max_runs
            {
                s.done = false;
            }
        }
    }

    /// This round's samples: the open baselines, then the open configurations, each shuffled.
    pub(super) fn round_order(&self, plan: &ExperimentPlan, round: u64) -> Vec<usize> {
        let open = |serial: bool| -> Vec<usize> {
            self.states
                .iter()
                .enumerate()
                .filter(|(_, s)| !s.done && s.config.spec.is_none() == serial)
                .map(|(i, _)| i)
                .collect()
        };
        let seed = plan.stats.seed ^ round.wrapping_mul(0x9e37_79b9_7f4a_7c15);
        let (mut a, mut b) = (open(true), open(false));
        shuffle(&mut a, seed);
        shuffle(&mut b, seed.rotate_left(17));
        a.extend(b);
        a
    }

    /// The most samples still to come (every open configuration up to its run cap).
    pub(super) fn upper_bound_now(&self, plan: &ExperimentPlan) -> u64 {
        self.states
            .iter()
            .filter(|s| match s.config.spec {
                Some(_) => !s.own_criteria_met(plan),
                None => !s.done,
            })
            .map(|s| u64::from(plan.stats.max_runs.saturating_sub(s.walls.len() as u32)))
            .sum()
    }

    fn upper_bound(&self, plan: &ExperimentPlan) -> u64 {
        self.upper_bound_now(plan)
    }
}

/// The measurement loop's state: where rows go and what has been seen.
struct Session<'p, 'r> {
    plan: &'p ExperimentPlan,
    dir: PathBuf,
    runs: RunsFile,
    serial: HashMap<usize, SerialInfo>,
    progress: Progress,
    remote: Option<&'r mut dyn Remote>,
    mismatches: usize,
    measured: usize,
    untimed: usize,
    /// The cost model's prediction per configuration id (`predict = true`).
    predictions: HashMap<String, Prediction>,
    /// This round's machine-speed probe, seconds.
    probe_s: Option<f64>,
    /// This process measures one round for a parent ([`super::isolate`]).
    child: bool,
}

/// The probe's samples per pixel: a few, scaled to the configuration's (see `model::probe`).
const PROBE_SPP: u32 = 4;

/// Configurations sharing one probe: (baseline, workers), their specs and their ids.
type ProbeGroup<'a> = ((usize, usize), Vec<&'a SchedulerSpec>, Vec<&'a str>);

/// The cost model's prediction for every local thread-scheduler configuration of `plan` not
/// yet done: one probe per (scene, tracer, workers), every configuration predicted from it.
/// Animations are not probed (the probe times one frame).
pub(super) fn predictions(
    plan: &ExperimentPlan,
    todo: &Todo<'_>,
) -> Result<HashMap<String, Prediction>, RunError> {
    let mut out = HashMap::new();
    let mut groups: Vec<ProbeGroup<'_>> = Vec::new();
    for st in todo.states.iter().filter(|s| !s.done) {
        let c = st.config;
        let (Some(spec), Sources::Local(setup)) = (&c.spec, &c.sources) else {
            continue;
        };
        if setup.set != crate::sched::SourceSet::threads() {
            continue; // the cost model knows threads only
        }
        if plan.scene_of(c).scene.frames() > 1 {
            continue;
        }
        let key = (c.baseline, spec.workers);
        match groups.iter_mut().find(|g| g.0 == key) {
            Some(g) => {
                g.1.push(spec);
                g.2.push(&c.id);
            }
            None => groups.push((key, vec![spec], vec![&c.id])),
        }
    }
    for ((baseline, workers), specs, ids) in groups {
        let b = &plan.baselines[baseline];
        let full = &plan.scenes[b.scene].scene;
        let spp = full.settings.spp;
        let mut low = (**full).clone();
        low.settings.spp = spp.min(PROBE_SPP);
        let low = std::sync::Arc::new(low);
        let policies: Vec<_> = specs.iter().map(|s| s.policy).collect();
        let probed = Probed::measure(&low, &b.tracer, workers, &policies).map_err(|source| {
            RunError::Sched {
                config: format!("cost-model probe of {} ×{workers}", full.name),
                source,
            }
        })?;
        for (spec, id) in specs.iter().zip(ids) {
            out.insert(id.to_string(), probed.predict(spec, spp));
        }
    }
    Ok(out)
}

/// A configuration's label for the progress line.
fn label_of(plan: &ExperimentPlan, c: &RunConfig) -> String {
    let label = c
        .spec
        .as_ref()
        .map_or(super::results::SERIAL.to_string(), |s| match &c.sources {
            Sources::Local(setup) => format!("{}{} ×{}", s.label(), setup.label(), s.workers),
            Sources::Mpi { transport } => {
                format!("{} over {} ranks ({transport})", s.label(), s.workers)
            }
        });
    let b = &plan.baselines[c.baseline];
    format!(
        "{} · {} · {label}",
        plan.scene_of(c).scene.name,
        b.tracer_id
    )
}

impl Session<'_, '_> {
    /// A round's process starts cold (page faults on its first buffers, empty caches): one
    /// untimed render of the round's first configuration, unless that one's own warm-ups come
    /// first anyway.
    fn warm_process(&mut self, first: &ConfigState<'_>) -> Result<(), RunError> {
        if first.inner.is_none() && self.plan.warmup > 0 {
            return Ok(());
        }
        measure(self.plan, first.config, false, &mut self.remote)?;
        self.untimed += 1;
        Ok(())
    }

    /// One timed sample of `st` (its warm-ups first when it has none yet), appended.
    fn sample(&mut self, st: &mut ConfigState<'_>) -> Result<(), RunError> {
        let plan = self.plan;
        let c = st.config;
        self.progress.set_message(label_of(plan, c));
        let inner = match st.inner {
            Some(k) => k,
            None => {
                let mut last = None;
                for _ in 0..plan.warmup {
                    last = Some(measure(plan, c, false, &mut self.remote)?.1.wall_s);
                    self.untimed += 1;
                }
                let k = if plan.stats.min_sample_s > 0.0 {
                    let t = match last {
                        Some(t) => t,
                        None => {
                            self.untimed += 1;
                            measure(plan, c, false, &mut self.remote)?.1.wall_s
                        }
                    };
                    inner_count(t, plan.stats.min_sample_s)
                } else {
                    1
                };
                st.inner = Some(k);
                k
            }
        };
        let rep = st.next_rep;
        let want_timeline = plan.timeline && rep == 0 && c.spec.is_some();
        let load_before = crate::util::host::load_average().map(|l| l[0]);
        let cpu0 = crate::util::cpu_time::process_cpu_s();
        let timestamp = meta::now_utc();
        let mut total = 0.0;
        let mut first_hash = None;
        let mut same = true;
        let mut last = None;
        let mut timeline = None;
        for k in 0..inner {
            let (image, mut stats) = measure(plan, c, want_timeline && k == 0, &mut self.remote)?;
            if k == 0 {
                // The first render's timeline: the row keeps the last render's stats.
                timeline = stats.timeline.take();
            }
            total += stats.wall_s;
            let h = image.hash();
            same &= *first_hash.get_or_insert(h) == h;
            last = Some((image, stats));
        }
        let cpu1 = crate::util::cpu_time::process_cpu_s();
        let (image, mut stats) = last.expect("inner ≥ 1");
        stats.wall_s = total / f64::from(inner);
        stats.timeline = timeline;
        let sample = Sample {
            rep,
            inner,
            timestamp,
            cpu: cpu0.zip(cpu1).map(|(a, b)| (b.0 - a.0, b.1 - a.1)),
            load: (load_before, crate::util::host::load_average().map(|l| l[0])),
            same,
        };
        self.record(c, &sample, &image, &stats)?;
        st.walls.push(stats.wall_s);
        st.timed_s += total;
        st.next_rep += 1;
        self.measured += 1;
        self.progress.inc();
        if self.child {
            println!("{}", sample_line(&label_of(plan, c)));
        }
        Ok(())
    }

    /// One measured sample: its row (compared with the serial image), its timeline, and for
    /// the serial baseline's first repetition its image.
    fn record(
        &mut self,
        c: &RunConfig,
        sample: &Sample,
        image: &Image,
        stats: &RunStats,
    ) -> Result<(), RunError> {
        let plan = self.plan;
        let rep = sample.rep;
        let hash = hex(image.hash());
        let mut row = RunRow::for_config(plan, c);
        row.repetition = rep;
        row.set_stats(stats);
        row.image_hash = hash.clone();
        row.inner = sample.inner;
        row.timestamp = sample.timestamp.clone();
        row.user_s = sample.cpu.map(|c| c.0);
        row.sys_s = sample.cpu.map(|c| c.1);
        row.load_before = sample.load.0;
        row.load_after = sample.load.1;
        row.probe_s = self.probe_s;
        row.process = Some(std::process::id());
        if let Some(p) = self.predictions.get(&c.id) {
            row.predicted_wall_s = Some(p.wall_s);
            row.predicted_handout_s = Some(p.handout_s);
            row.predicted_refill_s = Some(p.refill_s);
            row.predicted_imbalance_s = Some(p.imbalance_s);
        }
        let serial_image = serial_image_path(&self.dir, plan, c);
        let info = self.serial.entry(c.baseline).or_default();
        match &c.spec {
            None => {
                if info.hash.is_none() {
                    // The image goes first: a row on disk implies its image is too.
                    image
                        .save_with_preview(&serial_image)
                        .map_err(|e| io_err(&serial_image, e))?;
                    info.hash = Some(hash.clone());
                    if plan.gpu.is_some() {
                        info.image = Some(image.clone());
                    }
                }
                info.walls.push(stats.wall_s);
                row.serial_s = stats.wall_s;
            }
            Some(_) => row.serial_s = median(&info.walls),
        }
        row.identical = sample.same && info.hash.as_deref() == Some(hash.as_str());
        if c.sources.has_gpu() {
            if info.image.is_none() {
                // Resumed: the baseline's image is on disk since its first row.
                let img = Image::load_exr(&serial_image).map_err(|e| io_err(&serial_image, e))?;
                info.image = Some(img);
            }
            let check = super::image_check::compare(image, info.image.as_ref().expect("just set"));
            row.image_z = Some(check.z);
            row.agrees = Some(check.agrees);
        }
        let w = row.workers as f64;
        row.speedup = row.serial_s / row.wall_s;
        row.efficiency = row.speedup / w;
        row.overhead_s = w * row.wall_s - row.serial_s;
        if let Some(t) = &stats.timeline {
            write_atomic(
                &timeline_path(&self.dir, &c.id),
                timeline_text(t, stats).as_bytes(),
            )?;
        }
        if !row.identical && row.agrees != Some(true) {
            self.mismatches += 1;
            let serial = info.hash.as_deref().unwrap_or("?");
            let msg = match row.image_z {
                Some(z) => format!(
                    "IMAGE MISMATCH: {} rep {rep}: mean difference to serial {serial} is {z:+.1}σ (beyond 3σ)",
                    row.label
                ),
                None => format!(
                    "IMAGE MISMATCH: {} rep {rep}: hash {} ≠ serial {serial}",
                    row.label, row.image_hash
                ),
            };
            self.progress.println(&msg);
        }
        self.runs.append(&row).map_err(RunError::from)
    }
}

/// Where the serial image of `c`'s baseline is: `images/serial_<scene>_<baseline config>.exr`.
fn serial_image_path(dir: &Path, plan: &ExperimentPlan, c: &RunConfig) -> PathBuf {
    let id = plan
        .configs
        .iter()
        .find(|b| b.spec.is_none() && b.baseline == c.baseline)
        .map_or(c.id.as_str(), |b| b.id.as_str());
    let name = &plan.scene_of(c).scene.name;
    // `with_extension`, as the images were always named: a scene name with a dot loses its tail.
    dir.join("images")
        .join(format!("serial_{}_{id}", slug(name)))
        .with_extension("exr")
}

/// A timeline file: one `worker,item,start_ns,end_ns,source` line per span, `source` being
/// the worker's kind of source (`threads`, `gpu`, …; `master` on the master's lane), so the
/// Gantt chart groups its lanes by kind.
pub fn timeline_text(spans: &[crate::core::metrics::Span], stats: &RunStats) -> String {
    let mut text = String::from("worker,item,start_ns,end_ns,source\n");
    for s in spans {
        let source = if s.worker == crate::core::metrics::MASTER_LANE {
            "master"
        } else {
            stats
                .workers
                .get(s.worker as usize)
                .and_then(|w| w.source)
                .map_or("", |k| k.id())
        };
        text += &format!(
            "{},{},{},{},{source}\n",
            s.worker, s.item, s.start_ns, s.end_ns
        );
    }
    text
}

/// What one timed sample recorded besides its renders.
struct Sample {
    rep: u32,
    inner: u32,
    timestamp: String,
    /// (user, system) CPU seconds of the process during the sample.
    cpu: Option<(f64, f64)>,
    /// 1-minute load average before and after.
    load: (Option<f64>, Option<f64>),
    /// Every render of the sample gave the same image.
    same: bool,
}

/// Renders per timed sample for a render of `t` seconds: enough to fill `min_sample_s`.
pub fn inner_count(t: f64, min_sample_s: f64) -> u32 {
    if t.is_nan() || t <= 0.0 || t >= min_sample_s {
        return 1;
    }
    ((min_sample_s / t).ceil() as u32).clamp(1, MAX_INNER)
}

/// One timed run. Only the render is inside the timed section (scenes and tracers were built by
/// the plan).
fn measure(
    plan: &ExperimentPlan,
    c: &RunConfig,
    timeline: bool,
    remote: &mut Option<&mut dyn Remote>,
) -> Result<(Image, RunStats), RunError> {
    let b = &plan.baselines[c.baseline];
    let scene = &plan.scene_of(c).scene;
    match &c.spec {
        None => {
            let t0 = Instant::now();
            let (image, counters) = render_serial(scene.as_ref(), b.tracer.as_ref());
            let wall_s = t0.elapsed().as_secs_f64();
            let rows = scene.height() as u64 * scene.frames() as u64; // render_serial's items
            let stats = RunStats {
                wall_s,
                workers: vec![WorkerStats {
                    busy_s: wall_s,
                    idle_s: 0.0,
                    items: rows,
                    pixels: scene.pixel_count() as u64 * scene.frames() as u64,
                    rays: counters.rays,
                    source: Some(crate::core::metrics::SourceKind::Threads),
                }],
                items: rows,
                issued: rows,
                rays: counters.rays,
                nonfinite: counters.nonfinite,
                ..Default::default()
            };
            let (used, left_out) = scene.feature_report(b.tracer.accelerated());
            Ok((
                image,
                RunStats {
                    features_used: used,
                    features_left_out: left_out,
                    ..stats
                },
            ))
        }
        Some(spec) if c.sources.has_gpu() => {
            let mut spec = spec.clone();
            spec.timeline = timeline;
            measure_gpu(plan, c, &spec)
        }
        Some(spec) if c.sources != Sources::threads() => {
            let mut spec = spec.clone();
            spec.timeline = timeline;
            let r = remote.as_deref_mut().ok_or_else(|| {
                RunError::Mpi(format!(
                    "{}: MPI configuration outside an mpirun launch",
                    c.id
                ))
            })?;
            r.measure(plan, c, &spec)
        }
        Some(spec) => {
            let mut spec = spec.clone();
            spec.timeline = timeline;
            render_scene(
                &spec,
                scene,
                &b.tracer,
                &RenderOn::threads(),
                &crate::sched::RunOptions::default(),
            )
            .map(|(frames, stats)| (Image::stack(frames), stats))
            .map_err(|source| RunError::Sched {
                config: format!("{} {}", c.id, spec.label()),
                source,
            })
        }
    }
}

/// One timed run of a configuration with a GPU source, on the plan's device.
#[cfg(feature = "gpu")]
fn measure_gpu(
    plan: &ExperimentPlan,
    c: &RunConfig,
    spec: &SchedulerSpec,
) -> Result<(Image, RunStats), RunError> {
    let b = &plan.baselines[c.baseline];
    let scene = &plan.scene_of(c).scene;
    let (Sources::Local(setup), Some(gpu)) = (&c.sources, &plan.gpu) else {
        return Err(RunError::Refused(format!(
            "{}: a GPU configuration without the plan's GPU",
            c.id
        )));
    };
    let renderer = gpu.renderers[b.scene].clone();
    let on = RenderOn {
        setup,
        gpu: Some(renderer),
    };
    render_scene(
        spec,
        scene,
        &b.tracer,
        &on,
        &crate::sched::RunOptions::default(),
    )
    .map(|(frames, stats)| (Image::stack(frames), stats))
    .map_err(|source| RunError::Sched {
        config: format!("{} {}{}", c.id, spec.label(), setup.label()),
        source,
    })
}

/// Without feature `gpu` no configuration has a GPU source ([`crate::sched::SourceSet::new`]).
#[cfg(not(feature = "gpu"))]
fn measure_gpu(
    _plan: &ExperimentPlan,
    c: &RunConfig,
    _spec: &SchedulerSpec,
) -> Result<(Image, RunStats), RunError> {
    Err(RunError::Refused(format!(
        "{}: a GPU configuration in a build without feature `gpu`",
        c.id
    )))
}

/// A round's process's line after each sample: the prefix, then the configuration's label
/// (`isolate` reads it).
pub(super) const SAMPLE: &str = "sample\t";

/// A child's line for one sample of the configuration labelled `label`.
fn sample_line(label: &str) -> String {
    format!("{SAMPLE}{label}")
}

/// The cost model's predictions, computed once by the parent for every child to record.
pub(super) fn predictions_path(dir: &Path) -> PathBuf {
    dir.join(".predictions.json")
}

/// The predictions the parent left for the children (none when the plan records none).
fn read_predictions(
    plan: &ExperimentPlan,
    dir: &Path,
) -> Result<HashMap<String, Prediction>, RunError> {
    if !plan.predict {
        return Ok(HashMap::new());
    }
    let path = predictions_path(dir);
    let text = std::fs::read_to_string(&path).map_err(|e| io_err(&path, e))?;
    serde_json::from_str(&text).map_err(|e| io_err(&path, e))
}
