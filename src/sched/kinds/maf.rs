//! `maf`: modified adaptive factoring (mAF; Korndörfer, Eleliemy, Mohammed & Ciorba, "LB4OMP",
//! IEEE TPDS 33(4), 2022, §3): adaptive factoring ([`super::adaptive_factoring`]) whose item
//! times include the scheduling overhead. LB4OMP's `kmp_sch_af_a` (`runtime/src/
//! kmp_dispatch.cpp` 5918–6089) times each sub-chunk from one request to the next ("total
//! times (+h)"), so a worker's μᵢ is its items' mean time plus its hand-outs' cost spread over
//! the items they brought. Here: μᵢ′ = μᵢ + Σ hᵢ / Σ nᵢ, from each report's hand-out time;
//! σᵢ is AF's. The chunk formula and the probe chunks are AF's.

use super::adaptive_factoring::AdaptiveFactoring;
use super::BuiltIn;
use crate::sched::dls::{ChunkRule, Report, Timing};
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

/// mAF on P workers.
pub struct Maf {
    af: AdaptiveFactoring,
    /// Per worker: hand-out seconds and items so far.
    overhead: Vec<(f64, u64)>,
}

impl Maf {
    /// mAF on `p` workers, chunks of at least `grab` items.
    pub fn new(p: usize, grab: usize) -> Self {
        let p = p.max(1);
        Self {
            af: AdaptiveFactoring::new(p, grab),
            overhead: vec![(0.0, 0); p],
        }
    }
}

impl ChunkRule for Maf {
    fn next(&mut self, worker: usize, remaining: usize) -> usize {
        self.af.next(worker, remaining)
    }

    fn report(&mut self, worker: usize, r: &Report) {
        let (h, n) = &mut self.overhead[worker];
        *h += r.grab_secs;
        *n += r.items as u64;
        let mut with_h = *r;
        if *n > 0 {
            with_h.times.mean += *h / *n as f64;
        }
        self.af.report(worker, &with_h);
    }

    fn timing(&self) -> Timing {
        Timing::Items
    }
}

scheduler_params! {
    /// mAF's parameters.
    pub struct MafParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for MafParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("mAF", true));
    const DOC: &'static str = "Modified adaptive factoring (mAF; LB4OMP, Korndörfer et al. \
        2022): adaptive factoring with each item's time including its share of the hand-out \
        cost.";
    // Catalogue kinds: `advise` weighs them when named (`--scheduler`), not by default.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, _n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(Maf::new(workers, self.grab)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::dls::{sequence, ItemTimes};
    use crate::sched::kinds::adaptive_factoring::af_chunk;

    #[test]
    fn maf_adds_the_hand_out_cost_to_each_items_time() {
        let mut maf = Maf::new(2, 1);
        let mut times = [ItemTimes::default(); 2];
        // Both workers 1 s an item, no spread; worker 1's hand-outs cost 1 s each.
        let got = sequence(&mut maf, 1000, 2, |w, items| {
            for _ in 0..items {
                times[w].add(1.0);
            }
            Some(Report {
                items,
                times: times[w],
                grab_secs: w as f64,
                ..Default::default()
            })
        });
        // Probes 63, 59; then worker 0 (μ = 1, worker 1 not yet reported: counted at μ = 1)
        // gets half of R = 878; worker 1 (μ′ = 1 + 1/59) less than worker 0's share.
        assert_eq!(&got[..3], [63, 59, 439]);
        let mu1 = 1.0 + 1.0 / 59.0;
        let want = af_chunk(mu1, &[(1.0, 0.0), (mu1, 0.0)], 439).ceil() as usize;
        assert_eq!(got[3], want);
        assert!(want < 439 / 2 + 1);
    }
}
