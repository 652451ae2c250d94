//! `master`: the founding design. A master thread that renders nothing keeps at most B items
//! outstanding per compute source, from one FIFO queue, re-queueing handed-out items at the
//! back ([`MasterQueue`](crate::sched::rule::MasterQueue) is the queue's state machine).

use super::BuiltIn;
use crate::sched::param::{scheduler_params, Passes, Requeue, Returns, Slow, Wait};
use crate::sched::rule::{HandOut, MasterRule};
use serde::{Deserialize, Serialize};

scheduler_params! {
    /// The master's parameters.
    pub struct MasterParams {
        /// Items outstanding per compute source (B).
        buffer: usize = 2, label Some("B");
        /// When a handed-out, unfinished item is handed out again: seed (when it comes round
        /// in the queue), never or timeout:<ms>.
        requeue: Requeue = Requeue::Never, label Some("requeue");
        /// How the master waits for results: spin, yield or block.
        wait: Wait = Wait::Block, label Some("wait");
        /// How local threads hand results back: item (each as soon as it is rendered) or
        /// hand_out (a hand-out's together, when its last item is done; the master then hands
        /// out at most ⌈B/2⌉ items at a time, so a source has the next one queued).
        returns: Returns = Returns::Item, label Some("returns");
        /// Who runs the master's passes: thread (a thread of its own that renders nothing; any
        /// source) or workers (each local thread for itself under one lock when it reports,
        /// the queue and re-queue rules unchanged; local threads only, no fault injection).
        passes: Passes = Passes::Thread, label Some("passes");
    }
}

impl From<MasterParams> for MasterRule {
    fn from(p: MasterParams) -> Self {
        Self {
            buffer: p.buffer,
            requeue: p.requeue,
            wait: p.wait,
            returns: p.returns,
            passes: p.passes,
        }
    }
}

impl BuiltIn for MasterParams {
    const DOC: &'static str = "The founding design: a master thread (renders nothing) keeps \
        ≤ B items outstanding per compute source, re-queueing handed-out items at the back of \
        a FIFO.";

    fn hand_out(&self, _n: usize, _workers: usize, _slow: Slow) -> HandOut {
        HandOut::ByMaster((*self).into())
    }
}
