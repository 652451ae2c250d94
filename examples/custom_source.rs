//! A researcher's own compute source, written outside the crate: a remote machine seen
//! through a network with a fixed one-way delay. Each item travels `delay` before its own
//! thread renders it; the result travels back at once (a fixed delay each way would only
//! double the constant).
//!
//! It implements [`ComputeSource`] with the crate's public parts ([`DelayedResult::pending`],
//! its [`Completer`], the master's [`Notifier`]) and joins a run beside the crate's own
//! sources through [`run`]'s [`Sources::Boxed`]: the master and every rule a source can play
//! hand out to it. `tests/it/extension.rs` checks the image is the serial one bit for bit.
//!
//! ```sh
//! cargo run --release --example custom_source
//! ```

use crossbeam::channel::{unbounded, Sender};
use raysched::metrics::{Probe, RunStats, WorkerStats};
use raysched::render::{Image, WorkItem};
use raysched::scene::Scene;
use raysched::sched::rule::Scheduler;
use raysched::sched::{
    assemble, decompose, render_job, run, Chunk, Hetero, Order, RunOptions, RunPlan, Slow, Sources,
};
use raysched::source::{
    Completer, ComputeSource, DelayedResult, Job, LocalThreadSource, Notifier, SourceReport,
};
use raysched::tracer::BvhTracer;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// What travels to the remote side: the item, its result's completer and when it left.
type Message = (WorkItem, Completer, Instant);

/// A source behind a network of fixed one-way `delay`.
pub struct NetworkSource {
    id: u32,
    to_remote: Option<Sender<Message>>,
    remote: Option<JoinHandle<WorkerStats>>,
    notifier: Arc<Mutex<Option<Notifier>>>,
}

impl NetworkSource {
    /// Start source `id`, whose remote thread runs `job` on each item `delay` after it was sent.
    pub fn spawn(id: u32, job: Job, delay: Duration) -> Self {
        let (tx, rx) = unbounded::<Message>();
        let notifier: Arc<Mutex<Option<Notifier>>> = Arc::default();
        let ring = Arc::clone(&notifier);
        let remote = std::thread::spawn(move || {
            let mut stats = WorkerStats::default();
            for (item, done, sent) in rx {
                std::thread::sleep((sent + delay).saturating_duration_since(Instant::now()));
                let t0 = Instant::now();
                let r = job(&item);
                stats.busy_s += t0.elapsed().as_secs_f64();
                stats.count(&item, r.rays);
                done.complete(Ok(r));
                if let Some(n) = ring.lock().unwrap_or_else(|p| p.into_inner()).as_ref() {
                    n.ring();
                }
            }
            stats
        });
        Self {
            id,
            to_remote: Some(tx),
            remote: Some(remote),
            notifier,
        }
    }
}

impl ComputeSource for NetworkSource {
    fn id(&self) -> u32 {
        self.id
    }

    fn label(&self) -> String {
        format!("network-{}", self.id)
    }

    fn submit(&mut self, item: WorkItem) -> DelayedResult {
        let (result, done) = DelayedResult::pending(item.id, self.id);
        if let Some(tx) = &self.to_remote {
            // A send fails only once the remote thread is gone: the dropped completer then
            // fails the result as lost, which is what the master must see.
            let _ = tx.send((item, done, Instant::now()));
        }
        result
    }

    fn is_lost(&self) -> bool {
        self.remote.as_ref().is_none_or(|r| r.is_finished())
    }

    fn set_notifier(&mut self, notifier: Notifier) {
        *self.notifier.lock().unwrap_or_else(|p| p.into_inner()) = Some(notifier);
    }

    fn finish(mut self: Box<Self>) -> SourceReport {
        drop(self.to_remote.take());
        let stats = self.remote.take().map(|r| r.join()).and_then(Result::ok);
        SourceReport {
            lost: stats.is_none(),
            stats: stats.unwrap_or_default(),
            spans: Vec::new(),
        }
    }
}

/// Render `scene` in 8×8 tiles under `scheduler` on `threads` local thread sources and
/// `remote` network sources of one-way `delay`, in that order.
pub fn render_mixed(
    scheduler: &dyn Scheduler,
    (threads, remote, delay): (usize, usize, Duration),
    scene: &Arc<Scene>,
    tracer: &Arc<BvhTracer>,
) -> (Image, RunStats) {
    let (w, h) = (scene.width(), scene.height());
    let items = decompose(w, h, Chunk::Tile { w: 8, h: 8 }, Order::Scanline);
    let job = render_job(scene, tracer);
    let probe = Probe::new(true, false);
    let mut sources: Vec<Box<dyn ComputeSource>> = Vec::new();
    for _ in 0..threads {
        let id = sources.len() as u32;
        sources.push(Box::new(LocalThreadSource::spawn(id, job.clone(), probe)));
    }
    for _ in 0..remote {
        let id = sources.len() as u32;
        sources.push(Box::new(NetworkSource::spawn(id, job.clone(), delay)));
    }
    let opts = RunOptions::default();
    let plan = RunPlan {
        scheduler,
        slow: Slow::NONE,
        opts: &opts,
        probe,
    };
    let (results, stats) =
        run(&plan, &items, Sources::Boxed(sources, Hetero::default())).expect("the run completes");
    (assemble(w, h, &items, &results).expect("every item"), stats)
}

#[allow(dead_code)]
fn main() {
    use raysched::scene::{load_scene, SceneOverrides};
    use raysched::sched::{Policy, SchedulerKind};
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box.toml");
    let o = SceneOverrides {
        width: Some(64),
        height: Some(64),
        spp: Some(4),
        ..Default::default()
    };
    let scene = Arc::new(load_scene(&path, &o).expect("scenes/cornell_box.toml loads"));
    let tracer = Arc::new(BvhTracer::new(&scene.geometry));
    let delay = Duration::from_millis(2);
    for kind in [SchedulerKind::Master, SchedulerKind::SelfScheduling] {
        let policy = Policy::defaults(kind);
        let (image, stats) = render_mixed(&policy, (1, 1, delay), &scene, &tracer);
        let per_source: Vec<u64> = stats.workers.iter().map(|w| w.items).collect();
        println!(
            "{}: 1 thread + 1 network source ({} ms each way): wall {:.3} s, items per source \
             {per_source:?}, image hash {:016x}",
            policy.id(),
            delay.as_millis(),
            stats.wall_s,
            image.hash()
        );
    }
}
