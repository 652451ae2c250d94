//! A new rule *shape*, written outside the crate: a two-level pool. Workers form groups of
//! `group`; a group takes a chunk of the items left (a share over the groups), and its workers
//! take their hand-outs from their group's chunk (a share over the group's workers) until it
//! is used up, when the next of them takes the group's next chunk. Contention for the shared
//! pool is per group, not per worker (as a node of a cluster would take work for its cores).
//!
//! The shape implements [`Dispense`], the pool protocol every executor drives; the scheduler
//! returns it as [`WorkerRule::Dispense`]. Nothing under `src/` changes: local threads, the
//! thread that hands out to compute sources, the cost model and the SimGrid simulation play it
//! (`tests/it/extension.rs` checks each, the images bit for bit).
//!
//! ```sh
//! cargo run --release --example two_level_pool
//! ```

use raysched::render::Image;
use raysched::scene::{load_scene, SceneOverrides};
use raysched::sched::rule::{Dispense, HandOut, Report, Scheduler, WorkerRule};
use raysched::sched::{
    assemble, decompose, render_job, run, Chunk, Order, RunOptions, RunPlan, Slow, Sources,
};
use raysched::tracer::BvhTracer;
use std::ops::Range;
use std::path::Path;
use std::sync::Arc;

/// Groups of `group` workers share a chunk of the pool.
#[derive(Clone, Copy, Debug)]
pub struct TwoLevel {
    /// Workers per group (the last group may be smaller).
    pub group: usize,
}

/// The pool's state: what is left of the items, and what is left of each group's chunk.
pub struct TwoLevelPool {
    /// The next item of the shared pool, and its end.
    next: usize,
    n: usize,
    group: usize,
    /// What is left of each group's current chunk.
    local: Vec<Range<usize>>,
    /// Workers in each group.
    members: Vec<usize>,
}

impl TwoLevelPool {
    /// `n` items over `workers` workers in groups of `group`.
    pub fn new(n: usize, workers: usize, group: usize) -> Self {
        let (w, g) = (workers.max(1), group.max(1));
        let groups = w.div_ceil(g);
        Self {
            next: 0,
            n,
            group: g,
            local: vec![0..0; groups],
            members: (0..groups).map(|k| g.min(w - k * g)).collect(),
        }
    }
}

impl Dispense for TwoLevelPool {
    fn grant(&mut self, worker: usize, _report: Option<&Report>) -> Option<Range<usize>> {
        let k = (worker / self.group).min(self.local.len() - 1);
        if self.local[k].is_empty() {
            // The group's next chunk: half of its share of what is left, at least one item
            // per member (factoring over the groups).
            let left = self.n - self.next;
            if left == 0 {
                return None;
            }
            let groups = self.local.len();
            let c = left.div_ceil(2 * groups).max(self.members[k]).min(left);
            self.local[k] = self.next..self.next + c;
            self.next += c;
        }
        // The worker's hand-out: half of its share of the group's chunk, at least one item.
        let r = &mut self.local[k];
        let c = r.len().div_ceil(2 * self.members[k]).max(1);
        let out = r.start..r.start + c;
        r.start += c;
        Some(out)
    }
}

impl Scheduler for TwoLevel {
    fn id(&self) -> String {
        format!("two_level:{}", self.group)
    }

    fn hand_out(&self, n: usize, workers: usize, _slow: Slow) -> HandOut {
        HandOut::ByWorkers(WorkerRule::Dispense(Box::new(TwoLevelPool::new(
            n, workers, self.group,
        ))))
    }
}

/// The Cornell box at 64² and 4 spp in 4×4 tiles under `scheduler` on `workers` threads.
#[allow(dead_code)]
fn render_cornell(scheduler: &dyn Scheduler, workers: usize) -> Image {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box.toml");
    let o = SceneOverrides {
        width: Some(64),
        height: Some(64),
        spp: Some(4),
        ..Default::default()
    };
    let scene = Arc::new(load_scene(&path, &o).expect("scenes/cornell_box.toml loads"));
    let tracer = Arc::new(BvhTracer::new(&scene.geometry));
    let items = decompose(64, 64, Chunk::Tile { w: 4, h: 4 }, Order::Scanline);
    let job = render_job(&scene, &tracer);
    let opts = RunOptions::default();
    let plan = RunPlan {
        scheduler,
        slow: Slow::NONE,
        opts: &opts,
        probe: raysched::metrics::Probe::new(false, false),
    };
    let (results, _) = run(&plan, &items, Sources::Threads(vec![job; workers])).expect("runs");
    assemble(64, 64, &items, &results).expect("every item")
}

#[allow(dead_code)]
fn main() {
    let two = TwoLevel { group: 2 };
    let serial = render_cornell(&two, 1);
    let image = render_cornell(&two, 4);
    println!(
        "{} on 4 threads: image hash {:016x} ({})",
        two.id(),
        image.hash(),
        if image.hash() == serial.hash() {
            "the serial image, bit for bit"
        } else {
            "DIFFERS from the serial image"
        }
    );
}
