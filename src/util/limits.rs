//! Every size limit of raysched's input, in one place. Each is checked (with checked or
//! widened arithmetic) before anything sized by it is allocated or spawned, and each error names
//! the limit. They are sanity bounds, far above any experiment the project runs (the largest
//! shipped scene has 1 M triangles, the largest image 1024², the widest sweep 4096 runs), and
//! small enough that what they size fits in this project's machines' memory.
//! docs/limits.md lists them for users.

/// Largest image width or height, in pixels; also the largest tile side of `--chunk`.
pub const MAX_IMAGE_SIDE: u32 = 1 << 16;

/// Largest pixel count of a render, every frame of an animation included (width × height ×
/// frames): 2²⁵ ≈ 33.5 M pixels, an 8K UHD frame; the image alone is 400 MB of f32 RGB.
pub const MAX_PIXELS: u64 = 1 << 25;

/// Largest sample count per pixel (`render.spp`, `--spp`, `max_spp`, `ref_spp`).
pub const MAX_SPP: u32 = 1 << 20;

/// Largest number of camera samples of one render (pixels × frames × spp): 2⁴⁰, about 40
/// hours of one core at this project's 6.9 M rays per second for one-segment paths.
pub const MAX_SAMPLES: u64 = 1 << 40;

/// Largest path length in segments. `max_depth = -1` (unlimited) lets Russian roulette end a
/// path and stops it here at the latest, so a lossless scene (albedo 1 inside a closed
/// emitter) terminates; a larger explicit `max_depth` is refused.
pub const MAX_DEPTH: u32 = 1 << 10;

/// Largest `count` of one generator shape (triangles or spheres).
pub const MAX_GENERATOR_COUNT: u64 = 1 << 24;

/// Largest number of primitives (triangles and spheres) of a whole scene: explicit shapes,
/// generators and meshes together.
pub const MAX_PRIMITIVES: u64 = 1 << 24;

/// Largest number of animation frames (every frame keeps a camera).
pub const MAX_FRAMES: u32 = 100_000;

/// Largest worker thread count (`--threads`, experiment `workers`, `--local-threads`).
pub const MAX_THREADS: usize = 4096;

/// Largest count a scheduler parameter may take (`--buffer`, `--grab`, `--guided-k`): far
/// beyond any useful buffer or grab, small enough that nothing sized by it can exhaust memory.
pub const MAX_COUNT: usize = 1 << 20;

/// Largest number of run configurations one experiment file may expand to (scenes × tracers ×
/// every scheduler grid × worker counts).
pub const MAX_CONFIGS: u64 = 1 << 20;

/// Largest number of timed runs of one experiment (run configurations × repetitions): the
/// runner lists every pending one before it starts.
pub const MAX_RUNS: u64 = 1 << 24;

/// Largest `repetitions` and `warmup` of an experiment.
pub const MAX_REPETITIONS: u32 = 1 << 16;

// The limits fit together: checked when compiling.
const _: () = assert!(MAX_PIXELS <= MAX_IMAGE_SIDE as u64 * MAX_IMAGE_SIDE as u64);
const _: () = assert!(MAX_PIXELS * MAX_SPP as u64 >= MAX_SAMPLES);
const _: () = assert!(MAX_GENERATOR_COUNT <= MAX_PRIMITIVES);
const _: () = assert!(MAX_DEPTH <= i32::MAX as u32);

/// `a × b × …` in u64, `None` on overflow.
pub fn checked_product(factors: &[u64]) -> Option<u64> {
    factors.iter().try_fold(1u64, |acc, &f| acc.checked_mul(f))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn products_overflow_to_none() {
        assert_eq!(checked_product(&[3, 4, 5]), Some(60));
        assert_eq!(checked_product(&[]), Some(1));
        assert_eq!(checked_product(&[u64::MAX, 2]), None);
        assert_eq!(checked_product(&[u32::MAX as u64; 3]), None);
    }
}
