//! Tracer throughput and build time: `bvh` vs `embree` (and `brute` on the small scene), 1 and 2
//! threads, on scenes/complex.toml (1 M triangles; `RAYSCHED_BENCH_COUNT` overrides the count)
//! and scenes/simple.toml. Rays: one primary ray per pixel centre of a 256² image; the ray rate
//! is criterion's throughput (elements = rays). Build times are printed once per tracer.
//!
//! `cargo bench --bench tracers --features embree`; without the feature only bvh/brute run.

#![allow(
    missing_docs,
    reason = "`criterion_group!` expands to an undocumented `pub fn`, and an attribute on the macro call is ignored"
)]

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rayon::prelude::*;
use raysched::geometry::Ray;
use raysched::scene::{load_scene, Scene, SceneOverrides};
use raysched::tracer::{AnyTracer, Tracer, TracerKind};
use raysched::util::host::os_thread_count;
use std::path::Path;
use std::time::{Duration, Instant};

const SIDE: u32 = 256;

fn primary_rays(scene: &Scene) -> Vec<Ray> {
    let cam = scene.camera;
    (0..SIDE * SIDE)
        .map(|i| cam.pixel_ray(i % SIDE, i / SIDE, 0.5, 0.5))
        .collect()
}

fn load(name: &str, count: Option<u64>) -> Scene {
    let o = SceneOverrides {
        width: Some(SIDE),
        height: Some(SIDE),
        generator_count: count,
        ..Default::default()
    };
    load_scene(Path::new(&format!("scenes/{name}.toml")), &o).expect("scene")
}

fn trace_all(tracer: &AnyTracer, rays: &[Ray], pool: &rayon::ThreadPool) -> usize {
    pool.install(|| {
        rays.par_chunks(256)
            .map(|c| {
                c.iter()
                    .filter(|r| tracer.intersect(r, f32::INFINITY).is_some())
                    .count()
            })
            .sum()
    })
}

fn bench_scene(c: &mut Criterion, name: &str, count: Option<u64>, kinds: &[TracerKind]) {
    let scene = load(name, count);
    let rays = primary_rays(&scene);
    let mut group = c.benchmark_group(format!("trace/{name}"));
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .throughput(Throughput::Elements(rays.len() as u64));
    for &kind in kinds {
        if !kind.compiled_in() {
            continue;
        }
        let id = kind.id();
        for threads in [1, 2] {
            let t0 = Instant::now();
            let tracer = AnyTracer::build(kind, &scene, threads).expect("tracer");
            eprintln!(
                "build {name} ({} prims) {id} threads={threads}: {:.3} s, OS threads after build {:?}",
                scene.geometry.len(),
                t0.elapsed().as_secs_f64(),
                os_thread_count()
            );
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let hits = trace_all(&tracer, &rays, &pool);
            group.bench_with_input(BenchmarkId::new(id, threads), &threads, |b, _| {
                b.iter(|| assert_eq!(trace_all(&tracer, &rays, &pool), hits))
            });
        }
    }
    group.finish();
}

fn tracers(c: &mut Criterion) {
    let count = std::env::var("RAYSCHED_BENCH_COUNT")
        .ok()
        .and_then(|v| v.parse().ok());
    bench_scene(
        c,
        "simple",
        None,
        &[TracerKind::Bvh, TracerKind::Embree, TracerKind::Brute],
    );
    bench_scene(
        c,
        "complex",
        Some(count.unwrap_or(1_000_000)),
        &[TracerKind::Bvh, TracerKind::Embree],
    );
}

criterion_group!(benches, tracers);
criterion_main!(benches);
