//! `mitsuba`: Mitsuba 3's scalar `SamplingIntegrator::render` as a named policy: block size 32,
//! halved while the image has fewer blocks than threads (and the block is larger than 1);
//! blocks in spiral order from the centre ([`Order::Spiral`]); `parallel_for` over the block
//! range with grain `max(blocks / (4·threads), 1)`.

use super::{BuiltIn, Layout};
use crate::sched::param::{scheduler_params, Chunk, Order, Slow};
use crate::sched::rule::{Grab, HandOut};
use serde::{Deserialize, Serialize};

scheduler_params! {
    /// `mitsuba` has no parameters: it picks its blocks itself.
    pub struct MitsubaParams {}
}

impl BuiltIn for MitsubaParams {
    const DOC: &'static str = "Mitsuba 3 (scalar): 32² blocks halved until blocks ≥ threads, \
        spiral order, grabs of max(blocks/(4·threads), 1) blocks.";
    const OWN_LAYOUT: Option<Layout> = Some(layout);

    fn hand_out(&self, n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::pool(Box::new(Grab::fixed(mitsuba_grain(n, workers.max(1)))))
    }
}

fn layout(width: u32, height: u32, workers: usize) -> (Chunk, Order) {
    let b = mitsuba_block(width, height, workers);
    (Chunk::Tile { w: b, h: b }, Order::Spiral)
}

/// Mitsuba 3's block side: 32, halved until the image has at least `threads` blocks.
pub fn mitsuba_block(width: u32, height: u32, threads: usize) -> u32 {
    let mut b = 32u32;
    let blocks = |b: u32| width.div_ceil(b) as usize * height.div_ceil(b) as usize;
    while b > 1 && blocks(b) < threads {
        b /= 2;
    }
    b
}

/// Mitsuba 3's grain: blocks per task, `max(blocks / (4·threads), 1)`.
pub fn mitsuba_grain(blocks: usize, threads: usize) -> usize {
    (blocks / (4 * threads.max(1))).max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mitsuba_blocks_halve_until_every_thread_has_one() {
        assert_eq!(mitsuba_block(256, 256, 2), 32); // 64 blocks
        assert_eq!(mitsuba_block(32, 32, 2), 16); // 1 block at 32, 4 at 16
        assert_eq!(mitsuba_block(17, 13, 5), 8); // 1 block at 32, 2 at 16, 3·2 = 6 ≥ 5 at 8
        assert_eq!(mitsuba_block(1, 1, 4), 1);
        assert_eq!(mitsuba_grain(64, 2), 8);
        assert_eq!(mitsuba_grain(6, 5), 1);
    }
}
