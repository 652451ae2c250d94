//! `awf_e`: adaptive weighted factoring, variant E (AWF-E; Cariño & Banicescu, J.
//! Supercomputing 44(1), 2008): by chunk: each request sized from the items left, elapsed time (hand-out cost included). The rule, its formulas and the
//! peers' line numbers are in [`super::awf_b`].

use super::awf_b::{AwfCb, AwfVariant};
use super::BuiltIn;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

scheduler_params! {
    /// AWF-E's parameters.
    pub struct AwfEParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for AwfEParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("AWF-E", true));
    const DOC: &'static str = "Adaptive weighted factoring, variant E (Cariño & Banicescu \
        2008): by chunk: each request sized from the items left, elapsed time (hand-out cost included); re-weighed after every chunk.";
    // Catalogue kinds: `advise` weighs them when named (`--scheduler`), not by default.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, _n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(AwfCb::new(AwfVariant::E, workers, self.grab)))
    }
}
