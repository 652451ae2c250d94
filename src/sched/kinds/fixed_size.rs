//! Fixed-size chunking (FSC; Kruskal & Weiss, "Allocating independent subtasks on parallel
//! processors", IEEE TSE 11(10), 1985): every chunk holds the same K items,
//!
//!   K = ( √2 · N · h / (σ · P · √(ln P)) )^(2/3),
//!
//! with h the overhead of one hand-out and σ the standard deviation of an item's time: the K
//! that balances hand-out cost (N·h/K in all) against the expected imbalance of the last
//! chunks (∝ σ·√K). Here both are **measured online**: the first `fsc_warm` items go out one
//! at a time, each timed by its worker (σ: their sample standard deviation) and each hand-out
//! timed from the worker's request to its answer, lock wait included (h: their mean); K is
//! then fixed from N = the items still left at that point. P = 1 (ln P = 0) or σ = 0 give one
//! chunk per worker of what is left, K = ⌈R/P⌉, which is also the largest K used.

use crate::sched::dls::{ceil_count, ChunkRule, ItemTimes, Report, Timing};
use super::BuiltIn;
use crate::sched::param::scheduler_params;
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};
use crate::sched::param::Slow;

/// Kruskal & Weiss's K for `n` items, hand-out cost `h` and spread `sigma` (seconds) on `p`
/// workers, capped at ⌈n/p⌉.
pub fn kruskal_weiss(n: usize, p: usize, h: f64, sigma: f64) -> usize {
    kruskal_weiss_k(n, p, h, sigma, true)
}

/// Kruskal & Weiss's K, capped at ⌈n/p⌉ where `cap` (this kind) or left as the formula gives
/// it (`fsc`, the published form: P = 1 or σ = 0 make K infinite, one chunk of all `n`).
pub fn kruskal_weiss_k(n: usize, p: usize, h: f64, sigma: f64, cap: bool) -> usize {
    let cap = if cap {
        n.div_ceil(p.max(1)).max(1)
    } else {
        n.max(1)
    };
    let ln_p = (p as f64).ln();
    if p <= 1 || sigma <= 0.0 {
        return cap;
    }
    if h.is_nan() || h <= 0.0 {
        return 1;
    }
    let k = (std::f64::consts::SQRT_2 * n as f64 * h / (sigma * p as f64 * ln_p.sqrt()))
        .powf(2.0 / 3.0);
    ceil_count(k).min(cap)
}

/// FSC with its warm-up measurement.
pub struct FixedSize {
    p: usize,
    warm: usize,
    /// Items of the warm phase timed so far (their times pooled over the workers).
    items: ItemTimes,
    /// Hand-outs timed so far and their summed time.
    grabs: (u64, f64),
    /// The chunk size, once measured.
    k: Option<usize>,
    /// K capped at ⌈R/P⌉ (this kind) or not (`fsc`).
    cap: bool,
}

impl FixedSize {
    /// FSC over `n` items on `p` workers, measuring over the first `warm` items (at most
    /// half of `n`).
    pub fn new(n: usize, p: usize, warm: usize) -> Self {
        Self {
            p,
            warm: warm.min(n / 2).max(1),
            items: ItemTimes::default(),
            grabs: (0, 0.0),
            k: None,
            cap: true,
        }
    }

    /// Published FSC ([`super::fsc`]): K uncapped, measured over the first `warm` items.
    pub fn uncapped(n: usize, p: usize, warm: usize) -> Self {
        Self {
            cap: false,
            ..Self::new(n, p, warm)
        }
    }

    /// FSC with h and σ known beforehand (LB4OMP reads them from a profiling run): every
    /// chunk is K from the start, capped at ⌈n/p⌉ where `cap`.
    pub fn profiled(n: usize, p: usize, h: f64, sigma: f64, cap: bool) -> Self {
        Self {
            k: Some(kruskal_weiss_k(n, p, h, sigma, cap)),
            cap,
            ..Self::new(n, p, 1)
        }
    }

    /// The measured K, once the warm phase is over.
    pub fn k(&self) -> Option<usize> {
        self.k
    }
}

impl ChunkRule for FixedSize {
    fn next(&mut self, _worker: usize, remaining: usize) -> usize {
        if let Some(k) = self.k {
            return k;
        }
        if (self.items.n as usize) < self.warm {
            return 1;
        }
        let h = self.grabs.1 / self.grabs.0.max(1) as f64;
        let k = kruskal_weiss_k(remaining, self.p, h, self.items.var().sqrt(), self.cap);
        self.k = Some(k);
        k
    }

    fn report(&mut self, _worker: usize, r: &Report) {
        if self.k.is_some() || r.items != 1 {
            return;
        }
        self.items.add(r.secs);
        self.grabs.0 += 1;
        self.grabs.1 += r.grab_secs;
    }

    fn timing(&self) -> Timing {
        if self.k.is_some() {
            Timing::None
        } else {
            Timing::Chunks
        }
    }
}


scheduler_params! {
    /// Fixed-size chunking's parameters.
    pub struct FixedSizeParams {
        /// Items handed out one at a time first, to measure the hand-out cost h and the spread
        /// σ of item times online.
        fsc_warm: usize = 32, label Some("warm");
    }
}

impl BuiltIn for FixedSizeParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("FSC", false));
    const DOC: &'static str = "Fixed-size chunking (FSC): one chunk size K from the measured \
        hand-out cost and the spread of item times (Kruskal–Weiss).";
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(FixedSize::new(n, workers.max(1), self.fsc_warm)))
    }
}

#[cfg(test)]
mod tests {
    use crate::sched::dls::sequence;
    use super::*;

    #[test]
    fn kruskal_weiss_by_hand() {
        // The scale the README quotes: Cornell 128² per pixel (N = 16384), h = 20 ns,
        // σ = 5 µs, P = 2: (√2·16384·2e-8 / (5e-6·2·√ln 2))^(2/3) = (55.66)^(2/3) = 14.6 → 15.
        assert_eq!(kruskal_weiss(16384, 2, 20e-9, 5e-6), 15);
        // N = 1000, P = 4, h = 1, σ = 1: (√2·1000 / (4·√ln 4))^(2/3) = (300.3)^(2/3) = 44.8 → 45.
        assert_eq!(kruskal_weiss(1000, 4, 1.0, 1.0), 45);
        // Capped at one chunk per worker; one worker or no spread: one chunk each.
        assert_eq!(kruskal_weiss(1000, 4, 1e3, 1.0), 250);
        assert_eq!(kruskal_weiss(1000, 1, 1.0, 1.0), 1000);
        assert_eq!(kruskal_weiss(1000, 4, 1.0, 0.0), 250);
    }

    #[test]
    fn fsc_warms_up_one_item_at_a_time_then_fixes_k() {
        let mut fsc = FixedSize::new(1000, 4, 8);
        // Item times alternate 0 and 2 s (σ ≈ 1.07), each hand-out 1 s.
        let mut i = 0;
        let got = sequence(&mut fsc, 1000, 4, |_, items| {
            i += 1;
            Some(Report {
                items,
                secs: if i % 2 == 0 { 2.0 } else { 0.0 },
                grab_secs: 1.0,
                ..Default::default()
            })
        });
        let k = fsc.k().expect("measured");
        assert!(got[..8].iter().all(|&c| c == 1), "{got:?}");
        // Reports come in once each worker asks again: the 8th with the 12th request, which
        // is the first answered with K (11 single items went out before it).
        let warm = got.iter().take_while(|&&c| c == 1).count();
        assert_eq!(warm, 11);
        let sigma = {
            let mut t = ItemTimes::default();
            for j in 1..=8 {
                t.add(if j % 2 == 0 { 2.0 } else { 0.0 });
            }
            t.var().sqrt()
        };
        assert_eq!(k, kruskal_weiss(1000 - 11, 4, 1.0, sigma));
        assert!(got[warm..got.len() - 1].iter().all(|&c| c == k));
    }
}
