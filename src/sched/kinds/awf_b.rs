//! `awf_b`: adaptive weighted factoring, variant B (AWF-B; Cariño & Banicescu, "Dynamic load
//! balancing with adaptive factoring methods in scientific applications", J. Supercomputing
//! 44(1), 2008, §3), and the rule its siblings [`super::awf_c`], [`super::awf_d`] and
//! [`super::awf_e`] share.
//!
//! Worker i's performance is its weighted average time per item over the chunks it has
//! finished, chunk j (from 1) weighted by j so that recent chunks count more:
//!
//!   πᵢ = Σⱼ j·tᵢⱼ / Σⱼ j·nᵢⱼ,
//!
//! and its weight wᵢ = K·(1/πᵢ) / Σₖ (1/πₖ) over the K workers that have finished a chunk (a
//! worker without one keeps weight 1). The weights are recomputed after **every** chunk in
//! all four variants. The variants differ in two ways:
//!
//! - **B, D: by batch.** Chunks go out in FAC2 batches: R left when a batch starts, each of
//!   its P chunks ⌈wᵢ·⌈R/(2P)⌉⌉ with wᵢ current at the request. **C, E: by chunk.** Every
//!   request is sized from the items left at that request, ⌈wᵢ·⌈R/(2P)⌉⌉.
//! - **B, C: work time.** tᵢⱼ is the chunk's execution time. **D, E: elapsed time.** tᵢⱼ
//!   also holds the hand-out's cost (the time from asking to being answered), so a worker
//!   slow to be served counts as slow.
//!
//! Peers: LB4OMP (`runtime/src/kmp_dispatch.cpp` 5155–5307 B, 5308–5448 C; D and E are B and
//! C with total times) computes πᵢ and the K-worker weights as above, but sizes B's batches by
//! halving ⌈N/(2P)⌉ (FAC2a) and C's first chunk per worker from N; DLS4LB (`DLS.c` 274–327,
//! 852–861, 908–945) sizes B's batches from R at the batch start and C from R at each request,
//! as the paper does and as we do, and rounds w·chunk to nearest where we round up.
//! The older `awf` (FAC2 batches, a probe chunk, Σj·(t/n)/Σj) stays as a variant.

use super::factoring::{weighted, Batches};
use super::BuiltIn;
use crate::sched::dls::{ChunkRule, Report, Timing};
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

/// Which of Cariño & Banicescu's AWF variants.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AwfVariant {
    /// B and D: FAC2 batches; C and E: each request from the items left.
    pub batched: bool,
    /// D and E: a chunk's time includes its hand-out's.
    pub elapsed: bool,
}

impl AwfVariant {
    /// AWF-B.
    pub const B: Self = Self {
        batched: true,
        elapsed: false,
    };
    /// AWF-C.
    pub const C: Self = Self {
        batched: false,
        elapsed: false,
    };
    /// AWF-D.
    pub const D: Self = Self {
        batched: true,
        elapsed: true,
    };
    /// AWF-E.
    pub const E: Self = Self {
        batched: false,
        elapsed: true,
    };
}

/// AWF-B, -C, -D or -E on P workers.
pub struct AwfCb {
    variant: AwfVariant,
    batches: Batches,
    p: usize,
    grab: usize,
    /// Per worker: Σ j·t, Σ j·n, and j of its next finished chunk.
    perf: Vec<(f64, f64, u64)>,
    weights: Vec<f64>,
}

impl AwfCb {
    /// `variant` on `p` workers, chunks of at least `grab` items.
    pub fn new(variant: AwfVariant, p: usize, grab: usize) -> Self {
        let p = p.max(1);
        Self {
            variant,
            batches: Batches::new(p),
            p,
            grab,
            perf: vec![(0.0, 0.0, 1); p],
            weights: vec![1.0; p],
        }
    }

    /// The current weights.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    fn reweigh(&mut self) {
        let inv: Vec<Option<f64>> = self
            .perf
            .iter()
            .map(|&(t, n, _)| (t > 0.0 && n > 0.0).then(|| n / t))
            .collect();
        let known: Vec<f64> = inv.iter().flatten().copied().collect();
        let total: f64 = known.iter().sum();
        if !(total.is_finite() && total > 0.0) {
            return;
        }
        let k = known.len() as f64;
        for (w, s) in self.weights.iter_mut().zip(&inv) {
            *w = s.map_or(1.0, |s| k * s / total);
        }
    }
}

impl ChunkRule for AwfCb {
    fn next(&mut self, worker: usize, remaining: usize) -> usize {
        let base = if self.variant.batched {
            self.batches.base(remaining)
        } else {
            remaining.div_ceil(2 * self.p).max(1)
        };
        weighted(self.weights[worker], base).max(self.grab)
    }

    fn report(&mut self, worker: usize, r: &Report) {
        if r.items == 0 {
            return;
        }
        let t = if self.variant.elapsed {
            r.secs + r.grab_secs
        } else {
            r.secs
        };
        let (st, sn, j) = &mut self.perf[worker];
        *st += *j as f64 * t;
        *sn += *j as f64 * r.items as f64;
        *j += 1;
        self.reweigh();
    }

    fn timing(&self) -> Timing {
        Timing::Chunks
    }
}

scheduler_params! {
    /// AWF-B's parameters.
    pub struct AwfBParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for AwfBParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("AWF-B", true));
    const DOC: &'static str = "Adaptive weighted factoring, variant B (Cariño & Banicescu \
        2008): FAC2 batches, each chunk weighted by the worker's measured speed, re-weighed \
        after every chunk.";
    // Catalogue kinds: `advise` weighs them when named (`--scheduler`), not by default.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, _n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(AwfCb::new(AwfVariant::B, workers, self.grab)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::dls::sequence;

    #[test]
    fn weights_are_the_chunk_weighted_speed_by_hand() {
        let mut awf = AwfCb::new(AwfVariant::C, 3, 1);
        // Worker 0: 10 items in 20 s, then 30 items in 30 s: π₀ = (20 + 2·30)/(10 + 2·30) = 8/7.
        // Worker 1: 10 items in 10 s: π₁ = 1. Worker 2 has none: weight 1.
        for (w, items, secs) in [(0, 10, 20.0), (1, 10, 10.0), (0, 30, 30.0)] {
            awf.report(
                w,
                &Report {
                    items,
                    secs,
                    ..Default::default()
                },
            );
        }
        let (s0, s1) = (7.0 / 8.0, 1.0);
        assert!((awf.weights()[0] - 2.0 * s0 / (s0 + s1)).abs() < 1e-12);
        assert!((awf.weights()[1] - 2.0 * s1 / (s0 + s1)).abs() < 1e-12);
        assert_eq!(awf.weights()[2], 1.0);
    }

    #[test]
    fn awf_c_sizes_from_the_items_left_at_each_request() {
        // Equal speeds: every weight 1, so AWF-C is ⌈R/(2P)⌉ at each request: 125, 110, 96 …
        let got = sequence(&mut AwfCb::new(AwfVariant::C, 4, 1), 1000, 4, |_, items| {
            Some(Report {
                items,
                secs: items as f64,
                ..Default::default()
            })
        });
        assert_eq!(&got[..4], [125, 110, 96, 84]);
        // AWF-B at equal speeds is FAC2.
        let got = sequence(&mut AwfCb::new(AwfVariant::B, 4, 1), 1000, 4, |_, items| {
            Some(Report {
                items,
                secs: items as f64,
                ..Default::default()
            })
        });
        assert_eq!(&got[..8], [125, 125, 125, 125, 63, 63, 63, 63]);
    }
}
