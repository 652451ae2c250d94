//! Stage two: the validated plan. Every scene is loaded, every tracer built, every id resolved
//! and every value range-checked here, before any timing starts; errors name the experiment
//! file and the field (`experiments/x.toml: schedulers[1].buffer: …`).

use super::config::{
    ExperimentFile, ExperimentKind, MpiEntry, SchedulerEntry, WorkerCount, WorkersSpec,
};
use crate::core::scene::{load_scene, Scene, SceneOverrides};
use crate::core::tracer::{AnyTracer, TracerKind};
use crate::sched::sources::SourceField;
use crate::sched::{
    source_params, Chunk, Order, Policy, Runner, SchedulerKind, SchedulerSpec, Slow, SourceKind,
    SourceSet, SourceSetup,
};
use crate::util::hash::{fnv, hex};
use crate::util::limits::{
    checked_product, MAX_CONFIGS, MAX_REPETITIONS, MAX_RUNS, MAX_SPP, MAX_THREADS,
};
use crate::util::one_line::OneLine;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

mod baselines;
mod grid;
mod settings;
use baselines::*;
use grid::*;
use settings::*;
pub use settings::{
    StatsSettings, DEFAULT_BUDGET_S, DEFAULT_CI_TARGET, DEFAULT_MAX_RUNS, DEFAULT_MIN_SAMPLE_S,
};

/// A bad experiment file: `file: field: message`, on one line whatever bytes the file names
/// hold ([`OneLine`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}: {}{}{}", OneLine(path), OneLine(field), if field.is_empty() { "" } else { ": " }, OneLine(msg))]
pub struct ConfigError {
    /// The experiment file, with `:line:column` for a TOML error.
    pub path: String,
    /// The offending field (`schedulers[1].buffer`, …); empty for the whole file.
    pub field: String,
    /// What is wrong.
    pub msg: String,
}

/// A scene loaded with its overrides (the load time is recorded, never timed with a run).
pub struct PlannedScene {
    /// The path as written in the experiment file.
    pub file: String,
    /// The experiment's overrides, applied to the loaded scene.
    pub overrides: SceneOverrides,
    /// The loaded scene.
    pub scene: Arc<Scene>,
    /// Seconds taken to load the scene.
    pub load_s: f64,
}

/// One (scene, tracer) pair: the unit a serial baseline is measured for.
pub struct Baseline {
    /// Index into [`ExperimentPlan::scenes`].
    pub scene: usize,
    /// The tracer's id.
    pub tracer_id: String,
    /// The tracer, built on the scene.
    pub tracer: Arc<AnyTracer>,
    /// Seconds taken to build the tracer.
    pub build_s: f64,
}

/// Who renders a configuration's items.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Sources {
    /// Sources of this process: threads, a GPU or both, with each kind's hand-out settings.
    Local(SourceSetup),
    /// MPI ranks 1…K−1 of an `mpirun -n K` launch whose transport has this name.
    Mpi {
        /// The launch's transport name.
        transport: String,
    },
}

impl Sources {
    /// Threads of this process, as every configuration without `sources` has.
    pub fn threads() -> Self {
        Self::Local(SourceSetup::default())
    }

    /// The `sources` column's value: `local` (threads), `gpu`, `threads+gpu` or `mpi`.
    pub fn id(&self) -> String {
        match self {
            Self::Local(s) => s.set.column(),
            Self::Mpi { .. } => SourceKind::Mpi.id().into(),
        }
    }

    /// Does a GPU render (some of) the items?
    pub fn has_gpu(&self) -> bool {
        matches!(self, Self::Local(s) if s.set.has(SourceKind::Gpu))
    }
}

/// The GPU adapter of a run (as the driver reports it), its provenance beside the CPU's.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize, PartialEq, Eq)]
pub struct GpuMeta {
    /// Adapter name (`llvmpipe (LLVM 15.0.6, 256 bits)`, `NVIDIA H200`, …).
    pub name: String,
    /// Driver name and version.
    pub driver: String,
    /// wgpu backend (`vulkan`).
    pub backend: String,
    /// Device type (`Cpu`, `DiscreteGpu`, …).
    pub device_type: String,
}

/// The GPU of an experiment's source sets with `gpu`, opened once by the plan with every
/// scene uploaded to it (never timed with a run).
pub struct PlannedGpu {
    /// The adapter (recorded in `meta.toml`).
    pub info: GpuMeta,
    /// Seconds taken to upload each scene, in [`ExperimentPlan::scenes`] order.
    pub upload_s: Vec<f64>,
    /// Each scene on the device, in [`ExperimentPlan::scenes`] order.
    #[cfg(feature = "gpu")]
    pub renderers: Vec<Arc<crate::core::gpu::GpuRenderer>>,
}

/// One `mpirun -n ranks` with one transport: the unit the MPI part of an experiment is
/// measured in (see [`RunConfig::in_launch`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Launch {
    /// Total ranks, rank 0 (the master) included.
    pub ranks: usize,
    /// The transport name the launch's environment maps to.
    pub transport: String,
}

/// One configuration to time `repetitions` times.
#[derive(Clone, Debug)]
pub struct RunConfig {
    /// Stable id (16 hex digits) of every config column: the resume key with the repetition.
    pub id: String,
    /// Index into [`ExperimentPlan::baselines`]: the scene and tracer.
    pub baseline: usize,
    /// `None` = the serial baseline (one thread, no scheduler).
    pub spec: Option<SchedulerSpec>,
    /// Who renders the items.
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
                        Sources::Local(_) => true,
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
    /// Transport names, one MPI configuration each per grid entry.
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

/// A validated experiment, scenes loaded and tracers built: what a run executes.
pub struct ExperimentPlan {
    /// The experiment's name (its results folder).
    pub name: String,
    /// Free text for the report.
    pub description: String,
    /// The experiment file's path.
    pub file: PathBuf,
    /// FNV-1a of the experiment file's bytes, 16 hex digits.
    pub file_hash: String,
    /// Timed runs per configuration at least (≥ 1).
    pub repetitions: u32,
    /// When to stop repeating, and how to time short renders.
    pub stats: StatsSettings,
    /// Untimed runs before each configuration's timed ones.
    pub warmup: u32,
    /// Record a Gantt timeline on repetition 0 of each scheduler configuration.
    pub timeline: bool,
    /// Record the cost model's prediction beside each thread-scheduler configuration.
    pub predict: bool,
    /// The loaded scenes, in file order.
    pub scenes: Vec<PlannedScene>,
    /// One per (scene, tracer), scene-major.
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
    /// `Some` when a source set has a GPU (`sources = ["threads+gpu", …]`).
    pub gpu: Option<PlannedGpu>,
}

/// The validated sample counts of a convergence experiment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ConvergenceSettings {
    /// The largest sample count of the 1, 2, 4, … progression.
    pub max_spp: u32,
    /// Samples of a rendered reference (default 1024).
    pub ref_spp: u32,
}

impl ExperimentPlan {
    /// The planned scene configuration `c` renders.
    pub fn scene_of(&self, c: &RunConfig) -> &PlannedScene {
        &self.scenes[self.baselines[c.baseline].scene]
    }
}

/// A field's problem before the file's path is attached: (field, message).
type FieldError = (String, String);

fn field(name: &str, msg: impl Into<String>) -> FieldError {
    (name.to_string(), msg.into())
}

/// Parse and validate an experiment file, load its scenes and build its tracers. The
/// configurations have no ids yet: they are keyed by their CSV columns
/// ([`super::results::assign_ids`]); [`super::load_plan`] does both.
pub fn plan_file(path: &Path) -> Result<ExperimentPlan, ConfigError> {
    let attach = |(field, msg): FieldError| ConfigError {
        path: path.display().to_string(),
        field,
        msg,
    };
    // 1. The raw file, its name and the settings that need no scene.
    let (bytes, file) = read_file(path)?;
    let name = plan_name(path, &file).map_err(attach)?;
    let settings = check_settings(&file).map_err(attach)?;
    // 2. Every scheduler grid, before the (slow) scene loading, so a typo fails fast.
    let grids = expand_grids(&file, &settings).map_err(attach)?;
    check_config_count(&file, &grids).map_err(attach)?;
    let max_workers = settings.workers.iter().copied().max().unwrap_or(1);
    // 3. Scenes loaded, tracers built: one baseline per (scene, tracer).
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let scenes = load_scenes(&file, &base).map_err(attach)?;
    let baselines = build_baselines(&settings.tracers, &scenes, max_workers).map_err(attach)?;
    let wants_gpu = settings.sources.iter().any(|s| s.has(SourceKind::Gpu));
    let gpu = open_gpu(wants_gpu, file.gpu_adapter.as_deref(), &scenes).map_err(attach)?;
    // 4. The configurations, serial baselines first, each with its stable id.
    let configs = configurations(baselines.len(), &grids, settings.mpi.as_ref());
    Ok(ExperimentPlan {
        name,
        description: file.description.clone(),
        file: path.to_path_buf(),
        file_hash: hex(fnv(&bytes)),
        repetitions: file.repetitions,
        stats: settings.stats,
        warmup: file.warmup,
        timeline: file.timeline,
        predict: file.predict,
        scenes,
        baselines,
        configs,
        convergence: settings.convergence,
        max_workers,
        mpi: settings.mpi,
        gpu,
    })
}

/// Open the GPU (`gpu_adapter`, else the high-performance adapter) and upload every scene,
/// when a source set has `gpu`; a missing adapter or an unsupported scene is a field error.
#[cfg(feature = "gpu")]
fn open_gpu(
    wanted: bool,
    adapter: Option<&str>,
    scenes: &[PlannedScene],
) -> Result<Option<PlannedGpu>, FieldError> {
    use crate::core::gpu::{GpuContext, GpuRenderer};
    if !wanted {
        return Ok(None);
    }
    let at = if adapter.is_some() {
        "gpu_adapter"
    } else {
        "sources"
    };
    let ctx = GpuContext::open(adapter).map_err(|e| field(at, e.to_string()))?;
    let info = GpuMeta {
        name: ctx.info.name.clone(),
        driver: ctx.info.driver.clone(),
        backend: ctx.info.backend.clone(),
        device_type: ctx.info.device_type.clone(),
    };
    let (mut renderers, mut upload_s) = (Vec::new(), Vec::new());
    for (i, s) in scenes.iter().enumerate() {
        let t0 = Instant::now();
        let r = GpuRenderer::new(ctx.clone(), &s.scene)
            .map_err(|e| field(&format!("scenes[{i}]"), format!("{}: {e}", s.file)))?;
        upload_s.push(t0.elapsed().as_secs_f64());
        renderers.push(Arc::new(r));
    }
    Ok(Some(PlannedGpu {
        info,
        upload_s,
        renderers,
    }))
}

/// Without feature `gpu` no source set can hold `gpu` ([`SourceSet::new`] refuses it).
#[cfg(not(feature = "gpu"))]
fn open_gpu(
    _wanted: bool,
    _adapter: Option<&str>,
    _scenes: &[PlannedScene],
) -> Result<Option<PlannedGpu>, FieldError> {
    Ok(None)
}

/// The file's bytes and its parsed text; a TOML error is `file:line:column: key: message`.
fn read_file(path: &Path) -> Result<(Vec<u8>, ExperimentFile), ConfigError> {
    let err = |path: String, (field, msg): FieldError| ConfigError { path, field, msg };
    let shown = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| {
        err(
            shown.clone(),
            field("", format!("cannot read experiment file: {e}")),
        )
    })?;
    let text = String::from_utf8(bytes.clone())
        .map_err(|_| err(shown.clone(), field("", "not UTF-8 text")))?;
    // A scene file where an experiment is expected: say so, not `unknown field 'camera'`.
    if let Ok(raw) = toml::from_str::<toml::Table>(&text) {
        let has = |k: &str| raw.contains_key(k);
        if (has("camera") || has("shapes")) && !has("scenes") && !has("schedulers") {
            return Err(err(
                shown,
                field(
                    "",
                    "is a scene file, not an experiment: render it with `raysched render`, or \
                     measure it by listing it in an experiment's [[scenes]] (path = ...)",
                ),
            ));
        }
    }
    let file: ExperimentFile = toml::from_str(&text).map_err(|e| {
        let (at, key, msg) = crate::core::scene::toml_error_at(&text, &e);
        let place = match at {
            Some((l, c)) => format!("{shown}:{l}:{c}"),
            None => shown.clone(),
        };
        err(place, field(&key, msg))
    })?;
    Ok((bytes, file))
}

/// The experiment's name (it names the results folder): `name`, else the file stem.
fn plan_name(path: &Path, file: &ExperimentFile) -> Result<String, FieldError> {
    let name = match &file.name {
        Some(n) => n.clone(),
        None => path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "experiment".into()),
    };
    let allowed = |c: char| c.is_ascii_alphanumeric() || "-_.".contains(c);
    if name.is_empty() || !name.chars().all(allowed) || name.starts_with('.') {
        return Err(field(
            "name",
            format!("'{name}': use letters, digits, '-', '_' or '.' (it names the results folder)"),
        ));
    }
    Ok(name)
}
