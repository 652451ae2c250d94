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
    /// of a `static_cyclic` run at chunk 1), and keep each pixel's median time. The median, not
    /// the fastest: the fastest of 3 underestimates what a pixel costs in a run (on the loaded
    /// 2-core dev box Σ of the fastest was 0.38 s where a serial render used 0.49 s of CPU),
    /// and a pixel during which the thread was descheduled (a whole time slice, tens of ms)
    /// is out-voted as long as it happens in fewer than half the renders.
    ///
    /// With `threads` > 1 the pixels are dealt out cyclically to that many threads rendering
    /// at once: the cost of a pixel while every core renders (cores share caches, memory and,
    /// on a virtual machine, possibly one physical core), for simulating a run of that many
    /// workers on this machine.
    pub fn probe(
        scene: &Arc<Scene>,
        tracer: &Arc<AnyTracer>,
        reps: u32,
        threads: usize,
    ) -> Result<Self, String> {
        let runs: Vec<Self> = (0..reps.max(1))
            .map(|_| Self::probe_once(scene, tracer, threads))
            .collect::<Result<_, _>>()?;
        let mid = |mut v: Vec<f64>| {
            v.sort_by(f64::total_cmp);
            let n = v.len();
            if n % 2 == 1 {
                v[n / 2]
            } else {
                0.5 * (v[n / 2 - 1] + v[n / 2])
            }
        };
        let cost_s = (0..runs[0].cost_s.len())
            .map(|p| mid(runs.iter().map(|r| r.cost_s[p]).collect()))
            .collect();
        Ok(Self {
            width: runs[0].width,
            height: runs[0].height,
            cost_s,
            wall_s: mid(runs.iter().map(|r| r.wall_s).collect()),
        })
    }

    fn probe_once(
        scene: &Arc<Scene>,
        tracer: &Arc<AnyTracer>,
        threads: usize,
    ) -> Result<Self, String> {
        if scene.frames() > 1 {
            return Err("animations are not simulated (the probe times one frame)".into());
        }
        let (w, h) = (scene.width(), scene.height());
        let mut spec = SchedulerSpec::new(
            SchedulerKind::StaticCyclic,
            Chunk::Tile { w: 1, h: 1 },
            threads.max(1),
        );
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

/// What zero-work runs of a scheduler measured: its cost per item and its fixed cost per run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZeroWork {
    /// Seconds per item: the slope between runs of n and 2n one-pixel zero-work items.
    pub per_item_s: f64,
    /// Seconds per run that do not grow with the items (threads started and joined, the
    /// results gathered): the intercept of the same two runs, ≥ 0.
    pub fixed_s: f64,
}

/// [`ZeroWork`] of `policy` on `workers` threads over one-pixel zero-work items: runs of
/// `items` and 2·`items` items, median of `reps` pairs (slope and intercept each).
pub fn zero_work(
    policy: Policy,
    items: u32,
    workers: usize,
    reps: u32,
) -> Result<ZeroWork, String> {
    let mut spec = SchedulerSpec::new(policy.kind(), Chunk::Tile { w: 1, h: 1 }, workers);
    spec.policy = policy;
    let wall = |n: u32| -> Result<(f64, usize), String> {
        let side = (n as f64).sqrt().ceil() as u32;
        let list = decompose(side, side, Chunk::Tile { w: 1, h: 1 }, Order::Scanline);
        let (_, s) = run_items(&spec, &list, nothing(), &RunOptions::default())
            .map_err(|e| e.to_string())?;
        Ok((s.wall_s, list.len()))
    };
    let pairs: Vec<(f64, f64)> = (0..reps.max(1))
        .map(|_| {
            let (a, na) = wall(items)?;
            let (b, nb) = wall(2 * items)?;
            let slope = ((b - a) / (nb - na) as f64).max(b / nb as f64 * 0.05);
            Ok((slope, (a - slope * na as f64).max(0.0)))
        })
        .collect::<Result<_, String>>()?;
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    Ok(ZeroWork {
        per_item_s: median(pairs.iter().map(|p| p.0).collect()),
        fixed_s: median(pairs.iter().map(|p| p.1).collect()),
    })
}

/// The master's cost per hand-out at `buffer` (zero-work dispatch per item) and its fixed cost.
pub fn master_zero_work(
    buffer: usize,
    items: u32,
    workers: usize,
    reps: u32,
) -> Result<ZeroWork, String> {
    let p = MasterParams {
        buffer,
        ..MasterParams::DEFAULT
    };
    zero_work(Policy::Master(p), items, workers, reps)
}

/// The shared counter's cost per grab (zero-work self-scheduling at grab 1, per item) and the
/// threaded schedulers' fixed cost per run.
pub fn counter_zero_work(items: u32, workers: usize, reps: u32) -> Result<ZeroWork, String> {
    zero_work(
        Policy::defaults(SchedulerKind::SelfScheduling),
        items,
        workers,
        reps,
    )
}
