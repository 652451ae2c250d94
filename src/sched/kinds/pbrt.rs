//! `pbrt`: pbrt-v4's parallel loop as a named policy, so its default can be measured beside the
//! other schedulers. `ParallelFor2D` (`src/pbrt/util/parallel.cpp`): tile side
//! `clamp(⌊√(W·H / (8·threads))⌋, 1, 32)`, tiles in row order, each worker takes the next tile
//! under the loop's mutex.

use super::{BuiltIn, Layout};
use crate::sched::param::{scheduler_params, Chunk, Order, Slow};
use crate::sched::rule::{Grab, HandOut, Pool, WorkerRule};
use serde::{Deserialize, Serialize};

scheduler_params! {
    /// `pbrt` has no parameters: it picks its tiles itself.
    pub struct PbrtParams {}
}

impl BuiltIn for PbrtParams {
    const DOC: &'static str = "pbrt-v4's parallel loop: tiles of \
        clamp(⌊√(W·H/(8·threads))⌋, 1, 32), row order, one tile per grab under a lock.";
    const OWN_LAYOUT: Option<Layout> = Some(layout);

    fn hand_out(&self, _n: usize, _workers: usize, _slow: Slow) -> HandOut {
        HandOut::ByWorkers(WorkerRule::Pool(Pool {
            locked: true,
            ..Pool::new(Box::new(Grab::fixed(1)))
        }))
    }
}

fn layout(width: u32, height: u32, workers: usize) -> (Chunk, Order) {
    let t = pbrt_tile(width, height, workers);
    (Chunk::Tile { w: t, h: t }, Order::Scanline)
}

/// pbrt-v4's tile side for a `width`×`height` image on `threads` threads.
pub fn pbrt_tile(width: u32, height: u32, threads: usize) -> u32 {
    let area = width as f64 * height as f64;
    ((area / (8.0 * threads.max(1) as f64)).sqrt().floor() as u32).clamp(1, 32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pbrt_tiles_from_the_formula() {
        // √(256·256/16) = 64 → 32; √(64·64/16) = 16; √(17·13/16) = 3.7 → 3; √(1/8) → 1.
        assert_eq!(pbrt_tile(256, 256, 2), 32);
        assert_eq!(pbrt_tile(64, 64, 2), 16);
        assert_eq!(pbrt_tile(17, 13, 2), 3);
        assert_eq!(pbrt_tile(1, 1, 1), 1);
        assert_eq!(pbrt_tile(128, 128, 4), 22); // √(16384/32) = 22.6
    }
}
