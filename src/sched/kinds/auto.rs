//! `auto`: a pool rule with no parameter to set. Every chunk is sized from what the workers
//! reported so far — each worker's time per item on its last chunk (its current speed), the
//! spread of item times and the measured cost of a hand-out — so the same rule runs a GPU
//! beside threads, a worker that slows down half-way and a slow network link without a grain
//! picked by hand.
//!
//! With R items left, every worker j's current time per item uⱼ (a worker not heard from yet
//! counts at the mean of those heard from) and the summed rate U = Σⱼ 1/uⱼ, worker i gets
//!
//! ```text
//! chunkᵢ = max(T/x, Q·hᵢ) / uᵢ,   T = R/U,
//! x = max(2, 1 + b² + b·√(b² + 2)),   b = P·σ/(2·√R·μ),
//! ```
//!
//! T is the time the workers together still need, T/x the share of it factoring (Hummel,
//! Schonberg & Flynn 1992) hands out next: x = 2 is FAC2 (each round half of what is left, so
//! the last chunks are small and finish together), and a larger spread σ/μ of item times (μ,
//! σ: the pooled item-time statistics the workers measure, `Timing::Items`) asks for smaller
//! chunks. Dividing by uᵢ weighs the chunk by worker i's speed, as weighted factoring does, but
//! from its *latest* chunk, so a worker that slows down gets smaller chunks from its next one
//! on (AWF-C's weights average over the whole run).
//!
//! The floor Q·hᵢ (hᵢ: worker i's measured hand-out cost, request to answer, lock or network
//! wait included) keeps each hand-out worth its cost: with FAC's halving a run of time T ends
//! in about log₂(T/(Q·h)) chunks per worker, each costing h, plus a tail of about Q·h/2, and
//! Q = 4 ≈ 2/ln 2 minimises their sum. Where hand-outs queue at a shared dispenser (4096
//! workers on one counter or one master), the queueing is in the measured hᵢ, which raises the
//! floor until the queue drains.
//!
//! A worker's first chunk is a probe of ⌈R/(8P)⌉ items (as adaptive factoring's): small
//! enough that a slow worker cannot end the run with it, large enough to time.

use super::BuiltIn;
use crate::sched::dls::{ChunkRule, ItemTimes, Report, Timing};
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

/// The floor of a chunk's time in hand-out costs (≈ 2/ln 2; see the module text).
pub const HAND_OUT_FLOOR: f64 = 4.0;

/// The smallest factoring divisor: FAC2's halving, whatever the spread.
const MIN_X: f64 = 2.0;

#[derive(Clone, Copy, Debug, Default)]
struct Seen {
    /// Seconds per item over the worker's last chunk (0: no report yet).
    per_item_s: f64,
    /// The worker's last hand-out cost, seconds.
    hand_out_s: f64,
    /// Its item times so far.
    times: ItemTimes,
}

/// `auto` on P workers.
pub struct Auto {
    seen: Vec<Seen>,
}

impl Auto {
    /// `auto` on `p` workers.
    pub fn new(p: usize) -> Self {
        Self {
            seen: vec![Seen::default(); p.max(1)],
        }
    }
}

/// Factoring's divisor x for `p` workers, `remaining` items of mean `mu` and spread `sigma`
/// (Hummel, Schonberg & Flynn 1992), at least [`MIN_X`].
pub fn factoring_divisor(p: usize, remaining: usize, mu: f64, sigma: f64) -> f64 {
    if !(mu > 0.0 && sigma > 0.0 && remaining > 0) {
        return MIN_X;
    }
    let b = p as f64 * sigma / (2.0 * (remaining as f64).sqrt() * mu);
    (1.0 + b * b + b * (b * b + 2.0).sqrt()).max(MIN_X)
}

impl ChunkRule for Auto {
    fn next(&mut self, worker: usize, remaining: usize) -> usize {
        let p = self.seen.len();
        let me = self.seen[worker.min(p - 1)];
        let known: Vec<&Seen> = self.seen.iter().filter(|s| s.per_item_s > 0.0).collect();
        if me.per_item_s <= 0.0 || known.is_empty() {
            return remaining.div_ceil(8 * p).max(1);
        }
        let mean_u = known.iter().map(|s| s.per_item_s).sum::<f64>() / known.len() as f64;
        let rate: f64 = self
            .seen
            .iter()
            .map(|s| 1.0 / if s.per_item_s > 0.0 { s.per_item_s } else { mean_u })
            .sum();
        let mut pooled = ItemTimes::default();
        let (mut n, mut m2, mut sum, mut groups) = (0u64, 0.0, 0.0, 0u64);
        for s in &known {
            n += s.times.n;
            sum += s.times.mean * s.times.n as f64;
            m2 += s.times.m2;
            groups += s.times.groups;
        }
        if n > 0 {
            pooled.n = n;
            pooled.mean = sum / n as f64;
            pooled.m2 = m2;
            pooled.groups = groups;
        }
        let x = factoring_divisor(p, remaining, pooled.mean, pooled.var().sqrt());
        let share_s = remaining as f64 / rate / x;
        let floor_s = HAND_OUT_FLOOR * me.hand_out_s;
        let items = share_s.max(floor_s) / me.per_item_s;
        if items.is_finite() && items >= 1.0 {
            (items.ceil() as usize).min(remaining)
        } else if items.is_finite() {
            1
        } else {
            remaining
        }
    }

    fn report(&mut self, worker: usize, r: &Report) {
        let Some(s) = self.seen.get_mut(worker) else {
            return;
        };
        if r.items > 0 && r.secs > 0.0 {
            s.per_item_s = r.secs / r.items as f64;
        }
        s.hand_out_s = r.grab_secs.max(0.0);
        s.times = r.times;
    }

    fn timing(&self) -> Timing {
        Timing::Items
    }
}

scheduler_params! {
    /// `auto` has no parameters.
    pub struct AutoParams {}
}

impl BuiltIn for AutoParams {
    const DOC: &'static str = "auto: no grain to pick. Factoring sized from the measured speed \
        of each worker's last chunk, the spread of item times and the measured hand-out cost \
        (no chunk shorter than 4 hand-outs).";
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, _n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(Auto::new(workers.max(1))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::dls::sequence;

    #[test]
    fn probes_then_weighs_each_worker_by_its_last_chunk_and_floors_at_the_hand_out_cost() {
        // Worker 0 takes 3 s per item, worker 1 takes 1 s, no spread, hand-outs free.
        let got = sequence(&mut Auto::new(2), 1000, 2, |w, items| {
            Some(Report {
                items,
                secs: items as f64 * if w == 0 { 3.0 } else { 1.0 },
                ..Default::default()
            })
        });
        // Probes ⌈1000/16⌉ = 63, ⌈937/16⌉ = 59. Worker 0 asks again before worker 1 has
        // reported, which counts at worker 0's 3 s: R = 878, rate 2/3, T = 1317 s, x = 2:
        // 658.5 s / 3 = 219.5 → 220. Then worker 1 (1 s): R = 658, rate 1/3 + 1 = 4/3,
        // T = 493.5 s: 246.75 → 247.
        assert_eq!(&got[..4], [63, 59, 220, 247]);
        assert_eq!(got.iter().sum::<usize>(), 1000);
        // A hand-out of 10 s: no chunk under 40 s of work (40 items at 1 s).
        let mut a = Auto::new(2);
        for w in 0..2 {
            a.report(
                w,
                &Report {
                    items: 10,
                    secs: 10.0,
                    grab_secs: 10.0,
                    ..Default::default()
                },
            );
        }
        assert_eq!(a.next(0, 60), 40);
        assert_eq!(a.next(0, 1000), 250);
    }

    #[test]
    fn spread_shrinks_the_chunk() {
        assert_eq!(factoring_divisor(4, 1000, 1.0, 0.0), 2.0);
        // b = 4·1/(2·√1000) = 0.0632: x = 1 + 0.004 + 0.0632·√2.004 = 1.0935 → 2 (floor).
        assert_eq!(factoring_divisor(4, 1000, 1.0, 1.0), 2.0);
        // b = 256·10/(2·√1000) = 40.5: x ≈ 1 + 2b² ≈ 3281.
        let x = factoring_divisor(256, 1000, 1.0, 10.0);
        assert!((3000.0..3600.0).contains(&x), "{x}");
    }
}
