//! The one definition of the kinds of compute source: ids (CLI `--sources`, experiment
//! `sources = [...]`, the CSV's `sources` column), the cargo feature each needs, the set a
//! run renders with, each kind's own hand-out settings under the master ([`SourceSetup`]:
//! `--gpu-chunk` / `gpu_chunk`, `--gpu-buffer` / `gpu_buffer`, `--balance` / `balance`) and
//! the per-kind columns of `runs.csv` ([`share_columns`]). A run's sources are a set of
//! kinds: `threads`, `gpu`, `threads+gpu`, `mpi`.

use super::param::{err, id_enum, one_of, Chunk, ParamValue, SpecError};
use crate::core::metrics::RunStats;
use serde::{Deserialize, Serialize};
use std::sync::OnceLock;

pub use crate::core::metrics::SourceKind;

/// The `sources` column's value for threads alone ([`SourceSet::column`]), also accepted
/// for `threads` wherever a set is parsed.
pub const THREADS_COLUMN: &str = "local";

id_enum!(impl SourceKind ("sources", "compute source") {
    Threads = "threads",
    Gpu = "gpu",
    Mpi = "mpi",
});

impl SourceKind {
    /// The cargo feature this kind needs, if any.
    pub fn feature(self) -> Option<&'static str> {
        match self {
            Self::Threads => None,
            Self::Gpu => Some("gpu"),
            Self::Mpi => Some("mpi"),
        }
    }

    /// Does this kind take its own chunk and buffer under the master (`gpu_chunk`,
    /// `gpu_buffer`)? Threads take the scheduler's `chunk` and `buffer`; MPI ranks are
    /// configured by their launch.
    pub fn own_handout(self) -> bool {
        matches!(self, Self::Gpu)
    }

    /// Was this build compiled with what the kind needs?
    pub fn compiled(self) -> bool {
        match self {
            Self::Threads => true,
            Self::Gpu => cfg!(feature = "gpu"),
            Self::Mpi => cfg!(feature = "mpi"),
        }
    }
}

/// The kinds of source one run renders with, in [`SourceKind::ALL`] order, no repeats.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct SourceSet(Vec<SourceKind>);

impl SourceSet {
    /// Local threads only: every run that names no sources.
    pub fn threads() -> Self {
        Self(vec![SourceKind::Threads])
    }

    /// `kinds` as a set; errors on an empty list, a repeat, `mpi` with another kind (MPI
    /// runs add local threads with `--local-threads`), or a kind this build lacks.
    pub fn new(kinds: &[SourceKind]) -> Result<Self, SpecError> {
        let mut v: Vec<SourceKind> = Vec::new();
        for &k in kinds {
            if v.contains(&k) {
                return Err(err("sources", format!("'{}' given twice", k.id())));
            }
            v.push(k);
        }
        if v.is_empty() {
            return Err(err("sources", "no compute source given".to_string()));
        }
        if v.contains(&SourceKind::Mpi) && v.len() > 1 {
            return Err(err(
                "sources",
                "mpi runs alone (add threads on rank 0 with --local-threads)".to_string(),
            ));
        }
        if let Some(k) = v.iter().find(|k| !k.compiled()) {
            let f = k.feature().unwrap_or_default();
            return Err(err(
                "sources",
                format!("'{}' needs cargo feature `{f}`, which this build was compiled without (cargo build --features {f})", k.id()),
            ));
        }
        v.sort_by_key(|k| SourceKind::ALL.iter().position(|a| a == k));
        Ok(Self(v))
    }

    /// The sources of an MPI launch: its ranks, then rank 0's local threads when it has any
    /// (`--local-threads`), numbered in that order.
    pub fn mpi_launch(local_threads: bool) -> Self {
        let mut v = vec![SourceKind::Mpi];
        if local_threads {
            v.push(SourceKind::Threads);
        }
        Self(v)
    }

    /// Parse `threads`, `gpu`, `threads,gpu` (or `+`), `mpi`; `local` means `threads`.
    pub fn parse(text: &str) -> Result<Self, SpecError> {
        let kinds = text
            .split([',', '+'])
            .map(|s| match s.trim() {
                THREADS_COLUMN => Ok(SourceKind::Threads),
                t => SourceKind::from_id(t),
            })
            .collect::<Result<Vec<_>, _>>()?;
        Self::new(&kinds)
    }

    /// The kinds, in order.
    pub fn kinds(&self) -> &[SourceKind] {
        &self.0
    }

    /// Does the set hold `k`?
    pub fn has(&self, k: SourceKind) -> bool {
        self.0.contains(&k)
    }

    /// The id: kinds joined by `+` (`threads+gpu`).
    pub fn id(&self) -> String {
        self.0.iter().map(|k| k.id()).collect::<Vec<_>>().join("+")
    }

    /// The `sources` column of runs.csv: [`Self::id`], except [`THREADS_COLUMN`] for threads
    /// alone (the column's value since before the other kinds; [`Self::parse`] reads it back).
    pub fn column(&self) -> String {
        if *self == Self::threads() {
            THREADS_COLUMN.into()
        } else {
            self.id()
        }
    }
}

impl Default for SourceSet {
    fn default() -> Self {
        Self::threads()
    }
}

impl ParamValue for SourceSet {
    fn parse_value(text: &str) -> Result<Self, crate::sched::param::ValueError> {
        Self::parse(text).map_err(|e| crate::sched::param::ValueError::new(e.msg))
    }
    fn show(&self) -> String {
        self.id()
    }
}

/// What one source kind takes under the master instead of the scheduler's values.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct HandOut {
    /// Pixels per hand-out: consecutive items of the decomposition (in hand-out order) until
    /// their pixels reach this chunk's, sent as one message (one dispatch on a GPU). `None`:
    /// item by item, as threads get them.
    pub chunk: Option<Chunk>,
    /// Hand-outs outstanding at most (its B); `None`: the master's `buffer`.
    pub buffer: Option<usize>,
}

/// Which hand-out setting a [`SourceParam`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SourceField {
    /// [`HandOut::chunk`] of one kind.
    Chunk(SourceKind),
    /// [`HandOut::buffer`] of one kind.
    Buffer(SourceKind),
    /// [`SourceSetup::balance`].
    Balance,
}

/// One setting of [`SourceSetup`]: its TOML key and CSV column (`gpu_chunk`), CLI flag
/// (`--gpu-chunk`) and help, derived from [`SourceKind::ALL`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SourceParam {
    /// TOML key and CSV column.
    pub name: String,
    /// What it sets.
    pub field: SourceField,
    /// One line of help.
    pub help: String,
}

impl SourceParam {
    /// The CLI flag without its dashes (`gpu-chunk`).
    pub fn flag(&self) -> String {
        self.name.replace('_', "-")
    }
}

/// Every [`SourceSetup`] setting: `<kind>_chunk` and `<kind>_buffer` of each kind that takes
/// its own hand-out ([`SourceKind::own_handout`]), then `balance`.
pub fn source_params() -> &'static [SourceParam] {
    static PARAMS: OnceLock<Vec<SourceParam>> = OnceLock::new();
    PARAMS.get_or_init(|| {
        let mut out = Vec::new();
        for k in SourceKind::ALL.into_iter().filter(|k| k.own_handout()) {
            out.push(SourceParam {
                name: format!("{}_chunk", k.id()),
                field: SourceField::Chunk(k),
                help: format!(
                    "With {0} among the sources (master): pixels per hand-out to {0} — \
                     consecutive items until their pixels reach this chunk's (N, WxH, rows:N, \
                     frame), sent as one message; default: item by item",
                    k.id()
                ),
            });
            out.push(SourceParam {
                name: format!("{}_buffer", k.id()),
                field: SourceField::Buffer(k),
                help: format!(
                    "With {0} among the sources (master): hand-outs outstanding on {0} (its \
                     B); default: the master's buffer",
                    k.id()
                ),
            });
        }
        out.push(SourceParam {
            name: "balance".into(),
            field: SourceField::Balance,
            help: "With several kinds of source (master): the balancer picks each source's \
                   grain and buffer from its measured rate (a GPU probed at its fill first) and \
                   shrinks hand-outs as the queue empties; default: on unless a source's chunk \
                   or buffer is given, whose values it then keeps (true or false)"
                .into(),
        });
        out
    })
}

/// Who renders a run and how the master hands out to each kind: the set of kinds, each
/// kind's own chunk and buffer, and whether the grain-picking balancer runs
/// ([`Self::balanced`]).
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct SourceSetup {
    /// The kinds of source.
    pub set: SourceSet,
    /// Per kind, in [`SourceKind::ALL`] order.
    pub own: [HandOut; SourceKind::ALL.len()],
    /// The balancer (`sched::rule::Balance`) on or off as given; `None`: on with several
    /// kinds unless a kind's chunk or buffer is given.
    pub balance: Option<bool>,
}

fn pos(k: SourceKind) -> usize {
    SourceKind::ALL
        .iter()
        .position(|&a| a == k)
        .expect("a kind is in ALL")
}

impl SourceSetup {
    /// `set` with the scheduler's chunk and buffer for every kind, the balancer by default.
    pub fn of(set: SourceSet) -> Self {
        Self {
            set,
            ..Self::default()
        }
    }

    /// Does the master play the grain-picking balancer? With several kinds: as `balance`
    /// says, else when no kind has its own chunk or buffer (the default run of
    /// `--sources threads,gpu`); never with one kind.
    pub fn balanced(&self) -> bool {
        let own_given = self.own.iter().any(|h| *h != HandOut::default());
        self.set.kinds().len() > 1 && self.balance.unwrap_or(!own_given)
    }

    /// Kind `k`'s own hand-out settings.
    pub fn own(&self, k: SourceKind) -> &HandOut {
        &self.own[pos(k)]
    }

    /// Set [`source_params`] entry `name` from its text form.
    pub fn set_param(&mut self, name: &str, text: &str) -> Result<(), SpecError> {
        let p = source_params()
            .iter()
            .find(|p| p.name == name)
            .ok_or_else(|| err(name, "unknown compute-source setting"))?;
        let bad = |m: String| err(name, m);
        match p.field {
            SourceField::Chunk(k) => {
                self.own[pos(k)].chunk = Some(Chunk::parse(text).map_err(|e| bad(e.msg))?)
            }
            SourceField::Buffer(k) => {
                self.own[pos(k)].buffer = Some(usize::parse_value(text).map_err(|e| bad(e.msg))?)
            }
            SourceField::Balance => {
                self.balance = match text.trim() {
                    "true" | "on" => Some(true),
                    "false" | "off" => Some(false),
                    t => return Err(bad(format!("'{t}': expected true or false"))),
                }
            }
        }
        Ok(())
    }

    /// The text form of [`source_params`] entry `name`; `None` where it is unset (the
    /// scheduler's value; for `balance`, the default).
    pub fn get_param(&self, name: &str) -> Option<String> {
        let p = source_params().iter().find(|p| p.name == name)?;
        match p.field {
            SourceField::Chunk(k) => self.own(k).chunk.map(|c| c.to_string()),
            SourceField::Buffer(k) => self.own(k).buffer.map(|b| b.to_string()),
            SourceField::Balance => self.balance.map(|b| b.to_string()),
        }
    }

    /// Settings given for a kind the set lacks, or a balancer over one kind: an error naming
    /// the setting.
    pub fn validate(&self) -> Result<(), SpecError> {
        for p in source_params() {
            let (SourceField::Chunk(k) | SourceField::Buffer(k)) = p.field else {
                continue;
            };
            if self.get_param(&p.name).is_some() && !self.set.has(k) {
                return Err(err(
                    &p.name,
                    format!(
                        "applies only with {} among the sources (got {})",
                        k.id(),
                        self.set.id()
                    ),
                ));
            }
        }
        if self.balance == Some(true) && self.set.kinds().len() < 2 {
            return Err(err(
                "balance",
                format!(
                    "needs several kinds of source (got {}; e.g. threads+gpu)",
                    self.set.id()
                ),
            ));
        }
        Ok(())
    }

    /// ` sources=threads+gpu gpu_chunk=4096 …` for a run label; empty for threads alone.
    pub fn label(&self) -> String {
        if *self == Self::default() {
            return String::new();
        }
        let mut s = format!(" sources={}", self.set.id());
        for p in source_params() {
            if let Some(v) = self.get_param(&p.name) {
                s += &match (p.field, self.balance) {
                    (SourceField::Balance, Some(true)) => " balance".to_string(),
                    _ => format!(" {}={v}", p.name),
                };
            }
        }
        s
    }
}

/// Who rendered what, per kind of source: the `<kind>_items`, `<kind>_pixels` and
/// `<kind>_busy_s` columns of runs.csv, in [`SourceKind::ALL`] order.
pub fn share_columns() -> &'static [String] {
    static COLUMNS: OnceLock<Vec<String>> = OnceLock::new();
    COLUMNS.get_or_init(|| {
        SourceKind::ALL
            .iter()
            .flat_map(|k| SHARE_PARTS.map(|part| format!("{}_{part}", k.id())))
            .collect()
    })
}

/// The three measurements [`share_columns`] has per kind.
const SHARE_PARTS: [&str; 3] = ["items", "pixels", "busy_s"];

/// What the sources of one kind did over a run (the sum over its workers).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Share {
    /// Items rendered.
    pub items: u64,
    /// Pixels of those items.
    pub pixels: u64,
    /// Busy seconds summed over the kind's sources.
    pub busy_s: f64,
}

impl Share {
    /// The per-kind sums of `stats.workers` (by [`crate::core::metrics::WorkerStats::source`]; a
    /// worker that recorded no kind counts as threads), `None` for kinds with no worker.
    pub fn of(stats: &RunStats) -> [Option<Share>; SourceKind::ALL.len()] {
        let mut out = [None; SourceKind::ALL.len()];
        for w in &stats.workers {
            let kind = w.source.unwrap_or(SourceKind::Threads);
            let s: &mut Share = out[pos(kind)].get_or_insert_with(Share::default);
            s.items += w.items;
            s.pixels += w.pixels;
            s.busy_s += w.busy_s;
        }
        out
    }

    /// The cells of [`share_columns`] for these shares (empty for an absent kind).
    pub fn cells(shares: &[Option<Share>]) -> Vec<Option<String>> {
        shares
            .iter()
            .flat_map(|s| match s {
                Some(s) => [
                    Some(s.items.to_string()),
                    Some(s.pixels.to_string()),
                    Some(format!("{:.6}", s.busy_s)),
                ],
                None => [None, None, None],
            })
            .collect()
    }

    /// The shares back from [`Self::cells`]' cells (`None` where a kind's cells are empty or
    /// unreadable).
    pub fn from_cells(cells: &[Option<String>]) -> Vec<Option<Share>> {
        cells
            .chunks(SHARE_PARTS.len())
            .map(|c| {
                let items = c.first()?.as_deref()?.parse().ok()?;
                let pixels = c.get(1)?.as_deref()?.parse().ok()?;
                let busy_s = c.get(2)?.as_deref()?.parse().ok()?;
                Some(Share {
                    items,
                    pixels,
                    busy_s,
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sets_parse_sort_and_refuse_what_cannot_run() {
        assert_eq!(SourceSet::parse("local").unwrap(), SourceSet::threads());
        assert_eq!(SourceSet::parse("threads").unwrap().id(), "threads");
        let e = SourceSet::parse("threads,threads").unwrap_err();
        assert!(e.msg.contains("twice"), "{}", e.msg);
        let e = SourceSet::parse("cuda").unwrap_err();
        assert!(e.msg.contains("unknown compute source 'cuda'"), "{}", e.msg);
        if cfg!(feature = "gpu") {
            assert_eq!(SourceSet::parse("gpu,threads").unwrap().id(), "threads+gpu");
        } else {
            let e = SourceSet::parse("threads,gpu").unwrap_err();
            assert!(e.msg.contains("--features gpu"), "{}", e.msg);
        }
        if cfg!(feature = "mpi") {
            assert!(SourceSet::parse("mpi,threads").is_err());
        }
        assert_eq!(SourceSet::threads().column(), "local");
    }

    #[test]
    fn setup_settings_derive_from_the_kinds_and_refuse_what_does_not_apply() {
        let names: Vec<&str> = source_params().iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, ["gpu_chunk", "gpu_buffer", "balance"]);
        assert_eq!(source_params()[0].flag(), "gpu-chunk");
        let mut s = SourceSetup::default();
        assert_eq!(s.label(), "");
        s.set_param("gpu_chunk", "64x32").unwrap();
        assert_eq!(
            s.own(SourceKind::Gpu).chunk,
            Some(Chunk::Tile { w: 64, h: 32 })
        );
        let e = s.validate().unwrap_err();
        assert_eq!(e.field, "gpu_chunk");
        assert!(
            e.msg.contains("only with gpu among the sources"),
            "{}",
            e.msg
        );
        assert!(s
            .set_param("gpu_buffer", "0")
            .unwrap_err()
            .msg
            .contains("between 1"));
        assert!(s
            .set_param("balance", "yes")
            .unwrap_err()
            .msg
            .contains("true or false"));
        s = SourceSetup::default();
        s.set_param("balance", "true").unwrap();
        assert_eq!(s.validate().unwrap_err().field, "balance");
        // The balancer: on by default with several kinds, off once a kind's own chunk or
        // buffer is given unless asked for, off as asked, never over one kind.
        {
            // Built directly: a build without `gpu` refuses the set, not its setup.
            let mut b = SourceSetup::of(SourceSet(vec![SourceKind::Threads, SourceKind::Gpu]));
            assert!(b.balanced());
            b.own[pos(SourceKind::Gpu)].buffer = Some(2);
            assert!(!b.balanced());
            b.set_param("balance", "on").unwrap();
            assert!(b.balanced());
            assert_eq!(b.get_param("balance").as_deref(), Some("true"));
            b.set_param("balance", "false").unwrap();
            assert!(!b.balanced());
            assert!(b.label().contains(" balance=false"), "{}", b.label());
        }
        assert!(!SourceSetup::default().balanced());
        assert_eq!(
            s.set_param("cpu_chunk", "4").unwrap_err().field,
            "cpu_chunk"
        );
    }

    #[test]
    fn a_kinds_serde_name_is_its_id() {
        // The type's serde names (the statistics' JSON) come from its variant names, its ids
        // from this module: they must spell the same.
        for k in SourceKind::ALL {
            assert_eq!(
                serde_json::to_string(&k).unwrap(),
                format!("\"{}\"", k.id())
            );
            assert_eq!(
                serde_json::from_str::<SourceKind>(&format!("\"{}\"", k.id())).unwrap(),
                k
            );
        }
    }

    #[test]
    fn shares_sum_workers_by_kind_and_round_trip_through_their_cells() {
        use crate::core::metrics::WorkerStats;
        let w = |source, items, busy_s| WorkerStats {
            items,
            pixels: 4 * items,
            busy_s,
            source: Some(source),
            ..Default::default()
        };
        let stats = RunStats {
            workers: vec![
                w(SourceKind::Threads, 3, 0.5),
                w(SourceKind::Threads, 2, 0.25),
                w(SourceKind::Gpu, 10, 0.125),
            ],
            ..Default::default()
        };
        let shares = Share::of(&stats);
        let t = shares[pos(SourceKind::Threads)].unwrap();
        assert_eq!((t.items, t.pixels, t.busy_s), (5, 20, 0.75));
        assert_eq!(shares[pos(SourceKind::Gpu)].unwrap().items, 10);
        assert_eq!(shares[pos(SourceKind::Mpi)], None);
        let cells = Share::cells(&shares);
        assert_eq!(cells.len(), share_columns().len());
        assert_eq!(share_columns()[0], "threads_items");
        assert_eq!(Share::from_cells(&cells), shares.to_vec());
        // MPI ranks count as mpi; a worker that recorded no kind counts as threads.
        let mpi = Share::of(&RunStats {
            workers: vec![
                w(SourceKind::Mpi, 7, 0.5),
                w(SourceKind::Mpi, 1, 0.25),
                WorkerStats {
                    items: 4,
                    ..Default::default()
                },
            ],
            ..Default::default()
        });
        assert_eq!(mpi[pos(SourceKind::Mpi)].unwrap().items, 8);
        assert_eq!(mpi[pos(SourceKind::Threads)].unwrap().items, 4);
    }
}
