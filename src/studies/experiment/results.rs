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

/// Give every configuration its id; the same configuration listed twice (overlapping grids)
/// is timed once.
pub fn assign_ids(plan: &mut ExperimentPlan) {
    let mut seen = std::collections::HashSet::new();
    let mut unique = Vec::new();
    for mut c in std::mem::take(&mut plan.configs) {
        c.id = config_id(plan, &c);
        if seen.insert(c.id.clone()) {
            unique.push(c);
        }
    }
    plan.configs = unique;
}

/// The stable id of a configuration: FNV-1a of its config columns.
pub fn config_id(plan: &ExperimentPlan, c: &RunConfig) -> String {
    hex(fnv(RunRow::for_config(plan, c).config_key().as_bytes()))
}

/// The scheduler parameters whose values the config id joins by position, as the columns
/// stood when this scheme was fixed. A parameter added since enters the key by
/// name and only off its kind's default ([`named_params_key`]), so adding one to a scheduler
/// leaves every id of an earlier `runs.csv` as it was: `resume` and `compare` still pair them.
const KEYED_BY_POSITION: [&str; 9] = [
    "buffer", "requeue", "wait", "returns", "passes", "grab", "guided_k", "weights", "fsc_warm",
];

/// `|name=value` for each parameter outside [`KEYED_BY_POSITION`] that has a value other
/// than `default(name)`; empty for a configuration at every newer parameter's default.
fn named_params_key<'a>(
    params: impl Iterator<Item = (&'a str, Option<&'a str>)>,
    default: impl Fn(&str) -> Option<String>,
) -> String {
    params
        .filter(|(name, _)| !KEYED_BY_POSITION.contains(name))
        .filter_map(|(name, v)| {
            let v = v?;
            (default(name).as_deref() != Some(v)).then(|| format!("|{name}={v}"))
        })
        .collect()
}

/// Parameter `name`'s default text for scheduler `scheduler` (its id), if the kind has it.
fn default_of(scheduler: &str, name: &str) -> Option<String> {
    let kind = crate::sched::SchedulerKind::from_id(scheduler).ok()?;
    crate::sched::Policy::defaults(kind).params()?.get(name)
}

/// Reading or writing `runs.csv` failed.
#[derive(Debug, thiserror::Error)]
pub enum ResultsError {
    /// The file's content cannot be resumed from (foreign header, bad row, duplicate row).
    #[error("{path}: {msg}")]
    Corrupt {
        /// The file.
        path: String,
        /// What is wrong, and how to recover.
        msg: String,
    },
    /// An I/O error on the file.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> ResultsError + '_ {
    move |source| ResultsError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// Rows of a runs.csv read leniently: a trailing partial line (a killed run) is ignored.
/// Returns the rows and the byte length of the valid prefix.
pub fn read_runs(path: &Path) -> Result<(Vec<RunRow>, u64), ResultsError> {
    let bytes = std::fs::read(path).map_err(io(path))?;
    parse_runs_of(path, &bytes)
}

/// [`parse_runs`] of the bytes read from `path`, a parse failure naming the file.
fn parse_runs_of(path: &Path, bytes: &[u8]) -> Result<(Vec<RunRow>, u64), ResultsError> {
    parse_runs(bytes).map_err(|msg| ResultsError::Corrupt {
        path: path.display().to_string(),
        msg,
    })
}

/// Parse runs.csv bytes; see [`read_runs`]. A missing or partial header gives no rows and length 0.
pub fn parse_runs(bytes: &[u8]) -> Result<(Vec<RunRow>, u64), String> {
    let columns = RunRow::header();
    let header = columns.join(",");
    let Some(h_end) = bytes.iter().position(|&b| b == b'\n') else {
        return Ok((vec![], 0));
    };
    let Some(names) = known_header(&bytes[..h_end]) else {
        return Err(format!(
            "the header is not this version's columns (expected '{header}'); rerun with --fresh"
        ));
    };
    // Fields are matched by name, so the columns an earlier version's row lacks (parameters of
    // schedulers added since, the MPI and sample columns) take their defaults.
    let ncols = names.len();
    let mut rows = Vec::new();
    let mut valid = h_end as u64 + 1;
    let mut start = h_end + 1;
    let mut line_no = 1;
    while start < bytes.len() {
        line_no += 1;
        // No newline: the tail of a killed write. Dropped.
        let Some(len) = bytes[start..].iter().position(|&b| b == b'\n') else {
            break;
        };
        let line = &bytes[start..start + len];
        let end = start + len + 1;
        let is_last = end >= bytes.len();
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .from_reader(line);
        let parsed = match rdr.records().next() {
            Some(Ok(rec)) if rec.len() == ncols => RunRow::parse_record(&rec, &names).map_err(Some),
            _ => Err(None),
        };
        match parsed {
            Ok(row) => rows.push(row),
            // A complete-looking last line with the wrong columns is a torn write too; one
            // with every column but an unreadable cell was written whole, so it is corrupt.
            Err(None) if is_last => break,
            Err(None) => {
                return Err(format!(
                    "line {line_no} is not a valid row; rerun with --fresh"
                ))
            }
            Err(Some(cell)) => return Err(format!("line {line_no}, {cell}")),
        }
        valid = end as u64;
        start = end;
    }
    Ok((rows, valid))
}

/// The names of a header this version reads: this version's columns, or an earlier version's
/// (a subset of them: every name known, none twice). `None` for anything else.
fn known_header(line: &[u8]) -> Option<csv::StringRecord> {
    let columns = RunRow::header();
    let text = std::str::from_utf8(line).ok()?;
    let names: Vec<&str> = text.split(',').collect();
    let mut seen = HashSet::new();
    let known = names
        .iter()
        .all(|n| columns.iter().any(|c| c == n) && seen.insert(*n));
    (known && names.contains(&"config")).then(|| csv::StringRecord::from(names))
}

/// A readable header other than this version's: the file is rewritten before appending.
fn is_legacy_header(line: &[u8]) -> bool {
    line != RunRow::header().join(",").as_bytes() && known_header(line).is_some()
}

/// runs.csv opened for appending, with the (config, repetition) pairs already in it.
pub struct RunsFile {
    /// The runs.csv path.
    pub path: PathBuf,
    file: File,
    done: HashSet<(String, u32)>,
}

impl RunsFile {
    /// Open (or create) `path`. With `fresh` any old content is discarded; otherwise a trailing
    /// partial row is dropped and the rest kept. Returns the file and the rows already in it.
    pub fn open(path: &Path, fresh: bool) -> Result<(Self, Vec<RunRow>), ResultsError> {
        Self::read(path, fresh)?.open()
    }

    /// Read `path` (one read) without changing it, so a caller can check its rows before
    /// [`OldRuns::open`] appends to it; with `fresh`, or where it does not exist, no rows.
    pub fn read(path: &Path, fresh: bool) -> Result<OldRuns, ResultsError> {
        let (rows, valid, legacy) = if fresh || !path.exists() {
            (vec![], 0, false)
        } else {
            let bytes = std::fs::read(path).map_err(io(path))?;
            let legacy = bytes
                .split(|&c| c == b'\n')
                .next()
                .is_some_and(is_legacy_header);
            let (rows, valid) = parse_runs_of(path, &bytes)?;
            (rows, valid, legacy)
        };
        // Checked here, before anything is written: a refused resume changes no file.
        let mut seen = HashSet::new();
        for r in &rows {
            if !seen.insert((&r.config, r.repetition)) {
                return Err(ResultsError::Corrupt {
                    path: path.display().to_string(),
                    msg: format!(
                        "config {} repetition {} appears twice; rerun with --fresh",
                        r.config, r.repetition
                    ),
                });
            }
        }
        Ok(OldRuns {
            path: path.to_path_buf(),
            rows,
            valid,
            legacy,
        })
    }
}

/// runs.csv as [`RunsFile::read`] found it: its rows, and what opening it for appending does.
pub struct OldRuns {
    path: PathBuf,
    /// The complete rows already in it.
    pub rows: Vec<RunRow>,
    /// Bytes up to the end of its last complete row.
    valid: u64,
    /// Its header is an earlier version's: it is rewritten in this version's columns.
    legacy: bool,
}

impl OldRuns {
    /// Open the file for appending: a legacy file rewritten (atomically), a trailing partial
    /// row cut off, a header written to an empty one. Returns the file and its rows.
    pub fn open(self) -> Result<(RunsFile, Vec<RunRow>), ResultsError> {
        let Self {
            path,
            rows,
            valid,
            legacy,
        } = self;
        let path = path.as_path();
        if legacy {
            // Rewrite in this version's columns (atomically) before appending to it.
            let mut text = RunRow::header().join(",").into_bytes();
            text.push(b'\n');
            for r in &rows {
                text.extend(r.to_line());
            }
            let tmp = path.with_extension("csv.tmp");
            std::fs::write(&tmp, &text).map_err(io(&tmp))?;
            std::fs::rename(&tmp, path).map_err(io(path))?;
        }
        let valid = if legacy {
            std::fs::metadata(path).map_err(io(path))?.len()
        } else {
            valid
        };
        let done = rows
            .iter()
            .map(|r| (r.config.clone(), r.repetition))
            .collect();
        let mut file = OpenOptions::new()
            .create(true)
            .read(true)
            .write(true)
            .truncate(false)
            .open(path)
            .map_err(io(path))?;
        file.set_len(valid).map_err(io(path))?;
        drop(file);
        file = OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(io(path))?;
        if valid == 0 {
            let mut h = RunRow::header().join(",").into_bytes();
            h.push(b'\n');
            file.write_all(&h).map_err(io(path))?;
            file.flush().map_err(io(path))?;
        }
        Ok((
            RunsFile {
                path: path.to_path_buf(),
                file,
                done,
            },
            rows,
        ))
    }
}

impl RunsFile {
    /// Is repetition `repetition` of configuration `config` already in the file?
    pub fn is_done(&self, config: &str, repetition: u32) -> bool {
        self.done.contains(&(config.to_string(), repetition))
    }

    /// Append one row: one `write_all` of the whole line, then flush.
    pub fn append(&mut self, row: &RunRow) -> Result<(), ResultsError> {
        self.file
            .write_all(&row.to_line())
            .map_err(io(&self.path))?;
        self.file.flush().map_err(io(&self.path))?;
        self.done.insert((row.config.clone(), row.repetition));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(config: &str, rep: u32) -> RunRow {
        let mut r = RunRow::example();
        r.config = config.into();
        r.repetition = rep;
        r.scheduler = "master".into();
        r.label = "master chunk=1 B=2".into();
        r.chunk = Some("1".into());
        r.wall_s = 0.25;
        r
    }

    #[test]
    fn rows_round_trip_and_torn_tails_are_dropped() {
        let mut bytes = RunRow::header().join(",").into_bytes();
        bytes.push(b'\n');
        bytes.extend(row("a", 0).to_line());
        bytes.extend(row("a", 1).to_line());
        let whole = bytes.len() as u64;
        let (rows, valid) = parse_runs(&bytes).unwrap();
        assert_eq!(rows, vec![row("a", 0), row("a", 1)]);
        assert_eq!(valid, whole);
        // Every possible cut of a third line leaves exactly the two whole rows.
        let third = row("b", 0).to_line();
        for cut in 0..third.len() {
            let mut b = bytes.clone();
            b.extend_from_slice(&third[..cut]);
            let (rows, valid) = parse_runs(&b).unwrap();
            assert_eq!(rows.len(), 2, "cut at {cut}");
            assert_eq!(valid, whole, "cut at {cut}");
        }
        // A last line that ends in a newline but has too few columns is dropped too.
        let mut b = bytes.clone();
        b.extend_from_slice(b"x,y\n");
        assert_eq!(parse_runs(&b).unwrap().1, whole);
        // ... but the same damage in the middle is corruption, not a torn write.
        let mut b = bytes.clone();
        b.extend_from_slice(b"x,y\n");
        b.extend(row("c", 0).to_line());
        assert!(parse_runs(&b).unwrap_err().contains("line 4"));
    }

    /// The columns added with MPI, before [`SAMPLE_COLUMNS`] and `slow`.
    const MPI_COLUMNS: usize = 3;
    /// The columns added with adaptive repetitions and the speed probe, before
    /// [`PREDICTION_COLUMNS`].
    const SAMPLE_COLUMNS: usize = 7;
    /// The cost model's columns, before [`CHECK_COLUMNS`].
    const PREDICTION_COLUMNS: usize = 4;
    /// The GPU image check's columns, before the per-source ones.
    const CHECK_COLUMNS: usize = 2;
    /// The per-source settings and shares, at the end of the row.
    fn source_columns() -> usize {
        sourcing_columns().count()
    }

    #[test]
    fn a_runs_file_from_before_the_mpi_columns_is_read_and_upgraded_on_resume() {
        let cols = RunRow::header();
        let old =
            MPI_COLUMNS + SAMPLE_COLUMNS + PREDICTION_COLUMNS + CHECK_COLUMNS + source_columns();
        let old_header = cols[..cols.len() - old].join(",");
        let strip = |r: &RunRow| {
            let line = String::from_utf8(r.to_line()).unwrap();
            let fields: Vec<&str> = line.trim_end().split(',').collect();
            fields[..fields.len() - old].join(",") + "\n"
        };
        let text = format!(
            "{old_header}\n{}{}",
            strip(&row("a", 0)),
            strip(&row("a", 1))
        );
        let (rows, valid) = parse_runs(text.as_bytes()).unwrap();
        assert_eq!(rows, vec![row("a", 0), row("a", 1)]);
        assert_eq!(rows[0].sources, "local");
        assert_eq!(valid, text.len() as u64);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("runs.csv");
        std::fs::write(&p, &text).unwrap();
        let (mut f, rows) = RunsFile::open(&p, false).unwrap();
        assert_eq!(rows.len(), 2);
        let mut r = row("b", 0);
        r.sources = "mpi".into();
        r.ranks = Some(3);
        r.transport = Some("shared_memory".into());
        f.append(&r).unwrap();
        let back = std::fs::read_to_string(&p).unwrap();
        assert!(back.starts_with(&(cols.join(",") + "\n")), "{back}");
        assert_eq!(read_runs(&p).unwrap().0, vec![row("a", 0), row("a", 1), r]);
    }

    #[test]
    fn a_runs_file_from_before_the_prediction_columns_reads_them_empty() {
        let cols = RunRow::header();
        let later = PREDICTION_COLUMNS + CHECK_COLUMNS + source_columns();
        assert_eq!(cols[cols.len() - later], "predicted_wall_s");
        let old_header = cols[..cols.len() - later].join(",");
        let line = String::from_utf8(row("a", 0).to_line()).unwrap();
        let fields: Vec<&str> = line.trim_end().split(',').collect();
        let text = format!(
            "{old_header}\n{}\n",
            fields[..fields.len() - later].join(",")
        );
        let (rows, _) = parse_runs(text.as_bytes()).unwrap();
        assert_eq!(rows, vec![row("a", 0)]);
        assert_eq!(rows[0].predicted_wall_s, None);
        // And a row with a prediction round-trips.
        let mut p = row("b", 0);
        p.predicted_wall_s = Some(0.125);
        p.predicted_handout_s = Some(0.001);
        let mut bytes = (cols.join(",") + "\n").into_bytes();
        bytes.extend(p.to_line());
        assert_eq!(parse_runs(&bytes).unwrap().0, vec![p]);
    }

    #[test]
    fn per_source_columns_derive_from_the_kinds_round_trip_and_read_empty_in_old_files() {
        let cols = RunRow::header();
        let n = source_columns();
        let tail: Vec<&str> = cols[cols.len() - n..].iter().map(String::as_str).collect();
        assert_eq!(
            &tail[..4],
            ["gpu_chunk", "gpu_buffer", "balance", "threads_items"]
        );
        assert!(tail.contains(&"gpu_busy_s") && tail.contains(&"mpi_pixels"));
        // A row of a threads+gpu run round-trips with its settings and shares.
        let mut r = row("g", 0);
        r.sources = "threads+gpu".into();
        r.image_z = Some(-0.5);
        r.agrees = Some(true);
        let worker = |source, items: u64, busy_s: f64| crate::core::metrics::WorkerStats {
            items,
            pixels: 16 * items,
            busy_s,
            source: Some(source),
            ..Default::default()
        };
        let shares = crate::sched::Share::of(&crate::core::metrics::RunStats {
            workers: vec![
                worker(crate::sched::SourceKind::Threads, 3, 0.25),
                worker(crate::sched::SourceKind::Gpu, 5, 0.125),
            ],
            ..Default::default()
        });
        r.sourcing = [Some("4096".to_string()), None, Some("true".into())]
            .into_iter()
            .chain(crate::sched::Share::cells(&shares))
            .collect();
        let mut bytes = (cols.join(",") + "\n").into_bytes();
        bytes.extend(r.to_line());
        let back = parse_runs(&bytes).unwrap().0;
        assert_eq!(back, vec![r.clone()]);
        assert_eq!(back[0].sourcing("gpu_chunk"), Some("4096"));
        assert_eq!(back[0].sourcing("gpu_items"), Some("5"));
        assert_eq!(back[0].shares(), shares.to_vec());
        // Its config key differs from the same row on threads alone; a threads row's does not
        // change with the new columns.
        let plain = row("g", 0);
        assert_ne!(r.config_key(), plain.config_key());
        assert!(!plain.config_key().contains("sources"));
        // A file from before the columns reads them as empty.
        let old_header = cols[..cols.len() - n].join(",");
        let line = String::from_utf8(plain.to_line()).unwrap();
        let fields: Vec<&str> = line.trim_end().split(',').collect();
        let text = format!("{old_header}\n{}\n", fields[..fields.len() - n].join(","));
        let rows = parse_runs(text.as_bytes()).unwrap().0;
        assert_eq!(rows, vec![plain]);
        assert!(rows[0].shares().iter().all(Option::is_none));
    }

    #[test]
    fn open_truncates_the_partial_row_and_appends_after_it() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("runs.csv");
        {
            let (mut f, rows) = RunsFile::open(&p, false).unwrap();
            assert!(rows.is_empty());
            f.append(&row("a", 0)).unwrap();
        }
        let line = row("a", 1).to_line();
        let mut tail = std::fs::OpenOptions::new().append(true).open(&p).unwrap();
        tail.write_all(&line[..line.len() / 2]).unwrap();
        drop(tail);
        let (mut f, rows) = RunsFile::open(&p, false).unwrap();
        assert_eq!(rows, vec![row("a", 0)]);
        assert!(f.is_done("a", 0) && !f.is_done("a", 1));
        f.append(&row("a", 1)).unwrap();
        let (rows, _) = read_runs(&p).unwrap();
        assert_eq!(rows, vec![row("a", 0), row("a", 1)]);
        let (_, rows) = RunsFile::open(&p, true).unwrap();
        assert!(rows.is_empty());
        assert_eq!(read_runs(&p).unwrap().0, vec![]);
    }

    /// Every row of a published run recomputes its own config id: the key is a function of
    /// the row's columns alone, and the scheme has not moved since that run (master rows with
    /// `returns` and `passes`, shared-scheduler rows without).
    #[test]
    fn published_ids_recompute_from_their_rows() {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("results/published/master_passes/runs.csv");
        let rows = read_runs(&path).unwrap().0;
        assert!(rows.len() > 50, "{} rows", rows.len());
        assert!(rows.iter().any(|r| r.param("passes") == Some("workers")));
        for r in &rows {
            assert_eq!(hex(fnv(r.config_key().as_bytes())), r.config, "{}", r.label);
        }
    }

    /// A parameter newer than [`KEYED_BY_POSITION`] adds nothing to the key at its default or
    /// where the kind lacks it, and `|name=value` off its default.
    #[test]
    fn a_newer_parameter_keys_only_off_its_default() {
        let default = |name: &str| (name == "new_knob").then(|| "4".to_string());
        let key = |v: Option<&'static str>| {
            named_params_key(
                [("buffer", Some("2")), ("new_knob", v), ("grab", None)].into_iter(),
                default,
            )
        };
        assert_eq!(key(None), "");
        assert_eq!(key(Some("4")), "");
        assert_eq!(key(Some("8")), "|new_knob=8");
        // Every name keyed by position is a parameter column still.
        for name in KEYED_BY_POSITION {
            assert!(param_columns().iter().any(|p| p.name == name), "{name}");
        }
        // And a kind's default reads back through its id.
        assert_eq!(default_of("master", "buffer").as_deref(), Some("2"));
        assert_eq!(default_of("no_such_kind", "buffer"), None);
    }
}
