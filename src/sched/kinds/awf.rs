//! Adaptive weighted factoring, variant C (AWF-C; Banicescu, Velusamy & Devaprasad, "On the
//! scalability of dynamic scheduling scientific applications with adaptive weighted
//! factoring", Cluster Computing 6, 2003; variants B and C in Cariño & Banicescu, J.
//! Supercomputing 44, 2008).
//!
//! Chunks go out in FAC2 batches ([`super::factoring`]): worker i's chunk is ⌈wᵢ·⌈R/(2P)⌉⌉
//! with R left at the batch start and weights summing to P. AWF-B updates the weights at batch
//! boundaries; this is **AWF-C**, which updates them after every chunk. A worker's
//! performance is the weighted mean of its per-item times over its chunks so far, chunk j
//! (from 1) weighted by j, so recent chunks count more:
//!
//!   πᵢ = Σⱼ j·(tᵢⱼ/nᵢⱼ) / Σⱼ j,   wᵢ = P·(1/πᵢ) / Σₖ (1/πₖ).
//!
//! A worker with no finished chunk yet counts at the mean speed of those that have one (all
//! weights are 1 before anyone has reported).
//!
//! A worker's first chunk is a probe of ⌈R/(8P)⌉ items outside the batches (our choice, as
//! adaptive factoring's probe): a first FAC2 batch at equal weights hands every worker a
//! quarter of the image on 2 workers before any speed is known, and a slow worker's blind
//! quarter was the run's tail (M-125).

use super::factoring::{normalise, probe_chunk, weighted, Batches};
use crate::sched::dls::{ChunkRule, Report, Timing};
use super::BuiltIn;
use crate::sched::param::scheduler_params;
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};
use crate::sched::param::Slow;

/// AWF-C on P workers.
pub struct Awf {
    batches: Batches,
    grab: usize,
    /// Per worker: Σ j·(t/n), Σ j, and j of the next chunk.
    perf: Vec<(f64, f64, u64)>,
    weights: Vec<f64>,
}

impl Awf {
    /// AWF-C on `p` workers, chunks of at least `grab` items.
    pub fn new(p: usize, grab: usize) -> Self {
        Self {
            batches: Batches::new(p),
            grab,
            perf: vec![(0.0, 0.0, 1); p],
            weights: vec![1.0; p],
        }
    }

    /// The current weights (summing to P).
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    fn reweigh(&mut self) {
        let speed: Vec<Option<f64>> = self
            .perf
            .iter()
            .map(|&(num, den, _)| (den > 0.0 && num > 0.0).then(|| den / num))
            .collect();
        let known: Vec<f64> = speed.iter().flatten().copied().collect();
        if known.is_empty() {
            return;
        }
        let mean = known.iter().sum::<f64>() / known.len() as f64;
        let all: Vec<f64> = speed.iter().map(|s| s.unwrap_or(mean)).collect();
        self.weights = normalise(&all);
    }
}

impl ChunkRule for Awf {
    fn next(&mut self, worker: usize, remaining: usize) -> usize {
        if self.perf[worker].2 == 1 {
            return probe_chunk(remaining, self.perf.len()).max(self.grab);
        }
        let base = self.batches.base(remaining);
        weighted(self.weights[worker], base).max(self.grab)
    }

    fn report(&mut self, worker: usize, r: &Report) {
        if r.items == 0 {
            return;
        }
        let (num, den, j) = &mut self.perf[worker];
        *num += *j as f64 * r.secs / r.items as f64;
        *den += *j as f64;
        *j += 1;
        self.reweigh();
    }

    fn timing(&self) -> Timing {
        Timing::Chunks
    }
}


scheduler_params! {
    /// Adaptive weighted factoring's parameters.
    pub struct AwfParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for AwfParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("AWF-B", false));
    const DOC: &'static str = "Adaptive weighted factoring, variant C (AWF-C): FAC2 batches, \
        weights updated from measured speed after every chunk.";
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, _n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(Awf::new(workers.max(1), self.grab)))
    }
}

#[cfg(test)]
mod tests {
    use crate::sched::dls::sequence;
    use super::*;

    #[test]
    fn awf_c_weights_by_hand() {
        let mut awf = Awf::new(2, 1);
        // Worker 0: chunks at 2 s then 4 s per item: π₀ = (1·2 + 2·4)/3 = 10/3.
        // Worker 1: 1 s per item: π₁ = 1. Speeds 0.3, 1 → weights 2·0.3/1.3, 2·1/1.3.
        for (w, secs) in [(0, 2.0), (1, 1.0), (0, 4.0)] {
            awf.report(
                w,
                &Report {
                    items: 10,
                    secs: secs * 10.0,
                    ..Default::default()
                },
            );
        }
        assert!((awf.weights()[0] - 0.6 / 1.3).abs() < 1e-12);
        assert!((awf.weights()[1] - 2.0 / 1.3).abs() < 1e-12);
    }

    #[test]
    fn awf_c_sequence_n1000_p2() {
        // Worker 0 takes 3 s per item, worker 1 takes 1 s.
        let got = sequence(&mut Awf::new(2, 1), 1000, 2, |w, items| {
            Some(Report {
                items,
                secs: items as f64 * if w == 0 { 3.0 } else { 1.0 },
                ..Default::default()
            })
        });
        // Probes: ⌈1000/16⌉ = 63, ⌈937/16⌉ = 59. Batch 1 (R = 878, base 220): worker 0 has
        // reported, worker 1 counts at its mean: weights 1 → 220; worker 1 reports → speeds
        // 1/3, 1 → weights 0.5, 1.5 → 330. Batch 2 (R = 328, base 82): 41, 123.
        assert_eq!(&got[..6], [63, 59, 220, 330, 41, 123]);
        assert_eq!(got.iter().sum::<usize>(), 1000);
    }
}
