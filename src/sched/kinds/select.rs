//! Run-time selection among DLS techniques (Auto4OMP; Mohammed & Ciorba, "Auto4OMP: automated
//! dynamic loop scheduling selection in OpenMP", 2022; implemented in LB4OMP's
//! `runtime/src/kmp_dispatch.cpp`, `auto_DLS_Search` and the functions above it), as one
//! [`ChunkRule`] that wraps the others: the rule of [`super::random_sel`],
//! [`super::exhaustive_sel`] and [`super::binary_sel`].
//!
//! Auto4OMP selects a technique per *instance* of a loop (a time step) from the previous
//! instance's loop time and load imbalance. A render is one loop, so its N items are cut into
//! `sel_phases` phases of ⌈N/phases⌉ consecutive items, each played as a fresh loop instance
//! by the technique chosen when it starts; a chunk never crosses a phase's end. A phase's
//! measures come from its chunks' reports (chunk time plus hand-out time per worker, Tᵢ):
//!
//! - loop time LT = P·maxᵢ Tᵢ / (items reported), the phase's parallel time per item, so
//!   that phases whose last chunks are still running when the next starts compare fairly;
//! - load imbalance LIB = (maxᵢ Tᵢ − meanᵢ Tᵢ)/maxᵢ Tᵢ · P/(P − 1) · 100 %, Auto4OMP's percent
//!   imbalance (`kmp_dispatch.cpp` 1085–1090).
//!
//! The decision at a phase's start reads the phase before it as far as it is reported.
//! The portfolio, in Auto4OMP's order from the least to the most adaptive (its `STATIC, SS,
//! TSS, GSS, mFAC2, AWF-B…E, mAF`, without LLVM's two extra GSS and static-steal): static
//! (⌈n/P⌉), self-scheduling, published TSS, GSS (⌈R/P⌉), FAC2, AWF-B, AWF-C, AWF-D, AWF-E, AF.

use super::adaptive_factoring::AdaptiveFactoring;
use super::awf_b::{AwfCb, AwfVariant};
use super::factoring::Factoring;
use super::rnd::splitmix64;
use super::tss::Tss;
use crate::sched::dls::{ChunkRule, Grab, Report, Timing};

/// The techniques a selector picks among, in Auto4OMP's order.
pub const PORTFOLIO: [&str; 10] = [
    "static", "ss", "tss", "gss", "fac2", "awf_b", "awf_c", "awf_d", "awf_e", "af",
];

/// Portfolio entry `i`'s rule over one phase of `n` items on `p` workers.
fn technique(i: usize, n: usize, p: usize) -> Box<dyn ChunkRule> {
    match i {
        0 => Box::new(Grab::fixed(n.div_ceil(p).max(1))),
        1 => Box::new(Grab::fixed(1)),
        2 => Box::new(Tss::new(n, p, 1)),
        3 => Box::new(Grab::guided(1, 1, p)),
        4 => Box::new(Factoring::fac2(p, 1)),
        5 => Box::new(AwfCb::new(AwfVariant::B, p, 1)),
        6 => Box::new(AwfCb::new(AwfVariant::C, p, 1)),
        7 => Box::new(AwfCb::new(AwfVariant::D, p, 1)),
        8 => Box::new(AwfCb::new(AwfVariant::E, p, 1)),
        _ => Box::new(AdaptiveFactoring::new(p, 1)),
    }
}

/// Which of Auto4OMP's selection methods.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// RandomSel (`autoRandomSearch`, 386–410): a uniformly random technique first; after
    /// each phase, jump to another random one with probability LIB/10 (LIB in percent).
    Random,
    /// ExhaustiveSel (`autoExhaustiveSearch`, 309–352): try every technique for one phase in
    /// portfolio order, then keep the one of least loop time; search again when a phase's LIB
    /// exceeds the one before by more than 10 points (1099–1105).
    Exhaustive,
    /// BinarySel (`autoBinarySearch`, 327–375): jump by 2K/2ᵗ positions (t the trial) to the
    /// right when the imbalance grew (and at the first trial), to the left when it fell,
    /// until the jump is 0; the same re-trigger as ExhaustiveSel.
    Binary,
}

/// One phase's reports.
#[derive(Clone, Debug)]
struct Phase {
    /// Per worker: time of its reported chunks, hand-outs included.
    time: Vec<f64>,
    /// Items reported, and items in the phase.
    items: usize,
    size: usize,
}

impl Phase {
    /// (LT, LIB) of what is reported; `None` before any report.
    fn measures(&self) -> Option<(f64, f64)> {
        if self.items == 0 {
            return None;
        }
        let p = self.time.len() as f64;
        let max = self.time.iter().copied().fold(0.0, f64::max);
        let mean = self.time.iter().sum::<f64>() / p;
        let lt = p * max / self.items as f64;
        let lib = if p > 1.0 && max > 0.0 {
            (max - mean) / max * p / (p - 1.0) * 100.0
        } else {
            0.0
        };
        Some((lt, lib))
    }
}

/// A selector over the [`PORTFOLIO`].
pub struct Selector {
    method: Method,
    n: usize,
    p: usize,
    per_phase: usize,
    grab: usize,
    phases: Vec<Phase>,
    /// The portfolio index each phase ran.
    chosen: Vec<usize>,
    inner: Option<Box<dyn ChunkRule>>,
    /// Per worker: the phase of its last chunk.
    last_phase: Vec<usize>,
    /// Phases up to this one have been decided on.
    decided: usize,
    /// Search state: searching, trials so far, each technique's last loop time, the
    /// imbalance of the last phase decided on.
    searching: bool,
    trials: u32,
    times: Vec<Option<f64>>,
    last_lib: Option<f64>,
    rng: u64,
}

impl Selector {
    /// `method` over `n` items on `p` workers in `phases` phases, chunks of at least `grab`.
    pub fn new(method: Method, n: usize, p: usize, phases: usize, grab: usize) -> Self {
        let p = p.max(1);
        Self {
            method,
            n,
            p,
            per_phase: n.div_ceil(phases.max(1)).max(1),
            grab: grab.max(1),
            phases: Vec::new(),
            chosen: Vec::new(),
            inner: None,
            last_phase: vec![0; p],
            decided: 0,
            searching: true,
            trials: 0,
            times: vec![None; PORTFOLIO.len()],
            last_lib: None,
            rng: super::rnd::RND_SEED,
        }
    }

    /// The portfolio index each phase so far ran.
    pub fn chosen(&self) -> &[usize] {
        &self.chosen
    }

    fn draw(&mut self) -> u64 {
        let (s, x) = splitmix64(self.rng);
        self.rng = s;
        x
    }

    fn uniform(&mut self) -> f64 {
        (self.draw() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// The technique for the phase about to start. A decision reads the newest phase whose
    /// every item is reported and that no decision has read yet (Auto4OMP reads the instance
    /// that just ended, all its threads joined; here the phase before the one starting
    /// still has chunks running, so the newest complete one stands in for it); without one,
    /// the current technique stays.
    fn select(&mut self) -> usize {
        let k = PORTFOLIO.len();
        let Some(&cur) = self.chosen.last() else {
            // The first phase: RandomSel jumps anyway, ExhaustiveSel starts its sweep at the
            // first technique, BinarySel's first jump (2K from "none") lands on the last.
            self.trials = 1;
            return match self.method {
                Method::Random => (self.draw() % k as u64) as usize,
                Method::Exhaustive => 0,
                Method::Binary => k - 1,
            };
        };
        let newest = (self.decided..self.phases.len())
            .rev()
            .find(|&i| self.phases[i].items >= self.phases[i].size);
        let Some(at) = newest else {
            return cur;
        };
        self.decided = at + 1;
        let ran = self.chosen[at];
        let Some((lt, lib)) = self.phases[at].measures() else {
            return cur;
        };
        let last_lib = self.last_lib.replace(lib);
        if !self.searching && self.method != Method::Random {
            if last_lib.is_some_and(|l| lib > l + 10.0) {
                self.searching = true;
                self.trials = 0;
                self.times = vec![None; k];
            } else {
                return cur;
            }
        }
        match self.method {
            Method::Random => {
                if lib / 10.0 > self.uniform() {
                    (self.draw() % k as u64) as usize
                } else {
                    cur
                }
            }
            Method::Exhaustive => {
                self.times[ran] = Some(lt);
                if (self.trials as usize) < k {
                    self.trials += 1;
                    (cur + 1) % k
                } else if self.times.iter().all(Option::is_some) {
                    self.searching = false;
                    (0..k)
                        .min_by(|&a, &b| self.times[a].partial_cmp(&self.times[b]).unwrap())
                        .unwrap_or(cur)
                } else {
                    cur
                }
            }
            Method::Binary => {
                if ran != cur {
                    return cur;
                }
                let step = (2 * k) >> self.trials.min(63);
                // A first trial, or no imbalance read before: Auto4OMP's −1 sentinel, which
                // any imbalance exceeds.
                let grew = self.trials <= 1 || last_lib.is_none_or(|l| lib > l);
                self.trials += 1;
                if step == 0 {
                    self.searching = false;
                    self.trials = 0;
                    cur
                } else if grew {
                    (cur + step).min(k - 1)
                } else {
                    cur.saturating_sub(step)
                }
            }
        }
    }
}

impl ChunkRule for Selector {
    fn next(&mut self, worker: usize, remaining: usize) -> usize {
        let handed = self.n.saturating_sub(remaining);
        let phase = handed / self.per_phase;
        if self.inner.is_none() || phase >= self.chosen.len() {
            let pick = self.select();
            let end = ((phase + 1) * self.per_phase).min(self.n);
            self.inner = Some(technique(pick, end - handed, self.p));
            self.chosen.push(pick);
            self.phases.push(Phase {
                time: vec![0.0; self.p],
                items: 0,
                size: end - handed,
            });
        }
        let phase = self.chosen.len() - 1;
        let left_in_phase = ((phase + 1) * self.per_phase)
            .min(self.n)
            .saturating_sub(handed);
        let left = left_in_phase.clamp(1, remaining.max(1));
        self.last_phase[worker] = phase;
        let inner = self.inner.as_mut().expect("set above");
        inner.next(worker, left).max(self.grab).clamp(1, left)
    }

    fn report(&mut self, worker: usize, r: &Report) {
        let ph = self.last_phase[worker];
        if let Some(phase) = self.phases.get_mut(ph) {
            phase.time[worker] += r.secs + r.grab_secs;
            phase.items += r.items;
        }
        if ph + 1 == self.chosen.len() {
            if let Some(inner) = self.inner.as_mut() {
                inner.report(worker, r);
            }
        }
    }

    fn timing(&self) -> Timing {
        match self.inner.as_ref().map(|i| i.timing()) {
            Some(Timing::Items) => Timing::Items,
            _ => Timing::Chunks,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::dls::sequence;

    fn run(method: Method, slow: f64) -> (Vec<usize>, Selector) {
        let mut s = Selector::new(method, 20_000, 4, 20, 1);
        // Worker 0 `slow`× slower per item; every hand-out costs 0.5 s of the asker's time.
        let seq = sequence(&mut s, 20_000, 4, |w, items| {
            Some(Report {
                items,
                secs: items as f64 * if w == 0 { slow } else { 1.0 },
                grab_secs: 0.5,
                ..Default::default()
            })
        });
        (seq, s)
    }

    #[test]
    fn chunks_never_cross_a_phase_and_every_item_goes_out() {
        for m in [Method::Random, Method::Exhaustive, Method::Binary] {
            let (seq, s) = run(m, 3.0);
            assert_eq!(seq.iter().sum::<usize>(), 20_000, "{m:?}");
            let mut at = 0;
            for c in seq {
                assert_eq!(
                    at / 1000,
                    (at + c - 1) / 1000,
                    "{m:?}: a chunk crosses a phase"
                );
                at += c;
            }
            assert_eq!(s.chosen().len(), 20, "{m:?}");
        }
    }

    #[test]
    fn exhaustive_tries_every_technique_then_keeps_one_that_balances_the_slow_worker() {
        let (_, s) = run(Method::Exhaustive, 4.0);
        let c = s.chosen();
        // A decision reads the newest phase fully reported, so a technique may run for two
        // phases before the next is tried: the sweep is the sequence without its repeats.
        let mut sweep = c.to_vec();
        sweep.dedup();
        assert_eq!(
            &sweep[..10],
            (0..10).collect::<Vec<_>>().as_slice(),
            "{c:?}"
        );
        // After the sweep one technique is kept. With a worker 4× slower, static (a quarter
        // of each phase to everyone) is the worst loop time; self-scheduling pays a 0.5 s
        // hand-out per item: neither may win. (Auto4OMP's re-trigger, LIB up by more than
        // 10 points, may start a new sweep later in this synthetic run.)
        let kept = sweep[10];
        assert!(kept != 0 && kept != 1, "{c:?}");
        let end = c.iter().position(|&i| i == 9).unwrap();
        let at = end + c[end..].iter().position(|&i| i == kept).unwrap();
        assert!(
            c.get(at + 1) == Some(&kept),
            "kept for one phase only: {c:?}"
        );
    }

    #[test]
    fn binary_starts_at_the_most_adaptive_and_halves_its_jump_until_it_keeps_one() {
        let (_, s) = run(Method::Binary, 4.0);
        let c = s.chosen();
        assert_eq!(c[0], PORTFOLIO.len() - 1);
        // Trials 2, 3, 4 jump by 2K/2ᵗ = 5, 2, 1 positions (left or right as the imbalance
        // fell or grew); the fifth step is 0 and the technique is kept for a phase at least.
        let mut path = c.to_vec();
        path.dedup();
        let jumps: Vec<usize> = path
            .windows(2)
            .take(3)
            .map(|w| w[0].abs_diff(w[1]))
            .collect();
        assert_eq!(jumps, [5, 2, 1], "{c:?}");
        let kept = path[3];
        let end = c.iter().position(|&i| i == path[2]).unwrap();
        let at = end + c[end..].iter().position(|&i| i == kept).unwrap();
        assert!(c.get(at + 1) == Some(&kept), "{c:?}");
    }

    #[test]
    fn random_jumps_with_probability_lib_over_ten() {
        let mut s = Selector::new(Method::Random, 1000, 4, 10, 1);
        let mut after = |time: [f64; 4]| -> Vec<usize> {
            (0..50)
                .map(|_| {
                    s.chosen = vec![3];
                    s.phases = vec![Phase {
                        time: time.to_vec(),
                        items: 40,
                        size: 40,
                    }];
                    s.decided = 0;
                    s.select()
                })
                .collect()
        };
        // Balanced: LIB 0, never a jump.
        assert!(after([5.0; 4]).iter().all(|&i| i == 3));
        // LIB = (10 − 3.25)/10 · 4/3 · 100 = 90 %: a jump every time, to random techniques.
        let picks = after([10.0, 1.0, 1.0, 1.0]);
        let distinct: std::collections::BTreeSet<_> = picks.iter().collect();
        assert!(distinct.len() >= 5, "{picks:?}");
        let (lt, lib) = Phase {
            time: vec![10.0, 1.0, 1.0, 1.0],
            items: 40,
            size: 40,
        }
        .measures()
        .unwrap();
        assert!(
            (lt - 1.0).abs() < 1e-12 && (lib - 90.0).abs() < 1e-9,
            "{lt} {lib}"
        );
    }
}
