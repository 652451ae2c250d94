//! `weighted_factoring`: weighted factoring (WF; Hummel et al. 1996): FAC2's batches, each
//! worker's chunk scaled by its relative speed. The rule is [`Factoring::weighted`].

use super::factoring::Factoring;
use super::BuiltIn;
use crate::sched::param::{scheduler_params, Slow, Weights};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

scheduler_params! {
    /// Weighted factoring's parameters.
    pub struct WeightedFactoringParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
        /// Where the per-worker weights come from: known (the run's slow setting) or measured
        /// (each worker's first chunk).
        weights: Weights = Weights::Known, label Some("weights");
    }
}

impl BuiltIn for WeightedFactoringParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("WF2", true));
    const DOC: &'static str = "Weighted factoring: FAC2 batches, each worker's chunk scaled by \
        its relative speed.";
    // Over equal workers the cost model plays it as `factoring`, which `advise` weighs.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, _n: usize, workers: usize, slow: Slow) -> HandOut {
        HandOut::shares(Box::new(Factoring::weighted(
            workers.max(1),
            self.grab,
            self.weights,
            slow,
        )))
    }
}
