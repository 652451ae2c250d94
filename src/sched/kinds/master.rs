//! `master`: the founding design. A master thread that renders nothing keeps at most B items
//! outstanding per compute source, from one FIFO queue, re-queueing handed-out items at the
//! back ([`MasterQueue`](crate::sched::rule::MasterQueue) is the queue's state machine).

use super::BuiltIn;
use crate::sched::param::Slow;
use crate::sched::rule::HandOut;
pub use crate::sched::rule::MasterParams;

impl BuiltIn for MasterParams {
    const DOC: &'static str = "The founding design: a master thread (renders nothing) keeps \
        ≤ B items outstanding per compute source, re-queueing handed-out items at the back of \
        a FIFO.";

    fn hand_out(&self, _n: usize, _workers: usize, _slow: Slow) -> HandOut {
        HandOut::ByMaster(*self)
    }
}
