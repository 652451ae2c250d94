//! Trapezoid factoring self-scheduling (TFSS; Chronopoulos, Andonie, Benche & Grosu, "A class
//! of loop self-scheduling for heterogeneous clusters", IEEE Cluster 2001).
//!
//! TSS's linearly falling chunks (first f = ⌈N/(2P)⌉, last l, decrement δ; see
//! [`super::trapezoid`]) dealt out in factoring's batches: batch j hands each of the P workers
//! the mean of TSS chunks jP … jP + P − 1, that is ⌈f − δ·(jP + (P − 1)/2)⌉ items, never fewer
//! than l. Fewer distinct sizes than TSS, and a batch's chunks are equal, so a slow worker's
//! chunk is no larger than a fast one's.

use super::trapezoid::Trapezoid;
use super::BuiltIn;
use crate::sched::dls::{ceil_count, ChunkRule};
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

scheduler_params! {
    /// Trapezoid factoring self-scheduling's parameters.
    pub struct TrapezoidFactoringParams {
        /// The smallest chunk, l in TSS.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for TrapezoidFactoringParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("TFSS", false));
    const DOC: &'static str = "Trapezoid factoring self-scheduling (TFSS): batches of P equal \
        chunks, each the mean of the next P chunks of TSS.";
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(TrapezoidFactoring::new(n, workers.max(1), self.grab)))
    }
}

/// TFSS over `n` items on `p` workers.
pub struct TrapezoidFactoring {
    tss: Trapezoid,
    p: usize,
    batch: usize,
    left_in_batch: usize,
    size: usize,
}

impl TrapezoidFactoring {
    /// The TFSS sequence of `n` items on `p` workers, smallest chunk `last` items.
    pub fn new(n: usize, p: usize, last: usize) -> Self {
        Self {
            tss: Trapezoid::new(n, p.max(1), last),
            p: p.max(1),
            batch: 0,
            left_in_batch: 0,
            size: 0,
        }
    }
}

impl ChunkRule for TrapezoidFactoring {
    fn next(&mut self, _worker: usize, _remaining: usize) -> usize {
        if self.left_in_batch == 0 {
            // The mean of TSS chunks bP … bP + P − 1 is TSS's chunk at their mean index.
            let mid = (self.batch * self.p) as f64 + (self.p - 1) as f64 / 2.0;
            self.size = ceil_count(self.tss.at(mid) - 1e-9).max(self.tss.last());
            self.batch += 1;
            self.left_in_batch = self.p;
        }
        self.left_in_batch -= 1;
        self.size
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::dls::sequence;

    #[test]
    fn tfss_n1000_p4_by_hand() {
        // TSS: f = 125, l = 1, δ = 124/15 = 8.2667. Batch j: ⌈125 − δ·(4j + 1.5)⌉ =
        // ⌈112.6⌉, ⌈79.53⌉, ⌈46.47⌉, ⌈13.4⌉ = 113, 80, 47, 14, four of each until the
        // 1000 are out (960 after three batches: 14, 14, then the 12 left).
        let got = sequence(&mut TrapezoidFactoring::new(1000, 4, 1), 1000, 4, |_, _| None);
        let mut want = vec![113; 4];
        want.extend([80; 4]);
        want.extend([47; 4]);
        want.extend([14, 14, 12]);
        assert_eq!(got, want);
    }

    #[test]
    fn chunks_never_fall_below_the_smallest() {
        let got = sequence(&mut TrapezoidFactoring::new(100, 2, 5), 100, 2, |_, _| None);
        assert_eq!(got.iter().sum::<usize>(), 100);
        let (last, init) = got.split_last().unwrap();
        assert!(init.iter().all(|&c| c >= 5), "{got:?}");
        assert!(*last >= 1);
    }
}
