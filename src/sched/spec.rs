//! What a scheduler run is asked to do: stable snake_case ids shared by CLI, TOML and CSV,
//! parsed and validated here (one place maps an id to a type).

use serde::{Deserialize, Serialize};
use std::fmt;
use std::time::Duration;

/// The master's wait strategy lives with the doorbell it drives; its ids are parsed here.
pub use crate::source::Wait;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {msg}")]
pub struct SpecError {
    pub field: String,
    pub msg: String,
}

fn err(field: &str, msg: impl Into<String>) -> SpecError {
    SpecError {
        field: field.to_string(),
        msg: msg.into(),
    }
}

/// Who decides who renders what.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SchedulerKind {
    /// Contiguous bands of items, one per worker; no master.
    Static,
    /// Item i to worker i mod n; no master.
    StaticCyclic,
    /// The report's design: a master thread (renders nothing) keeps ≤ B items outstanding per
    /// compute source, re-queueing handed-out items at the back of a FIFO.
    Master,
    /// rayon over items, split no finer than `chunk` items per task.
    WorkStealing,
    /// One crossbeam-deque per worker, stealing from the others when empty.
    WorkStealingDeque,
    /// One shared atomic counter over items; each grab takes `grab` items.
    SelfScheduling,
    /// Grabs of max(min, remaining / (k·workers)) items from a shared counter.
    Guided,
}

impl SchedulerKind {
    pub const ALL: [SchedulerKind; 7] = [
        Self::Static,
        Self::StaticCyclic,
        Self::Master,
        Self::WorkStealing,
        Self::WorkStealingDeque,
        Self::SelfScheduling,
        Self::Guided,
    ];
    pub fn id(self) -> &'static str {
        match self {
            Self::Static => "static",
            Self::StaticCyclic => "static_cyclic",
            Self::Master => "master",
            Self::WorkStealing => "work_stealing",
            Self::WorkStealingDeque => "work_stealing_deque",
            Self::SelfScheduling => "self_scheduling",
            Self::Guided => "guided",
        }
    }
    pub fn from_id(s: &str) -> Result<Self, SpecError> {
        Self::ALL.into_iter().find(|k| k.id() == s).ok_or_else(|| {
            err(
                "scheduler",
                format!(
                    "unknown scheduler '{s}' (expected one of: {})",
                    Self::ALL.map(|k| k.id()).join(", ")
                ),
            )
        })
    }
    /// Only the master has a buffer, a re-queue policy and a wait strategy.
    pub fn has_master(self) -> bool {
        self == Self::Master
    }
}

/// Granularity: how many pixels make one work item.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Chunk {
    /// A w×h tile (1×1 = one pixel = per-ray granularity).
    Tile { w: u32, h: u32 },
    /// Bands of `n` full rows.
    Rows(u32),
    /// The whole image as one item: one item per frame of an animation (the coarsest item).
    /// Parsed from `frame` or `frames`.
    Frame,
}

impl Chunk {
    /// `1`, `16` (16×16), `8x4`, `rows:4`, `frame` (alias `frames`: one whole frame per item
    /// is what `frame` already means on an animation; one id is written to CSVs).
    pub fn parse(s: &str) -> Result<Self, SpecError> {
        let bad = |m: &str| err("chunk", format!("'{s}': {m}"));
        let pos = |t: &str| -> Result<u32, SpecError> {
            match t.trim().parse::<u32>() {
                Ok(0) => Err(bad("sizes must be ≥ 1 (chunk 0 has no pixels)")),
                Ok(v) => Ok(v),
                Err(_) => Err(bad("expected N, WxH, rows:N, frame or frames")),
            }
        };
        let s = s.trim();
        if s == "frame" || s == "frames" {
            Ok(Self::Frame)
        } else if let Some(n) = s.strip_prefix("rows:") {
            Ok(Self::Rows(pos(n)?))
        } else if let Some((w, h)) = s.split_once(['x', '×']) {
            Ok(Self::Tile {
                w: pos(w)?,
                h: pos(h)?,
            })
        } else {
            let n = pos(s)?;
            Ok(Self::Tile { w: n, h: n })
        }
    }
    /// Pixels per item on an image of this width and height (edge items may be smaller).
    pub fn pixels(&self, width: u32, height: u32) -> u64 {
        match *self {
            Self::Tile { w, h } => w.min(width) as u64 * h.min(height) as u64,
            Self::Rows(n) => width as u64 * n.min(height) as u64,
            Self::Frame => width as u64 * height as u64,
        }
    }
}

impl fmt::Display for Chunk {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Tile { w, h } if w == h => write!(f, "{w}"),
            Self::Tile { w, h } => write!(f, "{w}x{h}"),
            Self::Rows(n) => write!(f, "rows:{n}"),
            Self::Frame => write!(f, "frame"),
        }
    }
}

/// The order items are generated (and so handed out) in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Order {
    Scanline,
    Morton,
    Hilbert,
}

impl Order {
    pub const ALL: [Order; 3] = [Self::Scanline, Self::Morton, Self::Hilbert];
    pub fn id(self) -> &'static str {
        match self {
            Self::Scanline => "scanline",
            Self::Morton => "morton",
            Self::Hilbert => "hilbert",
        }
    }
    pub fn from_id(s: &str) -> Result<Self, SpecError> {
        Self::ALL.into_iter().find(|o| o.id() == s).ok_or_else(|| {
            err(
                "order",
                format!("unknown order '{s}' (expected scanline, morton or hilbert)"),
            )
        })
    }
}

/// When the master may hand an outstanding item out again.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Requeue {
    /// The seed's policy: as soon as the item comes round in the queue again.
    Seed,
    /// Only once it has been outstanding this long.
    Timeout(Duration),
    /// Never: a lost item stays lost (the run fails with a count of lost items).
    Never,
}

impl Requeue {
    /// `seed`, `never`, `timeout:<ms>`.
    pub fn parse(s: &str) -> Result<Self, SpecError> {
        match s.trim() {
            "seed" => Ok(Self::Seed),
            "never" => Ok(Self::Never),
            t => match t.strip_prefix("timeout:").map(|ms| ms.parse::<u64>()) {
                Some(Ok(ms)) if ms > 0 => Ok(Self::Timeout(Duration::from_millis(ms))),
                _ => Err(err(
                    "requeue",
                    format!("'{s}': expected seed, never or timeout:<ms> with ms ≥ 1"),
                )),
            },
        }
    }
}

impl fmt::Display for Requeue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Seed => write!(f, "seed"),
            Self::Never => write!(f, "never"),
            Self::Timeout(d) => write!(f, "timeout:{}", d.as_millis()),
        }
    }
}

impl Wait {
    pub const ALL: [Wait; 3] = [Self::Spin, Self::Yield, Self::Block];
    pub fn id(self) -> &'static str {
        match self {
            Self::Spin => "spin",
            Self::Yield => "yield",
            Self::Block => "block",
        }
    }
    pub fn from_id(s: &str) -> Result<Self, SpecError> {
        Self::ALL.into_iter().find(|w| w.id() == s).ok_or_else(|| {
            err(
                "wait",
                format!("unknown wait strategy '{s}' (expected spin, yield or block)"),
            )
        })
    }
}

/// One scheduler run, fully specified.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SchedulerSpec {
    pub kind: SchedulerKind,
    pub chunk: Chunk,
    pub order: Order,
    /// Compute sources / worker threads (the master is extra and counted separately).
    pub workers: usize,
    /// Master: items outstanding per source.
    pub buffer: usize,
    pub requeue: Requeue,
    pub wait: Wait,
    /// self_scheduling: items per grab; guided: the minimum grab; work_stealing: minimum split.
    pub grab: usize,
    /// guided: divisor k in remaining / (k·workers).
    pub guided_k: usize,
    /// Record a (worker, item, start, end) timeline for Gantt plots.
    pub timeline: bool,
}

impl SchedulerSpec {
    pub fn new(kind: SchedulerKind, chunk: Chunk, workers: usize) -> Self {
        Self {
            kind,
            chunk,
            order: Order::Scanline,
            workers,
            buffer: 2,
            requeue: Requeue::Never,
            wait: Wait::Block,
            grab: 1,
            guided_k: 2,
            timeline: false,
        }
    }

    pub fn validate(&self) -> Result<(), SpecError> {
        if self.workers == 0 {
            return Err(err("workers", "must be ≥ 1 (got 0)"));
        }
        if self.buffer == 0 {
            return Err(err("buffer", "must be ≥ 1 (got 0)"));
        }
        if self.grab == 0 {
            return Err(err("grab", "must be ≥ 1 (got 0)"));
        }
        if self.guided_k == 0 {
            return Err(err("guided_k", "must be ≥ 1 (got 0)"));
        }
        if let Chunk::Tile { w: 0, .. } | Chunk::Tile { h: 0, .. } | Chunk::Rows(0) = self.chunk {
            return Err(err("chunk", "sizes must be ≥ 1 (chunk 0 has no pixels)"));
        }
        Ok(())
    }

    /// A short label for plots and logs, e.g. `master chunk=16 B=2 wait=block`.
    pub fn label(&self) -> String {
        let mut s = format!("{} chunk={}", self.kind.id(), self.chunk);
        if self.kind.has_master() {
            s += &format!(
                " B={} requeue={} wait={}",
                self.buffer,
                self.requeue,
                self.wait.id()
            );
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_round_trip_and_unknown_ids_are_errors() {
        for k in SchedulerKind::ALL {
            assert_eq!(SchedulerKind::from_id(k.id()).unwrap(), k);
        }
        assert!(SchedulerKind::from_id("fastest")
            .unwrap_err()
            .msg
            .contains("unknown scheduler"));
        assert!(Order::from_id("zigzag").is_err());
        assert!(Wait::from_id("nap").is_err());
    }

    #[test]
    fn chunk_parsing() {
        assert_eq!(Chunk::parse("1").unwrap(), Chunk::Tile { w: 1, h: 1 });
        assert_eq!(Chunk::parse("8x4").unwrap(), Chunk::Tile { w: 8, h: 4 });
        assert_eq!(Chunk::parse("rows:3").unwrap(), Chunk::Rows(3));
        assert_eq!(Chunk::parse("frame").unwrap(), Chunk::Frame);
        assert_eq!(Chunk::parse("frames").unwrap(), Chunk::Frame);
        for bad in ["0", "0x4", "rows:0", "x", ""] {
            assert!(Chunk::parse(bad).is_err(), "{bad}");
        }
        for c in ["1", "8x4", "rows:3", "frame"] {
            assert_eq!(Chunk::parse(c).unwrap().to_string(), c);
        }
    }

    #[test]
    fn requeue_parsing() {
        assert_eq!(Requeue::parse("seed").unwrap(), Requeue::Seed);
        assert_eq!(
            Requeue::parse("timeout:50").unwrap(),
            Requeue::Timeout(Duration::from_millis(50))
        );
        assert!(Requeue::parse("timeout:0").is_err());
        assert!(Requeue::parse("later").is_err());
    }

    #[test]
    fn zero_sizes_are_rejected() {
        let base = SchedulerSpec::new(SchedulerKind::Master, Chunk::Frame, 2);
        assert!(base.validate().is_ok());
        for (field, spec) in [
            (
                "workers",
                SchedulerSpec {
                    workers: 0,
                    ..base.clone()
                },
            ),
            (
                "buffer",
                SchedulerSpec {
                    buffer: 0,
                    ..base.clone()
                },
            ),
            (
                "grab",
                SchedulerSpec {
                    grab: 0,
                    ..base.clone()
                },
            ),
        ] {
            assert_eq!(spec.validate().unwrap_err().field, field);
        }
    }
}
