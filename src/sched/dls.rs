//! The dynamic-loop-scheduling family: workers take chunks of consecutive items from one
//! shared dispenser, and a [`ChunkRule`] decides each chunk's size from the items left (R),
//! the workers (P) and, for the adaptive rules, what the workers measured so far. The
//! catalogue and names follow LB4OMP (Korndörfer et al., TPDS 2021) and DLS4LB:
//!
//! - [`factoring`](super::kinds::factoring): FAC2; weighted factoring (WF) in
//!   [`weighted_factoring`](super::kinds::weighted_factoring).
//! - [`trapezoid`](super::kinds::trapezoid): trapezoid self-scheduling (TSS).
//! - [`fixed_size`](super::kinds::fixed_size): fixed-size chunking (FSC), K from Kruskal & Weiss.
//! - [`adaptive_factoring`](super::kinds::adaptive_factoring): adaptive factoring (AF).
//! - [`awf`](super::kinds::awf): adaptive weighted factoring, variant C (AWF-C).
//!
//! Each rule lives in its scheduler's file under [`super::kinds`]. The dispenser (in
//! `shared`) is a mutex over (next item, rule): one lock per chunk, and
//! these rules hand out O(P·log N) chunks, so the lock costs well under a nanosecond per item
//! at the dispatch bench's 2¹⁸ items. A worker reports its previous chunk's timing when it
//! asks for the next one, under the same lock.

use super::rule::Grab;

/// What a rule needs measured by the workers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Timing {
    /// Nothing: the chunk sizes depend on R and P alone.
    None,
    /// Each chunk's wall time (two clock reads per chunk).
    Chunks,
    /// Item times for per-item means and spreads, read per group of consecutive items
    /// ([`timed_group`]: at most [`TIMED_GROUPS`] clock reads per chunk).
    Items,
}

/// Running mean and variance (Welford, weighted as in West 1979) of a worker's item times, in
/// seconds, from groups of consecutive items timed together: a group of m items averaging a
/// adds m·(a − μ)² to the spread, so for independent items `var` estimates one item's
/// variance (E[m·(a − μ)²] = σ²) while the clock is read once per group, not per item.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ItemTimes {
    /// Items timed.
    pub n: u64,
    /// Mean item time.
    pub mean: f64,
    /// Σ m·(a − mean)² over the groups (Σ of squared deviations for groups of one).
    pub m2: f64,
    /// Groups timed.
    pub groups: u64,
}

impl ItemTimes {
    /// Add one item's time.
    pub fn add(&mut self, secs: f64) {
        self.add_group(1, secs);
    }

    /// Add a group of `items` consecutive items that took `secs` together.
    pub fn add_group(&mut self, items: u64, secs: f64) {
        if items == 0 {
            return;
        }
        let (m, a) = (items as f64, secs / items as f64);
        self.n += items;
        self.groups += 1;
        let d = a - self.mean;
        self.mean += d * m / self.n as f64;
        self.m2 += m * d * (a - self.mean);
    }

    /// The estimated variance of one item's time (0 below two groups).
    pub fn var(&self) -> f64 {
        if self.groups < 2 {
            0.0
        } else {
            self.m2 / (self.groups - 1) as f64
        }
    }
}

/// Groups a chunk's items are timed in under [`Timing::Items`]: at most this many per chunk.
pub const TIMED_GROUPS: usize = 32;

/// Items per timed group of a `chunk`-item chunk: ⌈chunk / [`TIMED_GROUPS`]⌉, at least 1.
pub fn timed_group(chunk: usize) -> usize {
    chunk.div_ceil(TIMED_GROUPS).max(1)
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
    /// Every item this worker has timed so far, in groups ([`Timing::Items`] only).
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
    /// `Some` where the size depends on the items left alone: an executor may then take
    /// hand-outs without the dispenser's lock, sizing them by the [`Grab`] itself.
    fn as_grab(&self) -> Option<Grab> {
        None
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_of_one_are_the_sample_variance_and_groups_estimate_one_items_variance() {
        // Items 1, 2, 3, 6 one by one: mean 3, sample variance (4 + 1 + 0 + 9)/3 = 14/3.
        let mut one = ItemTimes::default();
        for t in [1.0, 2.0, 3.0, 6.0] {
            one.add(t);
        }
        assert!((one.mean - 3.0).abs() < 1e-12 && (one.var() - 14.0 / 3.0).abs() < 1e-12);
        // Groups (2 items averaging 1) and (2 items averaging 3): μ = 2, Σ m·(a − μ)² = 4
        // over 2 − 1 degrees of freedom.
        let mut g = ItemTimes::default();
        g.add_group(2, 2.0);
        g.add_group(2, 6.0);
        assert_eq!((g.n, g.groups), (4, 2));
        assert!(
            (g.mean - 2.0).abs() < 1e-12 && (g.var() - 4.0).abs() < 1e-12,
            "{g:?}"
        );
        // Independent items of mean 1 and variance 1/3 (uniform on 0..2, a fixed LCG),
        // timed in 4 000 groups of 16: the estimate is within 5 % of 1/3 (its own spread
        // is √(2/3999) ≈ 2.2 %).
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut uniform = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            2.0 * (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut pooled = ItemTimes::default();
        for _ in 0..4000 {
            let s: f64 = (0..16).map(|_| uniform()).sum();
            pooled.add_group(16, s);
        }
        assert!((pooled.mean - 1.0).abs() < 0.01, "{pooled:?}");
        assert!((pooled.var() * 3.0 - 1.0).abs() < 0.05, "{pooled:?}");
        assert_eq!(timed_group(1024), 32);
        assert_eq!(timed_group(33), 2);
        assert_eq!((timed_group(32), timed_group(0)), (1, 1));
    }
}
