//! The dynamic-loop-scheduling family: workers take chunks of consecutive items from one
//! shared dispenser, and a [`ChunkRule`] decides each chunk's size from the items left (R),
//! the workers (P) and, for the adaptive rules, what the workers measured so far. The
//! catalogue and names follow LB4OMP (Korndörfer et al., TPDS 2021) and DLS4LB:
//!
//! - [`factoring`]: FAC2 and weighted factoring (WF).
//! - [`trapezoid`]: trapezoid self-scheduling (TSS).
//! - [`fixed_size`]: fixed-size chunking (FSC), K from Kruskal & Weiss.
//! - [`adaptive_factoring`]: adaptive factoring (AF).
//! - [`awf`]: adaptive weighted factoring, variant C (AWF-C).
//!
//! The dispenser (in `shared`) is a mutex over (next item, rule): one lock per chunk, and
//! these rules hand out O(P·log N) chunks, so the lock costs well under a nanosecond per item
//! at the dispatch bench's 2¹⁸ items. A worker reports its previous chunk's timing when it
//! asks for the next one, under the same lock.

pub mod adaptive_factoring;
pub mod awf;
pub mod factoring;
pub mod fixed_size;
pub mod trapezoid;

use super::param::Slow;
use super::spec::Policy;

/// What a rule needs measured by the workers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Timing {
    /// Nothing: the chunk sizes depend on R and P alone.
    None,
    /// Each chunk's wall time (two clock reads per chunk).
    Chunks,
    /// Each item's time (one clock read per item), for per-item means and spreads.
    Items,
}

/// Running mean and variance (Welford) of a worker's item times, in seconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ItemTimes {
    /// Items timed.
    pub n: u64,
    /// Mean item time.
    pub mean: f64,
    /// Sum of squared deviations from the mean.
    pub m2: f64,
}

impl ItemTimes {
    /// Add one item's time.
    pub fn add(&mut self, secs: f64) {
        self.n += 1;
        let d = secs - self.mean;
        self.mean += d / self.n as f64;
        self.m2 += d * (secs - self.mean);
    }

    /// The sample variance (0 below two items).
    pub fn var(&self) -> f64 {
        if self.n < 2 {
            0.0
        } else {
            self.m2 / (self.n - 1) as f64
        }
    }
}

/// What a worker reports of its previous chunk when it asks for the next.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Report {
    /// Items in the chunk.
    pub items: usize,
    /// The chunk's wall time, seconds (0 unless the rule asked for [`Timing::Chunks`] or
    /// [`Timing::Items`]).
    pub secs: f64,
    /// How long asking for the chunk took, lock wait included (the hand-out cost h).
    pub grab_secs: f64,
    /// Every item this worker has timed so far ([`Timing::Items`] only).
    pub times: ItemTimes,
}

/// Decides each chunk's size. Called under the dispenser's lock, so it may keep state.
pub trait ChunkRule: Send {
    /// Items in `worker`'s next chunk, `remaining` ≥ 1 items not yet handed out. The
    /// dispenser clamps the answer to 1..=remaining.
    fn next(&mut self, worker: usize, remaining: usize) -> usize;
    /// `worker` finished the chunk it was last given.
    fn report(&mut self, _worker: usize, _r: &Report) {}
    /// What the workers must measure for this rule.
    fn timing(&self) -> Timing {
        Timing::None
    }
}

/// The rule of a dynamic-loop-scheduling policy over `n` items on `workers` workers, or
/// `None` for a policy of another family.
pub fn rule(policy: &Policy, n: usize, workers: usize, slow: Slow) -> Option<Box<dyn ChunkRule>> {
    let p = workers.max(1);
    Some(match *policy {
        Policy::Factoring(f) => Box::new(factoring::Factoring::fac2(p, f.grab)),
        Policy::WeightedFactoring(f) => {
            Box::new(factoring::Factoring::weighted(p, f.grab, f.weights, slow))
        }
        Policy::Trapezoid(t) => Box::new(trapezoid::Trapezoid::new(n, p, t.grab)),
        Policy::FixedSize(f) => Box::new(fixed_size::FixedSize::new(n, p, f.fsc_warm)),
        Policy::AdaptiveFactoring(a) => {
            Box::new(adaptive_factoring::AdaptiveFactoring::new(p, a.grab))
        }
        Policy::Awf(a) => Box::new(awf::Awf::new(p, a.grab)),
        _ => return None,
    })
}

/// `⌈x⌉` of a non-negative float as a count, at least 1.
pub(crate) fn ceil_count(x: f64) -> usize {
    if x.is_finite() && x > 1.0 {
        x.ceil() as usize
    } else {
        1
    }
}

/// The chunk sizes a rule hands out over `n` items when workers ask in turn (0, 1, …, P−1,
/// 0, …), each reporting `report(worker, items)` for its previous chunk: the sequence the
/// unit tests check against hand-computed values.
#[cfg(test)]
pub(crate) fn sequence(
    rule: &mut dyn ChunkRule,
    n: usize,
    p: usize,
    mut report: impl FnMut(usize, usize) -> Option<Report>,
) -> Vec<usize> {
    let (mut next, mut out, mut last) = (0, Vec::new(), vec![0usize; p]);
    let mut w = 0;
    while next < n {
        if last[w] > 0 {
            if let Some(r) = report(w, last[w]) {
                rule.report(w, &r);
            }
        }
        let c = rule.next(w, n - next).clamp(1, n - next);
        out.push(c);
        last[w] = c;
        next += c;
        w = (w + 1) % p;
    }
    out
}
