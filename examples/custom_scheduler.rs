//! A researcher's own scheduler, written outside the crate: each hand-out is a fixed fraction
//! of the items left (at least `min`), a one-parameter cousin of guided self-scheduling.
//!
//! The rule implements [`ChunkRule`]; the scheduler implements [`Scheduler`] by returning it
//! as a pool rule. Nothing under `src/` changes: [`run`] plays it on local threads (the workers
//! take their own chunks) and over compute sources (this thread hands the chunks out), the
//! cost model predicts it (`model::predict_with`) and the SimGrid simulation plays it
//! (`simgrid::simulate_with`, feature `simgrid`). `tests/it/extension.rs` checks all four.
//!
//! ```sh
//! cargo run --release --example custom_scheduler
//! ```

use raysched::metrics::{Probe, RunStats};
use raysched::model::{predict_with, Overheads, Prediction, Workload};
use raysched::render::Image;
use raysched::scene::{load_scene, Scene, SceneOverrides};
use raysched::sched::rule::{ChunkRule, HandOut, Pool, Scheduler, WorkerRule};
use raysched::sched::{
    assemble, decompose, render_job, run, Chunk, Hetero, Order, RunOptions, RunPlan, Slow, Sources,
};
use raysched::source::{ComputeSource, LocalThreadSource};
use raysched::tracer::BvhTracer;
use std::path::Path;
use std::sync::Arc;

/// Hand out `fraction` of what is left, never fewer than `min` items.
#[derive(Clone, Copy, Debug)]
pub struct Fraction {
    /// The share of the items left that one hand-out takes (0 < fraction ≤ 1).
    pub fraction: f64,
    /// The smallest hand-out.
    pub min: usize,
}

/// The rule itself: pure arithmetic on the items left, no state, no clock.
struct FractionRule(Fraction);

impl ChunkRule for FractionRule {
    fn next(&mut self, _worker: usize, remaining: usize) -> usize {
        ((remaining as f64 * self.0.fraction).ceil() as usize).max(self.0.min)
    }
}

impl Scheduler for Fraction {
    fn id(&self) -> String {
        format!("fraction:{}", self.fraction)
    }

    fn hand_out(&self, _n: usize, _workers: usize, _slow: Slow) -> HandOut {
        HandOut::ByWorkers(WorkerRule::Pool(Pool::new(Box::new(FractionRule(*self)))))
    }
}

/// Where a run's items go.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum On {
    /// Local threads that take their own chunks.
    Threads,
    /// Thread sources behind the source interface, handed their chunks by this thread.
    Sources,
}

/// The Cornell box at `side`² and `spp`, from the repository's scenes.
pub fn cornell(side: u32, spp: u32) -> (Arc<Scene>, Arc<BvhTracer>) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box.toml");
    let o = SceneOverrides {
        width: Some(side),
        height: Some(side),
        spp: Some(spp),
        ..Default::default()
    };
    let scene = Arc::new(load_scene(&path, &o).expect("scenes/cornell_box.toml loads"));
    let tracer = Arc::new(BvhTracer::new(&scene.geometry));
    (scene, tracer)
}

/// Render `scene` in 4×4 tiles under `scheduler` on `workers` workers, `on` threads or sources.
pub fn render(
    scheduler: &dyn Scheduler,
    on: On,
    workers: usize,
    scene: &Arc<Scene>,
    tracer: &Arc<BvhTracer>,
) -> (Image, RunStats) {
    let (w, h) = (scene.width(), scene.height());
    let items = decompose(w, h, Chunk::Tile { w: 4, h: 4 }, Order::Scanline);
    let job = render_job(scene, tracer);
    let probe = Probe::new(true, false);
    let sources = match on {
        On::Threads => Sources::Threads(vec![job; workers]),
        On::Sources => Sources::Boxed(
            (0..workers as u32)
                .map(|id| {
                    Box::new(LocalThreadSource::spawn(id, job.clone(), probe))
                        as Box<dyn ComputeSource>
                })
                .collect(),
            Hetero::default(),
        ),
    };
    let opts = RunOptions::default();
    let plan = RunPlan {
        scheduler,
        slow: Slow::NONE,
        opts: &opts,
        probe,
    };
    let (results, stats) = run(&plan, &items, sources).expect("the run completes");
    (assemble(w, h, &items, &results).expect("every item"), stats)
}

/// The cost model's prediction of `scheduler` over `items` equal items of `item_s` seconds.
pub fn predict(scheduler: &dyn Scheduler, workers: usize, items: usize, item_s: f64) -> Prediction {
    let cost = vec![item_s; items];
    let work = Workload {
        item_s: &cost,
        noise_cv: 0.0,
        per_item_s: 0.0,
    };
    let o = Overheads {
        per_item_s: 1e-6,
        fixed_s: 0.0,
        refill_s: 0.0,
    };
    predict_with(scheduler, workers, Slow::NONE, &work, &o)
}

#[allow(dead_code)]
fn main() {
    let (scene, tracer) = cornell(64, 4);
    let fraction = Fraction {
        fraction: 0.25,
        min: 2,
    };
    let (serial, _) = render(&fraction, On::Threads, 1, &scene, &tracer);
    for on in [On::Threads, On::Sources] {
        let (image, stats) = render(&fraction, on, 2, &scene, &tracer);
        println!(
            "{} on {on:?}: wall {:.3} s, {} items, image hash {:016x} ({})",
            fraction.id(),
            stats.wall_s,
            stats.items,
            image.hash(),
            if image.hash() == serial.hash() {
                "the serial image, bit for bit"
            } else {
                "DIFFERS from the serial image"
            }
        );
    }
    let p = predict(&fraction, 2, 256, 1e-4);
    println!(
        "model: 256 items of 0.1 ms on 2 workers: wall {:.2} ms, imbalance {:.3} ms",
        p.wall_s * 1e3,
        p.imbalance_s * 1e3
    );
}
