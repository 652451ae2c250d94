//! [`MpiRankSource`]: one worker rank as a `ComputeSource` of the master on rank 0.
//!
//! The communicator may only be used by the thread that initialised MPI (`FUNNELED`), and the
//! master runs on another thread; so `submit` puts (item, completer) on a channel to the
//! [`super::hub::Hub`], which sends it, polls for results and completes the completers.

use crate::core::render::WorkItem;
use crate::source::{
    submit_one, Completer, ComputeSource, DelayedResult, Notifier, SourceFailure, SourceReport,
};
use crossbeam::channel::Sender;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

/// One hand-out to one rank: it travels as one ITEM message.
pub struct Cmd {
    pub(super) rank: i32,
    pub(super) items: Vec<(WorkItem, Completer)>,
}

/// What a source and the hub both see of one rank.
pub(super) struct Shared {
    pub(super) lost: AtomicBool,
    pub(super) notifier: OnceLock<Notifier>,
    pub(super) report: Mutex<SourceReport>,
}

impl Shared {
    /// A rank not yet heard from: its report's statistics say it is an MPI rank.
    pub(super) fn new() -> Self {
        let mut report = SourceReport::default();
        report.stats.source = Some(crate::core::metrics::SourceKind::Mpi);
        Self {
            lost: AtomicBool::new(false),
            notifier: OnceLock::new(),
            report: Mutex::new(report),
        }
    }
}

/// One worker rank as a compute source of the master on rank 0.
pub struct MpiRankSource {
    id: u32,
    rank: i32,
    tx: Sender<Cmd>,
    shared: Arc<Shared>,
}

impl ComputeSource for MpiRankSource {
    fn id(&self) -> u32 {
        self.id
    }
    fn label(&self) -> String {
        format!("mpi-rank-{}", self.rank)
    }
    fn submit(&mut self, item: WorkItem) -> DelayedResult {
        submit_one(self, item)
    }
    /// One MPI message for the whole hand-out (per-ray items over TCP: ~14–16 µs per message
    /// through rank 0's MPI thread, the per-ray bottleneck).
    fn submit_batch(&mut self, items: &mut Vec<WorkItem>, out: &mut Vec<DelayedResult>) {
        let lost = self.is_lost();
        let mut cmd = Cmd {
            rank: self.rank,
            items: Vec::with_capacity(items.len()),
        };
        for item in items.drain(..) {
            let (d, done) = DelayedResult::pending(item.id, self.id);
            out.push(d);
            if lost {
                done.complete(Err(self.lost_failure()));
            } else {
                cmd.items.push((item, done));
            }
        }
        if !cmd.items.is_empty() {
            // A closed channel drops the completers, which fails the results.
            let _ = self.tx.send(cmd);
        }
    }
    fn is_lost(&self) -> bool {
        self.shared.lost.load(Ordering::SeqCst)
    }
    fn set_notifier(&mut self, notifier: Notifier) {
        let _ = self.shared.notifier.set(notifier);
    }
    fn finish(self: Box<Self>) -> SourceReport {
        std::mem::take(&mut *self.shared.report.lock().unwrap_or_else(|e| e.into_inner()))
    }
}

impl MpiRankSource {
    /// The source of `rank` (source id `id`), whose hand-outs go to the hub over `tx`.
    pub(super) fn new(id: u32, rank: i32, tx: Sender<Cmd>, shared: Arc<Shared>) -> Self {
        Self {
            id,
            rank,
            tx,
            shared,
        }
    }

    fn lost_failure(&self) -> SourceFailure {
        SourceFailure::Lost {
            source_id: self.id,
            reason: format!("MPI rank {} lost", self.rank),
        }
    }
}
