//! `work_stealing`: rayon over the items, each worker splitting its range and idle workers
//! stealing halves.

use super::BuiltIn;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::{HandOut, Steal, WorkerRule};
use serde::{Deserialize, Serialize};

scheduler_params! {
    /// Work stealing's parameters.
    pub struct WorkStealingParams {
        /// The fewest items one task holds (rayon's minimum split).
        grab: usize = 1, label None;
    }
}

impl BuiltIn for WorkStealingParams {
    const DOC: &'static str = "rayon over items, split no finer than `grab` items per task.";

    fn hand_out(&self, _n: usize, _workers: usize, _slow: Slow) -> HandOut {
        HandOut::ByWorkers(WorkerRule::Steal(Steal::Split { min: self.grab }))
    }
}
