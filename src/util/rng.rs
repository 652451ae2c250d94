//! Counter-based random numbers: every value is a pure hash of (seed, pixel, sample, dimension).
//!
//! There is no generator state shared between pixels, so a pixel's value never depends on which
//! thread renders it, in which order, or with which other pixels: the property every scheduler
//! test relies on. The mixer is SplitMix64's finaliser ([`crate::util::hash::mix64`]).

use crate::util::hash::mix64;

/// The seed frame `frame` of an animation samples with: `seed` itself for frame 0 (SplitMix's
/// finaliser maps 0 to 0), so static scenes keep their images bit for bit, and a scrambled one
/// for every later frame. Rendering the static scene with frame k's camera and this seed gives
/// frame k's random numbers exactly.
pub fn frame_seed(seed: u64, frame: u32) -> u64 {
    seed ^ mix64(frame as u64)
}

/// The random stream of one (seed, pixel, sample) triple; `next` advances the dimension.
#[derive(Clone, Debug)]
pub struct Sampler {
    key: u64,
    dim: u64,
}

impl Sampler {
    /// The stream of `sample` of `pixel` under `seed`, positioned before its first dimension.
    #[inline]
    pub fn new(seed: u64, pixel: u64, sample: u64) -> Self {
        let key = mix64(mix64(seed ^ 0x9e37_79b9_7f4a_7c15).wrapping_add(pixel))
            .wrapping_add(mix64(sample.wrapping_mul(0xd1b5_4a32_d192_ed03)));
        Self { key, dim: 0 }
    }

    /// Uniform in [0, 1), 24 bits of resolution. (Not an `Iterator`: the stream never ends.)
    #[allow(clippy::should_implement_trait)]
    #[inline]
    pub fn next(&mut self) -> f32 {
        self.dim += 1;
        let bits = mix64(
            self.key
                .wrapping_add(self.dim.wrapping_mul(0x9e37_79b9_7f4a_7c15)),
        );
        (bits >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

    /// The next two dimensions, e.g. a 2-D jitter or direction sample.
    #[inline]
    pub fn next2(&mut self) -> (f32, f32) {
        (self.next(), self.next())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_key_same_stream_different_key_different_stream() {
        let a: Vec<f32> = (0..8)
            .map({
                let mut s = Sampler::new(7, 42, 3);
                move |_| s.next()
            })
            .collect();
        let b: Vec<f32> = (0..8)
            .map({
                let mut s = Sampler::new(7, 42, 3);
                move |_| s.next()
            })
            .collect();
        let c: Vec<f32> = (0..8)
            .map({
                let mut s = Sampler::new(7, 43, 3);
                move |_| s.next()
            })
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn frame_0_keeps_the_seed_and_frames_differ() {
        assert_eq!(frame_seed(12345, 0), 12345);
        let seeds: std::collections::HashSet<u64> = (0..100).map(|f| frame_seed(7, f)).collect();
        assert_eq!(seeds.len(), 100);
    }

    #[test]
    fn uniform_mean_and_range() {
        let mut sum = 0.0f64;
        let n = 100_000;
        for p in 0..n {
            let v = Sampler::new(1, p, 0).next();
            assert!((0.0..1.0).contains(&v));
            sum += v as f64;
        }
        let mean = sum / n as f64;
        // Standard error of the mean of U(0,1) over 1e5 draws is 0.0009.
        assert!((mean - 0.5).abs() < 0.004, "mean {mean}");
    }
}
