//! The hand-out rules: the founding design's *specification*. A rule says which items go to
//! whom and when, from the state of the run alone (items left, who asks, what came back); it
//! does no I/O and reads no clock. Every executor — local threads, the master, the workers-run
//! master, MPI ranks, the SimGrid protocols and the cost model — plays these rules and holds
//! no scheduler arithmetic of its own.
//!
//! Each built-in scheduler states its rule in its own file under [`super::kinds`]
//! ([`BuiltIn::hand_out`](super::kinds::BuiltIn::hand_out)); `Policy::rule` reaches it. A
//! scheduler from outside the crate implements [`Scheduler`] and returns a [`HandOut`] of its
//! own (see `examples/custom_scheduler.rs`). This module names no scheduler: the kinds build
//! on it, not it on them.
//!
//! # Examples
//!
//! ```
//! use raysched::sched::rule::{HandOut, WorkerRule};
//! use raysched::sched::{Policy, SchedulerKind, Slow};
//!
//! // Guided self-scheduling over 100 items on 2 workers: chunks of max(grab, ⌈R/(k·P)⌉).
//! let HandOut::ByWorkers(WorkerRule::Pool(mut pool)) =
//!     Policy::defaults(SchedulerKind::Guided).rule(100, 2, Slow::NONE)
//! else {
//!     unreachable!()
//! };
//! assert_eq!(pool.rule.next(0, 100), 25);
//! ```

mod balance;
mod dispense;
mod master;

pub use super::dls::{ChunkRule, Grab, ItemTimes, Report, Timing};
pub use balance::{
    Balance, Dispatch, Facts, Grant, Shape, DISPATCH_BUFFER, GPU_DISPATCH, LONG_ITEM, PEAK_SHARE,
    TAIL_SLACK,
};
pub use dispense::{Dispense, Dispenser, StealState};
pub use master::{MasterQueue, MasterRule, Take};

use super::param::Slow;
use std::ops::Range;

/// Worker `k`'s contiguous band of `n` items split over `w` workers: `k·n/w .. (k+1)·n/w`.
/// The one place this formula lives (static, the deques' first fill, MPI's static split).
pub fn band(k: usize, n: usize, w: usize) -> Range<usize> {
    let w = w.max(1);
    k * n / w..(k + 1) * n / w
}

/// Who hands out: a master that renders nothing, or the workers themselves.
pub enum HandOut {
    /// A master: ≤ B items outstanding per source from one FIFO ([`MasterQueue`]), re-queued
    /// at the back; its passes run on its own thread or by the workers ([`MasterRule`]).
    ByMaster(MasterRule),
    /// The workers take their own items under a rule.
    ByWorkers(WorkerRule),
}

impl HandOut {
    /// Workers take consecutive chunks from one pool, each sized by `rule`.
    pub fn pool(rule: Box<dyn ChunkRule>) -> Self {
        Self::ByWorkers(WorkerRule::Pool(Pool::new(rule)))
    }

    /// A pool whose chunks are shares of what is left (guided and the factoring family): a
    /// worker runs each hand-out's items in scanline order
    /// (`SchedulerKind::runs_hand_outs_in_scanline`).
    pub fn shares(rule: Box<dyn ChunkRule>) -> Self {
        Self::ByWorkers(WorkerRule::Pool(Pool {
            scanline: true,
            ..Pool::new(rule)
        }))
    }
}

/// How workers without a master take their items.
pub enum WorkerRule {
    /// Every item has its owner from the start ([`Ownership`]).
    Own(Ownership),
    /// One pool of consecutive items; each request gets the next chunk that the pool's
    /// [`ChunkRule`] sizes.
    Pool(Pool),
    /// Each worker starts with its [`band`]; an idle one steals from another.
    Steal(Steal),
    /// A pool of another shape, over the run's `n` items: each request gets what the
    /// [`Dispense`] grants (a rule from outside the crate; see `docs/extending.md`).
    Dispense(Box<dyn Dispense>),
}

impl WorkerRule {
    /// The pool protocol this rule's pool plays over `n` items, if it is a pool of any shape.
    pub fn into_dispense(self, n: usize) -> Result<Box<dyn Dispense>, Self> {
        match self {
            Self::Pool(pool) => Ok(Box::new(pool.dispenser(n))),
            Self::Dispense(d) => Ok(d),
            other => Err(other),
        }
    }
}

/// What a rule's shape needs from whoever plays it: the one question the model, the
/// simulation, the experiment plan, `advise` and the plots ask instead of naming a kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Needs {
    /// A thread of its own that hands out and renders nothing (its refill period r and its
    /// cost per hand-out are measured; the simulated one computes on its host).
    pub hand_out_thread: bool,
    /// Sources that each hold up to this many items, topped up by a pass (the master's B):
    /// the probes of its hand-out cost are keyed by it.
    pub outstanding: Option<usize>,
    /// Per-source settings: each kind of source may have its own buffer and grain (a GPU's
    /// chunk, `balance`).
    pub per_source: bool,
    /// Workers that share memory (stealing): not playable over the source interface.
    pub shared_memory: bool,
    /// What the workers measure and report.
    pub timing: Timing,
}

impl HandOut {
    /// What playing this rule needs ([`Needs`]).
    pub fn needs(&self) -> Needs {
        let none = Needs {
            hand_out_thread: false,
            outstanding: None,
            per_source: false,
            shared_memory: false,
            timing: Timing::None,
        };
        match self {
            Self::ByMaster(m) => Needs {
                hand_out_thread: m.passes == super::param::Passes::Thread,
                outstanding: Some(m.buffer),
                per_source: true,
                ..none
            },
            Self::ByWorkers(WorkerRule::Own(_)) => none,
            Self::ByWorkers(WorkerRule::Pool(p)) => Needs {
                timing: p.rule.timing(),
                ..none
            },
            Self::ByWorkers(WorkerRule::Dispense(d)) => Needs {
                timing: d.timing(),
                ..none
            },
            Self::ByWorkers(WorkerRule::Steal(_)) => Needs {
                shared_memory: true,
                ..none
            },
        }
    }
}

/// A fixed assignment of items to workers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ownership {
    /// Worker k owns [`band`]`(k, n, w)`.
    Bands,
    /// Worker k owns items k, k + w, k + 2w, …
    Cyclic,
}

impl Ownership {
    /// The items worker `k` of `w` owns among `n`, in the order it runs them.
    pub fn items(self, k: usize, n: usize, w: usize) -> std::iter::StepBy<Range<usize>> {
        match self {
            Self::Bands => band(k, n, w).step_by(1),
            Self::Cyclic => (k.min(n)..n).step_by(w.max(1)),
        }
    }

    /// The worker that owns item `i` of `n` over `w` workers.
    pub fn owner(self, i: usize, n: usize, w: usize) -> usize {
        let w = w.max(1);
        match self {
            // The last band whose start is at or before i (bands may be empty when n < w).
            Self::Bands => (0..w)
                .rev()
                .find(|&k| band(k, n, w).start <= i)
                .unwrap_or(0),
            Self::Cyclic => i % w,
        }
    }
}

/// A pool of consecutive items, each hand-out sized by `rule`.
pub struct Pool {
    /// Sizes each chunk (clamped by every executor to 1..=items left).
    pub rule: Box<dyn ChunkRule>,
    /// Whether the hand-outs are taken under a lock even where the rule would allow an
    /// atomic counter (pbrt's loop takes each tile under its mutex).
    pub locked: bool,
    /// Whether a worker runs each hand-out's items in scanline order rather than as handed
    /// out (the rules whose chunks are a share of all items, over `scatter`-ordered items).
    pub scanline: bool,
}

impl Pool {
    /// A pool whose executor may take hand-outs without a lock where the rule allows.
    pub fn new(rule: Box<dyn ChunkRule>) -> Self {
        Self {
            rule,
            locked: false,
            scanline: false,
        }
    }
}

/// How idle workers steal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Steal {
    /// rayon's recursive splitting of the item range, no part smaller than `min` items.
    Split {
        /// The smallest part rayon runs as one task.
        min: usize,
    },
    /// One deque per worker filled with its band; a thief takes half a victim's deque.
    Half,
}

impl Steal {
    /// Items a worker runs per take from its own deque (the simulation's grab).
    pub fn grab(self) -> usize {
        match self {
            Self::Split { min } => min.max(1),
            Self::Half => 1,
        }
    }
}

/// A scheduler as the run path sees it: an id and the rule it hands out by. Every built-in
/// [`Policy`] is one; a researcher's own scheduler implements this trait outside the crate.
pub trait Scheduler: Send + Sync {
    /// The scheduler's id, as in labels and CSV rows.
    fn id(&self) -> String;
    /// The rule over `n` items on `workers` workers, worker i slowed as `slow` says.
    fn hand_out(&self, n: usize, workers: usize, slow: Slow) -> HandOut;
    /// What its shape needs from an executor ([`HandOut::needs`] of a small run; a shape's
    /// needs do not depend on the item count).
    fn needs(&self) -> Needs {
        self.hand_out(1, 1, Slow::NONE).needs()
    }
}

/// The chunk sizes a pool rule hands out over `n` items when `p` workers ask in turn (0, 1,
/// …, P−1, 0, …), none reporting: what a rule does before any measurement.
pub fn chunk_sequence(rule: &mut dyn ChunkRule, n: usize, p: usize) -> Vec<usize> {
    let (mut next, mut out, mut w) = (0, Vec::new(), 0);
    while next < n {
        let c = rule.next(w, n - next).clamp(1, n - next);
        out.push(c);
        next += c;
        w = (w + 1) % p.max(1);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_cover_every_item_once_in_order_even_with_more_workers_than_items() {
        for (n, w) in [(10, 3), (3, 5), (0, 2), (17, 1), (64, 4)] {
            let all: Vec<usize> = (0..w).flat_map(|k| band(k, n, w)).collect();
            assert_eq!(all, (0..n).collect::<Vec<_>>(), "n={n} w={w}");
            for i in 0..n {
                let k = Ownership::Bands.owner(i, n, w);
                assert!(band(k, n, w).contains(&i), "n={n} w={w} i={i} k={k}");
            }
        }
        // 10 over 3: 0..3, 3..6, 6..10.
        assert_eq!(band(2, 10, 3), 6..10);
    }

    #[test]
    fn cyclic_ownership_strides_by_the_worker_count() {
        let k1: Vec<usize> = Ownership::Cyclic.items(1, 10, 3).collect();
        assert_eq!(k1, [1, 4, 7]);
        assert_eq!(Ownership::Cyclic.items(4, 3, 5).count(), 0);
        assert_eq!(Ownership::Cyclic.owner(8, 10, 3), 2);
    }
}
