//! `tap`: taper (TAP; Lucco, "A dynamic scheduling method for irregular parallel programs",
//! PLDI 1992): guided self-scheduling shrunk by the spread of item times. With R items left
//! and T = R/P, each request gets
//!
//!   K = max(grab, ⌈T + v²/2 − v·√(2T + v²/4)⌉),   v = α·σ/μ,
//!
//! μ and σ the mean and standard deviation of an item's time and α a scaling factor. With
//! σ = 0 (v = 0) it is guided self-scheduling, ⌈R/P⌉; the larger v, the smaller each chunk
//! below R/P, most so near the end where T is small (for T ≲ v² the bracket falls below 1
//! and `grab` takes over).
//!
//! μ, σ and α are parameters, as in the peer: LB4OMP `kmp_sch_tap`
//! (`runtime/src/kmp_dispatch.cpp` 1966–2006 at commit bd45b1e: v = α·σ/μ from a profiling
//! run's μ, σ and `KMP_ALPHA`'s α; 4100–4125: the chunk above, at least the minimum chunk).
//! Only σ/μ enters, the parameter `tap_cv` in percent (default 100, like `fac`'s `fac_cv`; a
//! researcher measures it with a profiling run as for LB4OMP). α is `tap_alpha` in percent,
//! default 100: LB4OMP's default α = 1.0 (`runtime/src/kmp_global.cpp` 574). The DLS
//! literature restates Lucco's empirically chosen α as 1.3 (`tap_alpha = 130`); the paper
//! itself was not at hand to check, so the default follows the peer a researcher compares with.
//! LB4OMP keeps μ in an integer of microseconds; the ratio here is exact.

use super::BuiltIn;
use crate::sched::dls::ChunkRule;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

/// TAP's chunk for `remaining` items on `p` workers with v = α·σ/μ, at least 1.
pub fn tap_chunk(remaining: usize, p: usize, v: f64) -> usize {
    let t = remaining as f64 / p.max(1) as f64;
    let k = (t + v * v / 2.0 - v * (2.0 * t + v * v / 4.0).sqrt()).ceil();
    if k.is_finite() && k > 1.0 {
        k as usize
    } else {
        1
    }
}

/// TAP over P workers with v = α·σ/μ.
pub struct Tap {
    p: usize,
    v: f64,
    grab: usize,
}

impl Tap {
    /// TAP on `p` workers, v = `v`, chunks of at least `grab` items.
    pub fn new(p: usize, v: f64, grab: usize) -> Self {
        Self {
            p: p.max(1),
            v,
            grab,
        }
    }
}

impl ChunkRule for Tap {
    fn next(&mut self, _worker: usize, remaining: usize) -> usize {
        tap_chunk(remaining, self.p, self.v).max(self.grab)
    }
}

scheduler_params! {
    /// Taper's parameters.
    pub struct TapParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
        /// σ/μ of an item's time, in percent (TAP's v = α·σ/μ).
        tap_cv: usize = 100, label Some("cv%");
        /// The scaling factor α, in percent (LB4OMP's default 1.0; Lucco's reported 1.3 = 130).
        tap_alpha: usize = 100, label Some("alpha%");
    }
}

impl BuiltIn for TapParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("TAP", true));
    const DOC: &'static str = "Taper (TAP; Lucco 1992): each request gets \
        ⌈T + v²/2 − v·√(2T + v²/4)⌉ items, T = R/P, v = α·σ/μ: guided shrunk by the spread of \
        item times.";
    // Catalogue kinds: `advise` weighs them when named (`--scheduler`), not by default.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, _n: usize, workers: usize, _slow: Slow) -> HandOut {
        let v = self.tap_alpha as f64 / 100.0 * self.tap_cv as f64 / 100.0;
        HandOut::shares(Box::new(Tap::new(workers, v, self.grab)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::dls::sequence;

    #[test]
    fn tap_n1000_p4_by_hand() {
        // v = 1: T = 250, 250 + 0.5 − √500.25 = 250.5 − 22.366 = 228.13 → 229.
        // R = 771: T = 192.75, 193.25 − √385.75 = 193.25 − 19.641 = 173.61 → 174.
        let got = sequence(&mut Tap::new(4, 1.0, 1), 1000, 4, |_, _| None);
        assert_eq!(&got[..2], [229, 174]);
        // v = 0: guided, ⌈R/P⌉: 250, ⌈750/4⌉ = 188.
        let got = sequence(&mut Tap::new(4, 0.0, 1), 1000, 4, |_, _| None);
        assert_eq!(&got[..2], [250, 188]);
        // v = 1.3, T = 1: 1 + 0.845 − 1.3·√2.4225 = 1.845 − 2.023 < 0: the floor of 1 item.
        assert_eq!(tap_chunk(4, 4, 1.3), 1);
        assert_eq!(Tap::new(4, 1.3, 3).next(0, 4), 3);
    }
}
