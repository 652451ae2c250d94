//! `tss`: trapezoid self-scheduling as published (TSS; Tzen & Ni, "Trapezoid self-scheduling:
//! a practical scheduling scheme for parallel compilers", IEEE TPDS 4(1), 1993, §III).
//!
//! The first chunk is f = ⌈N/(2P)⌉, the last l (`grab`, default 1); the number of chunks is
//! n = ⌈2N/(f + l)⌉ and the decrement the whole number δ = ⌊(f − l)/(n − 1)⌋, so chunk k
//! (from 0) holds f − k·δ items, never fewer than l; the last chunk is cut to what is left.
//! The paper keeps δ whole so that a compiler can emit the chunk bounds with integer adds;
//! the chunks then run a little larger than the real-δ trapezoid, and for N below about 8P²
//! (δ < 1) the published TSS hands out fixed chunks of f.
//!
//! Peers: LB4OMP (`runtime/src/kmp_dispatch.cpp`, `kmp_sch_trapezoidal`, lines 1874–1920)
//! takes f = ⌊N/(2P)⌋ and caps l at f; DLS4LB (`DLS.c` 588–591, 242–249) takes f = ⌈N/(2P)⌉ and
//! n = ⌊2N/(f + 1)⌋. We follow the paper: f rounded up, n rounded up. The real-δ rule of the
//! same paper's analysis stays as the variant `trapezoid`.

use super::BuiltIn;
use crate::sched::dls::ChunkRule;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

/// Published TSS over `n` items on `p` workers.
#[derive(Clone, Debug)]
pub struct Tss {
    first: usize,
    last: usize,
    delta: usize,
    k: usize,
}

impl Tss {
    /// TSS over `n` items on `p` workers, smallest chunk `last`.
    pub fn new(n: usize, p: usize, last: usize) -> Self {
        let last = last.max(1);
        let first = n.div_ceil(2 * p.max(1)).max(last);
        let chunks = (2 * n).div_ceil(first + last).max(1);
        let delta = if chunks > 1 {
            (first - last) / (chunks - 1)
        } else {
            0
        };
        Self {
            first,
            last,
            delta,
            k: 0,
        }
    }

    /// Chunk `k` (from 0) of the sequence: max(l, f − k·δ).
    pub fn chunk(&self, k: usize) -> usize {
        self.first.saturating_sub(k * self.delta).max(self.last)
    }

    /// (f, l, δ).
    pub fn shape(&self) -> (usize, usize, usize) {
        (self.first, self.last, self.delta)
    }
}

impl ChunkRule for Tss {
    fn next(&mut self, _worker: usize, _remaining: usize) -> usize {
        let c = self.chunk(self.k);
        self.k += 1;
        c
    }
}

scheduler_params! {
    /// Published TSS's parameters.
    pub struct TssParams {
        /// The last (smallest) chunk, l in TSS.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for TssParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("TSS", true));
    const DOC: &'static str = "Trapezoid self-scheduling as published (Tzen & Ni 1993): chunks \
        falling from ⌈N/(2P)⌉ to 1 by the whole-number decrement ⌊(f − l)/(n − 1)⌋.";
    // Catalogue kinds: `advise` weighs them when named (`--scheduler`), not by default.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(Tss::new(n, workers.max(1), self.grab)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::dls::sequence;

    #[test]
    fn tss_n1000_p4_by_hand() {
        // f = 125, l = 1, n = ⌈2000/126⌉ = 16, δ = ⌊124/15⌋ = 8: 125, 117, …, 13 chunks reach
        // 1001 − … : 125 + 117 + 109 + 101 + 93 + 85 + 77 + 69 + 61 + 53 + 45 = 935, then 37
        // and the 28 left.
        let got = sequence(&mut Tss::new(1000, 4, 1), 1000, 4, |_, _| None);
        assert_eq!(
            got,
            [125, 117, 109, 101, 93, 85, 77, 69, 61, 53, 45, 37, 28]
        );
    }

    #[test]
    fn small_loops_degenerate_to_fixed_chunks() {
        // N = 100, P = 4: f = 13, n = ⌈200/14⌉ = 15, δ = ⌊12/14⌋ = 0: chunks of 13.
        let got = sequence(&mut Tss::new(100, 4, 1), 100, 4, |_, _| None);
        assert_eq!(got, [13, 13, 13, 13, 13, 13, 13, 9]);
    }
}
