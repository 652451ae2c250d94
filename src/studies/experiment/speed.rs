//! The machine's own speed, measured beside the configurations: a fixed single-core workload
//! that shares no code with the renderer, timed once per round of an experiment.
//!
//! A shared VM drifts as a whole between runs minutes apart (M-115). Dividing a run's wall times by its
//! median probe time cancels that common drift in `compare`, while a change in raysched's own
//! code leaves the probe untouched and still shows.

use std::hint::black_box;
use std::time::Instant;

/// Table the probe walks: 64 KiB, the L1/L2 traffic of a BVH walk over a small scene.
const TABLE_LEN: usize = 1 << 14;
/// Steps per probe: 2^21 took 12.7 ms (fastest of 40, optimised build, load 7) on the 2-core
/// AMD EPYC VM raysched is developed on, so 2^20 is ~6 ms: 0.2 % of a round of `quick` (54
/// samples of ≥ 50 ms each).
const STEPS: u32 = 1 << 20;

/// Seconds one run of the fixed workload took (dependent loads, integer mixing and an f64
/// multiply-add chain, so neither memory nor FP alone decides).
pub fn probe_s() -> f64 {
    let mut table = vec![0u32; TABLE_LEN];
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    for v in &mut table {
        x = mix(x);
        *v = x as u32;
    }
    let start = Instant::now();
    let (mut idx, mut acc) = (0usize, 0.0f64);
    for i in 0..STEPS {
        let v = black_box(table[idx]);
        x = mix(x ^ u64::from(v));
        acc = acc.mul_add(0.999_999, (x >> 11) as f64 * (1.0 / (1u64 << 53) as f64));
        table[idx] = x as u32;
        idx = (v as usize ^ i as usize) & (TABLE_LEN - 1);
    }
    black_box((acc, idx));
    start.elapsed().as_secs_f64()
}

/// One SplitMix64 step: the golden-ratio increment, then the finaliser.
fn mix(z: u64) -> u64 {
    crate::util::hash::mix64(z.wrapping_add(0x9e37_79b9_7f4a_7c15))
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_probe_measures_a_positive_finite_time() {
        let t = super::probe_s();
        assert!(t.is_finite() && t > 0.0, "{t}");
    }
}
