//! `awf_d`: adaptive weighted factoring, variant D (AWF-D; Cariño & Banicescu, J.
//! Supercomputing 44(1), 2008): FAC2 batches, elapsed time (hand-out cost included). The rule, its formulas and the
//! peers' line numbers are in [`super::awf_b`].

use super::awf_b::{AwfCb, AwfVariant};
use super::BuiltIn;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

scheduler_params! {
    /// AWF-D's parameters.
    pub struct AwfDParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for AwfDParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("AWF-D", true));
    const DOC: &'static str = "Adaptive weighted factoring, variant D (Cariño & Banicescu \
        2008): FAC2 batches, elapsed time (hand-out cost included); re-weighed after every chunk.";
    // Catalogue kinds: `advise` weighs them when named (`--scheduler`), not by default.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, _n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(AwfCb::new(AwfVariant::D, workers, self.grab)))
    }
}
