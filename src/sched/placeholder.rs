//! PLACEHOLDER — NOT A SCHEDULER. Delete at merge and wire the real `run_scheduler`.
//!
//! Exists only so the experiment runner (src/experiment/) compiles and can be tested before the
//! schedulers branch lands. It ignores every field of the spec except `workers` and `timeline`,
//! renders with [`render_parallel`] (rows on a rayon pool) and fills [`RunStats`] plausibly:
//! busy = wall for every worker, items = rows. Its numbers mean nothing.

use super::{RunStats, SchedulerSpec, Span, WorkerStats};
use crate::render::{render_parallel, Image};
use crate::scene::Scene;
use crate::tracer::Tracer;
use std::sync::Arc;
use std::time::Instant;

/// PLACEHOLDER error type (the real one comes with the schedulers).
#[derive(Debug, thiserror::Error)]
pub enum SchedError {
    #[error("invalid scheduler spec: {0}")]
    Spec(#[from] super::SpecError),
    #[error("thread pool: {0}")]
    Pool(String),
}

/// PLACEHOLDER: same signature as the real entry point.
pub fn run_scheduler<T: Tracer + 'static>(
    spec: &SchedulerSpec,
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
) -> Result<(Image, RunStats), SchedError> {
    spec.validate()?;
    let t0 = Instant::now();
    let (image, counters) = render_parallel(scene.as_ref(), tracer.as_ref(), spec.workers)
        .map_err(|e| SchedError::Pool(e.to_string()))?;
    let wall = t0.elapsed();
    let wall_s = wall.as_secs_f64();
    let rows = scene.height() as u64;
    let n = spec.workers as u64;
    let workers = (0..n)
        .map(|i| {
            let items = rows / n + u64::from(i < rows % n);
            WorkerStats {
                busy_s: wall_s,
                idle_s: 0.0,
                items,
                pixels: items * scene.width() as u64,
                rays: counters.rays / n,
            }
        })
        .collect();
    let timeline = spec.timeline.then(|| {
        (0..n as u32)
            .map(|w| Span {
                worker: w,
                item: w,
                start_ns: 0,
                end_ns: wall.as_nanos() as u64,
            })
            .collect()
    });
    Ok((
        image,
        RunStats {
            wall_s,
            workers,
            master: None,
            items: rows,
            issued: rows,
            reissued: 0,
            duplicates: 0,
            bytes: 0,
            rays: counters.rays,
            nonfinite: counters.nonfinite,
            lost_sources: 0,
            timeline,
        },
    ))
}
