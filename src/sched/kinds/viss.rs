//! `viss`: variable increase self-scheduling (VISS; Philip & Das, PDCS 1997): chunks grow from
//! batch to batch by half of the previous increase, c₀, 1.5·c₀, 1.75·c₀, … towards 2·c₀:
//! batch j's P chunks hold ⌊c₀·(1 − ½^(j+1)) / (1 − ½)⌋ items, c₀ = ⌊N/(V·P)⌋ with V = P
//! (LB4OMP's default `KMP_VISS_PARAM`), at least `grab`.
//!
//! Peer: LB4OMP `kmp_sch_viss` (`runtime/src/kmp_dispatch.cpp` 2211–2218 and 4627–4670), whose
//! c₀ is an integer division (rounded down) as here.

use super::BuiltIn;
use crate::sched::dls::ChunkRule;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

/// VISS over `n` items on `p` workers.
pub struct Viss {
    p: usize,
    first: usize,
    grab: usize,
    handed: usize,
}

impl Viss {
    /// VISS over `n` items on `p` workers, chunks of at least `grab`.
    pub fn new(n: usize, p: usize, grab: usize) -> Self {
        let p = p.max(1);
        Self {
            p,
            first: n / (p * p),
            grab,
            handed: 0,
        }
    }
}

impl ChunkRule for Viss {
    fn next(&mut self, _worker: usize, _remaining: usize) -> usize {
        let batch = (self.handed / self.p).min(64) as i32;
        self.handed += 1;
        let c = self.first as f64 * (1.0 - 0.5f64.powi(batch + 1)) / 0.5;
        (c.floor() as usize).max(self.grab).max(1)
    }
}

scheduler_params! {
    /// VISS's parameters.
    pub struct VissParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for VissParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("VISS", true));
    const DOC: &'static str = "Variable increase self-scheduling (VISS; Philip & Das 1997): \
        batches of P chunks growing from ⌊N/P²⌋ towards twice that, each increase half the last.";
    // Catalogue kinds: `advise` weighs them when named (`--scheduler`), not by default.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(Viss::new(n, workers, self.grab)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::dls::sequence;

    #[test]
    fn viss_n1000_p4_by_hand() {
        // c₀ = ⌊1000/16⌋ = 62: 4 × 62, 4 × 93 (248 + 372 = 620; 380 left), then 108 three
        // times (324; 56 left) and the last 56 clamped to what is left.
        let got = sequence(&mut Viss::new(1000, 4, 1), 1000, 4, |_, _| None);
        assert_eq!(got, [62, 62, 62, 62, 93, 93, 93, 93, 108, 108, 108, 56]);
    }
}
