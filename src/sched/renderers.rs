//! The work decomposition of two production renderers, as named policies (`pbrt`, `mitsuba`)
//! so their defaults can be measured beside the other schedulers.
//!
//! - pbrt-v4, `ParallelFor2D` (`src/pbrt/util/parallel.cpp`): tile side
//!   `clamp(⌊√(W·H / (8·threads))⌋, 1, 32)`, tiles in row order, each worker takes the next
//!   tile under the loop's mutex.
//! - Mitsuba 3, scalar `SamplingIntegrator::render`: block size 32, halved while the image has
//!   fewer blocks than threads (and the block is larger than 1); blocks in spiral order from
//!   the centre ([`Order::Spiral`](super::Order::Spiral)); `parallel_for` over the block range
//!   with grain `max(blocks / (4·threads), 1)`.

/// pbrt-v4's tile side for a `width`×`height` image on `threads` threads.
pub fn pbrt_tile(width: u32, height: u32, threads: usize) -> u32 {
    let area = width as f64 * height as f64;
    ((area / (8.0 * threads.max(1) as f64)).sqrt().floor() as u32).clamp(1, 32)
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
    fn pbrt_tiles_from_the_formula() {
        // √(256·256/16) = 64 → 32; √(64·64/16) = 16; √(17·13/16) = 3.7 → 3; √(1/8) → 1.
        assert_eq!(pbrt_tile(256, 256, 2), 32);
        assert_eq!(pbrt_tile(64, 64, 2), 16);
        assert_eq!(pbrt_tile(17, 13, 2), 3);
        assert_eq!(pbrt_tile(1, 1, 1), 1);
        assert_eq!(pbrt_tile(128, 128, 4), 22); // √(16384/32) = 22.6
    }

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
