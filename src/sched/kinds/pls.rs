//! `pls`: performance-based loop scheduling (PLS; Shih, Yang & Tseng, "A performance-based
//! parallel loop scheduling on grid environments", J. Supercomputing 41(3), 2007): a static
//! part first, a dynamic part after. Each worker's first request takes ⌈N·SWR/P⌉ items (SWR,
//! the static workload ratio, the parameter `pls_swr` in percent); every later request is
//! sized by guided self-scheduling over what is left, ⌈R/P⌉ (at least `grab`).
//!
//! Peer: LB4OMP `kmp_sch_pls` (`runtime/src/kmp_dispatch.cpp` 2268–2284 and 4804–4855)
//! writes GSS's chunks in closed form, ⌈(1 − 1/P)^s · N′/P⌉ for the s-th dynamic request,
//! N′ = N − P·⌈N·SWR/P⌉; we size from the items actually left, as GSS is defined. The two
//! part a chunk or two apart at the tail (the conformance test lists it).

use super::BuiltIn;
use crate::sched::dls::ChunkRule;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

/// PLS over `n` items on `p` workers.
pub struct Pls {
    p: usize,
    static_part: usize,
    grab: usize,
    handed: usize,
}

impl Pls {
    /// PLS over `n` items on `p` workers, static ratio `swr` (0..=1), chunks ≥ `grab`.
    pub fn new(n: usize, p: usize, swr: f64, grab: usize) -> Self {
        let p = p.max(1);
        Self {
            p,
            static_part: ((n as f64 * swr / p as f64).ceil() as usize).max(1),
            grab,
            handed: 0,
        }
    }
}

impl ChunkRule for Pls {
    fn next(&mut self, _worker: usize, remaining: usize) -> usize {
        self.handed += 1;
        let c = if self.handed <= self.p {
            self.static_part
        } else {
            remaining.div_ceil(self.p)
        };
        c.max(self.grab)
    }
}

scheduler_params! {
    /// PLS's parameters.
    pub struct PlsParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
        /// The static workload ratio SWR, in percent: the share of the items handed out
        /// statically, one equal part per worker, before guided self-scheduling takes over.
        pls_swr: usize = 50, label Some("swr%");
    }
}

impl BuiltIn for PlsParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("PLS", true));
    const DOC: &'static str = "Performance-based loop scheduling (PLS; Shih et al. 2007): \
        each worker first takes ⌈N·SWR/P⌉ items, then guided self-scheduling over the rest.";
    // Catalogue kinds: `advise` weighs them when named (`--scheduler`), not by default.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, n: usize, workers: usize, _slow: Slow) -> HandOut {
        let swr = (self.pls_swr.min(100)) as f64 / 100.0;
        HandOut::shares(Box::new(Pls::new(n, workers, swr, self.grab)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::dls::sequence;

    #[test]
    fn pls_n1000_p4_by_hand() {
        // Static: 4 × 125; then ⌈500/4⌉ = 125, ⌈375/4⌉ = 94, ⌈281/4⌉ = 71 …
        let got = sequence(&mut Pls::new(1000, 4, 0.5, 1), 1000, 4, |_, _| None);
        assert_eq!(&got[..7], [125, 125, 125, 125, 125, 94, 71]);
        assert_eq!(got.iter().sum::<usize>(), 1000);
    }
}
