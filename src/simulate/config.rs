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
use crate::scene::SceneOverrides;
use crate::sched::{Chunk, Runner, SchedulerKind, SchedulerSpec};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SimFile {
    kind: String,
    name: Option<String>,
    #[serde(default)]
    description: String,
    workers: Vec<i64>,
    platforms: Vec<String>,
    probe: ProbeEntry,
    #[serde(default)]
    schedulers: Vec<SchedEntry>,
    #[serde(default)]
    lost: Vec<LostWorker>,
    validation: Option<ValidationEntry>,
    #[serde(default)]
    seed: u64,
    run_limit_s: Option<f64>,
    coarse_network_from: Option<i64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ProbeEntry {
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
    pub tracer: crate::tracer::TracerKind,
    /// Zero-work items, threads and runs of the dispatch measurement.
    pub dispatch: (u32, usize, u32),
    /// Pixel passes of the probe; each pixel's median is kept.
    pub probe_repetitions: u32,
    /// Bulk renders of the probe (≥ `probe_repetitions`): the costs' level is their median.
    pub probe_level_repetitions: u32,
    /// Pairs of passes (rows, then the layout) measuring each item layout's cost factor
    /// ([`crate::model::probe::layout_factor`]); 0: every factor 1.
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
    /// ([`crate::simulate::job::Network::Coarse`]); `None`: every run on SimGrid's.
    pub coarse_network_from: Option<usize>,
}

impl SimPlan {
    /// The network a run of `workers` workers is simulated on.
    pub fn network(&self, workers: usize) -> crate::simulate::job::Network {
        use crate::simulate::job::Network;
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
    if file.kind != "simulation" {
        return Err(field(
            path,
            "kind",
            format!(
                "'{}': `raysched simulate` takes kind = \"simulation\"",
                file.kind
            ),
        ));
    }
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let name = file.name.clone().unwrap_or_else(|| {
        path.file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    });
    if name.is_empty()
        || !name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    {
        return Err(field(
            path,
            "name",
            format!("'{name}': letters, digits, _ and - only"),
        ));
    }
    if file.workers.is_empty() {
        return Err(field(
            path,
            "workers",
            "must list at least one simulated worker count",
        ));
    }
    if let Some(bad) = file
        .workers
        .iter()
        .find(|&&w| !(1..=MAX_SIM_WORKERS).contains(&w))
    {
        return Err(field(
            path,
            "workers",
            format!("must be between 1 and {MAX_SIM_WORKERS} (got {bad})"),
        ));
    }
    let mut workers: Vec<usize> = file.workers.iter().map(|&w| w as usize).collect();
    workers.sort_unstable();
    workers.dedup();
    if file.schedulers.is_empty() {
        return Err(field(
            path,
            "schedulers",
            "must list at least one [[schedulers]] grid",
        ));
    }
    let mut specs = Vec::new();
    for (i, s) in file.schedulers.iter().enumerate() {
        specs.extend(expand(s).map_err(|(f, m)| field(path, &format!("schedulers[{i}].{f}"), m))?);
    }
    let load_platform = |what: &str, p: &str| -> Result<Platform, SimConfigError> {
        let full = base.join(p);
        let info = child::inspect(exe, &full)
            .map_err(|m| field(path, what, format!("{}: {m}", full.display())))?;
        Ok(Platform {
            name: full
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            path: full,
            info,
        })
    };
    if file.platforms.is_empty() {
        return Err(field(
            path,
            "platforms",
            "must list at least one SimGrid platform file",
        ));
    }
    let mut platforms = Vec::new();
    for (i, p) in file.platforms.iter().enumerate() {
        let pf = load_platform(&format!("platforms[{i}]"), p)?;
        let most = *workers.last().unwrap_or(&1);
        if most > pf.info.worker_slots() {
            return Err(field(
                path,
                &format!("platforms[{i}]"),
                format!(
                    "{} holds {} workers (one per core{}), not {most}",
                    pf.path.display(),
                    pf.info.worker_slots(),
                    if pf.info.hosts.len() > 1 {
                        " of the hosts after the master's"
                    } else {
                        ""
                    }
                ),
            ));
        }
        platforms.push(pf);
    }
    for (i, l) in file.lost.iter().enumerate() {
        let least = workers[0];
        if l.worker >= least || !(l.at_s >= 0.0 && l.at_s.is_finite()) {
            return Err(field(path, &format!("lost[{i}]"), format!(
                "worker {} at {} s: needs a worker below the smallest count ({least}) and a time ≥ 0",
                l.worker, l.at_s
            )));
        }
        if let Some(p) = platforms.iter().find(|p| p.info.hosts.len() < 2) {
            return Err(field(
                path,
                &format!("lost[{i}]"),
                format!(
                    "{} is one node: turning its host off would stop the master too",
                    p.path.display()
                ),
            ));
        }
    }
    if let Some((s, r)) = specs
        .iter()
        .find_map(|s| Some((s, Runner::Simulation.refuses(&s.policy)?)))
    {
        return Err(field(
            path,
            "schedulers",
            format!("{}: {} = {}", s.label(), r.param, r.as_value()),
        ));
    }
    let most = *workers.last().unwrap_or(&1);
    let budget = super::job::mapping_budget();
    if let Some(s) = specs
        .iter()
        .find(|s| super::job::actors_needed(s.kind(), most, file.lost.len()) > budget)
    {
        return Err(field(
            path,
            "workers",
            format!(
                "{most} simulated workers of {} need about {} SimGrid actors, more than this system's {budget} memory mappings per process (vm.max_map_count) allow",
                s.kind().id(),
                super::job::actors_needed(s.kind(), most, file.lost.len())
            ),
        ));
    }
    let probe = &file.probe;
    let tracer = crate::tracer::TracerKind::from_id(&probe.tracer)
        .and_then(crate::tracer::TracerKind::available)
        .map_err(|e| field(path, "probe.tracer", e))?;
    if probe.dispatch_items < 64 || probe.dispatch_workers == 0 || probe.dispatch_repetitions == 0 {
        return Err(field(
            path,
            "probe",
            "dispatch_items ≥ 64, dispatch_workers ≥ 1 and dispatch_repetitions ≥ 1",
        ));
    }
    let existing = |what: &str, p: &str| -> Result<PathBuf, SimConfigError> {
        let full = base.join(p);
        std::fs::metadata(&full)
            .map_err(|e| field(path, what, format!("{}: {e}", full.display())))?;
        Ok(full)
    };
    let validation = match &file.validation {
        None => None,
        Some(v) => Some((
            existing("validation.measured", &v.measured)?,
            load_platform("validation.platform", &v.platform)?,
        )),
    };
    let mpi_validation = match file.validation.as_ref().map(|v| (&v.mpi_measured, v)) {
        Some((Some(m), v)) => {
            let measured = existing("validation.mpi_measured", m)?;
            if v.mpi_platforms.is_empty() {
                return Err(field(
                    path,
                    "validation.mpi_platforms",
                    "must name a platform per measured transport (shared_memory = \"…xml\")",
                ));
            }
            let mut platforms = BTreeMap::new();
            for (t, p) in &v.mpi_platforms {
                let what = format!("validation.mpi_platforms.{t}");
                platforms.insert(t.clone(), load_platform(&what, p)?);
            }
            Some((measured, platforms))
        }
        Some((None, v)) if !v.mpi_platforms.is_empty() => {
            return Err(field(
                path,
                "validation.mpi_platforms",
                "given without validation.mpi_measured",
            ))
        }
        _ => None,
    };
    let mpi_spin = match file.validation.as_ref().and_then(|v| v.mpi_spin.as_ref()) {
        Some(_) if mpi_validation.is_none() => {
            return Err(field(
                path,
                "validation.mpi_spin",
                "given without validation.mpi_measured",
            ))
        }
        Some(p) => Some(existing("validation.mpi_spin", p)?),
        None => None,
    };
    Ok(SimPlan {
        name,
        description: file.description,
        file: path.to_path_buf(),
        workers,
        platforms,
        scene: base.join(&probe.scene),
        overrides: SceneOverrides {
            width: probe.width,
            height: probe.height,
            spp: probe.spp,
            max_depth: probe.max_depth,
            ..Default::default()
        },
        tracer,
        probe_repetitions: probe.probe_repetitions.max(1),
        probe_level_repetitions: probe
            .probe_level_repetitions
            .max(probe.probe_repetitions.max(1)),
        layout_repetitions: probe.layout_repetitions,
        dispatch: (
            probe.dispatch_items,
            probe.dispatch_workers,
            probe.dispatch_repetitions,
        ),
        specs,
        lost: file.lost,
        validation,
        mpi_validation,
        mpi_spin,
        seed: file.seed,
        run_limit_s: match file.run_limit_s {
            Some(t) if !(t > 0.0 && t <= 86_400.0) => {
                return Err(field(
                    path,
                    "run_limit_s",
                    format!("must be in (0, 86400] seconds (got {t})"),
                ))
            }
            t => t,
        },
        coarse_network_from: match file.coarse_network_from {
            Some(w) if !(1..=MAX_SIM_WORKERS).contains(&w) => {
                return Err(field(
                    path,
                    "coarse_network_from",
                    format!("must be a worker count in 1..={MAX_SIM_WORKERS} (got {w})"),
                ))
            }
            w => w.map(|w| w as usize),
        },
    })
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
