//! `RunStats`: the same measurements for every scheduler, so runs compare column by column.

use serde::{Deserialize, Serialize};

/// What one worker (compute source) did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WorkerStats {
    /// Time spent inside `render_item`.
    pub busy_s: f64,
    /// Wall time of the run minus busy time.
    pub idle_s: f64,
    /// Items it rendered.
    pub items: u64,
    /// Pixels of those items.
    pub pixels: u64,
    /// Rays those items traced.
    pub rays: u64,
    /// What kind of compute source it is (`None` where not recorded).
    #[serde(default)]
    pub source: Option<SourceKind>,
}

/// A kind of compute source. The type lives here, below both `sched` and `source`, so that a
/// source records its kind in its [`WorkerStats`] without importing the scheduler; its ids
/// (the CLI's `--sources`, experiment files, the CSV's columns) and what each kind needs are
/// `crate::sched`'s (`sched/sources.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SourceKind {
    /// Worker threads of this process (sets written `local` parse to it).
    Threads,
    /// One GPU through wgpu/Vulkan (feature `gpu`): one dispatch per hand-out.
    Gpu,
    /// MPI ranks 1…K−1 under `mpirun -n K` (feature `mpi`).
    Mpi,
}

impl WorkerStats {
    /// A local thread's statistics, nothing counted yet.
    pub fn local_thread() -> Self {
        Self {
            source: Some(SourceKind::Threads),
            ..Default::default()
        }
    }

    /// One finished item of this worker.
    pub fn count(&mut self, item: &crate::core::render::WorkItem, rays: u64) {
        self.items += 1;
        self.pixels += item.pixel_count() as u64;
        self.rays += rays;
    }
}

/// What the master thread did (absent for schedulers without one).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MasterStats {
    /// Time spent handing out items and collecting results (bookkeeping).
    pub dispatch_s: f64,
    /// Time spent waiting for results (spinning, yielding or blocked).
    pub wait_s: f64,
    /// Passes of the master's loop (collect, hand out, wait).
    pub iterations: u64,
    /// Hand-outs the balancer's tail guard cut, and sources it first refused.
    #[serde(default)]
    pub rebalances: u64,
}

/// One span of a timeline: `worker` rendered `item` from `start_ns` to `end_ns` after the run
/// started. The master's spans use `worker = u32::MAX`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Span {
    /// The worker (source id or thread index), or [`MASTER_LANE`].
    pub worker: u32,
    /// The item's id.
    pub item: u32,
    /// Start, in nanoseconds after the run's time zero.
    pub start_ns: u64,
    /// End, in nanoseconds after the run's time zero.
    pub end_ns: u64,
}

/// The [`Span::worker`] of the master's own spans (its hand-out passes).
pub const MASTER_LANE: u32 = u32::MAX;

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
/// Everything one scheduler run measured; every scheduler fills in the same fields.
pub struct RunStats {
    /// Wall time of the run, in seconds.
    pub wall_s: f64,
    /// One entry per worker (compute source or thread).
    pub workers: Vec<WorkerStats>,
    /// The master thread's time (`None` for schedulers without one).
    pub master: Option<MasterStats>,
    /// Items in the decomposition of the image.
    pub items: u64,
    /// Hand-outs, re-issues included.
    pub issued: u64,
    /// Hand-outs of an item that was already handed out.
    pub reissued: u64,
    /// Results that arrived for an item already done (counted and discarded).
    pub duplicates: u64,
    /// Serialised bytes of items sent plus results returned.
    pub bytes: u64,
    /// Rays traced over all first results (duplicates not counted).
    pub rays: u64,
    /// Samples that came out NaN/Inf (dropped, never written).
    pub nonfinite: u64,
    /// Sources lost during the run (panicked, killed).
    pub lost_sources: u64,
    /// Per-item spans of every worker (and the master's hand-out passes), when a timeline was
    /// recorded.
    pub timeline: Option<Vec<Span>>,
    /// Scene features the render path was specialised to (see `stability::features`).
    #[serde(default)]
    pub features_used: Vec<String>,
    /// Features compiled out of the render path (and acceleration not built).
    #[serde(default)]
    pub features_left_out: Vec<String>,
}

impl RunStats {
    /// max busy / mean busy over workers (1 = perfectly balanced).
    pub fn imbalance(&self) -> f64 {
        let busy: Vec<f64> = self.workers.iter().map(|w| w.busy_s).collect();
        let mean = busy.iter().sum::<f64>() / busy.len().max(1) as f64;
        let max = busy.iter().cloned().fold(0.0, f64::max);
        if mean > 0.0 {
            max / mean
        } else {
            1.0
        }
    }
    /// Busy seconds summed over workers.
    pub fn busy_s(&self) -> f64 {
        self.workers.iter().map(|w| w.busy_s).sum()
    }
    /// Idle seconds summed over workers.
    pub fn idle_s(&self) -> f64 {
        self.workers.iter().map(|w| w.idle_s).sum()
    }
    /// The master's dispatch seconds (0 without a master).
    pub fn dispatch_s(&self) -> f64 {
        self.master.as_ref().map_or(0.0, |m| m.dispatch_s)
    }
}

impl RunStats {
    /// A human-readable multi-line summary (the `render` command prints it).
    pub fn summary(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "wall {:.4} s · items {} · issued {} (re-issued {}) · duplicates {} · bytes {} · rays {} · lost sources {}",
            self.wall_s, self.items, self.issued, self.reissued, self.duplicates, self.bytes, self.rays, self.lost_sources
        );
        let _ = writeln!(
            s,
            "busy {:.4} s · idle {:.4} s · imbalance (max/mean busy) {:.3}",
            self.busy_s(),
            self.idle_s(),
            self.imbalance()
        );
        for (i, w) in self.workers.iter().enumerate() {
            let kind = w.source.map_or(String::new(), |k| format!(" ({})", k.id()));
            let _ = writeln!(
                s,
                "  worker {i}{kind}: busy {:.4} s · idle {:.4} s · items {} · pixels {} · rays {}",
                w.busy_s, w.idle_s, w.items, w.pixels, w.rays
            );
        }
        if let Some(m) = &self.master {
            let _ = writeln!(
                s,
                "  master: dispatch {:.4} s · wait {:.4} s · iterations {} · rebalances {}",
                m.dispatch_s, m.wait_s, m.iterations, m.rebalances
            );
        }
        if let Some(t) = &self.timeline {
            let _ = writeln!(s, "  timeline: {} spans", t.len());
        }
        s
    }
}
