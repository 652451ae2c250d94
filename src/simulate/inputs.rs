//! The measured inputs of a simulation: the cost of every pixel (one per-pixel render with a
//! timeline) and the per-hand-out costs of the master and of the shared counter (zero-work
//! runs, as `benches/dispatch.rs` measures them). Nothing here is estimated.

use crate::render::{TileResult, WorkItem};
use crate::scene::Scene;
use crate::sched::{
    decompose, render_job, run_items, wire, Chunk, MasterParams, Order, Policy, RunOptions,
    SchedulerKind, SchedulerSpec,
};
use crate::source::Job;
use crate::tracer::AnyTracer;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Bytes MPI adds to each result entry: the worker's busy time (`u64`, see `mpi::wire`).
const RESULT_BUSY_BYTES: u32 = 8;

/// Seconds each pixel took in one per-pixel render on one worker.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PixelCosts {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Seconds per pixel, index `y·width + x`.
    pub cost_s: Vec<f64>,
    /// Wall time of the probe run (the serial-equivalent time), seconds.
    pub wall_s: f64,
}

impl PixelCosts {
    /// Render `scene` `reps` times pixel by pixel on one worker, timing each pixel (a timeline
    /// of a `static` run at chunk 1), and keep each pixel's fastest time: on a shared machine a
    /// pixel during which the thread was descheduled shows the whole time slice (tens of ms,
    /// seen under a load average of 20), which would make one pixel the run's critical path.
    pub fn probe(scene: &Arc<Scene>, tracer: &Arc<AnyTracer>, reps: u32) -> Result<Self, String> {
        let mut best = Self::probe_once(scene, tracer)?;
        for _ in 1..reps {
            let next = Self::probe_once(scene, tracer)?;
            for (b, n) in best.cost_s.iter_mut().zip(&next.cost_s) {
                *b = b.min(*n);
            }
            best.wall_s = best.wall_s.min(next.wall_s);
        }
        Ok(best)
    }

    fn probe_once(scene: &Arc<Scene>, tracer: &Arc<AnyTracer>) -> Result<Self, String> {
        if scene.frames() > 1 {
            return Err("animations are not simulated (the probe times one frame)".into());
        }
        let (w, h) = (scene.width(), scene.height());
        let mut spec = SchedulerSpec::new(SchedulerKind::Static, Chunk::Tile { w: 1, h: 1 }, 1);
        spec.timeline = true;
        let items = decompose(w, h, spec.chunk, Order::Scanline);
        let (_, stats) = run_items(
            &spec,
            &items,
            render_job(scene, tracer),
            &RunOptions::default(),
        )
        .map_err(|e| e.to_string())?;
        let mut cost_s = vec![0.0; (w * h) as usize];
        for span in stats.timeline.unwrap_or_default() {
            if let Some(item) = items.get(span.item as usize) {
                for p in item.pixels(w) {
                    cost_s[p as usize] = (span.end_ns - span.start_ns) as f64 * 1e-9;
                }
            }
        }
        Ok(Self {
            width: w,
            height: h,
            cost_s,
            wall_s: stats.wall_s,
        })
    }

    /// Σ pixel costs: the serial time the simulation's speedups are relative to.
    pub fn serial_s(&self) -> f64 {
        self.cost_s.iter().sum()
    }
}

/// The per-item inputs of a simulated run at one chunk size: cost and wire sizes by item id.
#[derive(Clone, Debug, PartialEq)]
pub struct ItemInputs {
    /// Seconds per item (Σ of its pixels' costs).
    pub cost_s: Vec<f64>,
    /// ITEM message bytes per item.
    pub item_bytes: Vec<u32>,
    /// RESULT message bytes per item.
    pub result_bytes: Vec<u32>,
}

impl ItemInputs {
    /// The items of `chunk` in `order`, costed from `px`.
    pub fn new(px: &PixelCosts, chunk: Chunk, order: Order) -> Self {
        let items = decompose(px.width, px.height, chunk, order);
        let cost_s = items
            .iter()
            .map(|it| it.pixels(px.width).map(|p| px.cost_s[p as usize]).sum())
            .collect();
        let item_bytes = items.iter().map(|it| wire::item_bytes(it) as u32).collect();
        let result_bytes = items
            .iter()
            .map(|it| {
                let r = TileResult {
                    item: it.id,
                    pixels: vec![[0.0; 3]; it.pixel_count()],
                    rays: 0,
                    nonfinite: 0,
                };
                wire::result_bytes(&r) as u32 + RESULT_BUSY_BYTES
            })
            .collect();
        Self {
            cost_s,
            item_bytes,
            result_bytes,
        }
    }
}

fn nothing() -> Job {
    Arc::new(|it: &WorkItem| TileResult {
        item: it.id,
        pixels: Vec::new(),
        rays: 0,
        nonfinite: 0,
    })
}

/// Seconds per item of `policy` on `workers` threads over one-pixel zero-work items: the
/// slope between runs of `items` and 2·`items` items (so the run's fixed cost, thread start-up
/// and join, ~100–260 µs here, is left out), median of `reps` pairs.
pub fn zero_work_s(policy: Policy, items: u32, workers: usize, reps: u32) -> Result<f64, String> {
    let mut spec = SchedulerSpec::new(policy.kind(), Chunk::Tile { w: 1, h: 1 }, workers);
    spec.policy = policy;
    let wall = |n: u32| -> Result<(f64, usize), String> {
        let side = (n as f64).sqrt().ceil() as u32;
        let list = decompose(side, side, Chunk::Tile { w: 1, h: 1 }, Order::Scanline);
        let (_, s) = run_items(&spec, &list, nothing(), &RunOptions::default())
            .map_err(|e| e.to_string())?;
        Ok((s.wall_s, list.len()))
    };
    let mut per_item: Vec<f64> = (0..reps.max(1))
        .map(|_| {
            let (a, na) = wall(items)?;
            let (b, nb) = wall(2 * items)?;
            Ok(((b - a) / (nb - na) as f64).max(b / nb as f64 * 0.05))
        })
        .collect::<Result<_, String>>()?;
    per_item.sort_by(f64::total_cmp);
    Ok(per_item[per_item.len() / 2])
}

/// The master's cost per hand-out at `buffer`: zero-work dispatch per item.
pub fn master_h_s(buffer: usize, items: u32, workers: usize, reps: u32) -> Result<f64, String> {
    let p = MasterParams {
        buffer,
        ..MasterParams::DEFAULT
    };
    zero_work_s(Policy::Master(p), items, workers, reps)
}

/// The shared counter's cost per grab: zero-work self-scheduling at grab 1, per item.
pub fn counter_s(items: u32, workers: usize, reps: u32) -> Result<f64, String> {
    zero_work_s(
        Policy::defaults(SchedulerKind::SelfScheduling),
        items,
        workers,
        reps,
    )
}
