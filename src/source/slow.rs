//! A known slowdown for heterogeneous runs on one machine: a worker that renders each item and
//! then spins for `factor − 1` times as long, so it is exactly `factor`× slower per item than
//! an unslowed worker on the same core, whatever the item costs. It spins rather than sleeps
//! so the slowed worker holds its core as a slower processor would.

use super::Job;
use crate::core::render::WorkItem;
use std::sync::Arc;
use std::time::Instant;

/// `job`, each item taking `factor`× its own time (`factor` ≤ 1: `job` itself).
pub fn slowed_job(job: Job, factor: f64) -> Job {
    if factor <= 1.0 {
        return job;
    }
    Arc::new(move |item: &WorkItem| {
        let t0 = Instant::now();
        let r = job(item);
        let until = t0.elapsed().mul_f64(factor);
        while t0.elapsed() < until {
            std::hint::spin_loop();
        }
        r
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::render::TileResult;
    use std::time::Duration;

    #[test]
    fn a_slowed_item_takes_at_least_factor_times_as_long_and_returns_the_same_result() {
        let job: Job = Arc::new(|it: &WorkItem| {
            std::thread::sleep(Duration::from_millis(2));
            TileResult {
                item: it.id,
                pixels: Default::default(),
                rays: 7,
                nonfinite: 0,
            }
        });
        let slow = slowed_job(job, 3.0);
        let t0 = Instant::now();
        let r = slow(&WorkItem::rect(5, 0, 0, 1, 1));
        // A lower bound only: the spin ends once 3× the measured render time has passed.
        assert!(t0.elapsed() >= Duration::from_millis(6));
        assert_eq!((r.item, r.rays), (5, 7));
    }
}
