//! `runs.csv`: long format, one row per timed run, appended and resumable.
//!
//! Crash safety: each row is serialised first and written with a single `write_all` of the whole
//! line, then flushed, on a file opened for appending. A kill at any moment can therefore leave at
//! most one trailing partial line; [`RunsFile::open`] drops a last line that lacks its newline or
//! has the wrong column count, and truncates the file to the last good row.

use super::plan::{ExperimentPlan, RunConfig};
use crate::sched::{param_columns, share_columns, source_params};
use crate::util::hash::{fnv, hex};
use serde::{Deserialize, Serialize};
use std::collections::HashSet;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

mod file;
mod ids;
mod read;
#[cfg(test)]
mod tests;
pub use file::{OldRuns, RunsFile};
use ids::*;
pub use ids::{assign_ids, config_id};
use read::*;
pub use read::{parse_runs, read_runs, ResultsError, RunsParseError};

/// One timed run. Column order is the file's column order; `None` is an empty cell
/// (a parameter the scheduler does not have).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunRow {
    /// The experiment's name.
    pub experiment: String,
    /// The configuration's id (16 hex digits of its config columns).
    pub config: String,
    /// The scene's name.
    pub scene: String,
    /// The scene file as written in the experiment file.
    pub scene_file: String,
    /// The scene's hash when measured, 16 hex digits (checked on resume).
    pub scene_hash: String,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Maximum path depth.
    pub max_depth: i32,
    /// The experiment's generator-count override, if any.
    pub generator_count: Option<u64>,
    /// The tracer's id.
    pub tracer: String,
    /// Scheduler id, or `serial` for the baseline.
    pub scheduler: String,
    /// The scheduler's label with its settings (`serial` for the baseline).
    pub label: String,
    /// The chunk setting in its text form (`1`, `frame`, …); `None` for the baseline.
    pub chunk: Option<String>,
    /// Pixels per item (the x axis of the granularity plots).
    pub chunk_px: Option<u64>,
    /// The item order's id; `None` for the baseline.
    pub order: Option<String>,
    /// One cell per [`crate::sched::param_columns`] entry, written right after `order`: the
    /// parameter's text form, `None` where the scheduler has no such parameter.
    #[serde(skip)]
    pub params: Vec<Option<String>>,
    /// Worker threads or ranks (1 for the baseline).
    pub workers: usize,
    /// The repetition's index, from 0.
    pub repetition: u32,
    /// Wall time of the timed render, seconds.
    pub wall_s: f64,
    /// Median wall time of the serial baseline this run is compared with.
    pub serial_s: f64,
    /// `serial_s / wall_s`.
    pub speedup: f64,
    /// `speedup / workers`.
    pub efficiency: f64,
    /// workers · wall − serial.
    pub overhead_s: f64,
    /// Σ worker busy time.
    pub work_s: f64,
    /// Master time spent handing out and collecting (on its own thread).
    pub dispatch_s: f64,
    /// Σ worker idle time.
    pub idle_s: f64,
    /// max busy / mean busy (1 = balanced).
    pub imbalance: f64,
    /// The part of idle caused by uneven work: Σ (max busy − busy).
    pub imbalance_s: f64,
    /// Items in the decomposition of the image.
    pub items: u64,
    /// Hand-outs, re-issues included.
    pub issued: u64,
    /// Hand-outs of an item that was already handed out.
    pub reissued: u64,
    /// Results that arrived for an item already done (discarded).
    pub duplicates: u64,
    /// Serialised bytes of items sent plus results returned.
    pub bytes: u64,
    /// Rays traced.
    pub rays: u64,
    /// Samples that came out NaN/Inf (dropped, never written).
    pub nonfinite: u64,
    /// What the scene's render path uses and leaves out, `+`-separated (e.g.
    /// `spheres+environment+shadow_rays` / `triangles+bvh+…`).
    pub features_used: String,
    /// What the render path leaves out, in the same form.
    pub features_left_out: String,
    /// The rendered image's hash, 16 hex digits.
    pub image_hash: String,
    /// The image hash equals the serial baseline's.
    pub identical: bool,
    /// Who rendered: `local` (threads) or `mpi` (ranks). The last three columns came with
    /// MPI; files written before them are read (and rewritten on resume) with these defaults.
    #[serde(default = "local")]
    pub sources: String,
    /// Total ranks of the `mpirun` launch an MPI row, or its local-thread baseline
    /// (`ranks − 1` threads), belongs to; empty elsewhere.
    #[serde(default)]
    pub ranks: Option<usize>,
    /// The launch's transport (`shared_memory`, `tcp_loopback`, … or `unknown`), MPI rows only.
    #[serde(default)]
    pub transport: Option<String>,
    /// The heterogeneous-run setting (`K:F`: the first K workers F× slower), empty for equal
    /// workers and the baseline. Files written before it are read with it empty.
    #[serde(default)]
    pub slow: Option<String>,
    /// Renders inside this timed sample; `wall_s` is their mean (1 in files before it).
    #[serde(default = "one")]
    pub inner: u32,
    /// UTC when the sample was taken (empty in files before it).
    #[serde(default)]
    pub timestamp: String,
    /// User CPU seconds of the whole process during the sample (all renders of it).
    #[serde(default)]
    pub user_s: Option<f64>,
    /// System CPU seconds of the whole process during the sample.
    #[serde(default)]
    pub sys_s: Option<f64>,
    /// 1-minute load average just before the sample.
    #[serde(default)]
    pub load_before: Option<f64>,
    /// 1-minute load average just after it.
    #[serde(default)]
    pub load_after: Option<f64>,
    /// Seconds of the machine-speed probe ([`super::speed::probe_s`]) taken at the start of this
    /// sample's round (empty in files before it).
    #[serde(default)]
    pub probe_s: Option<f64>,
    /// The id of the process that took the sample (rows of one process share it; with
    /// `isolation = "round"` each round has its own; empty in files before it).
    #[serde(default)]
    pub process: Option<u32>,
    /// The cost model's predicted wall time of one render (`predict = true`; empty otherwise
    /// and in files before it).
    #[serde(default)]
    pub predicted_wall_s: Option<f64>,
    /// Its hand-out part: fixed cost + h × items / P.
    #[serde(default)]
    pub predicted_handout_s: Option<f64>,
    /// Its refill-waiting part (the master's sources waiting for the next item).
    #[serde(default)]
    pub predicted_refill_s: Option<f64>,
    /// Its imbalance part (the last worker's lead over the mean, noise included).
    #[serde(default)]
    pub predicted_imbalance_s: Option<f64>,
    /// Rows with a GPU source (whose image rounds differently, so is never bit-identical):
    /// the mean per-pixel difference to the serial image over its standard error
    /// ([`super::image_check`]); empty elsewhere and in files before it.
    #[serde(default)]
    pub image_z: Option<f64>,
    /// Rows with a GPU source: the image agrees with the serial one within 3σ of the paired
    /// per-pixel differences (empty elsewhere).
    #[serde(default)]
    pub agrees: Option<bool>,
    /// One cell per [`crate::sched::source_params`] entry (`gpu_chunk`, `gpu_buffer`,
    /// `balance`), then one per [`crate::sched::share_columns`] entry (`threads_items`,
    /// `threads_pixels`, `threads_busy_s`, `gpu_items`, …: who rendered what), written at the
    /// end of the row; empty where unset, for a kind that did not render, and in files
    /// before them.
    #[serde(skip)]
    pub sourcing: Vec<Option<String>>,
}

fn local() -> String {
    crate::sched::sources::THREADS_COLUMN.into()
}
fn one() -> u32 {
    1
}

/// The columns after the struct's own, from the compute-source definition: the per-source
/// settings, then the per-kind shares.
pub fn sourcing_columns() -> impl Iterator<Item = &'static str> {
    source_params()
        .iter()
        .map(|p| p.name.as_str())
        .chain(share_columns().iter().map(String::as_str))
}

/// Where the parameter columns start: right after `order`.
fn params_at(cols: &[String]) -> usize {
    cols.iter()
        .position(|c| c == "order")
        .map_or(cols.len(), |i| i + 1)
}

/// The `scheduler` (and label) of the serial baseline's rows: no scheduler, one thread
/// renders the rows in order.
pub const SERIAL: &str = "serial";

/// Where configuration `config`'s Gantt timeline goes: `dir/timelines/<config>.csv`.
pub fn timeline_path(dir: &Path, config: &str) -> PathBuf {
    dir.join("timelines").join(format!("{config}.csv"))
}

impl RunRow {
    /// Is this a row of the serial baseline?
    pub fn is_serial(&self) -> bool {
        self.scheduler == SERIAL
    }

    /// Were its workers equal (the `slow` column empty or `none`)?
    pub fn equal_workers(&self) -> bool {
        self.slow
            .as_deref()
            .is_none_or(|v| crate::sched::Slow::parse(v).is_ok_and(|s| s.is_none()))
    }

    /// Did MPI ranks render it (the `sources` column `mpi`)?
    pub fn on_mpi(&self) -> bool {
        self.sources == crate::sched::SourceKind::Mpi.id()
    }

    /// Did this process's threads alone render it (the `sources` column `local`)?
    pub fn on_threads_alone(&self) -> bool {
        self.sources == crate::sched::sources::THREADS_COLUMN
    }

    /// The column names, in order: the struct's fields (from serde, so they never drift from
    /// it) with the scheduler parameters' columns after `order`.
    pub fn header() -> Vec<String> {
        let mut w = csv::Writer::from_writer(vec![]);
        w.serialize(Self::example()).expect("serialise example row");
        let bytes = w.into_inner().expect("flush to Vec");
        let text = String::from_utf8(bytes).expect("utf8");
        let mut cols: Vec<String> = text
            .lines()
            .next()
            .unwrap_or("")
            .split(',')
            .map(str::to_string)
            .collect();
        let at = params_at(&cols);
        cols.splice(at..at, param_columns().iter().map(|p| p.name.to_string()));
        cols.extend(sourcing_columns().map(str::to_string));
        cols
    }

    /// The value of per-source column `name` (a [`crate::sched::source_params`] or
    /// [`crate::sched::share_columns`] entry; `None`: empty).
    pub fn sourcing(&self, name: &str) -> Option<&str> {
        let i = sourcing_columns().position(|c| c == name)?;
        self.sourcing.get(i)?.as_deref()
    }

    /// Who rendered what, per kind in `SourceKind::ALL` order (`None`: the kind did not
    /// render, or the row predates the columns).
    pub fn shares(&self) -> Vec<Option<crate::sched::Share>> {
        let skip = source_params().len();
        crate::sched::Share::from_cells(self.sourcing.get(skip..).unwrap_or_default())
    }

    /// The master's buffer size (what the buffer plots are drawn against).
    pub fn buffer(&self) -> Option<usize> {
        self.param("buffer")
            .and_then(crate::sched::spec::parse_param)
    }

    /// The value of scheduler parameter `name` (`None`: the scheduler has none).
    pub fn param(&self, name: &str) -> Option<&str> {
        let i = param_columns().iter().position(|p| p.name == name)?;
        self.params.get(i)?.as_deref()
    }
    pub(crate) fn example() -> Self {
        Self {
            experiment: String::new(),
            config: String::new(),
            scene: String::new(),
            scene_file: String::new(),
            scene_hash: String::new(),
            width: 0,
            height: 0,
            spp: 0,
            max_depth: 0,
            generator_count: None,
            tracer: String::new(),
            scheduler: String::new(),
            label: String::new(),
            chunk: None,
            chunk_px: None,
            order: None,
            params: vec![None; param_columns().len()],
            workers: 0,
            repetition: 0,
            wall_s: 0.0,
            serial_s: 0.0,
            speedup: 0.0,
            efficiency: 0.0,
            overhead_s: 0.0,
            work_s: 0.0,
            dispatch_s: 0.0,
            idle_s: 0.0,
            imbalance: 0.0,
            imbalance_s: 0.0,
            items: 0,
            issued: 0,
            reissued: 0,
            duplicates: 0,
            bytes: 0,
            rays: 0,
            nonfinite: 0,
            features_used: String::new(),
            features_left_out: String::new(),
            image_hash: String::new(),
            identical: false,
            sources: local(),
            ranks: None,
            transport: None,
            slow: None,
            inner: 1,
            timestamp: String::new(),
            user_s: None,
            sys_s: None,
            load_before: None,
            load_after: None,
            probe_s: None,
            process: None,
            predicted_wall_s: None,
            predicted_handout_s: None,
            predicted_refill_s: None,
            predicted_imbalance_s: None,
            image_z: None,
            agrees: None,
            sourcing: vec![None; sourcing_columns().count()],
        }
    }

    /// A row with every config column of `c` filled and every measurement zero.
    pub fn for_config(plan: &ExperimentPlan, c: &RunConfig) -> Self {
        let ps = plan.scene_of(c);
        let sc = &ps.scene;
        let b = &plan.baselines[c.baseline];
        let mut r = Self::example();
        r.experiment = plan.name.clone();
        r.config = c.id.clone();
        r.scene = sc.name.clone();
        r.scene_file = ps.file.clone();
        r.scene_hash = hex(sc.hash);
        r.width = sc.width();
        r.height = sc.height();
        r.spp = sc.settings.spp;
        r.max_depth = sc.settings.max_depth;
        r.generator_count = ps.overrides.generator_count;
        r.tracer = b.tracer_id.clone();
        r.sources = c.sources.id();
        r.ranks = c.ranks;
        let mut setup_label = String::new();
        match &c.sources {
            super::plan::Sources::Mpi { transport } => r.transport = Some(transport.clone()),
            super::plan::Sources::Local(setup) => {
                for (cell, p) in r.sourcing.iter_mut().zip(source_params()) {
                    *cell = setup.get_param(&p.name);
                }
                setup_label = setup.label();
            }
        }
        match &c.spec {
            None => {
                r.scheduler = SERIAL.into();
                r.label = SERIAL.into();
                r.workers = 1;
            }
            Some(s) => {
                r.scheduler = s.kind().id().into();
                r.label = s.label() + &setup_label;
                // The tiles actually cut (the production-renderer policies choose their own).
                let (chunk, order) = s.layout(sc.width(), sc.height());
                r.chunk = Some(chunk.to_string());
                r.chunk_px = Some(chunk.pixels(sc.width(), sc.height()));
                r.order = Some(order.id().into());
                r.slow = (!s.slow.is_none()).then(|| s.slow.to_string());
                r.params = param_columns().iter().map(|p| s.get(p.name)).collect();
                r.workers = s.workers;
            }
        }
        r
    }

    /// The config columns joined: what the config id hashes (the scene hash is checked
    /// separately, so an edited scene file is refused rather than silently re-keyed).
    fn config_key(&self) -> String {
        let o = |v: &Option<String>| v.clone().unwrap_or_default();
        let n = |v: Option<usize>| v.map(|x| x.to_string()).unwrap_or_default();
        let mut key = [
            self.scene_file.clone(),
            self.scene.clone(),
            self.width.to_string(),
            self.height.to_string(),
            self.spp.to_string(),
            self.max_depth.to_string(),
            self.generator_count
                .map(|g| g.to_string())
                .unwrap_or_default(),
            self.tracer.clone(),
            self.scheduler.clone(),
            o(&self.chunk),
            o(&self.order),
        ]
        .into_iter()
        .chain(
            KEYED_BY_POSITION
                .iter()
                .map(|name| o(&self.param(name).map(str::to_string))),
        )
        .chain([self.workers.to_string()])
        .collect::<Vec<_>>()
        .join("|");
        key += &named_params_key(
            param_columns()
                .iter()
                .map(|p| p.name)
                .zip(&self.params)
                .map(|(name, v)| (name, v.as_deref())),
            |name| default_of(&self.scheduler, name),
        );
        // Only rows of an MPI experiment carry these, so every older id stays what it was.
        if self.ranks.is_some() {
            key += &format!("|{}|{}|{}", self.sources, n(self.ranks), o(&self.transport));
        }
        // Likewise only heterogeneous rows carry a slowdown.
        if let Some(slow) = &self.slow {
            key += &format!("|slow={slow}");
        }
        // ... and only rows with other sources than threads their set and settings.
        if self.ranks.is_none() && !self.on_threads_alone() {
            key += &format!("|sources={}", self.sources);
        }
        for (name, v) in sourcing_columns()
            .zip(&self.sourcing)
            .take(source_params().len())
        {
            if let Some(v) = v {
                key += &format!("|{name}={v}");
            }
        }
        key
    }

    /// One CSV line, newline included.
    pub fn to_line(&self) -> Vec<u8> {
        let mut fields = csv::WriterBuilder::new()
            .has_headers(false)
            .from_writer(vec![]);
        fields.serialize(self).expect("a RunRow always serialises");
        let line = fields.into_inner().expect("flush to Vec");
        let mut record = csv::ReaderBuilder::new()
            .has_headers(false)
            .from_reader(&line[..])
            .records()
            .next()
            .and_then(Result::ok)
            .expect("a serialised row reads back");
        let at = params_at(&Self::header()[..]);
        let mut cells: Vec<String> = record.iter().map(str::to_string).collect();
        cells.splice(
            at..at,
            self.params.iter().map(|p| p.clone().unwrap_or_default()),
        );
        cells.extend(self.sourcing.iter().map(|c| c.clone().unwrap_or_default()));
        record = csv::StringRecord::from(cells);
        let mut w = csv::WriterBuilder::new()
            .has_headers(false)
            .from_writer(vec![]);
        w.write_record(&record).expect("write to Vec");
        w.into_inner().expect("flush to Vec")
    }

    /// A row from its cells under `names` (a prefix of [`Self::header`]): the parameter
    /// columns are taken out, the rest deserialised by name.
    /// An unreadable cell is named: `column N (name): `text` is not a valid value`.
    fn parse_record(rec: &csv::StringRecord, names: &csv::StringRecord) -> Result<Self, String> {
        if rec.len() != names.len() {
            return Err(format!(
                "{} cells, the header has {}",
                rec.len(),
                names.len()
            ));
        }
        let params = param_columns();
        let is_param =
            |n: &str| params.iter().any(|p| p.name == n) || sourcing_columns().any(|c| c == n);
        let rest_names: csv::StringRecord = names.iter().filter(|n| !is_param(n)).collect();
        let rest: csv::StringRecord = names
            .iter()
            .zip(rec.iter())
            .filter(|(n, _)| !is_param(n))
            .map(|(_, v)| v)
            .collect();
        let mut row: Self = rest.deserialize(Some(&rest_names)).map_err(|e| {
            let field = match e.kind() {
                csv::ErrorKind::Deserialize { err, .. } => err.field(),
                _ => None,
            };
            let Some(name) = field.and_then(|f| rest_names.get(f as usize)) else {
                return e.to_string();
            };
            let col = names.iter().position(|n| n == name).map_or(0, |i| i + 1);
            let value = rest.get(field.unwrap_or(0) as usize).unwrap_or("");
            // A cell may be huge or hold control characters; the message stays one short line.
            let shown: String = value.chars().take(40).collect();
            let more = if shown.len() < value.len() { "…" } else { "" };
            format!(
                "column {col} ({name}): `{}{more}` is not a valid value",
                crate::util::one_line::escape_controls(&shown)
            )
        })?;
        row.params = params
            .iter()
            .map(|p| {
                let v = names.iter().position(|n| n == p.name).map(|i| &rec[i])?;
                (!v.is_empty()).then(|| v.to_string())
            })
            .collect();
        row.sourcing = sourcing_columns()
            .map(|c| {
                let v = names.iter().position(|n| n == c).map(|i| &rec[i])?;
                (!v.is_empty()).then(|| v.to_string())
            })
            .collect();
        Ok(row)
    }
}
