//! The measurement loop: serial baselines first, then every configuration × repetition not yet
//! in `runs.csv`, each row appended whole as soon as it is measured.

use super::meta::{self, Meta};
use super::plan::{ExperimentPlan, Launch, RunConfig, Sources};
use super::results::{ResultsError, RunRow, RunsFile};
use super::summary::median;
use crate::hash::hex;
use crate::metrics::{RunStats, WorkerStats};
use crate::render::{render_serial, Image};
use crate::sched::{run_scheduler, SchedError, SchedulerSpec};
use crate::tracer::Tracer;
use indicatif::{ProgressBar, ProgressStyle};
use std::collections::HashMap;
use std::io::Write;
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
}

/// What a run did.
#[derive(Debug)]
pub struct RunOutcome {
    /// The experiment's results folder, `out/<name>/`.
    pub dir: PathBuf,
    /// Repetitions measured by this run.
    pub measured: usize,
    /// Repetitions of this launch already in runs.csv, not measured again.
    pub skipped: usize,
    /// Rows (old and new) whose image differs from the serial baseline's.
    pub mismatches: usize,
    /// Configurations × repetitions that belong to other `mpirun` launches (not measured here).
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
}

fn io_err(path: &Path, e: impl std::fmt::Display) -> RunError {
    RunError::Io {
        path: path.display().to_string(),
        msg: e.to_string(),
    }
}

/// Write via a temporary file and a rename, so a kill never leaves a half-written file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), RunError> {
    let tmp = path.with_extension("tmp");
    let mut f = std::fs::File::create(&tmp).map_err(|e| io_err(&tmp, e))?;
    f.write_all(bytes).map_err(|e| io_err(&tmp, e))?;
    drop(f);
    std::fs::rename(&tmp, path).map_err(|e| io_err(path, e))
}

/// Where configuration `config`'s Gantt timeline goes: `dir/timelines/<config>.csv`.
pub fn timeline_path(dir: &Path, config: &str) -> PathBuf {
    dir.join("timelines").join(format!("{config}.csv"))
}

/// Check (or start) `meta.toml`: an existing one must carry this experiment file's hash.
fn prepare_meta(plan: &ExperimentPlan, dir: &Path, fresh: bool) -> Result<(), RunError> {
    let path = dir.join("meta.toml");
    let runs = dir.join("runs.csv");
    let mut meta = meta::collect(plan);
    if !fresh && runs.exists() {
        let old: Option<Meta> = std::fs::read_to_string(&path)
            .ok()
            .and_then(|t| toml::from_str(&t).ok());
        match old {
            None => {
                return Err(RunError::Refused(format!(
                    "{}: missing or unreadable beside {}; rerun with --fresh to start over",
                    path.display(),
                    runs.display()
                )))
            }
            Some(old) if old.experiment_hash != plan.file_hash => {
                return Err(RunError::Refused(format!(
                    "{}: changed since {} was started (hash {} → {}); rerun with --fresh to start over",
                    plan.file.display(),
                    runs.display(),
                    old.experiment_hash,
                    plan.file_hash
                )))
            }
            Some(old) => {
                meta.started = old.started;
                meta.resumed = Some(meta::now_utc());
            }
        }
    }
    let text = toml::to_string(&meta).map_err(|e| io_err(&path, e))?;
    write_atomic(&path, text.as_bytes())
}

/// What the serial baseline of one (scene, tracer) measured so far.
#[derive(Default)]
struct SerialInfo {
    walls: Vec<f64>,
    hash: Option<String>,
}

/// Measure every configuration × repetition of `plan` not yet in `out/<name>/runs.csv`,
/// outside any `mpirun` launch: configurations of an `[mpi]` launch are left out.
pub fn run_experiment(plan: &ExperimentPlan, opts: &RunOptions) -> Result<RunOutcome, RunError> {
    run_experiment_with(plan, opts, None)
}

/// [`run_experiment`] inside an `mpirun` launch: `remote` measures the MPI rows of its launch;
/// configurations of other launches are left for them (their rows may already be in runs.csv).
pub fn run_experiment_with(
    plan: &ExperimentPlan,
    opts: &RunOptions,
    remote: Option<&mut dyn Remote>,
) -> Result<RunOutcome, RunError> {
    let launch = remote.as_ref().map(|r| r.launch().clone());
    let dir = opts.out.join(&plan.name);
    let _lock = super::lock::ResultsLock::acquire(&dir)?;
    prepare_dir(plan, &dir, opts.fresh)?;
    prepare_meta(plan, &dir, opts.fresh)?;
    let (runs, old_rows) = RunsFile::open(&dir.join("runs.csv"), opts.fresh)?;
    let serial = check_old_rows(plan, &runs, &old_rows)?;
    let todo = Todo::of(plan, &runs, launch.as_ref());
    let mut session = Session {
        plan,
        dir,
        runs,
        serial,
        bar: progress_bar(opts.quiet, todo.total_runs(plan)),
        remote,
        mismatches: old_rows.iter().filter(|r| !r.identical).count(),
        measured: 0,
    };
    for (c, reps) in &todo.pending {
        session.run_config(c, reps)?;
    }
    session.bar.finish_and_clear();
    Ok(RunOutcome {
        dir: session.dir,
        measured: session.measured,
        skipped: todo.skipped,
        mismatches: session.mismatches,
        other_launches: todo.other_launches,
    })
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

/// Resume: old rows must belong to this plan's scenes as they are now. Returns what the serial
/// baselines measured so far.
fn check_old_rows(
    plan: &ExperimentPlan,
    runs: &RunsFile,
    old_rows: &[RunRow],
) -> Result<HashMap<usize, SerialInfo>, RunError> {
    let by_id: HashMap<&str, &RunConfig> =
        plan.configs.iter().map(|c| (c.id.as_str(), c)).collect();
    let mut serial: HashMap<usize, SerialInfo> = HashMap::new();
    for r in old_rows {
        let Some(c) = by_id.get(r.config.as_str()) else {
            return Err(RunError::Refused(format!(
                "{}: row for config {} is not in this experiment; rerun with --fresh",
                runs.path.display(),
                r.config
            )));
        };
        let now = hex(plan.scene_of(c).scene.hash);
        if r.scene_hash != now {
            return Err(RunError::Refused(format!(
                "{}: scene {} changed since these rows were measured (hash {} → {now}); rerun with --fresh",
                runs.path.display(),
                r.scene_file,
                r.scene_hash
            )));
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

/// What this launch still has to measure.
struct Todo<'p> {
    /// Each configuration with the repetitions not yet in runs.csv.
    pending: Vec<(&'p RunConfig, Vec<u32>)>,
    /// Configurations × repetitions that belong to other `mpirun` launches.
    other_launches: usize,
    /// Repetitions of this launch already in runs.csv.
    skipped: usize,
}

impl<'p> Todo<'p> {
    fn of(plan: &'p ExperimentPlan, runs: &RunsFile, launch: Option<&Launch>) -> Self {
        let mine = |c: &&RunConfig| c.in_launch(launch);
        let other_launches =
            plan.configs.iter().filter(|c| !mine(c)).count() * plan.repetitions as usize;
        let pending: Vec<(&RunConfig, Vec<u32>)> = plan
            .configs
            .iter()
            .filter(mine)
            .map(|c| {
                let reps = (0..plan.repetitions)
                    .filter(|&k| !runs.is_done(&c.id, k))
                    .collect();
                (c, reps)
            })
            .filter(|(_, reps): &(_, Vec<u32>)| !reps.is_empty())
            .collect();
        let skipped = plan.configs.len() * plan.repetitions as usize
            - other_launches
            - pending.iter().map(|(_, r)| r.len()).sum::<usize>();
        Self {
            pending,
            other_launches,
            skipped,
        }
    }

    /// Runs to make, warm-ups included (the progress bar's length).
    fn total_runs(&self, plan: &ExperimentPlan) -> u64 {
        self.pending
            .iter()
            .map(|(_, reps)| (plan.warmup as usize + reps.len()) as u64)
            .sum()
    }
}

fn progress_bar(quiet: bool, total: u64) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::new(total);
    b.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} runs, ETA {eta} · {msg}")
            .expect("valid template"),
    );
    b
}

/// The measurement loop's state: where rows go and what has been seen.
struct Session<'p, 'r> {
    plan: &'p ExperimentPlan,
    dir: PathBuf,
    runs: RunsFile,
    serial: HashMap<usize, SerialInfo>,
    bar: ProgressBar,
    remote: Option<&'r mut dyn Remote>,
    mismatches: usize,
    measured: usize,
}

impl Session<'_, '_> {
    /// Warm-ups, then each repetition of `c` measured and appended.
    fn run_config(&mut self, c: &RunConfig, reps: &[u32]) -> Result<(), RunError> {
        let plan = self.plan;
        let label = c
            .spec
            .as_ref()
            .map_or("serial".to_string(), |s| match &c.sources {
                Sources::Local => format!("{} ×{}", s.label(), s.workers),
                Sources::Mpi { transport } => {
                    format!("{} over {} ranks ({transport})", s.label(), s.workers)
                }
            });
        let b = &plan.baselines[c.baseline];
        let scene = &plan.scene_of(c).scene;
        self.bar
            .set_message(format!("{} · {} · {label}", scene.name, b.tracer_id));
        for _ in 0..plan.warmup {
            measure(plan, c, false, &mut self.remote)?;
            self.bar.inc(1);
        }
        for &rep in reps {
            let want_timeline = plan.timeline && rep == 0 && c.spec.is_some();
            let (image, stats) = measure(plan, c, want_timeline, &mut self.remote)?;
            self.record(c, rep, &image, &stats)?;
            self.measured += 1;
            self.bar.inc(1);
        }
        Ok(())
    }

    /// One measured repetition: its row (compared with the serial image), its timeline, and
    /// for the serial baseline's first repetition its image.
    fn record(
        &mut self,
        c: &RunConfig,
        rep: u32,
        image: &Image,
        stats: &RunStats,
    ) -> Result<(), RunError> {
        let plan = self.plan;
        let hash = hex(image.hash());
        let mut row = RunRow::for_config(plan, c);
        row.repetition = rep;
        fill_stats(&mut row, stats);
        row.image_hash = hash.clone();
        let info = self.serial.entry(c.baseline).or_default();
        match &c.spec {
            None => {
                if rep == 0 {
                    // The image goes first: a row on disk implies its image is too.
                    let name = &plan.scene_of(c).scene.name;
                    let stem =
                        self.dir
                            .join("images")
                            .join(format!("serial_{}_{}", slug(name), c.id));
                    image
                        .save_with_preview(&stem.with_extension("exr"))
                        .map_err(|e| io_err(&stem, e))?;
                    info.hash = Some(hash.clone());
                }
                info.walls.push(stats.wall_s);
                row.serial_s = stats.wall_s;
            }
            Some(_) => row.serial_s = median(&info.walls),
        }
        row.identical = info.hash.as_deref() == Some(hash.as_str());
        let w = row.workers as f64;
        row.speedup = row.serial_s / row.wall_s;
        row.efficiency = row.speedup / w;
        row.overhead_s = w * row.wall_s - row.serial_s;
        if let Some(t) = &stats.timeline {
            let mut text = String::from("worker,item,start_ns,end_ns\n");
            for s in t {
                text += &format!("{},{},{},{}\n", s.worker, s.item, s.start_ns, s.end_ns);
            }
            write_atomic(&timeline_path(&self.dir, &c.id), text.as_bytes())?;
        }
        if !row.identical {
            self.mismatches += 1;
            let serial = info.hash.as_deref().unwrap_or("?");
            self.bar.suspend(|| {
                eprintln!(
                    "IMAGE MISMATCH: {} rep {rep}: hash {} ≠ serial {serial}",
                    row.label, row.image_hash
                )
            });
        }
        self.runs.append(&row).map_err(RunError::from)
    }
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
        Some(spec) if c.sources != Sources::Local => {
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
            run_scheduler(&spec, scene, &b.tracer).map_err(|source| RunError::Sched {
                config: format!("{} {}", c.id, spec.label()),
                source,
            })
        }
    }
}

fn fill_stats(row: &mut RunRow, s: &RunStats) {
    row.wall_s = s.wall_s;
    row.work_s = s.busy_s();
    row.dispatch_s = s.dispatch_s();
    row.idle_s = s.idle_s();
    row.imbalance = s.imbalance();
    let max_busy = s.workers.iter().map(|w| w.busy_s).fold(0.0, f64::max);
    row.imbalance_s = s.workers.iter().map(|w| max_busy - w.busy_s).sum();
    row.items = s.items;
    row.issued = s.issued;
    row.reissued = s.reissued;
    row.duplicates = s.duplicates;
    row.bytes = s.bytes;
    row.rays = s.rays;
    row.nonfinite = s.nonfinite;
    row.features_used = s.features_used.join("+");
    row.features_left_out = s.features_left_out.join("+");
}

/// A file-name-safe form of a label.
pub fn slug(s: &str) -> String {
    let mut out: String = s
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect();
    while out.contains("__") {
        out = out.replace("__", "_");
    }
    out.trim_matches('_').to_string()
}
