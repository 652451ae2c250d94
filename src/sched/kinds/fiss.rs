//! `fiss`: fixed increase self-scheduling (FISS; Philip & Das, "Evaluation of loop scheduling
//! algorithms on distributed memory systems", PDCS 1997): chunks *grow* by a fixed amount from
//! batch to batch, so that B stages of P chunks hand out all N items:
//!
//!   X = B + 2,   c₀ = ⌊N/(X·P)⌋,   δ = ⌊2N·(1 − B/X) / (P·B·(B − 1))⌋,
//!
//! batch j's P chunks holding c₀ + j·δ items (at least `grab`). B = P − 1 as LB4OMP's default
//! (`KMP_FISS_STAGES`), but at least 2: B = 1 divides by zero in δ (LB4OMP, for P = 2,
//! converts an infinite δ to an integer).
//!
//! Peer: LB4OMP `kmp_sch_fiss` (`runtime/src/kmp_dispatch.cpp` 2220–2238 and 4671–4709).

use super::BuiltIn;
use crate::sched::dls::ChunkRule;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

/// FISS over `n` items on `p` workers.
pub struct Fiss {
    p: usize,
    first: usize,
    delta: usize,
    grab: usize,
    handed: usize,
}

impl Fiss {
    /// FISS over `n` items on `p` workers, chunks of at least `grab`.
    pub fn new(n: usize, p: usize, grab: usize) -> Self {
        let p = p.max(1);
        let b = (p.saturating_sub(1)).max(2) as f64;
        let x = b + 2.0;
        let n = n as f64;
        let first = (n / (x * p as f64)).floor() as usize;
        let delta = (2.0 * n * (1.0 - b / x) / (p as f64 * b * (b - 1.0))).floor() as usize;
        Self {
            p,
            first,
            delta,
            grab,
            handed: 0,
        }
    }
}

impl ChunkRule for Fiss {
    fn next(&mut self, _worker: usize, _remaining: usize) -> usize {
        let batch = self.handed / self.p;
        self.handed += 1;
        (self.first + batch * self.delta).max(self.grab).max(1)
    }
}

scheduler_params! {
    /// FISS's parameters.
    pub struct FissParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for FissParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("FISS", true));
    const DOC: &'static str = "Fixed increase self-scheduling (FISS; Philip & Das 1997): \
        batches of P chunks growing by a fixed δ over B = max(P − 1, 2) stages.";
    // Catalogue kinds: `advise` weighs them when named (`--scheduler`), not by default.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(Fiss::new(n, workers, self.grab)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::dls::sequence;

    #[test]
    fn fiss_n1000_p4_by_hand() {
        // B = 3, X = 5: c₀ = ⌊1000/20⌋ = 50, δ = ⌊2000·0.4/(4·3·2)⌋ = 33: 4 × 50, 4 × 83, then
        // 116 until the 1000 are out (468 left after two batches: 116 × 4 = 464, then 4).
        let got = sequence(&mut Fiss::new(1000, 4, 1), 1000, 4, |_, _| None);
        assert_eq!(got, [50, 50, 50, 50, 83, 83, 83, 83, 116, 116, 116, 116, 4]);
    }
}
