//! `static_cyclic`: item i to worker i mod n, fixed before the run; no master.

use super::BuiltIn;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::{HandOut, Ownership, WorkerRule};
use serde::{Deserialize, Serialize};

scheduler_params! {
    /// `static_cyclic` has no parameters.
    pub struct StaticCyclicParams {}
}

impl BuiltIn for StaticCyclicParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("STATIC", false));
    const DOC: &'static str = "Item i to worker i mod n; no master.";
    // A fixed assignment like `static`: `advise` weighs that one.
    const ADVISED_BY_DEFAULT: bool = false;

    fn hand_out(&self, _n: usize, _workers: usize, _slow: Slow) -> HandOut {
        HandOut::ByWorkers(WorkerRule::Own(Ownership::Cyclic))
    }
}
