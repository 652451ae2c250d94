//! Dispatch cost per item, per scheduler (issue 4 targets: `master` ≤ 150 ns, `self_scheduling`
//! ≤ 20 ns per item).
//!
//! The job renders nothing (it returns an empty `TileResult`), so all the time is the
//! scheduler's. One iteration runs 2¹⁸ = 262 144 one-pixel items (a 512² image in 1×1 tiles)
//! on 2 workers, thread start-up and the final merge of results included; criterion reports
//! time per element = wall time of one run / 2¹⁸ = **ns per item** (wall-clock, with 2 workers
//! running at once, so two items in flight). The fixed cost of a run (spawning and joining the
//! threads, allocating the result slots) is measured on its own by `dispatch_fixed/*` (the same
//! run with 8 items): ~100–200 µs, i.e. < 1 ns per item at 2¹⁸ items, so the numbers are the
//! steady-state cost of handing items out. `stats_on`/`stats_off` toggles `RunOptions::stats`
//! (per-item clocks); the difference is the instrumentation's cost per item.
//!
//! `cargo bench --bench dispatch` (~45 s)
//! `cargo bench --bench dispatch -- self_scheduling` for one scheduler

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use raysched::render::{TileResult, WorkItem};
use raysched::sched::{
    decompose, run_items, Chunk, Job, Order, Requeue, RunOptions, SchedulerKind, SchedulerSpec,
    Wait,
};
use std::sync::Arc;
use std::time::Duration;

/// 512 × 512 one-pixel items.
const SIDE: u32 = 512;

fn nothing() -> Job {
    Arc::new(|it: &WorkItem| TileResult {
        item: it.id,
        pixels: Vec::new(),
        rays: 0,
        nonfinite: 0,
    })
}

/// Every scheduler at grab 1 and the master in three settings (blocking B = 64 is the one the
/// issue's target refers to).
fn specs() -> Vec<(String, SchedulerSpec)> {
    let px = Chunk::Tile { w: 1, h: 1 };
    let mut specs: Vec<(String, SchedulerSpec)> = SchedulerKind::ALL
        .into_iter()
        .filter(|k| *k != SchedulerKind::Master)
        .map(|k| (k.id().to_string(), SchedulerSpec::new(k, px, 2)))
        .collect();
    for (wait, buffer) in [(Wait::Block, 64), (Wait::Spin, 64), (Wait::Block, 2)] {
        let mut s = SchedulerSpec::new(SchedulerKind::Master, px, 2);
        s.wait = wait;
        s.buffer = buffer;
        s.requeue = Requeue::Never;
        specs.push((format!("master_{}_b{buffer}", wait.id()), s));
    }
    specs
}

fn run_group(c: &mut Criterion, group: &str, items: &[WorkItem], stats_both: bool) {
    let job = nothing();
    let mut g = c.benchmark_group(group);
    g.throughput(Throughput::Elements(items.len() as u64));
    g.sample_size(10);
    g.warm_up_time(Duration::from_millis(300));
    g.measurement_time(Duration::from_millis(1500));
    for (name, spec) in specs() {
        for stats in if stats_both {
            &[true, false][..]
        } else {
            &[true][..]
        } {
            let opts = RunOptions {
                stats: *stats,
                ..Default::default()
            };
            let id = BenchmarkId::new(&name, if *stats { "stats_on" } else { "stats_off" });
            g.bench_function(id, |b| {
                b.iter(|| run_items(&spec, items, job.clone(), &opts).unwrap())
            });
        }
    }
    g.finish();
}

fn dispatch(c: &mut Criterion) {
    let items = decompose(SIDE, SIDE, Chunk::Tile { w: 1, h: 1 }, Order::Scanline);
    assert_eq!(items.len(), 1 << 18);
    run_group(c, "dispatch", &items, true);
}

fn dispatch_fixed(c: &mut Criterion) {
    let items = decompose(4, 2, Chunk::Tile { w: 1, h: 1 }, Order::Scanline);
    run_group(c, "dispatch_fixed", &items, false);
}

criterion_group!(benches, dispatch, dispatch_fixed);
criterion_main!(benches);
