//! Stage one: the raw experiment file (`experiments/*.toml`), exactly as written.
//!
//! ```toml
//! name = "quick"                  # optional, defaults to the file stem
//! description = "…"
//! repetitions = 5                 # timed runs per configuration, at least
//! ci_target = 0.02                # then more until the median's 95 % CI is ±2 % …
//! max_repetitions = 30            # … or 30 runs …
//! budget_s = 10                   # … or 10 s of timed runs have been spent
//! min_sample_s = 0.05             # shorter renders are repeated inside one timed sample
//! seed = 1                        # seeds the shuffled order of each round
//! isolation = "round"             # a fresh process per round ("none": one process)
//! warmup = 1                      # untimed runs before them
//! workers = [1, 2]                # or "1..max", or [1, 2, "max"]
//! tracers = ["bvh"]
//! sources = ["threads", "threads+gpu"]  # who renders (default ["threads"]; gpu: feature `gpu`)
//! gpu_adapter = "llvmpipe"        # the GPU whose name contains this (default: the fastest)
//! timeline = true                 # record a Gantt timeline on repetition 0
//! predict = false                 # record the cost model's prediction beside each configuration
//!
//! [[scenes]]
//! path = "../scenes/simple.toml"  # relative to this file
//! width = 64                      # any field of SceneOverrides
//!
//! [[schedulers]]                 # kind = "convergence": optional, one progressive run each
//! kind = "master"
//! chunk = ["1", "8", "frame"]     # every grid field takes a value or a list
//! buffer = [1, 2, 16]
//! gpu_chunk = ["4096", "frame"]   # master with a GPU: the GPU's own hand-out and buffer
//! gpu_buffer = 2
//! balance = [false, true]         # master with several kinds of source
//! ```

use crate::core::scene::SceneOverrides;
use serde::Deserialize;

/// An experiment file as deserialised, before any validation; unknown keys are errors.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentFile {
    /// Names the results folder; `None`: the file stem.
    pub name: Option<String>,
    /// Free text copied into the report.
    #[serde(default)]
    pub description: String,
    /// Timed runs per configuration at least (default 1); with a `ci_target` more follow until
    /// the target or the budget is reached.
    #[serde(default = "one")]
    pub repetitions: u32,
    /// Stop repeating a configuration once the 95 % CI half-width of its median wall time is
    /// at most this fraction of the median (default 0.02; 0: exactly `repetitions` runs).
    pub ci_target: Option<f64>,
    /// At most this many timed runs per configuration (default 30, at least `repetitions`).
    pub max_repetitions: Option<u32>,
    /// At most this many seconds of timed runs per configuration (default 10).
    pub budget_s: Option<f64>,
    /// A render shorter than this (seconds, default 0.05) is repeated inside one timed sample,
    /// which records the mean and the count (`inner`); 0 disables.
    pub min_sample_s: Option<f64>,
    /// Seeds the shuffled order of each round (default 1).
    pub seed: Option<u64>,
    /// Which process takes the timed samples (default `round`: a fresh one per round).
    #[serde(default)]
    pub isolation: Isolation,
    /// Untimed runs before each configuration's timed ones (default 0).
    #[serde(default)]
    pub warmup: u32,
    /// Required, except under `[mpi]` (there `ranks − 1` per launch).
    pub workers: Option<WorkersSpec>,
    /// Tracer ids, each built for every scene (default `["bvh"]`).
    #[serde(default = "default_tracers")]
    pub tracers: Vec<String>,
    /// Who renders: a grid axis of compute-source sets (`threads`, `gpu`, `threads+gpu`;
    /// default `["threads"]`). Sets with a GPU cross the master's entries only.
    pub sources: Option<OneOrMany<String>>,
    /// The GPU of the sets with `gpu`: the first adapter whose name contains this
    /// (default: the high-performance one).
    pub gpu_adapter: Option<String>,
    /// Record a Gantt timeline on repetition 0 of each scheduler configuration (default true).
    #[serde(default = "yes")]
    pub timeline: bool,
    /// Record the cost model's predicted wall time and its parts beside each thread-scheduler
    /// configuration (`raysched::studies::model`; a probe of a few seconds per scene, tracer and worker
    /// count before the first round; default false).
    #[serde(default)]
    pub predict: bool,
    /// The `[[scenes]]` entries, at least one.
    pub scenes: Vec<SceneEntry>,
    /// The `[[schedulers]]` grids; required for a timing experiment.
    #[serde(default)]
    pub schedulers: Vec<SchedulerEntry>,
    /// `timing` (the default: the scheduler sweep) or `convergence` (error against run time).
    #[serde(default)]
    pub kind: ExperimentKind,
    /// convergence: the largest sample count of the 1, 2, 4, … progression.
    pub max_spp: Option<u32>,
    /// convergence: samples of a rendered reference (cached under `<out>/refs/`) where the scene
    /// has no analytic answer.
    pub ref_spp: Option<u32>,
    /// MPI compute sources (`mpirun -n K raysched run …`): see [`MpiEntry`].
    pub mpi: Option<MpiEntry>,
}

/// `[mpi]`: which launches the experiment compares. One `mpirun -n K` with one transport
/// measures the configurations of (K, transport) plus the local-thread baseline with K − 1
/// threads; a driver (experiments/mpi_sweep.py) launches every (ranks, transport) pair and each
/// launch appends to the same runs.csv.
///
/// ```toml
/// [mpi]
/// ranks = [3]                                   # total ranks; rank 0 is the master
/// transports = ["shared_memory", "tcp_loopback"] # names a launch's environment maps to
/// silence_ms = 5000                             # a rank quiet this long with work is lost
/// ```
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MpiEntry {
    /// Total ranks per launch (rank 0 included), one count or a list.
    pub ranks: OneOrMany<i64>,
    /// Transport names, one set of MPI configurations each.
    pub transports: Vec<String>,
    /// Milliseconds a rank with work outstanding may stay silent before it is lost; `None`:
    /// the plan's default.
    pub silence_ms: Option<i64>,
}

/// What an experiment measures (`kind = …`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ExperimentKind {
    /// The scheduler sweep: wall time of every configuration against its serial baseline.
    #[default]
    Timing,
    /// Progressive renders: image error against run time.
    Convergence,
}

/// Which process takes a run's timed samples (`isolation = …`).
///
/// A process's speed depends on where its heap, stack and code landed and on the physical
/// pages behind them, fixed at its start (Mytkowicz et al., "Producing wrong data without
/// doing anything obviously wrong!", ASPLOS 2009; Curtsinger & Berger, "Stabilizer", ASPLOS
/// 2013). Samples that all come from one process share that draw, so two runs of one commit
/// differ per configuration by more than their samples' spread says.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Isolation {
    /// Each round (one sample of every open configuration) runs in a fresh process, so the
    /// layout draw varies between a configuration's samples and enters its interval.
    #[default]
    Round,
    /// Every round in the process that was started (no start-up cost per round).
    None,
}

impl Isolation {
    /// The key's values, for messages.
    pub const NAMES: [&'static str; 2] = ["round", "none"];

    /// Parse a flag's value.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "round" => Some(Self::Round),
            "none" => Some(Self::None),
            _ => None,
        }
    }
}

fn one() -> u32 {
    1
}
fn yes() -> bool {
    true
}
fn default_tracers() -> Vec<String> {
    vec!["bvh".into()]
}

/// One `[[scenes]]` entry: a scene file and the settings it overrides (`None`: the file's own).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneEntry {
    /// The scene file, relative to the experiment file.
    pub path: String,
    // Spelled out rather than `#[serde(flatten)]`: serde cannot combine flatten with
    // deny_unknown_fields, and a misspelt override must be an error.
    /// Image width in pixels.
    pub width: Option<u32>,
    /// Image height in pixels.
    pub height: Option<u32>,
    /// Samples per pixel.
    pub spp: Option<u32>,
    /// Maximum path depth (bounces).
    pub max_depth: Option<i32>,
    /// The render's random seed.
    pub seed: Option<u64>,
    /// Replaces `count` of every generator shape.
    pub generator_count: Option<u64>,
}

impl SceneEntry {
    /// The overrides in the form the scene loader takes.
    pub fn overrides(&self) -> SceneOverrides {
        SceneOverrides {
            width: self.width,
            height: self.height,
            spp: self.spp,
            max_depth: self.max_depth,
            seed: self.seed,
            generator_count: self.generator_count,
        }
    }
}

/// A worker count: a number or `"max"` (this machine's available parallelism).
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum WorkerCount {
    /// A literal count.
    N(i64),
    /// `"max"`, or a number written as a string.
    Word(String),
}

/// `[1, 2, "max"]`, a single number, or a range string `"1..max"` / `"1..8"` (inclusive).
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum WorkersSpec {
    /// A single count.
    One(i64),
    /// An explicit list of counts.
    List(Vec<WorkerCount>),
    /// An inclusive range `"A..B"`; either end may be `max`.
    Range(String),
}

/// A grid axis: one value or a list of values.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum OneOrMany<T> {
    /// A single value.
    One(T),
    /// A list of values.
    Many(Vec<T>),
}

impl<T: Clone> OneOrMany<T> {
    /// The values as a list (a single value gives a list of one).
    pub fn values(&self) -> Vec<T> {
        match self {
            Self::One(v) => vec![v.clone()],
            Self::Many(v) => v.clone(),
        }
    }
}

/// One scheduler and its parameter grid: `kind`, `chunk` (required), `order`, any
/// parameter the kind has (the names of `sched::spec`'s parameter structs: `buffer`, `grab`, …)
/// and, for the master, the per-source settings (`sched::source_params`: `gpu_chunk`, …).
/// Each grid field takes a value or a list. Keys the kind does not have are errors, so the
/// cartesian product holds no meaningless combination (`static` has no buffer).
#[derive(Debug, Clone, Deserialize)]
pub struct SchedulerEntry {
    /// The scheduler id (`master`, `static`, …), resolved by the plan.
    pub kind: String,
    /// Every other key, checked against the kind's parameters by the plan.
    #[serde(flatten)]
    pub grid: std::collections::BTreeMap<String, toml::Value>,
}
