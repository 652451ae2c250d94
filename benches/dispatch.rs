//! Scheduler costs. `dispatch/*`: a job that renders nothing, 16 384 one-pixel items on 2
//! workers, so time per element = dispatch cost per item (thread start-up included, ~3 ns/item
//! amortised). `instrumentation/*`: a real render (Cornell box 64², 1 spp) with RunStats
//! timing on vs off.
//!
//! `cargo bench --bench dispatch -- --warm-up-time 1 --measurement-time 3`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use raysched::render::{TileResult, WorkItem};
use raysched::scene::{load_scene, SceneOverrides};
use raysched::sched::{
    decompose, render_job, run_items, Chunk, Job, Order, Requeue, RunOptions, SchedulerKind,
    SchedulerSpec, Wait,
};
use raysched::tracer::AnyTracer;
use std::sync::Arc;

fn dispatch(c: &mut Criterion) {
    let items = decompose(128, 128, Chunk::Tile { w: 1, h: 1 }, Order::Scanline);
    let job: Job = Arc::new(|it: &WorkItem| TileResult {
        item: it.id,
        pixels: Vec::new(),
        rays: 0,
        nonfinite: 0,
    });
    let mut g = c.benchmark_group("dispatch");
    g.throughput(Throughput::Elements(items.len() as u64));
    g.sample_size(10);
    let mut specs: Vec<(String, SchedulerSpec)> = SchedulerKind::ALL
        .into_iter()
        .filter(|k| *k != SchedulerKind::Master)
        .map(|k| {
            (
                k.id().to_string(),
                SchedulerSpec::new(k, Chunk::Tile { w: 1, h: 1 }, 2),
            )
        })
        .collect();
    for (wait, buffer) in [(Wait::Block, 64), (Wait::Spin, 64), (Wait::Block, 2)] {
        let mut s = SchedulerSpec::new(SchedulerKind::Master, Chunk::Tile { w: 1, h: 1 }, 2);
        s.wait = wait;
        s.buffer = buffer;
        s.requeue = Requeue::Never;
        specs.push((format!("master_{}_b{buffer}", wait.id()), s));
    }
    for (name, spec) in specs {
        for stats in [true, false] {
            let opts = RunOptions {
                stats,
                ..Default::default()
            };
            let id = BenchmarkId::new(&name, if stats { "stats_on" } else { "stats_off" });
            g.bench_function(id, |b| {
                b.iter(|| run_items(&spec, &items, job.clone(), &opts).unwrap())
            });
        }
    }
    g.finish();
}

fn instrumentation(c: &mut Criterion) {
    let over = SceneOverrides {
        width: Some(64),
        height: Some(64),
        spp: Some(1),
        ..Default::default()
    };
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box.toml");
    let scene = Arc::new(load_scene(&path, &over).unwrap());
    let tracer = Arc::new(AnyTracer::build("bvh", &scene, 1).unwrap());
    let mut g = c.benchmark_group("instrumentation");
    g.sample_size(10);
    for (name, kind, chunk) in [
        (
            "self_scheduling_4x4",
            SchedulerKind::SelfScheduling,
            Chunk::Tile { w: 4, h: 4 },
        ),
        (
            "master_1px",
            SchedulerKind::Master,
            Chunk::Tile { w: 1, h: 1 },
        ),
    ] {
        let mut spec = SchedulerSpec::new(kind, chunk, 2);
        spec.buffer = 8;
        let items = decompose(64, 64, chunk, Order::Scanline);
        let job = render_job(&scene, &tracer);
        for stats in [true, false] {
            let opts = RunOptions {
                stats,
                ..Default::default()
            };
            let id = BenchmarkId::new(name, if stats { "stats_on" } else { "stats_off" });
            g.bench_function(id, |b| {
                b.iter(|| run_items(&spec, &items, job.clone(), &opts).unwrap())
            });
        }
    }
    g.finish();
}

criterion_group!(benches, dispatch, instrumentation);
criterion_main!(benches);
