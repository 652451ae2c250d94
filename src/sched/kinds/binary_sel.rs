//! `binary_sel`: Auto4OMP's BinarySel (Mohammed & Ciorba 2022) among the DLS techniques while
//! the render runs. The rule, its phases and measures are in [`super::select`].

use super::select::{Method, Selector};
use super::BuiltIn;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

scheduler_params! {
    /// BinarySel's parameters.
    pub struct BinarySelParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
        /// Loop instances the render's items are cut into, one technique chosen per instance.
        sel_phases: usize = 20, label Some("phases");
    }
}

impl BuiltIn for BinarySelParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("BinarySel", false));
    const DOC: &'static str = "Auto4OMP's BinarySel: jumps through the portfolio by halving steps, right when the imbalance grew, left when it fell (Mohammed & Ciorba 2022); the render cut into \
        `sel_phases` loop instances.";
    // Catalogue kinds: `advise` weighs them when named (`--scheduler`), not by default.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(Selector::new(
            Method::Binary,
            n,
            workers,
            self.sel_phases,
            self.grab,
        )))
    }
}
