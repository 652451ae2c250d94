//! Stage two: the validated plan. Every scene is loaded, every tracer built, every id resolved
//! and every value range-checked here, before any timing starts; errors name the experiment
//! file and the field (`experiments/x.toml: schedulers[1].buffer: …`).

use super::config::{
    ExperimentFile, ExperimentKind, MpiEntry, OneOrMany, SchedulerEntry, WorkerCount, WorkersSpec,
};
use crate::hash::{fnv, hex};
use crate::scene::{load_scene, Scene, SceneOverrides};
use crate::sched::{Chunk, Order, Requeue, SchedulerKind, SchedulerSpec, Wait};
use crate::tracer::{AnyTracer, TracerKind};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// A bad experiment file: `file: field: message`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{path}: {field}{}{msg}", if field.is_empty() { "" } else { ": " })]
pub struct ConfigError {
    pub path: String,
    pub field: String,
    pub msg: String,
}

/// A scene loaded with its overrides (the load time is recorded, never timed with a run).
pub struct PlannedScene {
    /// The path as written in the experiment file.
    pub file: String,
    pub overrides: SceneOverrides,
    pub scene: Arc<Scene>,
    pub load_s: f64,
}

/// One (scene, tracer) pair: the unit a serial baseline is measured for.
pub struct Baseline {
    pub scene: usize,
    pub tracer_id: String,
    pub tracer: Arc<AnyTracer>,
    pub build_s: f64,
}

/// Who renders a configuration's items.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Sources {
    /// Threads of this process.
    Local,
    /// MPI ranks 1…K−1 of an `mpirun -n K` launch whose transport has this name.
    Mpi { transport: String },
}

impl Sources {
    pub fn id(&self) -> &'static str {
        match self {
            Self::Local => "local",
            Self::Mpi { .. } => "mpi",
        }
    }
}

/// One `mpirun -n ranks` with one transport: the unit the MPI part of an experiment is
/// measured in (see [`RunConfig::in_launch`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Launch {
    pub ranks: usize,
    pub transport: String,
}

/// One configuration to time `repetitions` times.
#[derive(Clone, Debug)]
pub struct RunConfig {
    /// Stable id (16 hex digits) of every config column: the resume key with the repetition.
    pub id: String,
    pub baseline: usize,
    /// `None` = the serial baseline (one thread, no scheduler).
    pub spec: Option<SchedulerSpec>,
    pub sources: Sources,
    /// The launch size an MPI row or its local-thread baseline belongs to (`None` elsewhere).
    pub ranks: Option<usize>,
}

impl RunConfig {
    /// Is this configuration measured by `launch` (`None`: a run without mpirun)? Serial
    /// baselines belong to every launch (the first one measures them); the local-thread
    /// baseline of K ranks to every launch of K ranks; an MPI row to its own launch only.
    pub fn in_launch(&self, launch: Option<&Launch>) -> bool {
        match (self.ranks, launch) {
            (None, _) => true,
            (Some(_), None) => false,
            (Some(r), Some(l)) => {
                r == l.ranks
                    && match &self.sources {
                        Sources::Local => true,
                        Sources::Mpi { transport } => *transport == l.transport,
                    }
            }
        }
    }
}

/// The validated `[mpi]` table.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MpiSettings {
    /// Total ranks per launch (each ≥ 2).
    pub ranks: Vec<usize>,
    pub transports: Vec<String>,
    /// A rank with work outstanding that has sent nothing (not even a heartbeat) this long is
    /// lost.
    pub silence_ms: u64,
}

/// Default silence limit: 25 worker heartbeats (200 ms each) missed in a row. Heartbeats
/// come from a thread that does not render, so a slow item never looks like a dead rank.
pub const DEFAULT_SILENCE_MS: u64 = 5000;
/// The shortest silence limit accepted: 5 heartbeats.
pub const MIN_SILENCE_MS: u64 = 1000;

/// Scheduler kinds that can hand items to MPI ranks.
pub const MPI_KINDS: [SchedulerKind; 3] = [
    SchedulerKind::Master,
    SchedulerKind::Static,
    SchedulerKind::SelfScheduling,
];

pub struct ExperimentPlan {
    pub name: String,
    pub description: String,
    pub file: PathBuf,
    /// FNV-1a of the experiment file's bytes, 16 hex digits.
    pub file_hash: String,
    pub repetitions: u32,
    pub warmup: u32,
    pub timeline: bool,
    pub scenes: Vec<PlannedScene>,
    pub baselines: Vec<Baseline>,
    /// Serial baselines first, so a scheduler run always finds its baseline measured.
    pub configs: Vec<RunConfig>,
    /// `Some` for a convergence experiment: each `configs` entry with a scheduler is one
    /// progressive run under it; a baseline without any is rendered on a row-parallel pool.
    pub convergence: Option<ConvergenceSettings>,
    /// The largest worker count: the thread budget of tracer builds and convergence renders.
    pub max_workers: usize,
    /// `Some` when the experiment runs under `mpirun` (`[mpi]`).
    pub mpi: Option<MpiSettings>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ConvergenceSettings {
    pub max_spp: u32,
    pub ref_spp: u32,
}

impl ExperimentPlan {
    pub fn scene_of(&self, c: &RunConfig) -> &PlannedScene {
        &self.scenes[self.baselines[c.baseline].scene]
    }
}

/// Parse and validate an experiment file, load its scenes and build its tracers.
pub fn load_plan(path: &Path) -> Result<ExperimentPlan, ConfigError> {
    let display = path.display().to_string();
    let err = |field: &str, msg: String| ConfigError {
        path: display.clone(),
        field: field.to_string(),
        msg,
    };
    let bytes =
        std::fs::read(path).map_err(|e| err("", format!("cannot read experiment file: {e}")))?;
    let text = String::from_utf8(bytes.clone()).map_err(|_| err("", "not UTF-8 text".into()))?;
    let file: ExperimentFile = toml::from_str(&text).map_err(|e| {
        let line = e
            .span()
            .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
        err(
            &line.map(|l| format!("line {l}")).unwrap_or_default(),
            e.message().to_string(),
        )
    })?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let name = match &file.name {
        Some(n) => n.clone(),
        None => path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "experiment".into()),
    };
    if name.is_empty()
        || !name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
        || name.starts_with('.')
    {
        return Err(err(
            "name",
            format!("'{name}': use letters, digits, '-', '_' or '.' (it names the results folder)"),
        ));
    }
    if file.repetitions == 0 {
        return Err(err("repetitions", "must be ≥ 1 (got 0)".into()));
    }
    let mpi = match &file.mpi {
        None => None,
        Some(m) => Some(validate_mpi(m, &file).map_err(|(f, msg)| err(&f, msg))?),
    };
    let workers = match (&file.workers, &mpi) {
        (Some(_), Some(_)) => {
            return Err(err(
                "workers",
                "set by mpi.ranks under [mpi] (ranks − 1 per launch); remove it".into(),
            ))
        }
        (None, Some(m)) => m.ranks.iter().map(|r| r - 1).collect(),
        (Some(w), None) => expand_workers(w).map_err(|m| err("workers", m))?,
        (None, None) => {
            return Err(err(
                "workers",
                "missing (e.g. workers = [1, 2] or \"1..max\")".into(),
            ))
        }
    };
    if file.tracers.is_empty() {
        return Err(err("tracers", "must name at least one tracer".into()));
    }
    let tracer_kinds = file
        .tracers
        .iter()
        .enumerate()
        .map(|(i, t)| {
            TracerKind::from_id(t)
                .and_then(TracerKind::available)
                .map_err(|e| err(&format!("tracers[{i}]"), e.to_string()))
        })
        .collect::<Result<Vec<_>, _>>()?;
    if file.scenes.is_empty() {
        return Err(err(
            "scenes",
            "must list at least one scene ([[scenes]] path = …)".into(),
        ));
    }
    let convergence = match file.kind {
        ExperimentKind::Timing => {
            if file.schedulers.is_empty() {
                return Err(err(
                    "schedulers",
                    "must list at least one scheduler ([[schedulers]] kind = …)".into(),
                ));
            }
            for f in ["max_spp", "ref_spp"] {
                if (f == "max_spp" && file.max_spp.is_some())
                    || (f == "ref_spp" && file.ref_spp.is_some())
                {
                    return Err(err(f, "applies only to kind = \"convergence\"".into()));
                }
            }
            None
        }
        ExperimentKind::Convergence => {
            let max_spp = file
                .max_spp
                .ok_or_else(|| err("max_spp", "kind = \"convergence\" needs max_spp".into()))?;
            let ref_spp = file.ref_spp.unwrap_or(1024);
            for (f, v) in [("max_spp", max_spp), ("ref_spp", ref_spp)] {
                if v == 0 {
                    return Err(err(f, "must be ≥ 1 (got 0)".into()));
                }
            }
            Some(ConvergenceSettings { max_spp, ref_spp })
        }
    };
    // Expand every scheduler grid before the (slow) scene loading, so a typo fails fast.
    // A progressive run records no timeline: a Gantt chart per step would be noise.
    let timeline = file.timeline && convergence.is_none();
    let mut grids = Vec::new();
    for (i, s) in file.schedulers.iter().enumerate() {
        let field = |f: &str| format!("schedulers[{i}].{f}");
        grids.push(expand_scheduler(s, &workers, timeline).map_err(|(f, m)| err(&field(&f), m))?);
    }
    let max_workers = workers.iter().copied().max().unwrap_or(1);

    let mut scenes = Vec::new();
    for (i, s) in file.scenes.iter().enumerate() {
        let p = base.join(&s.path);
        let overrides = s.overrides();
        let t0 = Instant::now();
        let scene =
            load_scene(&p, &overrides).map_err(|e| err(&format!("scenes[{i}]"), e.to_string()))?;
        scenes.push(PlannedScene {
            file: s.path.clone(),
            overrides,
            scene: Arc::new(scene),
            load_s: t0.elapsed().as_secs_f64(),
        });
    }
    let mut baselines = Vec::new();
    for (si, sc) in scenes.iter().enumerate() {
        for (ti, (t, &kind)) in file.tracers.iter().zip(&tracer_kinds).enumerate() {
            let t0 = Instant::now();
            let tracer = AnyTracer::build(kind, &sc.scene, max_workers)
                .map_err(|e| err(&format!("tracers[{ti}]"), format!("scene {}: {e}", sc.file)))?;
            baselines.push(Baseline {
                scene: si,
                tracer_id: t.clone(),
                tracer: Arc::new(tracer),
                build_s: t0.elapsed().as_secs_f64(),
            });
        }
    }

    let mut configs = Vec::new();
    for (bi, _) in baselines.iter().enumerate() {
        configs.push(RunConfig {
            id: String::new(),
            baseline: bi,
            spec: None,
            sources: Sources::Local,
            ranks: None,
        });
    }
    for (bi, _) in baselines.iter().enumerate() {
        for grid in &grids {
            for spec in grid {
                let local = RunConfig {
                    id: String::new(),
                    baseline: bi,
                    spec: Some(spec.clone()),
                    sources: Sources::Local,
                    ranks: None,
                };
                let Some(m) = &mpi else {
                    configs.push(local);
                    continue;
                };
                // Under [mpi], spec.workers = ranks − 1: the local-thread baseline of that
                // launch size, then one row set per transport.
                let ranks = Some(spec.workers + 1);
                configs.push(RunConfig { ranks, ..local });
                for t in &m.transports {
                    configs.push(RunConfig {
                        id: String::new(),
                        baseline: bi,
                        spec: Some(spec.clone()),
                        sources: Sources::Mpi {
                            transport: t.clone(),
                        },
                        ranks,
                    });
                }
            }
        }
    }
    let mut plan = ExperimentPlan {
        name,
        description: file.description.clone(),
        file: path.to_path_buf(),
        file_hash: hex(fnv(&bytes)),
        repetitions: file.repetitions,
        warmup: file.warmup,
        timeline: file.timeline,
        scenes,
        baselines,
        configs,
        convergence,
        max_workers,
        mpi,
    };
    let mut seen = std::collections::HashSet::new();
    let mut unique = Vec::new();
    for mut c in std::mem::take(&mut plan.configs) {
        c.id = super::results::config_id(&plan, &c);
        // The same configuration listed twice (overlapping grids) is timed once.
        if seen.insert(c.id.clone()) {
            unique.push(c);
        }
    }
    plan.configs = unique;
    Ok(plan)
}

fn validate_mpi(m: &MpiEntry, file: &ExperimentFile) -> Result<MpiSettings, (String, String)> {
    let f = |field: &str, msg: String| (format!("mpi.{field}"), msg);
    if file.kind == ExperimentKind::Convergence {
        return Err((
            "mpi".into(),
            "a convergence experiment has no MPI part".into(),
        ));
    }
    let mut ranks = Vec::new();
    for r in m.ranks.values() {
        if !(2..=4096).contains(&r) {
            return Err(f(
                "ranks",
                format!(
                    "must be between 2 and 4096 (got {r}): rank 0 schedules, ranks 1…K−1 render"
                ),
            ));
        }
        ranks.push(r as usize);
    }
    if ranks.is_empty() {
        return Err(f("ranks", "must list at least one rank count".into()));
    }
    ranks.sort_unstable();
    ranks.dedup();
    if m.transports.is_empty() {
        return Err(f(
            "transports",
            "must list at least one transport (e.g. [\"shared_memory\", \"tcp_loopback\"])".into(),
        ));
    }
    for t in &m.transports {
        if t.is_empty()
            || !t
                .chars()
                .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
        {
            return Err(f(
                "transports",
                format!("'{t}': use lower-case letters, digits and '_'"),
            ));
        }
    }
    let silence_ms = match m.silence_ms {
        None => DEFAULT_SILENCE_MS,
        Some(v) if v >= MIN_SILENCE_MS as i64 => v as u64,
        Some(v) => {
            return Err(f(
                "silence_ms",
                format!("must be ≥ {MIN_SILENCE_MS} (5 heartbeats of 200 ms; got {v})"),
            ))
        }
    };
    for (i, s) in file.schedulers.iter().enumerate() {
        if let Ok(k) = SchedulerKind::from_id(&s.kind) {
            if !MPI_KINDS.contains(&k) {
                return Err((
                    format!("schedulers[{i}].kind"),
                    format!(
                        "'{}' cannot hand items to MPI ranks (use master, static or self_scheduling)",
                        k.id()
                    ),
                ));
            }
        }
    }
    let mut transports = m.transports.clone();
    transports.dedup();
    Ok(MpiSettings {
        ranks,
        transports,
        silence_ms,
    })
}

fn expand_workers(w: &WorkersSpec) -> Result<Vec<usize>, String> {
    let max = crate::host::available_threads() as i64;
    let word = |s: &str| -> Result<i64, String> {
        match s.trim() {
            "max" => Ok(max),
            t => t
                .parse::<i64>()
                .map_err(|_| format!("'{s}': expected a number or \"max\"")),
        }
    };
    let mut out: Vec<i64> = match w {
        WorkersSpec::One(n) => vec![*n],
        WorkersSpec::List(l) => l
            .iter()
            .map(|c| match c {
                WorkerCount::N(n) => Ok(*n),
                WorkerCount::Word(s) => word(s),
            })
            .collect::<Result<_, _>>()?,
        WorkersSpec::Range(r) => {
            let (a, b) = r.split_once("..").ok_or_else(|| {
                format!("'{r}': expected a list, a number or a range \"A..B\" (B may be max)")
            })?;
            let (a, b) = (word(a)?, word(b.trim_start_matches('='))?);
            if a > b {
                return Err(format!("'{r}': empty range ({a} > {b})"));
            }
            (a..=b).collect()
        }
    };
    if out.is_empty() {
        return Err("must list at least one worker count".into());
    }
    if let Some(bad) = out.iter().find(|&&n| !(1..=4096).contains(&n)) {
        return Err(format!("must be between 1 and 4096 (got {bad})"));
    }
    out.sort_unstable();
    out.dedup();
    Ok(out.into_iter().map(|n| n as usize).collect())
}

fn axis<T: Clone>(
    v: &Option<OneOrMany<T>>,
    default: T,
    name: &str,
) -> Result<Vec<T>, (String, String)> {
    match v {
        None => Ok(vec![default]),
        Some(v) => {
            let vals = v.values();
            if vals.is_empty() {
                Err((name.to_string(), "must not be an empty list".into()))
            } else {
                Ok(vals)
            }
        }
    }
}

fn positive(vals: Vec<i64>, name: &str) -> Result<Vec<usize>, (String, String)> {
    vals.into_iter()
        .map(|v| {
            if (1..=1 << 20).contains(&v) {
                Ok(v as usize)
            } else {
                Err((
                    name.to_string(),
                    format!("must be between 1 and 1048576 (got {v})"),
                ))
            }
        })
        .collect()
}

/// The cartesian product of one scheduler's grid and the worker counts. Parameters the kind
/// does not have are rejected rather than multiplied in.
fn expand_scheduler(
    s: &SchedulerEntry,
    workers: &[usize],
    timeline: bool,
) -> Result<Vec<SchedulerSpec>, (String, String)> {
    let kind = SchedulerKind::from_id(&s.kind).map_err(|e| ("kind".to_string(), e.msg))?;
    let not_for = |field: &str, present: bool, who: &str| -> Result<(), (String, String)> {
        if present {
            Err((
                field.to_string(),
                format!("'{}' has no {field} (only {who})", kind.id()),
            ))
        } else {
            Ok(())
        }
    };
    if !kind.has_master() {
        not_for("buffer", s.buffer.is_some(), "master has one")?;
        not_for("requeue", s.requeue.is_some(), "master re-queues")?;
        not_for("wait", s.wait.is_some(), "master waits")?;
    }
    let grabs = matches!(
        kind,
        SchedulerKind::SelfScheduling | SchedulerKind::Guided | SchedulerKind::WorkStealing
    );
    if !grabs {
        not_for(
            "grab",
            s.grab.is_some(),
            "self_scheduling, guided and work_stealing grab",
        )?;
    }
    if kind != SchedulerKind::Guided {
        not_for("guided_k", s.guided_k.is_some(), "guided has one")?;
    }
    let chunk = s.chunk.as_ref().ok_or_else(|| {
        (
            "chunk".to_string(),
            "missing (e.g. chunk = [\"1\", \"8\", \"frame\"])".to_string(),
        )
    })?;
    let chunks = axis(&Some(chunk.clone()), String::new(), "chunk")?
        .iter()
        .map(|c| Chunk::parse(c).map_err(|e| ("chunk".to_string(), e.msg)))
        .collect::<Result<Vec<_>, _>>()?;
    let orders = axis(&s.order, "scanline".into(), "order")?
        .iter()
        .map(|o| Order::from_id(o).map_err(|e| ("order".to_string(), e.msg)))
        .collect::<Result<Vec<_>, _>>()?;
    let defaults = SchedulerSpec::new(kind, Chunk::Frame, 1);
    let buffers = positive(axis(&s.buffer, defaults.buffer as i64, "buffer")?, "buffer")?;
    let requeues = axis(&s.requeue, defaults.requeue.to_string(), "requeue")?
        .iter()
        .map(|r| Requeue::parse(r).map_err(|e| ("requeue".to_string(), e.msg)))
        .collect::<Result<Vec<_>, _>>()?;
    let waits = axis(&s.wait, defaults.wait.id().to_string(), "wait")?
        .iter()
        .map(|w| Wait::from_id(w).map_err(|e| ("wait".to_string(), e.msg)))
        .collect::<Result<Vec<_>, _>>()?;
    let grab_vals = positive(axis(&s.grab, defaults.grab as i64, "grab")?, "grab")?;
    let ks = positive(
        axis(&s.guided_k, defaults.guided_k as i64, "guided_k")?,
        "guided_k",
    )?;
    let mut out = Vec::new();
    for &chunk in &chunks {
        for &order in &orders {
            for &buffer in &buffers {
                for &requeue in &requeues {
                    for &wait in &waits {
                        for &grab in &grab_vals {
                            for &guided_k in &ks {
                                for &w in workers {
                                    let spec = SchedulerSpec {
                                        kind,
                                        chunk,
                                        order,
                                        workers: w,
                                        buffer,
                                        requeue,
                                        wait,
                                        grab,
                                        guided_k,
                                        timeline,
                                    };
                                    spec.validate().map_err(|e| (e.field.clone(), e.msg))?;
                                    out.push(spec);
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    Ok(out)
}
