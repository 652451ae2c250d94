//! Adaptive factoring (AF; Banicescu & Liu, "Adaptive factoring: a dynamic scheduling method
//! tuned to the rate of weight changes", HPC Symposium 2000; the formula as restated by Cariño
//! & Banicescu, "Dynamic load balancing with adaptive factoring methods in scientific
//! applications", J. Supercomputing 44, 2008, and implemented in LB4OMP's `AF`).
//!
//! Each worker i keeps the running mean μᵢ and standard deviation σᵢ of its item times. With
//! R items left, worker i's next chunk is
//!
//!   chunkᵢ = (D + 2·T·R − √(D² + 4·D·T·R)) / (2·μᵢ),
//!   D = Σⱼ σⱼ²/μⱼ,   T = 1 / Σⱼ (1/μⱼ),
//!
//! which is FAC's probabilistic chunk generalised to workers of different speeds: with σ = 0
//! it hands every worker its speed's share of R at once (T·R/μᵢ), and the larger the spread
//! the smaller the chunk. A worker that has timed fewer than two items has no σ yet: it gets a
//! probe chunk of ⌈R/(8P)⌉ (our choice: a quarter of a FAC2 chunk, small enough that a slow
//! worker's probe cannot dominate the run). Workers without statistics enter D and T with the
//! mean μ and σ² of those that have them.
//!
//! μᵢ and σᵢ are those of worker i's item times (Banicescu & Liu's definition), estimated
//! from groups of consecutive items timed together ([`Timing::Items`]: at most
//! [`super::TIMED_GROUPS`] clock reads per chunk; [`ItemTimes::add_group`]), as LB4OMP's
//! `AF` times sub-chunks rather than iterations. In stratified order a group's items sample
//! the whole image, so m·(a − μ)² of a group of m items averaging a estimates σᵢ².

use crate::sched::dls::{ceil_count, ChunkRule, ItemTimes, Report, Timing};
use super::BuiltIn;
use crate::sched::param::scheduler_params;
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};
use crate::sched::param::Slow;

/// AF on P workers.
pub struct AdaptiveFactoring {
    p: usize,
    grab: usize,
    times: Vec<ItemTimes>,
}

/// AF's chunk for a worker of mean item time `mu_i`, given everyone's (μ, σ²).
pub fn af_chunk(mu_i: f64, stats: &[(f64, f64)], remaining: usize) -> f64 {
    let d: f64 = stats.iter().map(|(mu, var)| var / mu).sum();
    let t = 1.0 / stats.iter().map(|(mu, _)| 1.0 / mu).sum::<f64>();
    let tr = t * remaining as f64;
    (d + 2.0 * tr - (d * d + 4.0 * d * tr).sqrt()) / (2.0 * mu_i)
}

impl AdaptiveFactoring {
    /// AF on `p` workers, chunks of at least `grab` items.
    pub fn new(p: usize, grab: usize) -> Self {
        Self {
            p,
            grab,
            times: vec![ItemTimes::default(); p],
        }
    }
}

impl ChunkRule for AdaptiveFactoring {
    fn next(&mut self, worker: usize, remaining: usize) -> usize {
        let known: Vec<(f64, f64)> = self
            .times
            .iter()
            .filter(|t| t.n >= 2 && t.mean > 0.0)
            .map(|t| (t.mean, t.var()))
            .collect();
        let me = self.times[worker];
        if me.n < 2 || me.mean <= 0.0 {
            return remaining.div_ceil(8 * self.p).max(self.grab);
        }
        let k = known.len() as f64;
        let mean_mu = known.iter().map(|s| s.0).sum::<f64>() / k;
        let mean_var = known.iter().map(|s| s.1).sum::<f64>() / k;
        let mut all = known;
        all.resize(self.p, (mean_mu, mean_var));
        ceil_count(af_chunk(me.mean, &all, remaining)).max(self.grab)
    }

    fn report(&mut self, worker: usize, r: &Report) {
        self.times[worker] = r.times;
    }

    fn timing(&self) -> Timing {
        Timing::Items
    }
}


scheduler_params! {
    /// Adaptive factoring's parameters.
    pub struct AdaptiveFactoringParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for AdaptiveFactoringParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("AF", true));
    const DOC: &'static str = "Adaptive factoring (AF): each chunk from the worker's running \
        mean and spread of item times.";
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, _n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(AdaptiveFactoring::new(workers.max(1), self.grab)))
    }
}

#[cfg(test)]
mod tests {
    use crate::sched::dls::sequence;
    use super::*;

    #[test]
    fn af_formula_by_hand() {
        // P = 4, μ = σ = 1 everywhere, R = 1000: D = 4, T = 1/4, TR = 250:
        // (4 + 500 − √(16 + 4000)) / 2 = (504 − 63.372) / 2 = 220.31. FAC's own chunk for
        // CV = 1 (R / (x·P), x = 1 + b² + b√(b² + 2), b = P·σ/(2√R·μ) = 0.0632) is 228.6: AF
        // is FAC's rule, per worker.
        let c = af_chunk(1.0, &[(1.0, 1.0); 4], 1000);
        assert!((c - 220.314).abs() < 1e-3, "{c}");
        // No spread: every worker gets its share of R at once; a worker twice as slow half as
        // much (T = 1/(1 + 1 + 1 + 0.5) = 2/7; chunk = T·R/μ).
        let s = [(1.0, 0.0), (1.0, 0.0), (1.0, 0.0), (2.0, 0.0)];
        assert!((af_chunk(1.0, &s, 700) - 200.0).abs() < 1e-9);
        assert!((af_chunk(2.0, &s, 700) - 100.0).abs() < 1e-9);
    }

    #[test]
    fn af_probes_then_follows_each_workers_statistics() {
        let mut af = AdaptiveFactoring::new(2, 1);
        let mut times = [ItemTimes::default(); 2];
        // Worker 0 takes 1 s per item, worker 1 alternates 1 and 3 s (μ = 2, σ² ≈ 1).
        let got = sequence(&mut af, 1000, 2, |w, items| {
            for j in 0..items {
                times[w].add(if w == 0 { 1.0 } else { [1.0, 3.0][j % 2] });
            }
            Some(Report {
                items,
                times: times[w],
                ..Default::default()
            })
        });
        // Probes: ⌈1000/16⌉ = 63, then ⌈937/16⌉ = 59.
        assert_eq!(&got[..2], [63, 59]);
        // Worker 0 asks again (R = 878) before worker 1 has reported: worker 1 enters with
        // worker 0's μ = 1, σ = 0, so D = 0 and worker 0 gets half of R, 439.
        assert_eq!(got[2], 439);
        // Worker 1 then reports its 59 items (μ ≈ 2, σ² ≈ 1): its chunk from R = 439.
        let t1 = times_of(59);
        let s = [(1.0, 0.0), (t1.mean, t1.var())];
        assert_eq!(got[3], af_chunk(t1.mean, &s, 439).ceil() as usize);
        assert_eq!(got.iter().sum::<usize>(), 1000);
    }

    fn times_of(n: usize) -> ItemTimes {
        let mut t = ItemTimes::default();
        for j in 0..n {
            t.add([1.0, 3.0][j % 2]);
        }
        t
    }
}
