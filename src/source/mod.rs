//! Compute sources: whatever renders items for a scheduler. A source takes a [`WorkItem`] and
//! hands back a [`DelayedResult`] at once; the result is polled, taken or waited on later.
//!
//! The trait is object safe so the master works over `Vec<Box<dyn ComputeSource>>`: local
//! threads ([`LocalThreadSource`]), fault-injecting wrappers ([`faulty`]) and MPI ranks
//! (`mpi::MpiRankSource`, feature `mpi`, which builds on this module from above) and a GPU
//! (`GpuSource`, feature `gpu`: one dispatch per hand-out; its results estimate the same
//! samples as `render_item` but are not bit-identical, see `source::gpu`).
//!
//! - [`delayed`]: the result cell, [`DelayedResult`] and its producing [`Completer`] (or, for a
//!   hand-out returned whole, one [`HandOutCompleter`] for all its items).
//! - [`doorbell`]: how a source wakes a waiting master ([`Doorbell`], [`Notifier`], [`Wait`]).

pub mod delayed;
pub mod doorbell;
pub mod faulty;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod local;
pub mod served;
pub mod slow;
pub mod thread;

pub use delayed::{Completer, DelayedResult, HandOutCompleter};
pub use doorbell::{Doorbell, Notifier, Wait};
pub use faulty::{FaultPlan, FaultySource};
#[cfg(feature = "gpu")]
pub use gpu::GpuSource;
pub use local::LocalThreadSource;
pub use served::ServedSources;
pub use slow::slowed_job;
pub use thread::SourceThread;

use crate::core::metrics::{Span, WorkerStats};
use crate::core::render::{TileResult, WorkItem};
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::Duration;

/// What a dispatch costs beyond its pixels, as the source knows it from measurement: what a
/// source that runs each hand-out as one dispatch says of itself
/// ([`ComputeSource::dispatch`]), for the master's balancer (`sched::rule::Balance`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Dispatch {
    /// One dispatch's fixed cost: submit to results mapped, empty kernel.
    pub overhead: Duration,
    /// Pixels per dispatch that fill the device: a smaller dispatch takes about as long.
    pub fill_px: u64,
}

/// What the balancer assumes of a GPU's dispatch (the GPU source's [`Dispatch`]), from the
/// H200 (M-150): 105 µs submit → mapped for an empty kernel, and the device filled at 2^17
/// pixels: its 1-spp curve of pixels/s against pixels per dispatch fits
/// `o + b·n + a·max(n, 91 k)` (`simulate::hetero::GpuModel::h200`), a dispatch below ~91 k
/// pixels taking as long as one of 91 k.
pub const GPU_DISPATCH: Dispatch = Dispatch {
    overhead: Duration::from_micros(105),
    fill_px: 1 << 17,
};

/// Something that renders items for a scheduler: a thread, a wrapper, a remote rank.
///
/// What an implementation guarantees:
/// - **One outcome per item.** Every [`DelayedResult`] it hands out gets exactly one
///   [`Outcome`], carrying the item's id and this source's [`ComputeSource::id`]: the
///   result, or a [`SourceFailure`]. A source that dies fails its outstanding results as
///   [`SourceFailure::Lost`] (a dropped [`Completer`] does so by itself); work skipped after
///   [`ComputeSource::finish`] fails as [`SourceFailure::Cancelled`]. The one exception is a
///   result that is deliberately never delivered ([`FaultySource`]: a lost message), which
///   only the master's re-queue policy or deadline can deal with.
/// - **Results are the job's.** An `Ok` outcome is exactly what the run's [`Job`]
///   (`render_item` in real runs) returned for that item, unchanged, so every scheduler over
///   every source produces the same image bit for bit.
/// - **Never blocks the master.** `submit`/`submit_batch` return at once; the work happens
///   on other threads (or machines), which complete the results and ring the notifier.
/// - **Thread safety.** The source is `Send`: it is built on one thread and moved to the
///   master's, which then calls it from that one thread alone (`&mut self`). Completers and
///   the [`Notifier`] are used from the workers' threads.
/// - **Lifecycle.** [`ComputeSource::set_notifier`] comes first, at most once; then any
///   number of submissions; then [`ComputeSource::finish`], once, after the master has
///   dropped its result handles. Once [`ComputeSource::is_lost`] is true it stays true, and
///   later submissions return already failed results.
pub trait ComputeSource: Send {
    /// This source's id: unique among a run's sources, carried by its results.
    fn id(&self) -> u32;
    /// A human-readable name for logs (`local-thread-3`, `faulty(…)`, …).
    fn label(&self) -> String;
    /// Hand an item over; returns at once. A lost source returns an already failed result.
    fn submit(&mut self, item: WorkItem) -> DelayedResult;
    /// Hand several items over at once (one message where the source can; a local thread
    /// then wakes once per hand-out, not per item); their results are pushed to `out` in
    /// order, one per item. `items` is left empty (its allocation is kept for the next
    /// hand-out).
    fn submit_batch(&mut self, items: &mut Vec<WorkItem>, out: &mut Vec<DelayedResult>) {
        out.extend(items.drain(..).map(|it| self.submit(it)));
    }
    /// Hand several items over as one hand-out whose results come back together, once its
    /// last item is done: one cell, one publication and one ring for the lot instead of one
    /// per item ([`Returns::HandOut`]). Same contract as `submit_batch` otherwise. A source
    /// that cannot ([`ComputeSource::returns_per_hand_out`] false) hands them back item by
    /// item.
    fn submit_hand_out(&mut self, items: &mut Vec<WorkItem>, out: &mut Vec<DelayedResult>) {
        self.submit_batch(items, out)
    }
    /// Does [`ComputeSource::submit_hand_out`] return a hand-out's results together?
    fn returns_per_hand_out(&self) -> bool {
        false
    }
    /// Does one hand-out cost about as much whatever its size (a GPU dispatch), so that it
    /// should go whole rather than split? The master then does not send an idle source's
    /// first item ahead of the rest.
    fn runs_hand_outs_whole(&self) -> bool {
        false
    }
    /// Where each hand-out runs as one dispatch of fixed cost (a GPU): that cost and the
    /// pixels that fill the device, for the master's balancer (`sched::rule::Balance`, which
    /// probes such a source at its fill first). `None`: item by item, as a thread.
    fn dispatch(&self) -> Option<Dispatch> {
        None
    }
    /// The source is gone: none of its outstanding results will arrive.
    fn is_lost(&self) -> bool;
    /// How many of its items the source has taken to the end (rendered, failed or skipped),
    /// where it serves items in submission order and counts them; `None` where it cannot
    /// say. An item counted here whose result has not arrived was lost on the way back; one
    /// not counted yet is still queued or being rendered, however long it takes.
    fn finished(&self) -> Option<u64> {
        None
    }
    /// Where to ring after each completed result (sources that cannot simply never ring; the
    /// master then wakes on its own tick).
    fn set_notifier(&mut self, _notifier: Notifier) {}
    /// Stop (skipping queued work) and report what the source did.
    fn finish(self: Box<Self>) -> SourceReport;
}

/// How a source hands the master's results back (its ids are parsed in `sched::spec`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Returns {
    /// Each result as soon as its item is rendered: the founding design.
    Item,
    /// All of a hand-out's results at once, when its last item is rendered.
    HandOut,
}

/// The per-item work every source runs: `render_item` in real runs, nothing in dispatch benches.
pub type Job = Arc<dyn Fn(&WorkItem) -> TileResult + Send + Sync>;

/// Why an item has no result.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SourceFailure {
    #[error("compute source {source_id} lost: {reason}")]
    /// The source died (panicked, killed, unreachable); its outstanding results are lost.
    Lost {
        /// The lost source's id.
        source_id: u32,
        /// How it was lost (a panic's message, a failed MPI call, silence).
        reason: String,
    },
    #[error("item {item} cancelled: the run was over")]
    /// The run was over before the item was started.
    Cancelled {
        /// The item that was skipped.
        item: u32,
    },
}

/// What a [`DelayedResult`] resolves to.
pub type Outcome = Result<TileResult, SourceFailure>;

/// What a source did over a run (idle time is filled in by the scheduler from the wall time).
#[derive(Clone, Debug, Default)]
pub struct SourceReport {
    /// Its worker statistics (busy time, items, pixels, rays).
    pub stats: WorkerStats,
    /// Its per-item timeline spans (empty unless a timeline is recorded).
    pub spans: Vec<Span>,
    /// It was lost by the time it stopped: a worker that panicked as the run ended, after the
    /// master's last look (a panic's message and backtrace can take longer than what is left
    /// of a short run), still counts as a lost source.
    pub lost: bool,
}

/// `submit` of a source whose hand-out logic lives in `submit_batch`: a batch of one.
pub fn submit_one<S: ComputeSource + ?Sized>(src: &mut S, item: WorkItem) -> DelayedResult {
    let mut out = Vec::with_capacity(1);
    src.submit_batch(&mut vec![item], &mut out);
    out.pop().expect("one result per item")
}

/// An empty result of `item`, for the tests of this module's parts.
#[cfg(test)]
fn empty_result(item: u32) -> TileResult {
    TileResult {
        item,
        pixels: Default::default(),
        rays: 0,
        nonfinite: 0,
    }
}
