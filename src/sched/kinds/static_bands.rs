//! `static`: contiguous bands of items, one per worker, fixed before the run; no master.

use super::BuiltIn;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::{HandOut, Ownership, WorkerRule};
use serde::{Deserialize, Serialize};

scheduler_params! {
    /// `static` has no parameters.
    pub struct StaticParams {}
}

impl BuiltIn for StaticParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("STATIC", true));
    const DOC: &'static str = "Contiguous bands of items, one per worker; no master.";

    fn hand_out(&self, _n: usize, _workers: usize, _slow: Slow) -> HandOut {
        HandOut::ByWorkers(WorkerRule::Own(Ownership::Bands))
    }
}
