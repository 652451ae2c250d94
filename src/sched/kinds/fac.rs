//! `fac`: factoring as published (FAC; Flynn Hummel, Schonberg & Flynn, "Factoring: a method
//! for scheduling parallel loops", CACM 35(8), 1992, §3, eqs. (3)–(5)), the probabilistic rule
//! FAC2 approximates. Work goes out in batches of P equal chunks; with R items left when a
//! batch starts, its chunks hold ⌈R/(xⱼ·P)⌉ items, where, with b = P·σ/(2·μ·√R),
//!
//!   x₀ = 1 + b² + b·√(b² + 2)   (the first batch),
//!   xⱼ = 2 + b² + b·√(b² + 4)   (every later batch),
//!
//! μ and σ the mean and standard deviation of an item's time. Only their ratio enters, the
//! parameter `fac_cv` (σ/μ in percent). With σ = 0 the first batch hands every worker R/P
//! (one chunk each) and each later batch half of what is left (FAC2).
//!
//! Peers: LB4OMP `kmp_sch_fac` (`runtime/src/kmp_dispatch.cpp` 2007–2061 for the first batch,
//! 4155–4200 for the later ones) reads μ and σ from a profiling run; so does this kind from
//! its parameter (a researcher measures σ/μ with `fsc`'s warm phase or AF's statistics).

use super::BuiltIn;
use crate::sched::dls::ChunkRule;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

/// FAC's chunk for `remaining` items on `p` workers, σ/μ = `cv`, the first batch or a later.
pub fn fac_chunk(remaining: usize, p: usize, cv: f64, first: bool) -> usize {
    let p = p.max(1) as f64;
    let b = p * cv / (2.0 * (remaining.max(1) as f64).sqrt());
    let x = if first {
        1.0 + b * b + b * (b * b + 2.0).sqrt()
    } else {
        2.0 + b * b + b * (b * b + 4.0).sqrt()
    };
    ((remaining as f64 / (x * p)).ceil() as usize).max(1)
}

/// FAC over P workers with σ/μ = `cv`.
pub struct Fac {
    p: usize,
    cv: f64,
    grab: usize,
    batch: usize,
    left_in_batch: usize,
    size: usize,
}

impl Fac {
    /// FAC on `p` workers, σ/μ = `cv`, chunks of at least `grab` items.
    pub fn new(p: usize, cv: f64, grab: usize) -> Self {
        Self {
            p: p.max(1),
            cv,
            grab,
            batch: 0,
            left_in_batch: 0,
            size: 0,
        }
    }
}

impl ChunkRule for Fac {
    fn next(&mut self, _worker: usize, remaining: usize) -> usize {
        if self.left_in_batch == 0 {
            self.size = fac_chunk(remaining, self.p, self.cv, self.batch == 0).max(self.grab);
            self.batch += 1;
            self.left_in_batch = self.p;
        }
        self.left_in_batch -= 1;
        self.size
    }
}

scheduler_params! {
    /// Factoring's parameters.
    pub struct FacParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
        /// σ/μ of an item's time, in percent (FAC's b = P·σ/(2μ√R)).
        fac_cv: usize = 100, label Some("cv%");
    }
}

impl BuiltIn for FacParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("FAC", true));
    const DOC: &'static str = "Factoring as published (Flynn Hummel et al. 1992): batches of P \
        chunks of ⌈R/(x·P)⌉, x from the items left and the items' σ/μ.";
    // Catalogue kinds: `advise` weighs them when named (`--scheduler`), not by default.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, _n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(Fac::new(
            workers,
            self.fac_cv as f64 / 100.0,
            self.grab,
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::dls::sequence;

    #[test]
    fn fac_n1000_p4_cv1_by_hand() {
        // b = 4/(2√1000) = 0.0632: x₀ = 1 + 0.004 + 0.0632·1.4156 = 1.0935 → ⌈1000/4.374⌉ = 229.
        // R = 84: b = 0.2182, x = 2 + 0.0476 + 0.2182·2.0118 = 2.4866 → ⌈84/9.946⌉ = 9.
        let got = sequence(&mut Fac::new(4, 1.0, 1), 1000, 4, |_, _| None);
        assert_eq!(&got[..6], [229, 229, 229, 229, 9, 9]);
        // σ = 0: one chunk each (R/P), as b = 0 gives x₀ = 1.
        let got = sequence(&mut Fac::new(4, 0.0, 1), 1000, 4, |_, _| None);
        assert_eq!(got, [250; 4]);
    }
}
