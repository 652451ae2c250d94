//! `guided`: guided self-scheduling (Polychronopoulos & Kuck 1987) with a divisor k: each grab
//! takes max(grab, ⌈R/(k·P)⌉) of the R items left.

use super::BuiltIn;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::{Grab, HandOut};
use serde::{Deserialize, Serialize};

scheduler_params! {
    /// Guided self-scheduling's parameters.
    pub struct GuidedParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
        /// k in grab = max(grab, remaining / (k·workers)).
        guided_k: usize = 2, label None;
    }
}

impl BuiltIn for GuidedParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("GSS", false));
    const DOC: &'static str =
        "Grabs of max(grab, remaining / (k·workers)) items from a shared counter.";
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, _n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(Grab::guided(self.grab, self.guided_k, workers.max(1))))
    }
}
