//! `mfsc`: modified fixed-size chunking (mFSC; Banicescu, Velusamy & Devaprasad, Cluster
//! Computing 6, 2003, as implemented by both peers): FSC's one chunk size without its
//! profiled h and σ, chosen so that mFSC hands out about as many chunks as FAC2:
//!
//!   K = ⌊0.55 + t·ln 2 / ln t⌋,   t = ⌈N/P⌉,
//!
//! (at least `grab`; t = 1 gives K = 1). LB4OMP `kmp_sch_mfsc` (`runtime/src/kmp_dispatch.cpp`
//! 2240–2251) and DLS4LB (`DLS.c` 639–640) compute this K; so do we.

use super::BuiltIn;
use crate::sched::dls::Grab;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

/// mFSC's chunk for `n` items on `p` workers.
pub fn mfsc_chunk(n: usize, p: usize) -> usize {
    let t = n.div_ceil(p.max(1));
    if t <= 2 {
        return 1;
    }
    let t = t as f64;
    ((0.55 + t * std::f64::consts::LN_2 / t.ln()).floor() as usize).max(1)
}

scheduler_params! {
    /// mFSC's parameters.
    pub struct MfscParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for MfscParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("mFSC", true));
    const DOC: &'static str = "Modified fixed-size chunking (mFSC): one chunk size, \
        ⌊0.55 + t·ln 2/ln t⌋ with t = ⌈N/P⌉, about as many chunks as FAC2.";
    // Catalogue kinds: `advise` weighs them when named (`--scheduler`), not by default.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(Grab::fixed(mfsc_chunk(n, workers).max(self.grab))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mfsc_by_hand() {
        // t = 250: 0.55 + 250·0.6931/5.5215 = 31.93 → 31.
        assert_eq!(mfsc_chunk(1000, 4), 31);
        assert_eq!(mfsc_chunk(3, 4), 1);
    }
}
