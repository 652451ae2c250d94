//! `tfss`: trapezoid factoring self-scheduling as published (TFSS; Chronopoulos, Andonie,
//! Benche & Grosu, "A class of loop self-scheduling for heterogeneous clusters", IEEE Cluster
//! 2001, §3): the chunks of published TSS ([`super::tss`], whole-number δ) dealt out in
//! factoring's batches. Batch j hands each of the P workers the mean of TSS chunks jP …
//! jP + P − 1, that is ⌊(Σₖ max(l, f − k·δ))/P⌋ items (at least l): fewer distinct sizes
//! than TSS, and a batch's chunks are equal.
//!
//! The paper states the mean without its rounding; we round down as LB4OMP does
//! (`runtime/src/kmp_dispatch.cpp` 4745–4783: `accum_chunk /= total_threads` on integers).
//! LB4OMP's f is ⌈N/(2P)⌉ here as in the paper (2253–2266); its δ is stored in an integer
//! field, whole as in TSS. The real-δ rule stays as the variant `trapezoid_factoring`.

use super::tss::Tss;
use super::BuiltIn;
use crate::sched::dls::ChunkRule;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

/// Published TFSS over `n` items on `p` workers.
pub struct Tfss {
    tss: Tss,
    p: usize,
    batch: usize,
    left_in_batch: usize,
    size: usize,
}

impl Tfss {
    /// TFSS over `n` items on `p` workers, smallest chunk `last`.
    pub fn new(n: usize, p: usize, last: usize) -> Self {
        Self {
            tss: Tss::new(n, p.max(1), last),
            p: p.max(1),
            batch: 0,
            left_in_batch: 0,
            size: 0,
        }
    }
}

impl ChunkRule for Tfss {
    fn next(&mut self, _worker: usize, _remaining: usize) -> usize {
        if self.left_in_batch == 0 {
            let from = self.batch * self.p;
            let sum: usize = (from..from + self.p).map(|k| self.tss.chunk(k)).sum();
            self.size = (sum / self.p).max(self.tss.shape().1);
            self.batch += 1;
            self.left_in_batch = self.p;
        }
        self.left_in_batch -= 1;
        self.size
    }
}

scheduler_params! {
    /// Published TFSS's parameters.
    pub struct TfssParams {
        /// The smallest chunk, l in TSS.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for TfssParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("TFSS", true));
    const DOC: &'static str = "Trapezoid factoring self-scheduling as published (Chronopoulos \
        et al. 2001): batches of P equal chunks, each the mean of the next P chunks of \
        published TSS (whole-number δ).";
    // Catalogue kinds: `advise` weighs them when named (`--scheduler`), not by default.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(Tfss::new(n, workers.max(1), self.grab)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::dls::sequence;

    #[test]
    fn tfss_n1000_p4_by_hand() {
        // TSS: f = 125, δ = 8. Batch j: 125 − 8·(4j + 1.5) rounded down: 113, 81, 49, then
        // 17 (the TSS chunks 29, 21, 13, 5): 452 + 324 + 196 = 972, then 17 and the 11 left.
        let got = sequence(&mut Tfss::new(1000, 4, 1), 1000, 4, |_, _| None);
        let mut want = vec![113; 4];
        want.extend([81; 4]);
        want.extend([49; 4]);
        want.extend([17, 11]);
        assert_eq!(got, want);
    }
}
