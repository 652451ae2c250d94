//! `work_stealing_deque`: one deque per worker filled with its band; an idle worker steals
//! half of another's.

use super::BuiltIn;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::{HandOut, Steal, WorkerRule};
use serde::{Deserialize, Serialize};

scheduler_params! {
    /// `work_stealing_deque` has no parameters.
    pub struct WorkStealingDequeParams {}
}

impl BuiltIn for WorkStealingDequeParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("static_steal", false));
    const DOC: &'static str =
        "One crossbeam-deque per worker, stealing from the others when empty.";
    // The cost model plays it as `work_stealing`, which `advise` weighs.
    const ADVISED_BY_DEFAULT: bool = false;

    fn hand_out(&self, _n: usize, _workers: usize, _slow: Slow) -> HandOut {
        HandOut::ByWorkers(WorkerRule::Steal(Steal::Half))
    }
}
