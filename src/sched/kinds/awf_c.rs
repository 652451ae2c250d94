//! `awf_c`: adaptive weighted factoring, variant C (AWF-C; Cariño & Banicescu, J.
//! Supercomputing 44(1), 2008): by chunk: each request sized from the items left, work time. The rule, its formulas and the
//! peers' line numbers are in [`super::awf_b`].

use super::awf_b::{AwfCb, AwfVariant};
use super::BuiltIn;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

scheduler_params! {
    /// AWF-C's parameters.
    pub struct AwfCParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for AwfCParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("AWF-C", true));
    const DOC: &'static str = "Adaptive weighted factoring, variant C (Cariño & Banicescu \
        2008): by chunk: each request sized from the items left, work time; re-weighed after every chunk.";
    // Catalogue kinds: `advise` weighs them when named (`--scheduler`), not by default.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, _n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(AwfCb::new(AwfVariant::C, workers, self.grab)))
    }
}
