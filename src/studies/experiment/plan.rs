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

/// What the file says besides its scenes and schedulers, checked.
struct Settings {
    stats: StatsSettings,
    workers: Vec<usize>,
    tracers: Vec<TracerKind>,
    /// The source sets of the grid, in file order, no repeats.
    sources: Vec<SourceSet>,
    mpi: Option<MpiSettings>,
    convergence: Option<ConvergenceSettings>,
}

fn check_settings(file: &ExperimentFile) -> Result<Settings, FieldError> {
    if !(1..=MAX_REPETITIONS).contains(&file.repetitions) {
        return Err(field(
            "repetitions",
            format!(
                "must be in 1..={MAX_REPETITIONS} (got {})",
                file.repetitions
            ),
        ));
    }
    if file.warmup > MAX_REPETITIONS {
        return Err(field(
            "warmup",
            format!("must be in 0..={MAX_REPETITIONS} (got {})", file.warmup),
        ));
    }
    let mpi = file
        .mpi
        .as_ref()
        .map(|m| validate_mpi(m, file))
        .transpose()?;
    let workers = match (&file.workers, &mpi) {
        (Some(_), Some(_)) => {
            return Err(field(
                "workers",
                "set by mpi.ranks under [mpi] (ranks − 1 per launch); remove it",
            ))
        }
        (None, Some(m)) => m.ranks.iter().map(|r| r - 1).collect(),
        (Some(w), None) => expand_workers(w).map_err(|m| field("workers", m))?,
        (None, None) => {
            return Err(field(
                "workers",
                "missing (e.g. workers = [1, 2] or \"1..max\")",
            ))
        }
    };
    if file.tracers.is_empty() {
        return Err(field("tracers", "must name at least one tracer"));
    }
    let tracers = file
        .tracers
        .iter()
        .enumerate()
        .map(|(i, t)| {
            TracerKind::from_id(t)
                .and_then(TracerKind::available)
                .map_err(|e| field(&format!("tracers[{i}]"), e.to_string()))
        })
        .collect::<Result<Vec<_>, _>>()?;
    if file.scenes.is_empty() {
        return Err(field(
            "scenes",
            "must list at least one scene ([[scenes]] path = …)",
        ));
    }
    Ok(Settings {
        stats: check_stats(file)?,
        workers,
        tracers,
        sources: check_sources(file)?,
        mpi,
        convergence: check_convergence(file)?,
    })
}

/// The `sources` axis: each entry a set of kinds (`threads`, `gpu`, `threads+gpu`), parsed by
/// the one definition ([`SourceSet::parse`]); `["threads"]` when absent.
fn check_sources(file: &ExperimentFile) -> Result<Vec<SourceSet>, FieldError> {
    let Some(axis) = &file.sources else {
        if file.gpu_adapter.is_some() {
            return Err(field(
                "gpu_adapter",
                "applies only with gpu among the sources (e.g. sources = [\"threads\", \"threads+gpu\"])",
            ));
        }
        return Ok(vec![SourceSet::threads()]);
    };
    let many = matches!(axis, super::config::OneOrMany::Many(_));
    let name = |i: usize| {
        if many {
            format!("sources[{i}]")
        } else {
            "sources".to_string()
        }
    };
    let texts = axis.values();
    if texts.is_empty() {
        return Err(field(
            "sources",
            "must list at least one set (e.g. [\"threads\"])",
        ));
    }
    if file.mpi.is_some() {
        return Err(field(
            "sources",
            "an [mpi] experiment renders on its ranks and the local-thread baseline; remove sources",
        ));
    }
    if file.kind == ExperimentKind::Convergence {
        return Err(field(
            "sources",
            "a convergence experiment renders on threads; remove sources",
        ));
    }
    let mut sets: Vec<SourceSet> = Vec::new();
    for (i, t) in texts.iter().enumerate() {
        let set = SourceSet::parse(t).map_err(|e| field(&name(i), e.msg))?;
        if set.has(SourceKind::Mpi) {
            return Err(field(
                &name(i),
                "'mpi': MPI ranks are set by an [mpi] table (mpi.ranks), not by sources",
            ));
        }
        if !sets.contains(&set) {
            sets.push(set);
        }
    }
    if file.gpu_adapter.is_some() && !sets.iter().any(|s| s.has(SourceKind::Gpu)) {
        return Err(field(
            "gpu_adapter",
            "applies only with gpu among the sources",
        ));
    }
    Ok(sets)
}

/// The adaptive-repetition settings of a timing experiment.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StatsSettings {
    /// Timed runs per configuration at least.
    pub min_runs: u32,
    /// At most.
    pub max_runs: u32,
    /// Relative 95 % CI half-width of the median to reach (0: fixed `min_runs`).
    pub ci_target: f64,
    /// Seconds of timed runs per configuration at most.
    pub budget_s: f64,
    /// Renders shorter than this are repeated inside one timed sample.
    pub min_sample_s: f64,
    /// Seeds each round's shuffled order (bootstrap intervals are seeded by the configuration
    /// id, so `raysched plot` reproduces them from the CSV alone).
    pub seed: u64,
    /// Which process takes the samples (absent in `meta.toml` files before it: one process).
    #[serde(default = "one_process")]
    pub isolation: super::config::Isolation,
}

fn one_process() -> super::config::Isolation {
    super::config::Isolation::None
}

/// Default relative CI half-width: ±2 % of the median.
pub const DEFAULT_CI_TARGET: f64 = 0.02;
/// Default cap on timed runs per configuration.
pub const DEFAULT_MAX_RUNS: u32 = 30;
/// Default seconds of timed runs per configuration.
pub const DEFAULT_BUDGET_S: f64 = 10.0;
/// Default shortest timed sample: below ~50 ms, scheduling noise of a shared machine (a 4 ms
/// time slice, a page-cache flush) is a large fraction of the sample.
pub const DEFAULT_MIN_SAMPLE_S: f64 = 0.05;

impl StatsSettings {
    /// Is the number of runs fixed (no CI target)?
    pub fn fixed(&self) -> bool {
        self.ci_target == 0.0
    }
}

fn check_stats(file: &ExperimentFile) -> Result<StatsSettings, FieldError> {
    let ci_target = file.ci_target.unwrap_or(DEFAULT_CI_TARGET);
    if !(0.0..=0.5).contains(&ci_target) {
        return Err(field(
            "ci_target",
            format!("must be in [0, 0.5] (a fraction of the median; got {ci_target})"),
        ));
    }
    let min_runs = file.repetitions;
    let max_runs = match file.max_repetitions {
        Some(m) if m < min_runs => {
            return Err(field(
                "max_repetitions",
                format!("must be ≥ repetitions ({min_runs}; got {m})"),
            ))
        }
        Some(m) if m > 10_000 => {
            return Err(field(
                "max_repetitions",
                format!("must be ≤ 10000 (got {m})"),
            ))
        }
        Some(m) => m,
        None if ci_target == 0.0 => min_runs,
        None => DEFAULT_MAX_RUNS.max(min_runs),
    };
    let budget_s = file.budget_s.unwrap_or(DEFAULT_BUDGET_S);
    if !(budget_s > 0.0 && budget_s <= 86_400.0) {
        return Err(field(
            "budget_s",
            format!("must be in (0, 86400] seconds (got {budget_s})"),
        ));
    }
    let min_sample_s = file.min_sample_s.unwrap_or(DEFAULT_MIN_SAMPLE_S);
    if !(0.0..=10.0).contains(&min_sample_s) {
        return Err(field(
            "min_sample_s",
            format!("must be in [0, 10] seconds (got {min_sample_s})"),
        ));
    }
    Ok(StatsSettings {
        min_runs,
        max_runs,
        ci_target,
        budget_s,
        min_sample_s,
        seed: file.seed.unwrap_or(1),
        isolation: file.isolation,
    })
}

/// `kind = "convergence"` and its sample counts; a timing experiment must not set them.
fn check_convergence(file: &ExperimentFile) -> Result<Option<ConvergenceSettings>, FieldError> {
    match file.kind {
        ExperimentKind::Timing => {
            if file.schedulers.is_empty() {
                return Err(field(
                    "schedulers",
                    "must list at least one scheduler ([[schedulers]] kind = …)",
                ));
            }
            for (f, set) in [
                ("max_spp", file.max_spp.is_some()),
                ("ref_spp", file.ref_spp.is_some()),
            ] {
                if set {
                    return Err(field(f, "applies only to kind = \"convergence\""));
                }
            }
            Ok(None)
        }
        ExperimentKind::Convergence => {
            let max_spp = file
                .max_spp
                .ok_or_else(|| field("max_spp", "kind = \"convergence\" needs max_spp"))?;
            let ref_spp = file.ref_spp.unwrap_or(1024);
            for (f, v) in [("max_spp", max_spp), ("ref_spp", ref_spp)] {
                if !(1..=MAX_SPP).contains(&v) {
                    return Err(field(f, format!("must be in 1..={MAX_SPP} (got {v})")));
                }
            }
            Ok(Some(ConvergenceSettings { max_spp, ref_spp }))
        }
    }
}

/// Every scheduler entry's grid × worker counts × source setups ([`expand_setups`]). A
/// progressive run records no timeline: a Gantt chart per step would be noise.
fn expand_grids(file: &ExperimentFile, settings: &Settings) -> Result<Vec<Grid>, FieldError> {
    let timeline = file.timeline && settings.convergence.is_none();
    file.schedulers
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let at = |(f, m): FieldError| (format!("schedulers[{i}].{f}"), m);
            let (entry, source_axes) = split_source_keys(s).map_err(at)?;
            let specs = expand_scheduler(&entry, &settings.workers, timeline).map_err(at)?;
            let kind = specs
                .first()
                .map_or(SchedulerKind::FOR_MIXED_SOURCES, |s| s.kind());
            let setups = expand_setups(kind, &source_axes, &settings.sources).map_err(at)?;
            if (specs.len() as u64).saturating_mul(setups.len() as u64) > MAX_CONFIGS {
                return Err(at((
                    "kind".into(),
                    format!(
                        "{} scheduler configurations × {} source setups is more than the \
                         limit of {MAX_CONFIGS} run configurations",
                        specs.len(),
                        setups.len()
                    ),
                )));
            }
            let mut grid = Vec::with_capacity(specs.len() * setups.len());
            for setup in &setups {
                for spec in &specs {
                    let refusal = Runner::Gpu.refuses(&spec.policy);
                    if let Some(r) = refusal.filter(|_| setup.set.has(SourceKind::Gpu)) {
                        return Err(at((
                            r.param.into(),
                            format!("{} (sources = \"{}\")", r.as_value(), setup.set.id()),
                        )));
                    }
                    let mut spec = spec.clone();
                    if !setup.set.has(SourceKind::Threads) {
                        // A GPU alone is one source whatever the thread count: one
                        // configuration (the repeats are merged by their ids).
                        spec.workers = 1;
                    }
                    grid.push((spec, setup.clone()));
                }
            }
            Ok(grid)
        })
        .collect()
}

/// One scheduler entry's configurations: each spec with the source setup it runs on.
type Grid = Vec<(SchedulerSpec, SourceSetup)>;

/// The entry without its per-source keys (`gpu_chunk`, …), and those keys as axes.
fn split_source_keys(s: &SchedulerEntry) -> Result<(SchedulerEntry, Vec<Axis>), FieldError> {
    let mut entry = s.clone();
    let mut axes = Vec::new();
    for p in source_params() {
        if let Some(v) = entry.grid.remove(&p.name) {
            let values = axis_texts(&p.name, &v)?;
            for t in &values {
                SourceSetup::default()
                    .set_param(&p.name, t)
                    .map_err(|e| (e.field, e.msg))?;
            }
            axes.push(Axis {
                name: p.name.clone(),
                values,
            });
        }
    }
    Ok((entry, axes))
}

/// The source setups one entry of `kind` runs on: every set of the `sources` axis (those with
/// other sources than threads only for a rule that takes per-source settings, the master's)
/// crossed with the per-source axes that apply to it (a GPU's
/// chunk only to sets with a GPU, `balance` only to sets of several kinds).
fn expand_setups(
    kind: SchedulerKind,
    axes: &[Axis],
    sets: &[SourceSet],
) -> Result<Vec<SourceSetup>, FieldError> {
    let per_source = Policy::defaults(kind).needs().per_source;
    let applies = |name: &str, set: &SourceSet| match source_params()
        .iter()
        .find(|p| p.name == name)
        .map(|p| p.field)
    {
        Some(SourceField::Chunk(k) | SourceField::Buffer(k)) => set.has(k),
        Some(SourceField::Balance) => set.kinds().len() > 1,
        None => false,
    };
    for a in axes {
        if !per_source {
            return Err((
                a.name.clone(),
                format!(
                    "'{}' has no {} (only master takes the per-source settings)",
                    kind.id(),
                    a.name
                ),
            ));
        }
        if !sets.iter().any(|s| applies(&a.name, s)) {
            let listed: Vec<String> = sets.iter().map(|s| s.id()).collect();
            return Err((
                a.name.clone(),
                format!(
                    "applies to none of sources = [{}] (a GPU's settings need gpu in a set,                      balance a set of several kinds)",
                    listed.join(", ")
                ),
            ));
        }
    }
    let sizes: Vec<u64> = axes.iter().map(|a| a.values.len() as u64).collect();
    let per_set = checked_product(&sizes).filter(|&n| n <= MAX_CONFIGS);
    if per_set.is_none() {
        return Err((
            "kind".into(),
            format!("the per-source settings have more than {MAX_CONFIGS} combinations"),
        ));
    }
    let mut out = Vec::new();
    for set in sets {
        if !per_source && set.kinds() != [SourceKind::Threads] {
            continue; // only a rule with per-source settings hands out to other sources
        }
        let mut setups = vec![SourceSetup::of(set.clone())];
        for a in axes.iter().filter(|a| applies(&a.name, set)) {
            let mut next = Vec::with_capacity(setups.len() * a.values.len());
            for s in &setups {
                for v in &a.values {
                    let mut s = s.clone();
                    s.set_param(&a.name, v).map_err(|e| (e.field, e.msg))?;
                    next.push(s);
                }
            }
            setups = next;
        }
        for s in &setups {
            s.validate().map_err(|e| (e.field, e.msg))?;
        }
        out.extend(setups);
    }
    if out.is_empty() {
        return Err((
            "kind".into(),
            format!(
                "'{}' hands out to its own threads only, and sources has no \"threads\" set \
                 (add one, or use master)",
                kind.id()
            ),
        ));
    }
    Ok(out)
}

/// Scenes × tracers × every grid entry within [`MAX_CONFIGS`], before any scene is loaded.
fn check_config_count(file: &ExperimentFile, grids: &[Grid]) -> Result<(), FieldError> {
    let specs: u64 = grids.iter().map(|g| g.len() as u64).sum();
    let transports = file.mpi.as_ref().map_or(0, |m| m.transports.len() as u64);
    let n = checked_product(&[
        file.scenes.len() as u64,
        file.tracers.len() as u64,
        specs.saturating_add(1),
        transports + 1,
    ]);
    let runs = n.and_then(|n| n.checked_mul(file.repetitions as u64));
    if let (Some(n), Some(runs)) = (n, runs) {
        if n <= MAX_CONFIGS && runs > MAX_RUNS {
            return Err(field(
                "repetitions",
                format!(
                    "{n} run configurations × {} repetitions = {runs} runs is more than the \
                     limit of {MAX_RUNS}",
                    file.repetitions
                ),
            ));
        }
    }
    match n {
        Some(n) if n <= MAX_CONFIGS => Ok(()),
        _ => Err(field(
            "schedulers",
            format!(
                "{} scenes × {} tracers × {specs} scheduler configurations is more than the \
                 limit of {MAX_CONFIGS} run configurations",
                file.scenes.len(),
                file.tracers.len()
            ),
        )),
    }
}

fn load_scenes(file: &ExperimentFile, base: &Path) -> Result<Vec<PlannedScene>, FieldError> {
    let mut scenes = Vec::new();
    for (i, s) in file.scenes.iter().enumerate() {
        let overrides = s.overrides();
        let t0 = Instant::now();
        let scene =
            load_scene(&base.join(&s.path), &overrides).map_err(|e| scene_error(i, s, e))?;
        scenes.push(PlannedScene {
            file: s.path.clone(),
            overrides,
            scene: Arc::new(scene),
            load_s: t0.elapsed().as_secs_f64(),
        });
    }
    Ok(scenes)
}

/// Scene `i`'s load error as a field error of the experiment: a value the experiment overrides
/// (`width = 0`) is the experiment's field, not the scene file's.
fn scene_error(
    i: usize,
    s: &super::config::SceneEntry,
    e: crate::core::scene::SceneError,
) -> FieldError {
    let ours = e.line.is_none().then_some(()).and_then(|()| {
        Some(match e.field.as_str() {
            "camera.width" if s.width.is_some() => "width",
            "camera.height" if s.height.is_some() => "height",
            "render.spp" if s.spp.is_some() => "spp",
            "render.max_depth" if s.max_depth.is_some() => "max_depth",
            "render.seed" if s.seed.is_some() => "seed",
            f if f.ends_with(".count") && s.generator_count.is_some() => "generator_count",
            _ => return None,
        })
    });
    match ours {
        Some(key) => field(&format!("scenes[{i}].{key}"), e.msg),
        None => field(&format!("scenes[{i}]"), e.to_string()),
    }
}

/// One tracer per (scene, tracer), built with the largest worker count as its thread budget.
fn build_baselines(
    tracers: &[TracerKind],
    scenes: &[PlannedScene],
    max_workers: usize,
) -> Result<Vec<Baseline>, FieldError> {
    let mut baselines = Vec::new();
    for (si, sc) in scenes.iter().enumerate() {
        for (ti, &kind) in tracers.iter().enumerate() {
            let t0 = Instant::now();
            let tracer = AnyTracer::build(kind, &sc.scene, max_workers)
                .map_err(|e| field(&format!("tracers[{ti}]"), format!("scene {}: {e}", sc.file)))?;
            baselines.push(Baseline {
                scene: si,
                tracer_id: kind.id().to_string(),
                tracer: Arc::new(tracer),
                build_s: t0.elapsed().as_secs_f64(),
            });
        }
    }
    Ok(baselines)
}

/// Serial baselines first (so a scheduler run always finds its baseline measured), then every
/// baseline × grid entry; under `[mpi]` each entry is the local-thread baseline of its launch
/// size followed by one configuration per transport.
fn configurations(baselines: usize, grids: &[Grid], mpi: Option<&MpiSettings>) -> Vec<RunConfig> {
    let config = |baseline, spec, sources, ranks| RunConfig {
        id: String::new(),
        baseline,
        spec,
        sources,
        ranks,
    };
    let mut configs: Vec<RunConfig> = (0..baselines)
        .map(|b| config(b, None, Sources::threads(), None))
        .collect();
    for b in 0..baselines {
        for (spec, setup) in grids.iter().flatten() {
            let Some(m) = mpi else {
                let sources = Sources::Local(setup.clone());
                configs.push(config(b, Some(spec.clone()), sources, None));
                continue;
            };
            // Under [mpi], spec.workers = ranks − 1.
            let ranks = Some(spec.workers + 1);
            configs.push(config(b, Some(spec.clone()), Sources::threads(), ranks));
            for t in &m.transports {
                let sources = Sources::Mpi {
                    transport: t.clone(),
                };
                configs.push(config(b, Some(spec.clone()), sources, ranks));
            }
        }
    }
    configs
}

fn validate_mpi(m: &MpiEntry, file: &ExperimentFile) -> Result<MpiSettings, FieldError> {
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
            if !crate::sched::kinds::over_sources(k) {
                return Err((
                    format!("schedulers[{i}].kind"),
                    format!(
                        "'{}' steals between workers that share memory, which MPI ranks do not (use master or a scheduler without stealing)",
                        k.id()
                    ),
                ));
            }
            let lists = |key: &str, id: &str| {
                let id = toml::Value::String(id.into());
                s.grid
                    .get(key)
                    .is_some_and(|v| *v == id || v.as_array().is_some_and(|a| a.contains(&id)))
            };
            if let Some(r) = Runner::Mpi
                .refusals()
                .iter()
                .find(|r| lists(r.param, r.value))
            {
                return Err((format!("schedulers[{i}].{}", r.param), r.as_value()));
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
    let max = crate::util::host::available_threads() as i64;
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
            // Checked before the range is listed: "1..99999999999" must not allocate.
            if let Some(bad) = [a, b]
                .into_iter()
                .find(|n| !(1..=MAX_THREADS as i64).contains(n))
            {
                return Err(format!("must be between 1 and {MAX_THREADS} (got {bad})"));
            }
            (a..=b).collect()
        }
    };
    if out.is_empty() {
        return Err("must list at least one worker count".into());
    }
    if let Some(bad) = out
        .iter()
        .find(|&&n| !(1..=MAX_THREADS as i64).contains(&n))
    {
        return Err(format!("must be between 1 and {MAX_THREADS} (got {bad})"));
    }
    out.sort_unstable();
    out.dedup();
    Ok(out.into_iter().map(|n| n as usize).collect())
}

/// A grid field's values as text: one value or a list of numbers and strings.
fn axis_texts(name: &str, v: &toml::Value) -> Result<Vec<String>, (String, String)> {
    let text = |v: &toml::Value| match v {
        toml::Value::String(s) => Ok(s.clone()),
        toml::Value::Integer(i) => Ok(i.to_string()),
        toml::Value::Boolean(b) => Ok(b.to_string()),
        other => Err((
            name.to_string(),
            format!(
                "expected a number, a string or a boolean, got {}",
                other.type_str()
            ),
        )),
    };
    match v {
        toml::Value::Array(vals) if vals.is_empty() => {
            Err((name.to_string(), "must not be an empty list".into()))
        }
        toml::Value::Array(vals) => vals.iter().map(text).collect(),
        one => Ok(vec![text(one)?]),
    }
}

/// One grid axis: a field's name and its values, each already checked on `base`.
struct Axis {
    name: String,
    values: Vec<String>,
}

/// The grid keys every kind has: granularity, order and the heterogeneous-run setting.
const COMMON: [&str; 3] = ["chunk", "order", "slow"];

/// Apply one axis value to `spec`: `chunk`, `order` and `slow` are common to every kind, the
/// rest are the kind's parameters.
fn apply(spec: &mut SchedulerSpec, name: &str, value: &str) -> Result<(), (String, String)> {
    let fail = |e: crate::sched::SpecError| (name.to_string(), e.msg);
    match name {
        "chunk" => spec.chunk = Chunk::parse(value).map_err(fail)?,
        "order" => spec.order = Order::from_id(value).map_err(fail)?,
        "slow" => spec.slow = Slow::parse(value).map_err(fail)?,
        _ => spec.set(name, value).map_err(fail)?,
    }
    Ok(())
}

/// The axes of one scheduler entry, in grid order: chunk, order, then the kind's parameters
/// in column order; a parameter left out takes its default.
fn axes(s: &SchedulerEntry, base: &SchedulerSpec) -> Result<Vec<Axis>, (String, String)> {
    for key in s.grid.keys() {
        if !COMMON.contains(&key.as_str()) {
            base.check_name(key).map_err(|e| (key.clone(), e.msg))?;
        }
    }
    let own = base.kind().picks_own_layout();
    if own && (s.grid.contains_key("chunk") || s.grid.contains_key("order")) {
        return Err((
            "chunk".to_string(),
            format!(
                "'{}' picks its own tile size and order from the image and the thread count; \
                 leave chunk and order out",
                base.kind().id()
            ),
        ));
    }
    if !own && !s.grid.contains_key("chunk") {
        return Err((
            "chunk".to_string(),
            "missing (e.g. chunk = [\"1\", \"8\", \"frame\"])".to_string(),
        ));
    }
    let mut names = if own {
        vec!["slow"]
    } else {
        vec!["chunk", "order", "slow"]
    };
    names.extend(base.policy.info().iter().map(|p| p.name));
    let mut out = Vec::new();
    for name in names {
        let values = match s.grid.get(name) {
            Some(v) => axis_texts(name, v)?,
            None if name == "order" => vec![base.order.id().to_string()],
            None if name == "slow" => vec![base.slow.to_string()],
            None => vec![base.get(name).unwrap_or_default()],
        };
        for v in &values {
            apply(&mut base.clone(), name, v)?;
        }
        out.push(Axis {
            name: name.to_string(),
            values,
        });
    }
    Ok(out)
}

/// The cartesian product of one scheduler's grid and the worker counts (workers vary
/// fastest). Parameters the kind does not have are rejected rather than multiplied in.
fn expand_scheduler(
    s: &SchedulerEntry,
    workers: &[usize],
    timeline: bool,
) -> Result<Vec<SchedulerSpec>, (String, String)> {
    let kind = SchedulerKind::from_id(&s.kind).map_err(|e| ("kind".to_string(), e.msg))?;
    let base = SchedulerSpec {
        timeline,
        ..SchedulerSpec::new(kind, Chunk::Frame, 1)
    };
    let axes = axes(s, &base)?;
    let mut sizes: Vec<u64> = axes.iter().map(|a| a.values.len() as u64).collect();
    sizes.push(workers.len() as u64);
    if checked_product(&sizes).is_none_or(|n| n > MAX_CONFIGS) {
        let names: Vec<String> = axes
            .iter()
            .map(|a| format!("{} {}", a.values.len(), a.name))
            .collect();
        return Err((
            "kind".to_string(),
            format!(
                "the grid {} × {} worker counts has more than {MAX_CONFIGS} configurations",
                names.join(" × "),
                workers.len()
            ),
        ));
    }
    let mut specs = vec![base];
    for axis in &axes {
        let mut next = Vec::with_capacity(specs.len() * axis.values.len());
        for spec in &specs {
            for v in &axis.values {
                let mut spec = spec.clone();
                apply(&mut spec, &axis.name, v)?;
                next.push(spec);
            }
        }
        specs = next;
    }
    let mut out = Vec::with_capacity(specs.len() * workers.len());
    for spec in specs {
        for &w in workers {
            let spec = SchedulerSpec {
                workers: w,
                ..spec.clone()
            };
            spec.validate().map_err(|e| (e.field.clone(), e.msg))?;
            out.push(spec);
        }
    }
    Ok(out)
}
