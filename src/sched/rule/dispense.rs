//! The pool protocol and the steal protocol, each written once. Every executor that plays a
//! pool (local threads under the lock, the thread that hands out to sources, the simulated
//! counter, the cost model) drives a [`Dispense`]; every executor that plays stealing takes
//! its victims and splits from a [`StealState`].

use super::{ChunkRule, Report, Timing};
use std::ops::Range;

/// A pool's hand-out protocol: a worker reports its previous hand-out and asks for its next.
/// [`Dispenser`] is the one-level pool every built-in pool rule uses; a rule of another shape
/// (a pool per group of workers, say: `examples/two_level_pool.rs`) implements this trait
/// outside the crate and every executor plays it unchanged.
pub trait Dispense: Send {
    /// `worker` finished `report` (its previous hand-out, if any) and asks for more: the
    /// items it gets now, consecutive, or `None` when nothing is left for it.
    fn grant(&mut self, worker: usize, report: Option<&Report>) -> Option<Range<usize>>;
    /// What the workers must measure for this rule.
    fn timing(&self) -> Timing {
        Timing::None
    }
    /// Does a worker run each hand-out's items in scanline order (see
    /// [`super::Pool::scanline`])?
    fn scanline(&self) -> bool {
        false
    }
}

/// The one-level pool: report the previous chunk → ask the rule for the next → clamp it to
/// 1..=items left, taken from the front of what is left.
pub struct Dispenser {
    next: usize,
    n: usize,
    rule: Box<dyn ChunkRule>,
    scanline: bool,
}

impl Dispenser {
    /// Items `0..n` handed out in chunks that `rule` sizes.
    pub fn new(n: usize, rule: Box<dyn ChunkRule>) -> Self {
        Self {
            next: 0,
            n,
            rule,
            scanline: false,
        }
    }

    /// Items not handed out yet.
    pub fn left(&self) -> usize {
        self.n - self.next
    }
}

impl Dispense for Dispenser {
    #[inline]
    fn grant(&mut self, worker: usize, report: Option<&Report>) -> Option<Range<usize>> {
        if let Some(r) = report {
            self.rule.report(worker, r);
        }
        let left = self.left();
        if left == 0 {
            return None;
        }
        let c = self.rule.next(worker, left).clamp(1, left);
        let s = self.next;
        self.next += c;
        Some(s..s + c)
    }

    fn timing(&self) -> Timing {
        self.rule.timing()
    }

    fn scanline(&self) -> bool {
        self.scanline
    }
}

impl super::Pool {
    /// This pool over items `0..n`, as every executor plays it.
    pub fn dispenser(self, n: usize) -> Dispenser {
        Dispenser {
            scanline: self.scanline,
            ..Dispenser::new(n, self.rule)
        }
    }
}

/// The steal protocol's choices, per thief: whom it asks (a pseudo-random other worker first,
/// then each other one in turn) and how much it takes (the back half of the victim's items,
/// [`StealState::split`]). The threads' crossbeam deques take the same half
/// (`steal_batch_and_pop`); the simulation and the cost model split by [`StealState::split`].
#[derive(Clone, Copy, Debug)]
pub struct StealState {
    thief: usize,
    workers: usize,
    rng: u64,
}

impl StealState {
    /// The states of `workers` thieves, their draws seeded from `seed` (one xorshift stream
    /// each, from an LCG step per worker).
    pub fn per_worker(workers: usize, seed: u64) -> Vec<Self> {
        let mut s = seed | 1;
        (0..workers)
            .map(|thief| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                Self {
                    thief,
                    workers,
                    rng: s,
                }
            })
            .collect()
    }

    /// The first victim of the next steal: a pseudo-random worker other than the thief
    /// (`None` alone).
    pub fn victim(&mut self) -> Option<usize> {
        let w = self.workers;
        if w < 2 {
            return None;
        }
        self.rng ^= self.rng << 13;
        self.rng ^= self.rng >> 7;
        self.rng ^= self.rng << 17;
        Some((self.thief + 1 + (self.rng % (w as u64 - 1)) as usize) % w)
    }

    /// Every other worker once, from [`Self::victim`] on: the order a thief that may ask
    /// them all (threads, the cost model) asks in.
    pub fn victims(&mut self) -> impl Iterator<Item = usize> {
        let (w, thief) = (self.workers, self.thief);
        let first = self.victim().unwrap_or(thief);
        (0..w)
            .map(move |k| (first + k) % w)
            .filter(move |&v| v != thief)
    }

    /// How many of a victim's `len` queued items it keeps (the front); the thief takes the
    /// rest, the back half.
    pub fn split(len: usize) -> usize {
        len / 2
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::rule::Grab;

    #[test]
    fn the_dispenser_reports_then_clamps_each_chunk_to_what_is_left() {
        let mut d = Dispenser::new(10, Box::new(Grab::fixed(4)));
        let got: Vec<_> = std::iter::from_fn(|| d.grant(0, None)).collect();
        assert_eq!(got, [0..4, 4..8, 8..10]);
        assert_eq!(d.grant(1, None), None);
    }

    #[test]
    fn a_thief_asks_every_other_worker_once_and_takes_the_back_half() {
        let mut s = StealState::per_worker(4, 7);
        let mut v: Vec<usize> = s[2].victims().collect();
        assert_eq!(v.len(), 3);
        v.sort_unstable();
        assert_eq!(v, [0, 1, 3]);
        assert!(s[0].victim().is_some_and(|v| v != 0 && v < 4));
        assert_eq!(StealState::per_worker(1, 7)[0].victim(), None);
        assert_eq!((StealState::split(5), StealState::split(1)), (2, 0));
    }
}
