//! Cornell box 128², max_depth 8, one thread: CPU milliseconds per sample per pixel (one
//! iteration = one full-image pass at 1 spp). Issue target: ≤ 9 ms per spp on one core.
//!
//! `item_cost`: what one work item costs beyond its pixels. skewed_low at 1 spp (three
//! quarters open sky, so a pixel is cheap and the per-item part shows), every pixel rendered
//! once as a one-pixel item and once in rows of 128, one thread; c = (pixels − rows) / (16 384
//! − 128) items. Three more one-pixel runs split what a run adds: `kept` holds every result in
//! a reserved list, as a run's worker does (its allocations stay live), `scatter_kept` also
//! takes the pixels in stratified order (`--order scatter`, the factoring family's default) and
//! `scatter_blocks_kept` in stratified 4² blocks (`--order scatter_blocks`).

#![allow(
    missing_docs,
    reason = "`criterion_group!` expands to an undocumented `pub fn`, and an attribute on the macro call is ignored"
)]

use criterion::{criterion_group, criterion_main, Criterion};
use raysched::render::{render_item, render_serial, WorkItem};
use raysched::scene::{load_scene, Scene, SceneOverrides};
use raysched::sched::decompose;
use raysched::sched::param::{Chunk, Order};
use raysched::tracer::{AnyTracer, TracerKind};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

fn scene_1spp(name: &str) -> Scene {
    load_scene(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join(name),
        &SceneOverrides {
            spp: Some(1),
            ..Default::default()
        },
    )
    .unwrap()
}

fn cornell_ms_per_spp(c: &mut Criterion) {
    let scene = scene_1spp("scenes/cornell_box.toml");
    let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
    let mut g = c.benchmark_group("cornell_128_depth8");
    g.sample_size(20);
    g.bench_function("bvh_1spp_1thread", |b| {
        b.iter(|| render_serial(&scene, &tracer))
    });
    g.finish();
}

fn item_cost(c: &mut Criterion) {
    let scene = scene_1spp("scenes/skewed_low.toml");
    let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
    let (w, h) = (scene.width(), scene.height());
    let mut g = c.benchmark_group("item_cost");
    g.sample_size(30)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    g.bench_function("skewed_low_1spp_pixel_items", |b| {
        b.iter(|| {
            let mut rays = 0;
            for y in 0..h {
                for x in 0..w {
                    let item = WorkItem::rect(y * w + x, x, y, 1, 1);
                    rays += black_box(render_item(&scene, &tracer, &item)).rays;
                }
            }
            rays
        })
    });
    for (name, order) in [
        ("skewed_low_1spp_pixel_items_kept", Order::Scanline),
        ("skewed_low_1spp_pixel_items_scatter_kept", Order::Scatter),
        (
            "skewed_low_1spp_pixel_items_scatter_blocks_kept",
            Order::ScatterBlocks,
        ),
    ] {
        let items = decompose(w, h, Chunk::Tile { w: 1, h: 1 }, order);
        g.bench_function(name, |b| {
            // Dropped outside the timing, as a run frees its results after its wall time.
            b.iter_with_large_drop(|| {
                let mut kept = Vec::with_capacity(items.len());
                for item in &items {
                    kept.push(render_item(&scene, &tracer, item));
                }
                kept
            })
        });
    }
    g.bench_function("skewed_low_1spp_row_items", |b| {
        b.iter(|| {
            let mut rays = 0;
            for y in 0..h {
                let item = WorkItem::rect(y, 0, y, w, 1);
                rays += black_box(render_item(&scene, &tracer, &item)).rays;
            }
            rays
        })
    });
    g.finish();
}

criterion_group!(benches, cornell_ms_per_spp, item_cost);
criterion_main!(benches);
