//! `rnd`: random chunk sizes (RND; Ciorba, Iwainsky & Buder, "OpenMP loop scheduling
//! revisited: making a case for more schedules", IWOMP 2018): every chunk's size drawn
//! uniformly from `grab` … ⌈N/(2P)⌉, the range from self-scheduling's chunk to FAC2's first.
//! The draws come from a fixed-seed SplitMix64 (Steele, Lea & Flood 2014) per run, so a run's
//! sequence is reproducible; images do not depend on it in any case.
//!
//! Peer: LB4OMP `kmp_sch_rnd` (`runtime/src/kmp_dispatch.cpp` 2197–2209 and 4589–4626) draws
//! from 1 (`KMP_RND_START`) to the schedule's chunk, or to N − 1 when none is given, with
//! `rand_r` seeded from the clock: not reproducible, and its default upper bound lets one
//! chunk take nearly the whole loop. We keep its lower bound and take FAC2's first chunk as
//! the upper.

use super::BuiltIn;
use crate::sched::dls::ChunkRule;
use crate::sched::param::{scheduler_params, Slow};
use crate::sched::rule::HandOut;
use serde::{Deserialize, Serialize};

/// SplitMix64's seed for every RND run.
pub const RND_SEED: u64 = 0x0005_eed0_fa11_c4a7;

/// One SplitMix64 step: the next state and its output.
pub fn splitmix64(state: u64) -> (u64, u64) {
    let s = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = s;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    (s, z ^ (z >> 31))
}

/// RND over `n` items on `p` workers.
pub struct Rnd {
    lo: usize,
    hi: usize,
    state: u64,
}

impl Rnd {
    /// RND over `n` items on `p` workers, chunks from `grab` to ⌈n/(2p)⌉.
    pub fn new(n: usize, p: usize, grab: usize) -> Self {
        let lo = grab.max(1);
        Self {
            lo,
            hi: n.div_ceil(2 * p.max(1)).max(lo),
            state: RND_SEED,
        }
    }
}

impl ChunkRule for Rnd {
    fn next(&mut self, _worker: usize, _remaining: usize) -> usize {
        let (s, x) = splitmix64(self.state);
        self.state = s;
        self.lo + (x % (self.hi - self.lo + 1) as u64) as usize
    }
}

scheduler_params! {
    /// RND's parameters.
    pub struct RndParams {
        /// The smallest chunk drawn.
        grab: usize = 1, label None;
    }
}

impl BuiltIn for RndParams {
    const PUBLISHED: Option<(&'static str, bool)> = Some(("RND", false));
    const DOC: &'static str = "Random chunk sizes (RND; Ciorba et al. 2018): each drawn \
        uniformly from `grab` to ⌈N/(2P)⌉ by a fixed-seed generator.";
    // Catalogue kinds: `advise` weighs them when named (`--scheduler`), not by default.
    const ADVISED_BY_DEFAULT: bool = false;
    const SIZES_OWN_HAND_OUTS: bool = true;

    fn hand_out(&self, n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::shares(Box::new(Rnd::new(n, workers, self.grab)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::dls::sequence;

    #[test]
    fn rnd_stays_in_its_range_and_repeats() {
        let a = sequence(&mut Rnd::new(1000, 4, 3), 1000, 4, |_, _| None);
        let b = sequence(&mut Rnd::new(1000, 4, 3), 1000, 4, |_, _| None);
        assert_eq!(a, b);
        let (last, init) = a.split_last().unwrap();
        assert!(init.iter().all(|&c| (3..=125).contains(&c)), "{a:?}");
        assert!(*last >= 1);
        // Not a constant: at least ten different sizes.
        let mut d = init.to_vec();
        d.sort_unstable();
        d.dedup();
        assert!(d.len() >= 10, "{d:?}");
    }
}
