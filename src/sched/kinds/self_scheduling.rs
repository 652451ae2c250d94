//! `self_scheduling`: one shared counter over the items; each request takes the next `grab`.

use super::BuiltIn;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::{Grab, HandOut};
use serde::{Deserialize, Serialize};

scheduler_params! {
    /// Self-scheduling's parameters.
    pub struct SelfSchedulingParams {
        /// Items a worker takes from the shared counter at once.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for SelfSchedulingParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("SS", true));
    const DOC: &'static str =
        "One shared atomic counter over items; each grab takes `grab` items.";

    fn hand_out(&self, _n: usize, _workers: usize, _slow: Slow) -> HandOut {
        HandOut::pool(Box::new(Grab::fixed(self.grab)))
    }
}
