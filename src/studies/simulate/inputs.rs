//! The measured inputs of a simulation: the cost of every pixel (the cost model's probe,
//! [`crate::studies::model::probe::pixels`]) and the per-hand-out costs of the master and of the shared
//! counter (its zero-work runs, as `benches/dispatch.rs` measures them). Nothing here is
//! estimated.

use crate::core::render::TileResult;
use crate::core::scene::Scene;
use crate::core::tracer::AnyTracer;
use crate::sched::{decompose, wire, Chunk, Order, Policy, SchedulerKind};
use crate::studies::model::probe;
use crate::studies::simulate::error::SimError;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

pub use crate::studies::model::probe::ZeroWork;

/// Seconds the shorter zero-work run aims at (up to the plan's item count): 10× the cost
/// model's, because a simulated master at thousands of workers is limited by h alone.
pub(crate) const ZERO_WORK_RUN_S: f64 = 0.2;

/// Bytes MPI adds to each result entry: the worker's busy time (`u64`, see `mpi::wire`).
const RESULT_BUSY_BYTES: u32 = 8;

/// Seconds each pixel costs, from the probe.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PixelCosts {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Seconds per pixel, index `y·width + x`.
    pub cost_s: Vec<f64>,
    /// Σ of the pixels as timed one by one, before the probe's calibration to `bulk_s`.
    pub timed_s: f64,
    /// Σ of the bulk render (rows, timed per row) the costs are calibrated to.
    pub bulk_s: f64,
    /// The fastest and slowest bulk pass: the machine's speed while the probe ran.
    pub bulk_range_s: (f64, f64),
}

impl PixelCosts {
    /// The per-pixel probe ([`probe::pixels_with`], `reps` pixel passes among `level_reps`
    /// bulk passes) of `scene` on `threads` threads
    /// rendering at once: with `threads` > 1 the cost of a pixel while that many cores render
    /// (they share caches, memory and, on a virtual machine, possibly physical cores), for
    /// simulating a run of that many workers on this machine.
    pub fn probe(
        scene: &Arc<Scene>,
        tracer: &Arc<AnyTracer>,
        reps: u32,
        level_reps: u32,
        threads: usize,
    ) -> Result<Self, SimError> {
        if scene.frames() > 1 {
            return Err(SimError::Failed(
                "animations are not simulated (the probe times one frame)".into(),
            ));
        }
        let p = probe::pixels_with(scene, tracer, threads.max(1), reps, level_reps)?;
        Ok(Self {
            width: p.profile.width,
            height: p.profile.height,
            cost_s: p.profile.pixel_s,
            timed_s: p.timed_s,
            bulk_s: p.bulk_s,
            bulk_range_s: p.bulk_range_s,
        })
    }

    /// Σ pixel costs: the serial time the simulation's speedups are relative to.
    pub fn serial_s(&self) -> f64 {
        self.cost_s.iter().sum()
    }

    /// The same costs scaled by `k` (every pixel alike).
    pub fn scaled(&self, k: f64) -> Self {
        Self {
            cost_s: self.cost_s.iter().map(|c| c * k).collect(),
            ..self.clone()
        }
    }
}

/// The per-item inputs of a simulated run at one chunk size: cost and wire sizes by item id.
#[derive(Clone, Debug, PartialEq)]
pub struct ItemInputs {
    /// Seconds per item (Σ of its pixels' costs, times the layout's factor).
    pub cost_s: Vec<f64>,
    /// ITEM message bytes per item.
    pub item_bytes: Vec<u32>,
    /// RESULT message bytes per item.
    pub result_bytes: Vec<u32>,
}

impl ItemInputs {
    /// The items of `chunk` in `order`, costed from `px` and scaled by the layout's measured
    /// factor `layout` ([`crate::studies::model::probe::layout_factor`]; 1 leaves the pixel sums).
    pub fn new(px: &PixelCosts, chunk: Chunk, order: Order, layout: f64) -> Self {
        let items = decompose(px.width, px.height, chunk, order);
        let cost_s = items
            .iter()
            .map(|it| {
                layout
                    * it.pixels(px.width)
                        .map(|p| px.cost_s[p as usize])
                        .sum::<f64>()
            })
            .collect();
        let item_bytes = items.iter().map(|it| wire::item_bytes(it) as u32).collect();
        let result_bytes = items
            .iter()
            .map(|it| {
                let r = TileResult {
                    item: it.id,
                    pixels: crate::core::render::PixelValues::from_elem([0.0; 3], it.pixel_count()),
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

/// A hand-out thread's cost per hand-out at `buffer` (zero-work dispatch per item) and its
/// fixed cost: `kind` at its defaults with that buffer (its parameter `buffer`).
pub fn master_zero_work(
    kind: SchedulerKind,
    buffer: usize,
    items: u32,
    workers: usize,
    reps: u32,
) -> Result<ZeroWork, SimError> {
    let mut spec = crate::sched::SchedulerSpec::new(kind, Chunk::Frame, workers);
    spec.set("buffer", &buffer.to_string())?;
    Ok(probe::zero_work_for(
        spec.policy,
        items,
        workers,
        reps,
        ZERO_WORK_RUN_S,
    )?)
}

/// The shared counter's cost per grab (zero-work self-scheduling at grab 1, per item) and the
/// threaded schedulers' fixed cost per run.
pub fn counter_zero_work(items: u32, workers: usize, reps: u32) -> Result<ZeroWork, SimError> {
    Ok(probe::zero_work_for(
        Policy::defaults(SchedulerKind::SelfScheduling),
        items,
        workers,
        reps,
        ZERO_WORK_RUN_S,
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn item_costs_are_their_pixels_times_the_layouts_factor() {
        // A 4×2 image whose pixel (x, y) costs (1 + x + 4y) ms, in 2×2 tiles.
        let px = PixelCosts {
            width: 4,
            height: 2,
            cost_s: (0..8).map(|i| (1 + i) as f64 * 1e-3).collect(),
            timed_s: 0.036,
            bulk_s: 0.036,
            bulk_range_s: (0.036, 0.036),
        };
        let tiles = Chunk::Tile { w: 2, h: 2 };
        let plain = ItemInputs::new(&px, tiles, Order::Scanline, 1.0);
        // Tile 0: pixels 0, 1, 4, 5 (1 + 2 + 5 + 6 ms); tile 1: 2, 3, 6, 7 (3 + 4 + 7 + 8).
        assert_eq!(plain.cost_s, [0.014, 0.022]);
        let scaled = ItemInputs::new(&px, tiles, Order::Scanline, 1.25);
        assert_eq!(scaled.cost_s, [1.25 * 0.014, 1.25 * 0.022]);
        assert_eq!(scaled.item_bytes, plain.item_bytes);
        assert_eq!(scaled.result_bytes, plain.result_bytes);
    }
}
