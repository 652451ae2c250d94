//! `fsc`: fixed-size chunking as published (FSC; Kruskal & Weiss, "Allocating independent
//! subtasks on parallel processors", IEEE TSE 11(10), 1985, eq. (8)): every chunk holds
//!
//!   K = ( √2 · N · h / (σ · P · √(ln P)) )^(2/3)
//!
//! items, h the cost of one hand-out and σ the standard deviation of an item's time. h and σ
//! are measured online as in [`super::fixed_size`] (the first `fsc_warm` items one at a time);
//! unlike that variant, K is **not** capped at ⌈N/P⌉: with P = 1 or σ = 0 the formula's K
//! is infinite and the first worker takes everything left. The cap is kept as the documented
//! option of the variant `fixed_size`.
//!
//! Peers: LB4OMP `kmp_sch_fsc` (`runtime/src/kmp_dispatch.cpp` 1923–1964) and DLS4LB
//! (`DLS.c` 643–646) compute the same K from profiled h and σ, LB4OMP truncating it, DLS4LB
//! rounding up as we do.

use super::fixed_size::FixedSize;
use super::BuiltIn;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

scheduler_params! {
    /// Published FSC's parameters.
    pub struct FscParams {
        /// Items handed out one at a time first, to measure the hand-out cost h and the spread
        /// σ of item times online.
        fsc_warm: usize = 32, label Some("warm");
    }
}

impl BuiltIn for FscParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("FSC", true));
    const DOC: &'static str = "Fixed-size chunking as published (Kruskal & Weiss 1985): one \
        chunk size K from the measured hand-out cost and spread of item times, uncapped.";
    // Catalogue kinds: `advise` weighs them when named (`--scheduler`), not by default.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(FixedSize::uncapped(n, workers.max(1), self.fsc_warm)))
    }
}
