//! The H200 run of threads + GPU under the master, re-enacted with sources that sleep instead
//! of rendering, so the hand-out policy can be studied on any machine in a second.
//!
//! Sixteen thread-like sources take a 32² tile in `--thread-ms` (the first two tile rows, the
//! Cornell box's ceiling, in a third of that), one at a time. One GPU-like source runs a
//! dispatch of n tiles in `overhead + max(serial, n × per_tile)`: a small dispatch costs about
//! as much as a large one. The defaults are the H200's numbers at 512 spp divided by ten
//! (`results/published/gpu/`: 105 µs per dispatch, 1024 tiles in 1.6 s, a
//! thread's tile 0.27 s on the ceiling rows and 0.8 s elsewhere), except `serial`, one tile
//! alone, which was not measured there: 0.2 s is assumed (one pass of a pixel's samples). Prints the wall of the GPU alone, the threads
//! alone, both without and with the balancer, and both against the sum of the separate rates.
//!
//! ```sh
//! cargo run --release --example hetero_tail -- [--thread-ms 80] [--gpu-tile-ms 0.156]
//!     [--gpu-serial-ms 20] [--threads 16] [--thread-buffer 4] [--gpu-buffer 256] [--runs 3]
//!     [--tile 32] [--gpu-grain PIXELS]
//! ```
//!
//! `--tile` sets the items' side (costs scale with their pixels); `--gpu-grain` gives the GPU
//! its own hand-out of that many pixels (`--gpu-buffer` then counts such hand-outs), as
//! `render --gpu-chunk` does.
//!
//! ```sh
//! cargo run --release --example hetero_tail -- --tile 8 --thread-buffer 2 --gpu-grain 262144 \
//!     --gpu-buffer 2
//! ```

use crossbeam::channel::Receiver;
use raysched::metrics::{Probe, SourceKind, WorkerStats};
use raysched::render::{TileResult, WorkItem};
use raysched::sched::{Hetero, MasterParams, Policy, RunOptions, RunPlan, Slow, Sources};
use raysched::source::{
    submit_one,
    thread::{pending_batch, Flags},
    Completer, ComputeSource, DelayedResult, Job, LocalThreadSource, Notifier, SourceReport,
    SourceThread,
};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The image's side in pixels; the costs are per 32² tile of it.
const IMAGE: u32 = 1024;

struct Args {
    thread_ms: f64,
    tile: u32,
    gpu_grain: u64,
    gpu_tile_ms: f64,
    gpu_serial_ms: f64,
    gpu_overhead_ms: f64,
    threads: usize,
    thread_buffer: usize,
    gpu_buffer: usize,
    runs: usize,
}

fn parse() -> Result<Args, String> {
    let mut a = Args {
        thread_ms: 80.0,
        tile: 32,
        gpu_grain: 0,
        gpu_tile_ms: 0.156,
        gpu_serial_ms: 20.0,
        gpu_overhead_ms: 0.0105,
        threads: 16,
        thread_buffer: 4,
        gpu_buffer: 256,
        runs: 3,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut val = || it.next().ok_or(format!("{flag}: needs a value"));
        let f = |v: String| v.parse::<f64>().map_err(|e| format!("{flag}: {e}"));
        let u = |v: String| v.parse::<usize>().map_err(|e| format!("{flag}: {e}"));
        match flag.as_str() {
            "--thread-ms" => a.thread_ms = f(val()?)?,
            "--tile" => a.tile = u(val()?)? as u32,
            "--gpu-grain" => a.gpu_grain = u(val()?)? as u64,
            "--gpu-tile-ms" => a.gpu_tile_ms = f(val()?)?,
            "--gpu-serial-ms" => a.gpu_serial_ms = f(val()?)?,
            "--gpu-overhead-ms" => a.gpu_overhead_ms = f(val()?)?,
            "--threads" => a.threads = u(val()?)?,
            "--thread-buffer" => a.thread_buffer = u(val()?)?,
            "--gpu-buffer" => a.gpu_buffer = u(val()?)?,
            "--runs" => a.runs = u(val()?)?,
            _ => return Err(format!("unknown flag {flag}")),
        }
    }
    if a.threads == 0 || a.thread_buffer == 0 || a.gpu_buffer == 0 || a.runs == 0 {
        return Err(
            "--threads, --thread-buffer, --gpu-buffer and --runs must be at least 1".into(),
        );
    }
    if a.tile == 0 || !IMAGE.is_multiple_of(a.tile) {
        return Err(format!("--tile: must divide {IMAGE}"));
    }
    Ok(a)
}

/// What an item costs, from its place in the image: `thread_ms` per 32² tile, a third of that
/// in the top 64 rows (the ceiling).
#[derive(Clone, Copy)]
struct Costs {
    thread_ms: f64,
    tile: u32,
}

impl Costs {
    /// The item's cost to a thread.
    fn thread(self, item: &WorkItem) -> Duration {
        let y = (item.id / (IMAGE / self.tile)) * self.tile;
        let share = item.pixel_count() as f64 / 1024.0;
        let ceiling = if y < 64 { 1.0 / 3.0 } else { 1.0 };
        Duration::from_secs_f64(self.thread_ms * share * ceiling / 1e3)
    }

    /// The item's result: black pixels, rays in proportion to its cost (1 000 per thread-ms).
    fn result(self, item: &WorkItem) -> TileResult {
        TileResult {
            item: item.id,
            pixels: smallvec::smallvec![[0.0; 3]; item.pixel_count()],
            rays: (self.thread(item).as_secs_f64() * 1e6) as u64,
            nonfinite: 0,
        }
    }
}

/// A source that runs each hand-out as one dispatch of `overhead + max(serial, n × per_tile)`,
/// n in 32² tiles' worth of pixels.
struct GpuLike {
    id: u32,
    thread: SourceThread<Vec<(WorkItem, Completer)>>,
}

impl GpuLike {
    fn spawn(id: u32, a: &Args, costs: Costs) -> Self {
        let (tile_s, serial_s, overhead_s) = (
            a.gpu_tile_ms / 1e3,
            a.gpu_serial_ms / 1e3,
            a.gpu_overhead_ms / 1e3,
        );
        let serve = move |fl: &Flags, rx: &Receiver<Vec<(WorkItem, Completer)>>| {
            let mut stats = WorkerStats {
                source: Some(SourceKind::Gpu),
                ..Default::default()
            };
            for batch in rx.iter() {
                if fl.cancelled() {
                    break;
                }
                let t = Instant::now();
                let n = batch.len() as u64;
                let tiles =
                    batch.iter().map(|(it, _)| it.pixel_count()).sum::<usize>() as f64 / 1024.0;
                std::thread::sleep(Duration::from_secs_f64(
                    overhead_s + serial_s.max(tiles * tile_s),
                ));
                for (item, done) in batch {
                    let r = costs.result(&item);
                    stats.count(&item, r.rays);
                    done.complete(Ok(r));
                }
                stats.busy_s += t.elapsed().as_secs_f64();
                fl.items_finished(n);
                fl.ring();
            }
            SourceReport {
                stats,
                ..Default::default()
            }
        };
        Self {
            id,
            thread: SourceThread::spawn(format!("gpu-like-{id}"), serve),
        }
    }
}

impl ComputeSource for GpuLike {
    fn id(&self) -> u32 {
        self.id
    }
    fn label(&self) -> String {
        format!("gpu-like-{}", self.id)
    }
    fn submit(&mut self, item: WorkItem) -> DelayedResult {
        submit_one(self, item)
    }
    fn submit_batch(&mut self, items: &mut Vec<WorkItem>, out: &mut Vec<DelayedResult>) {
        self.thread.send(pending_batch(items, self.id, out));
    }
    fn runs_hand_outs_whole(&self) -> bool {
        true
    }
    fn set_notifier(&mut self, notifier: Notifier) {
        self.thread.set_notifier(notifier);
    }
    fn is_lost(&self) -> bool {
        self.thread.is_lost()
    }
    fn finish(mut self: Box<Self>) -> SourceReport {
        self.thread.finish()
    }
}

/// One run: wall seconds and, per source kind, (kind, items, the longest busy seconds of one
/// source of that kind).
fn run(a: &Args, threads: usize, gpu: bool, balance: bool) -> (f64, Vec<(String, u64, f64)>) {
    let (t, grid) = (a.tile, IMAGE / a.tile);
    let items: Vec<WorkItem> = (0..grid * grid)
        .map(|i| WorkItem::rect(i, (i % grid) * t, (i / grid) * t, t, t))
        .collect();
    let probe = Probe::new(true, false);
    let costs = Costs {
        thread_ms: a.thread_ms,
        tile: a.tile,
    };
    let job: Job = Arc::new(move |it: &WorkItem| {
        std::thread::sleep(costs.thread(it));
        costs.result(it)
    });
    let mut sources: Vec<Box<dyn ComputeSource>> = (0..threads)
        .map(|k| {
            Box::new(LocalThreadSource::spawn(k as u32, job.clone(), probe))
                as Box<dyn ComputeSource>
        })
        .collect();
    let mut buffers = vec![a.thread_buffer; threads];
    if gpu {
        sources.push(Box::new(GpuLike::spawn(threads as u32, a, costs)));
        buffers.push(a.gpu_buffer);
    }
    let mut grains = vec![0; threads];
    grains.push(a.gpu_grain);
    let hetero = Hetero {
        buffers,
        grains,
        balance,
    };
    let params = MasterParams {
        buffer: a.thread_buffer,
        ..Default::default()
    };
    let t = Instant::now();
    let plan = RunPlan {
        scheduler: &Policy::Master(params),
        slow: Slow::NONE,
        opts: &RunOptions::default(),
        probe,
    };
    let (_, stats) = raysched::sched::run(&plan, &items, Sources::Boxed(sources, hetero))
        .unwrap_or_else(|e| {
            eprintln!("error: {e}");
            std::process::exit(1)
        });
    let wall = t.elapsed().as_secs_f64();
    let mut kinds: Vec<(String, u64, f64)> = Vec::new();
    for w in &stats.workers {
        let kind = w.source.unwrap_or(SourceKind::Threads).id();
        match kinds.iter_mut().find(|k| k.0 == kind) {
            Some(k) => {
                k.1 += w.items;
                k.2 = k.2.max(w.busy_s);
            }
            None => kinds.push((kind.to_string(), w.items, w.busy_s)),
        }
    }
    (wall, kinds)
}

fn main() {
    let a = parse().unwrap_or_else(|e| {
        eprintln!("error: {e}");
        std::process::exit(2)
    });
    println!("pass,gpu_s,threads_s,unbalanced_s,balanced_s,unbalanced_of_sum,balanced_of_sum");
    for pass in 1..=a.runs {
        let (g, _) = run(&a, 0, true, false);
        let (c, _) = run(&a, a.threads, false, false);
        let (u, uk) = run(&a, a.threads, true, false);
        let (b, bk) = run(&a, a.threads, true, true);
        // Against the sum of the rates: 1/wall each, the same work.
        let sum = 1.0 / g + 1.0 / c;
        println!(
            "{pass},{g:.4},{c:.4},{u:.4},{b:.4},{:.3},{:.3}",
            (1.0 / u) / sum,
            (1.0 / b) / sum
        );
        eprintln!("  unbalanced (kind, items, longest busy s): {uk:?}");
        eprintln!("  balanced: {bk:?}");
    }
}
