//! A simulation experiment (`kind = "simulation"`), checked completely — every platform loaded
//! by SimGrid, every worker count fitted — before anything is measured or written.
//!
//! ```toml
//! kind = "simulation"
//! name = "simulation"
//! workers = [16, 64, 256, 1024, 4096]            # simulated workers
//! platforms = ["../platforms/cluster.xml"]        # SimGrid XML, relative to this file
//!
//! [probe]                                         # the measured inputs
//! scene = "../scenes/cornell_box.toml"
//! width = 128
//! height = 128
//! spp = 4
//! tracer = "bvh"
//! dispatch_items = 65536                          # zero-work runs for h
//! dispatch_workers = 2
//! probe_repetitions = 3                           # pixel passes: each pixel's median kept
//! probe_level_repetitions = 15                    # bulk renders: the level (Σ) of the costs
//! layout_repetitions = 3                          # pass pairs per item layout (0: none)
//!
//! [[schedulers]]                                  # as in a timing experiment
//! kind = "master"
//! chunk = ["1", "16"]
//! buffer = [2, 64]
//!
//! [[lost]]                                        # optional: a worker's host turned off
//! worker = 1
//! at_s = 0.01
//!
//! run_limit_s = 120                               # optional: a run simulating longer is cut
//! coarse_network_from = 8192                      # optional: runs this large on the coarse network
//!
//! [validation]                                    # optional: against a measured runs.csv
//! measured = "../results/runs/simvalidate/runs.csv"
//! platform = "../platforms/smp2.xml"
//! mpi_measured = "../results/runs/simvalidate_mpi/runs.csv"   # optional: MPI launches
//! mpi_spin = "../results/runs_spin/simvalidate_mpi/runs.csv"  # optional: the same, spinning
//! [validation.mpi_platforms]                       # a platform per measured transport
//! shared_memory = "../platforms/smp2_mpi_shared_memory_amd_epyc.xml"
//! ```

use super::child;
use super::job::{LostWorker, PlatformInfo};
use crate::core::scene::SceneOverrides;
use crate::sched::{Chunk, Runner, SchedulerKind, SchedulerSpec};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SimFile {
    #[serde(rename = "kind")]
    _kind: SimKind,
    name: Option<String>,
    #[serde(default)]
    description: String,
    workers: Workers,
    platforms: Vec<String>,
    probe: ProbeEntry,
    #[serde(default)]
    schedulers: Vec<SchedEntry>,
    #[serde(default)]
    lost: Vec<LostWorker>,
    validation: Option<ValidationEntry>,
    #[serde(default)]
    seed: u64,
    run_limit_s: Option<RunLimit>,
    coarse_network_from: Option<CoarseFrom>,
}

/// `kind = "simulation"`, refused otherwise while the file is read. The section types below
/// check themselves the same way (`try_from`): their errors name the field first, so that the
/// file error reads `path: field: why` like the checks that need more than one field.
#[derive(Debug, Deserialize)]
#[serde(try_from = "String")]
struct SimKind;

impl TryFrom<String> for SimKind {
    type Error = String;
    fn try_from(kind: String) -> Result<Self, String> {
        if kind == "simulation" {
            Ok(Self)
        } else {
            Err(format!(
                "kind: '{kind}': `raysched simulate` takes kind = \"simulation\""
            ))
        }
    }
}

/// The simulated worker counts: at least one, each in 1..=[`MAX_SIM_WORKERS`]; ascending,
/// without repeats.
#[derive(Debug, Deserialize)]
#[serde(try_from = "Vec<i64>")]
struct Workers(Vec<usize>);

impl TryFrom<Vec<i64>> for Workers {
    type Error = String;
    fn try_from(w: Vec<i64>) -> Result<Self, String> {
        if w.is_empty() {
            return Err("workers: must list at least one simulated worker count".into());
        }
        if let Some(bad) = w.iter().find(|&&w| !(1..=MAX_SIM_WORKERS).contains(&w)) {
            return Err(format!(
                "workers: must be between 1 and {MAX_SIM_WORKERS} (got {bad})"
            ));
        }
        let mut w: Vec<usize> = w.iter().map(|&w| w as usize).collect();
        w.sort_unstable();
        w.dedup();
        Ok(Self(w))
    }
}

/// `run_limit_s`: seconds in (0, 86400].
#[derive(Debug, Deserialize)]
#[serde(try_from = "f64")]
struct RunLimit(f64);

impl TryFrom<f64> for RunLimit {
    type Error = String;
    fn try_from(t: f64) -> Result<Self, String> {
        if t > 0.0 && t <= 86_400.0 {
            Ok(Self(t))
        } else {
            Err(format!(
                "run_limit_s: must be in (0, 86400] seconds (got {t})"
            ))
        }
    }
}

/// `coarse_network_from`: a worker count in 1..=[`MAX_SIM_WORKERS`].
#[derive(Debug, Deserialize)]
#[serde(try_from = "i64")]
struct CoarseFrom(usize);

impl TryFrom<i64> for CoarseFrom {
    type Error = String;
    fn try_from(w: i64) -> Result<Self, String> {
        if (1..=MAX_SIM_WORKERS).contains(&w) {
            Ok(Self(w as usize))
        } else {
            Err(format!(
                "coarse_network_from: must be a worker count in 1..={MAX_SIM_WORKERS} (got {w})"
            ))
        }
    }
}

/// The `[probe]` table: its tracer built in, its dispatch measurement checked.
#[derive(Debug, Deserialize)]
#[serde(try_from = "RawProbe")]
struct ProbeEntry {
    raw: RawProbe,
    tracer: crate::core::tracer::TracerKind,
}

impl TryFrom<RawProbe> for ProbeEntry {
    type Error = String;
    fn try_from(raw: RawProbe) -> Result<Self, String> {
        let tracer = crate::core::tracer::TracerKind::from_id(&raw.tracer)
            .and_then(crate::core::tracer::TracerKind::available)
            .map_err(|e| format!("probe.tracer: {e}"))?;
        if raw.dispatch_items < 64 || raw.dispatch_workers == 0 || raw.dispatch_repetitions == 0 {
            return Err(
                "probe: dispatch_items ≥ 64, dispatch_workers ≥ 1 and dispatch_repetitions ≥ 1"
                    .into(),
            );
        }
        Ok(Self { raw, tracer })
    }
}

impl ProbeEntry {
    /// The probe's scene overrides.
    fn overrides(&self) -> SceneOverrides {
        SceneOverrides {
            width: self.raw.width,
            height: self.raw.height,
            spp: self.raw.spp,
            max_depth: self.raw.max_depth,
            ..Default::default()
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawProbe {
    scene: String,
    width: Option<u32>,
    height: Option<u32>,
    spp: Option<u32>,
    max_depth: Option<i32>,
    #[serde(default = "bvh")]
    tracer: String,
    #[serde(default = "dispatch_items")]
    dispatch_items: u32,
    #[serde(default = "two")]
    dispatch_workers: usize,
    #[serde(default = "three")]
    dispatch_repetitions: u32,
    #[serde(default = "three")]
    probe_repetitions: u32,
    #[serde(default = "fifteen")]
    probe_level_repetitions: u32,
    #[serde(default = "three")]
    layout_repetitions: u32,
}

fn bvh() -> String {
    "bvh".into()
}
fn dispatch_items() -> u32 {
    1 << 16
}
fn two() -> usize {
    2
}
fn three() -> u32 {
    3
}
/// Bulk renders of the probe: the median of 3 moved ±10 % between probes a minute apart on
/// the dev box, about what one render moves (see `model::probe::pixels_with`).
fn fifteen() -> u32 {
    15
}

#[derive(Debug, Deserialize)]
struct SchedEntry {
    kind: String,
    #[serde(flatten)]
    grid: BTreeMap<String, toml::Value>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ValidationEntry {
    measured: String,
    platform: String,
    mpi_measured: Option<String>,
    mpi_spin: Option<String>,
    #[serde(default)]
    mpi_platforms: BTreeMap<String, String>,
}

/// A platform file, loaded once by SimGrid to check it.
#[derive(Clone, Debug)]
pub struct Platform {
    /// The file.
    pub path: PathBuf,
    /// Its stem (the `platform` column).
    pub name: String,
    /// Its hosts.
    pub info: PlatformInfo,
}

/// A checked simulation experiment.
pub struct SimPlan {
    /// Results folder name.
    pub name: String,
    /// Free text for the report.
    pub description: String,
    /// The experiment file.
    pub file: PathBuf,
    /// Simulated worker counts, ascending.
    pub workers: Vec<usize>,
    /// Platforms, in file order.
    pub platforms: Vec<Platform>,
    /// The probe's scene file (absolute or relative to the working directory).
    pub scene: PathBuf,
    /// The probe's overrides.
    pub overrides: SceneOverrides,
    /// The probe's tracer.
    pub tracer: crate::core::tracer::TracerKind,
    /// Zero-work items, threads and runs of the dispatch measurement.
    pub dispatch: (u32, usize, u32),
    /// Pixel passes of the probe; each pixel's median is kept.
    pub probe_repetitions: u32,
    /// Bulk renders of the probe (≥ `probe_repetitions`): the costs' level is their median.
    pub probe_level_repetitions: u32,
    /// Pairs of passes (rows, then the layout) measuring each item layout's cost factor
    /// ([`crate::studies::model::probe::layout_factor`]); 0: every factor 1.
    pub layout_repetitions: u32,
    /// Every scheduler configuration (workers set per simulated run).
    pub specs: Vec<SchedulerSpec>,
    /// Workers lost in every simulated run.
    pub lost: Vec<LostWorker>,
    /// `(measured runs.csv, platform)` to validate against.
    pub validation: Option<(PathBuf, Platform)>,
    /// `(measured MPI runs.csv, platform per transport)` to validate against.
    pub mpi_validation: Option<(PathBuf, BTreeMap<String, Platform>)>,
    /// The MPI launches again with spinning workers (`experiments/mpi_sweep.py --spin`): each
    /// configuration's period per item over MPI.
    pub mpi_spin: Option<PathBuf>,
    /// Seed of random choices (work-stealing victims).
    pub seed: u64,
    /// Seconds of real time one simulated run may take; a run still going then is stopped
    /// and its row says so (no wall time).
    pub run_limit_s: Option<f64>,
    /// Runs of at least this many workers are simulated on the coarse network
    /// ([`crate::studies::simulate::job::Network::Coarse`]); `None`: every run on SimGrid's.
    pub coarse_network_from: Option<usize>,
}

impl SimPlan {
    /// The network a run of `workers` workers is simulated on.
    pub fn network(&self, workers: usize) -> crate::studies::simulate::job::Network {
        use crate::studies::simulate::job::Network;
        match self.coarse_network_from {
            Some(from) if workers >= from => Network::Coarse,
            _ => Network::Fine,
        }
    }
}

/// The most simulated workers accepted.
pub const MAX_SIM_WORKERS: i64 = 1 << 16;

/// Why a simulation file was refused: its path first, then what is wrong, on one line.
#[derive(Debug, thiserror::Error)]
pub enum SimConfigError {
    /// The file could not be read or is no TOML of this format: `path: error`.
    #[error("{path}: {msg}")]
    File {
        /// The simulation file.
        path: String,
        /// The error's first line.
        msg: String,
    },
    /// A field's value is refused: `path: field: why`.
    #[error("{path}: {field}: {msg}")]
    Field {
        /// The simulation file.
        path: String,
        /// The field, e.g. `schedulers[0].chunk`.
        field: String,
        /// Why it is refused.
        msg: String,
    },
}

fn field(path: &Path, name: &str, msg: impl std::fmt::Display) -> SimConfigError {
    SimConfigError::Field {
        path: path.display().to_string(),
        field: name.to_string(),
        msg: msg.to_string(),
    }
}

/// Read and check `path`; `exe` is the raysched binary that loads platforms in a child.
pub fn load(path: &Path, exe: &Path) -> Result<SimPlan, SimConfigError> {
    let file_error = |msg: String| SimConfigError::File {
        path: path.display().to_string(),
        msg,
    };
    let text = std::fs::read_to_string(path).map_err(|e| file_error(e.to_string()))?;
    let file: SimFile = toml::from_str(&text).map_err(|e| {
        let msg = e.message().to_string();
        file_error(msg.lines().next().unwrap_or("").to_string())
    })?;
    let at = Files {
        path,
        base: path.parent().map(Path::to_path_buf).unwrap_or_default(),
        exe,
    };
    let on = |(f, m): (String, String)| field(path, &f, m);
    let name = file.name(path).map_err(on)?;
    let workers = file.workers.0.clone();
    let specs = file.specs(&workers).map_err(on)?;
    let platforms = at.platforms(&file.platforms, &workers)?;
    file.check_lost(&workers, &platforms).map_err(on)?;
    let (validation, mpi_validation, mpi_spin) = match &file.validation {
        Some(v) => v.resolve(&at)?,
        None => (None, None, None),
    };
    let probe = &file.probe;
    Ok(SimPlan {
        name,
        description: file.description,
        file: path.to_path_buf(),
        workers,
        platforms,
        scene: at.base.join(&probe.raw.scene),
        overrides: probe.overrides(),
        tracer: probe.tracer,
        probe_repetitions: probe.raw.probe_repetitions.max(1),
        probe_level_repetitions: probe
            .raw
            .probe_level_repetitions
            .max(probe.raw.probe_repetitions.max(1)),
        layout_repetitions: probe.raw.layout_repetitions,
        dispatch: (
            probe.raw.dispatch_items,
            probe.raw.dispatch_workers,
            probe.raw.dispatch_repetitions,
        ),
        specs,
        lost: file.lost,
        validation,
        mpi_validation,
        mpi_spin,
        seed: file.seed,
        run_limit_s: file.run_limit_s.map(|t| t.0),
        coarse_network_from: file.coarse_network_from.map(|w| w.0),
    })
}

/// A refused field: (field, why).
type FieldError = (String, String);

impl SimFile {
    /// `name`, or the file's stem: letters, digits, _ and - only.
    fn name(&self, path: &Path) -> Result<String, FieldError> {
        let name = self.name.clone().unwrap_or_else(|| {
            path.file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default()
        });
        let plain = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
        if name.is_empty() || !name.chars().all(plain) {
            return Err((
                "name".into(),
                format!("'{name}': letters, digits, _ and - only"),
            ));
        }
        Ok(name)
    }

    /// Every scheduler configuration of the grids, each one the simulation plays and within
    /// the system's SimGrid actors at the largest worker count.
    fn specs(&self, workers: &[usize]) -> Result<Vec<SchedulerSpec>, FieldError> {
        if self.schedulers.is_empty() {
            return Err((
                "schedulers".into(),
                "must list at least one [[schedulers]] grid".into(),
            ));
        }
        let mut specs = Vec::new();
        for (i, s) in self.schedulers.iter().enumerate() {
            specs.extend(expand(s).map_err(|(f, m)| (format!("schedulers[{i}].{f}"), m))?);
        }
        if let Some((s, r)) = specs
            .iter()
            .find_map(|s| Some((s, Runner::Simulation.refuses(&s.policy)?)))
        {
            return Err((
                "schedulers".into(),
                format!("{}: {} = {}", s.label(), r.param, r.as_value()),
            ));
        }
        let most = *workers.last().unwrap_or(&1);
        let budget = super::job::mapping_budget();
        let lost = self.lost.len();
        if let Some(s) = specs
            .iter()
            .find(|s| super::job::actors_needed(s.kind(), most, lost) > budget)
        {
            return Err((
                "workers".into(),
                format!(
                    "{most} simulated workers of {} need about {} SimGrid actors, more than this system's {budget} memory mappings per process (vm.max_map_count) allow",
                    s.kind().id(),
                    super::job::actors_needed(s.kind(), most, lost)
                ),
            ));
        }
        Ok(specs)
    }

    /// Each lost worker exists in every run, at a time ≥ 0, on platforms of several hosts.
    fn check_lost(&self, workers: &[usize], platforms: &[Platform]) -> Result<(), FieldError> {
        for (i, l) in self.lost.iter().enumerate() {
            let least = workers[0];
            if l.worker >= least || !(l.at_s >= 0.0 && l.at_s.is_finite()) {
                return Err((format!("lost[{i}]"), format!(
                    "worker {} at {} s: needs a worker below the smallest count ({least}) and a time ≥ 0",
                    l.worker, l.at_s
                )));
            }
            if let Some(p) = platforms.iter().find(|p| p.info.hosts.len() < 2) {
                return Err((
                    format!("lost[{i}]"),
                    format!(
                        "{} is one node: turning its host off would stop the master too",
                        p.path.display()
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// The files a simulation file names, relative to its folder: checked to exist, platforms
/// loaded by SimGrid in a child of `exe`.
struct Files<'a> {
    path: &'a Path,
    base: PathBuf,
    exe: &'a Path,
}

impl Files<'_> {
    /// Platform `p`, loaded to check it (`what`: the field naming it).
    fn platform(&self, what: &str, p: &str) -> Result<Platform, SimConfigError> {
        let full = self.base.join(p);
        let info = child::inspect(self.exe, &full)
            .map_err(|m| field(self.path, what, format!("{}: {m}", full.display())))?;
        Ok(Platform {
            name: full
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            path: full,
            info,
        })
    }

    /// The `platforms`, each holding the largest worker count.
    fn platforms(
        &self,
        list: &[String],
        workers: &[usize],
    ) -> Result<Vec<Platform>, SimConfigError> {
        if list.is_empty() {
            return Err(field(
                self.path,
                "platforms",
                "must list at least one SimGrid platform file",
            ));
        }
        let most = *workers.last().unwrap_or(&1);
        let mut platforms = Vec::new();
        for (i, p) in list.iter().enumerate() {
            let pf = self.platform(&format!("platforms[{i}]"), p)?;
            if most > pf.info.worker_slots() {
                let of_hosts = if pf.info.hosts.len() > 1 {
                    " of the hosts after the master's"
                } else {
                    ""
                };
                return Err(field(
                    self.path,
                    &format!("platforms[{i}]"),
                    format!(
                        "{} holds {} workers (one per core{of_hosts}), not {most}",
                        pf.path.display(),
                        pf.info.worker_slots(),
                    ),
                ));
            }
            platforms.push(pf);
        }
        Ok(platforms)
    }

    /// File `p`, which must exist (`what`: the field naming it).
    fn existing(&self, what: &str, p: &str) -> Result<PathBuf, SimConfigError> {
        let full = self.base.join(p);
        std::fs::metadata(&full)
            .map_err(|e| field(self.path, what, format!("{}: {e}", full.display())))?;
        Ok(full)
    }
}

/// What `[validation]` resolves to: the measured runs and their platform, the MPI ones and a
/// platform per transport, the spinning MPI runs.
type Validations = (
    Option<(PathBuf, Platform)>,
    Option<(PathBuf, BTreeMap<String, Platform>)>,
    Option<PathBuf>,
);

impl ValidationEntry {
    /// The files and platforms it names, each checked.
    fn resolve(&self, at: &Files<'_>) -> Result<Validations, SimConfigError> {
        let validation = Some((
            at.existing("validation.measured", &self.measured)?,
            at.platform("validation.platform", &self.platform)?,
        ));
        let mpi = match &self.mpi_measured {
            Some(m) => {
                let measured = at.existing("validation.mpi_measured", m)?;
                if self.mpi_platforms.is_empty() {
                    return Err(field(
                        at.path,
                        "validation.mpi_platforms",
                        "must name a platform per measured transport (shared_memory = \"…xml\")",
                    ));
                }
                let mut platforms = BTreeMap::new();
                for (t, p) in &self.mpi_platforms {
                    let what = format!("validation.mpi_platforms.{t}");
                    platforms.insert(t.clone(), at.platform(&what, p)?);
                }
                Some((measured, platforms))
            }
            None if !self.mpi_platforms.is_empty() => {
                return Err(field(
                    at.path,
                    "validation.mpi_platforms",
                    "given without validation.mpi_measured",
                ))
            }
            None => None,
        };
        let spin = match &self.mpi_spin {
            Some(_) if mpi.is_none() => {
                return Err(field(
                    at.path,
                    "validation.mpi_spin",
                    "given without validation.mpi_measured",
                ))
            }
            Some(p) => Some(at.existing("validation.mpi_spin", p)?),
            None => None,
        };
        Ok((validation, mpi, spin))
    }
}

fn texts(v: &toml::Value) -> Result<Vec<String>, String> {
    let one = |v: &toml::Value| match v {
        toml::Value::String(s) => Ok(s.clone()),
        toml::Value::Integer(i) => Ok(i.to_string()),
        other => Err(format!("expected a number or a string, got {other}")),
    };
    match v {
        toml::Value::Array(a) if a.is_empty() => Err("empty list".into()),
        toml::Value::Array(a) => a.iter().map(one).collect(),
        v => Ok(vec![one(v)?]),
    }
}

/// One grid's configurations: `chunk` × `order` × every parameter the kind has.
fn expand(s: &SchedEntry) -> Result<Vec<SchedulerSpec>, (String, String)> {
    let kind = SchedulerKind::from_id(&s.kind).map_err(|e| ("kind".to_string(), e.msg))?;
    let chunks = s
        .grid
        .get("chunk")
        .ok_or(("chunk".to_string(), "missing".to_string()))?;
    let mut out = Vec::new();
    for c in texts(chunks).map_err(|m| ("chunk".to_string(), m))? {
        let chunk = Chunk::parse(&c).map_err(|e| ("chunk".to_string(), e.msg))?;
        out.push(SchedulerSpec::new(kind, chunk, 1));
    }
    for (name, value) in &s.grid {
        if name == "chunk" {
            continue;
        }
        let vals = texts(value).map_err(|m| (name.clone(), m))?;
        let mut next = Vec::new();
        for base in &out {
            for v in &vals {
                let mut spec = base.clone();
                if name == "order" {
                    spec.order =
                        crate::sched::Order::from_id(v).map_err(|e| (name.clone(), e.msg))?;
                } else {
                    spec.set(name, v).map_err(|e| (name.clone(), e.msg))?;
                }
                next.push(spec);
            }
        }
        out = next;
    }
    Ok(out)
}
