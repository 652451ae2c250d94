//! Trapezoid self-scheduling (TSS; Tzen & Ni, "Trapezoid self-scheduling: a practical
//! scheduling scheme for parallel compilers", IEEE TPDS 4(1), 1993).
//!
//! Chunk sizes fall linearly from the first, f = ⌈N/(2P)⌉, to the last, l (here `grab`,
//! default 1), over n = ⌈2N/(f+l)⌉ chunks, decrement δ = (f−l)/(n−1). Chunk k (from 0) holds
//! ⌈f − k·δ⌉ items, never fewer than l; δ is kept as a real number (the paper rounds it to an
//! integer in its integer-only implementation), so the n chunks sum to about N and the last
//! one is cut to what is left.

use crate::sched::dls::{ceil_count, ChunkRule};
use super::BuiltIn;
use crate::sched::param::scheduler_params;
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};
use crate::sched::param::Slow;

/// TSS over `n` items on `p` workers.
pub struct Trapezoid {
    first: f64,
    last: usize,
    delta: f64,
    k: usize,
}

impl Trapezoid {
    /// The TSS sequence of `n` items on `p` workers, last chunk `last` items.
    pub fn new(n: usize, p: usize, last: usize) -> Self {
        let f = n.div_ceil(2 * p.max(1)).max(last).max(1);
        let chunks = (2 * n).div_ceil(f + last).max(1);
        let delta = if chunks > 1 {
            (f - last) as f64 / (chunks - 1) as f64
        } else {
            0.0
        };
        Self {
            first: f as f64,
            last,
            delta,
            k: 0,
        }
    }
}

impl Trapezoid {
    /// Chunk `k` of the sequence (from 0) before rounding: f − k·δ; `k` may be a mean index.
    pub(crate) fn at(&self, k: f64) -> f64 {
        self.first - k * self.delta
    }

    /// The smallest chunk, l.
    pub(crate) fn last(&self) -> usize {
        self.last
    }
}

impl ChunkRule for Trapezoid {
    fn next(&mut self, _worker: usize, _remaining: usize) -> usize {
        let c = ceil_count(self.at(self.k as f64) - 1e-9).max(self.last);
        self.k += 1;
        c
    }
}


scheduler_params! {
    /// Trapezoid self-scheduling's parameters.
    pub struct TrapezoidParams {
        /// The last (smallest) chunk, l in TSS.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for TrapezoidParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("TSS", false));
    const DOC: &'static str =
        "Trapezoid self-scheduling (TSS): chunks shrinking linearly from ⌈N/(2P)⌉ to 1.";
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(Trapezoid::new(n, workers.max(1), self.grab)))
    }
}

#[cfg(test)]
mod tests {
    use crate::sched::dls::sequence;
    use super::*;

    #[test]
    fn tss_n1000_p4_by_hand() {
        // f = ⌈1000/8⌉ = 125, l = 1, n = ⌈2000/126⌉ = 16, δ = 124/15 = 8.2667: chunks
        // ⌈125 − 8.2667k⌉ = 125, 117, 109, 101, 92, 84, 76, 68, 59, 51, 43, 35, 26, then 14 of
        // the 18 that would come (986 handed out by then).
        let got = sequence(&mut Trapezoid::new(1000, 4, 1), 1000, 4, |_, _| None);
        assert_eq!(
            got,
            [125, 117, 109, 101, 92, 84, 76, 68, 59, 51, 43, 35, 26, 14]
        );
    }

    #[test]
    fn tss_small_loops_and_the_last_chunk() {
        // N = 10, P = 2: f = 3, n = ⌈20/4⌉ = 5, δ = 0.5: 3, 3 (2.5), 2, 2 (1.5) = 10.
        let got = sequence(&mut Trapezoid::new(10, 2, 1), 10, 2, |_, _| None);
        assert_eq!(got, [3, 3, 2, 2]);
        // l = 4 holds the tail at 4 items.
        let got = sequence(&mut Trapezoid::new(100, 2, 4), 100, 2, |_, _| None);
        assert_eq!(got.first(), Some(&25));
        assert!(got[..got.len() - 1].iter().all(|&c| c >= 4), "{got:?}");
        assert_eq!(got.iter().sum::<usize>(), 100);
    }
}
