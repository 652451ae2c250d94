//! Factoring (FAC2; Hummel, Schonberg & Flynn, "Factoring: a method for scheduling parallel
//! loops", CACM 35(8), 1992) and weighted factoring (WF; Hummel, Schmidt, Uma & Wein, "Load-
//! sharing in heterogeneous systems via weighted factoring", SPAA 1996).
//!
//! Work goes out in batches. A batch starts when the previous one's P chunks are all handed
//! out; with R items left at that moment, each of its P chunks holds ⌈R/(2P)⌉ items (FAC2:
//! every batch hands out about half of what is left). WF scales worker i's chunk by its weight
//! wᵢ (the weights sum to P, so a batch still holds about half of R): ⌈wᵢ·⌈R/(2P)⌉⌉.
//!
//! WF's weights are either **known** — worker i slowed F× ([`Slow`]) has relative speed 1/F —
//! or **measured**: every worker's first chunk is a probe of ⌈R/(8P)⌉ items outside the
//! batches ([`probe_chunk`]) and its time per item fixes its weight for the rest of the run
//! (the online variant; a calibrated run would pass known speeds instead).

use crate::sched::dls::{ceil_count, ChunkRule, Report, Timing};
use crate::sched::param::{Slow, Weights};
use super::BuiltIn;
use crate::sched::param::scheduler_params;
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

/// Batches of P chunks: the part FAC2, WF and AWF share.
#[derive(Clone, Debug)]
pub(crate) struct Batches {
    p: usize,
    /// Chunks of the current batch not yet handed out.
    left: usize,
    /// ⌈R/(2P)⌉ of the current batch.
    base: usize,
}

impl Batches {
    pub(crate) fn new(p: usize) -> Self {
        Self {
            p,
            left: 0,
            base: 0,
        }
    }

    /// The current batch's unweighted chunk, starting a new batch when the last is used up.
    pub(crate) fn base(&mut self, remaining: usize) -> usize {
        if self.left == 0 {
            self.base = remaining.div_ceil(2 * self.p).max(1);
            self.left = self.p;
        }
        self.left -= 1;
        self.base
    }
}

/// The first chunk of a worker whose speed is not measured yet: ⌈R/(8P)⌉, a quarter of a FAC2
/// chunk, so that a slow worker's blind chunk stays a small part of the run.
pub(crate) fn probe_chunk(remaining: usize, p: usize) -> usize {
    remaining.div_ceil(8 * p.max(1)).max(1)
}

/// `⌈w·base⌉`, tolerant of the rounding in a weight that should be exactly 1.
pub(crate) fn weighted(w: f64, base: usize) -> usize {
    ceil_count(w * base as f64 - 1e-9)
}

/// Speeds → weights summing to P (equal weights when the speeds are unusable).
pub(crate) fn normalise(speeds: &[f64]) -> Vec<f64> {
    let total: f64 = speeds.iter().sum();
    let p = speeds.len() as f64;
    if !(total.is_finite() && total > 0.0) {
        return vec![1.0; speeds.len()];
    }
    speeds.iter().map(|s| p * s / total).collect()
}

/// FAC2 and WF.
pub struct Factoring {
    batches: Batches,
    grab: usize,
    weights: Vec<f64>,
    /// WF measured: each worker's time per item over its first chunk, until all have one.
    measuring: Option<Vec<Option<f64>>>,
}

impl Factoring {
    /// FAC2 on `p` workers, chunks of at least `grab` items.
    pub fn fac2(p: usize, grab: usize) -> Self {
        Self {
            batches: Batches::new(p),
            grab,
            weights: vec![1.0; p],
            measuring: None,
        }
    }

    /// WF on `p` workers with weights from `source`.
    pub fn weighted(p: usize, grab: usize, source: Weights, slow: Slow) -> Self {
        let mut f = Self::fac2(p, grab);
        match source {
            Weights::Known => {
                let speeds: Vec<f64> = (0..p).map(|i| 1.0 / slow.factor_of(i)).collect();
                f.weights = normalise(&speeds);
            }
            Weights::Measured => f.measuring = Some(vec![None; p]),
        }
        f
    }

    /// The current weights (summing to P).
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }
}

impl ChunkRule for Factoring {
    fn next(&mut self, worker: usize, remaining: usize) -> usize {
        if self.measuring.as_ref().is_some_and(|m| m[worker].is_none()) {
            return probe_chunk(remaining, self.weights.len()).max(self.grab);
        }
        let base = self.batches.base(remaining);
        weighted(self.weights[worker], base).max(self.grab)
    }

    fn report(&mut self, worker: usize, r: &Report) {
        let Some(m) = &mut self.measuring else {
            return;
        };
        if m[worker].is_none() && r.items > 0 {
            m[worker] = Some(r.secs / r.items as f64);
        }
        if m.iter().all(Option::is_some) {
            let speeds: Vec<f64> = m.iter().map(|t| 1.0 / t.unwrap_or(1.0)).collect();
            self.weights = normalise(&speeds);
            self.measuring = None;
        }
    }

    fn timing(&self) -> Timing {
        if self.measuring.is_some() {
            Timing::Chunks
        } else {
            Timing::None
        }
    }
}


scheduler_params! {
    /// Factoring's parameters.
    pub struct FactoringParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for FactoringParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("FAC2", true));
    const DOC: &'static str =
        "Factoring (FAC2): batches of P chunks of ⌈R/(2P)⌉ items, R left at the batch start.";
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, _n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(Factoring::fac2(workers.max(1), self.grab)))
    }
}

#[cfg(test)]
mod tests {
    use crate::sched::dls::sequence;
    use super::*;

    #[test]
    fn fac2_n1000_p4_by_hand() {
        // R = 1000 → 4 × 125; 500 → 4 × 63; 248 → 4 × 31; 124 → 4 × 16; 60 → 4 × 8;
        // 28 → 4 × 4; 12 → 4 × 2; 4 → 4 × 1.
        let want: Vec<usize> = [125, 63, 31, 16, 8, 4, 2, 1]
            .iter()
            .flat_map(|&c| [c; 4])
            .collect();
        let got = sequence(&mut Factoring::fac2(4, 1), 1000, 4, |_, _| None);
        assert_eq!(got, want);
        assert_eq!(got.iter().sum::<usize>(), 1000);
    }

    #[test]
    fn fac2_respects_the_smallest_grab_and_the_last_items() {
        // R = 100, P = 2: 25, 25; 50 → 13, 13; 24 → 6, 6; 12 → 3 → grab 4, 4; 4 → 1 → 4 (clamped).
        let got = sequence(&mut Factoring::fac2(2, 4), 100, 2, |_, _| None);
        assert_eq!(got, [25, 25, 13, 13, 6, 6, 4, 4, 4]);
    }

    #[test]
    fn wf_known_weights_follow_the_slowdown() {
        // Worker 0 at a quarter speed: speeds 0.25, 1 → weights 0.4, 1.6 (sum 2).
        let slow = Slow::parse("1:4").unwrap();
        let mut wf = Factoring::weighted(2, 1, Weights::Known, slow);
        assert!((wf.weights()[0] - 0.4).abs() < 1e-12 && (wf.weights()[1] - 1.6).abs() < 1e-12);
        // N = 1000, P = 2: base 250 → ⌈0.4·250⌉ = 100, ⌈1.6·250⌉ = 400; R = 500 → base 125 →
        // 50, 200; R = 250 → base 63 → 26 (25.2), 101 (100.8).
        let got = sequence(&mut wf, 1000, 2, |_, _| None);
        assert_eq!(&got[..6], [100, 400, 50, 200, 26, 101]);
        assert_eq!(got.iter().sum::<usize>(), 1000);
        // No slowdown: FAC2 exactly.
        let mut even = Factoring::weighted(4, 1, Weights::Known, Slow::NONE);
        let fac2 = sequence(&mut Factoring::fac2(4, 1), 1000, 4, |_, _| None);
        assert_eq!(sequence(&mut even, 1000, 4, |_, _| None), fac2);
    }

    #[test]
    fn wf_measured_weights_come_from_each_workers_first_chunk() {
        let mut wf = Factoring::weighted(2, 1, Weights::Measured, Slow::NONE);
        assert_eq!(wf.timing(), Timing::Chunks);
        // Worker 0 takes 3 s per item, worker 1 takes 1 s: speeds 1/3, 1 → weights 0.5, 1.5.
        let got = sequence(&mut wf, 1000, 2, |w, items| {
            Some(Report {
                items,
                secs: items as f64 * if w == 0 { 3.0 } else { 1.0 },
                ..Default::default()
            })
        });
        // Probes ⌈1000/16⌉ = 63 and ⌈937/16⌉ = 59. Worker 0 reports before worker 1 has, so
        // its first batch chunk is unweighted (R = 878, base 220); worker 1's report fixes the
        // weights at 0.5, 1.5: ⌈1.5·220⌉ = 330; then R = 328, base 82 → 41, 123.
        assert_eq!(&got[..6], [63, 59, 220, 330, 41, 123]);
        assert_eq!(wf.timing(), Timing::None);
        assert!((wf.weights()[0] - 0.5).abs() < 1e-12);
    }
}
