//! A scene pays only for what it uses: a diffuse-only scene through the pruned and
//! the forced-full path, and brute force against a BVH on tiny scenes (the crossover behind
//! `tracer::bvh::BVH_MIN_PRIMS`). Short on purpose: `cargo bench --bench features`.
//!
//! Measured 2026-11-23 on the quiet 2-core machine (the first numbers, taken while other builds
//! ran, were 393 vs 912 µs and did not reproduce): diffuse-only `simple` 32×32×2 spp, three runs:
//! pruned 182.3 / 183.3 / 176.9 µs, forced-full 183.6 / 179.5 / 179.2 µs — no gain beyond the
//! ±2 % noise on this scene: the unused branches it prunes are well predicted.
//! Closest hit, 256 rays, brute/bvh (4-wide BVH): 1 prim 1.99/2.72 µs, 2: 2.80/2.99,
//! 4: 4.93/3.20, 8: 9.30/4.09, 16: 19.1/5.67 → the BVH pays off from 4 primitives.

#![allow(
    missing_docs,
    reason = "`criterion_group!` expands to an undocumented `pub fn`, and an attribute on the macro call is ignored"
)]

use criterion::{criterion_group, criterion_main, Criterion};
use raysched::render::{render_sums, render_sums_full, WorkItem};
use raysched::scene::{load_scene, load_scene_str, SceneOverrides};
use raysched::tracer::{BruteTracer, BvhTracer, Tracer};
use std::path::Path;
use std::time::Duration;

fn pruned_vs_full(c: &mut Criterion) {
    let o = SceneOverrides {
        width: Some(32),
        height: Some(32),
        spp: Some(2),
        ..Default::default()
    };
    let scene = load_scene(Path::new("scenes/simple.toml"), &o).unwrap();
    let tracer = BruteTracer::new(&scene.geometry);
    let item = WorkItem::rect(0, 0, 0, 32, 32);
    let mut g = c.benchmark_group("diffuse_only_simple_32x32x2");
    g.measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500));
    g.bench_function("pruned", |b| {
        b.iter(|| render_sums(&scene, &tracer, &item, 0..2))
    });
    g.bench_function("full", |b| {
        b.iter(|| render_sums_full(&scene, &tracer, &item, 0..2))
    });
    g.finish();
}

fn spheres(n: u32) -> String {
    let mut s = String::from(
        "[camera]\norigin = [0, 0, 6]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov_deg = 50\nwidth = 16\nheight = 16\n\
         [materials.grey]\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n",
    );
    for i in 0..n {
        let x = (i % 4) as f64 - 1.5;
        let y = (i / 4) as f64 - 1.5;
        s.push_str(&format!(
            "[[shapes]]\ntype = \"sphere\"\nmaterial = \"grey\"\ncenter = [{x}, {y}, 0]\nradius = 0.4\n"
        ));
    }
    s
}

fn crossover(c: &mut Criterion) {
    let mut g = c.benchmark_group("closest_hit_256_rays");
    g.measurement_time(Duration::from_secs(1))
        .warm_up_time(Duration::from_millis(200));
    for n in [1u32, 2, 4, 8, 16] {
        let scene =
            load_scene_str(&spheres(n), "s", Path::new("."), "s", &Default::default()).unwrap();
        let brute = BruteTracer::new(&scene.geometry);
        let bvh = BvhTracer::forced(&scene.geometry);
        let rays: Vec<_> = (0..256u32)
            .map(|k| {
                scene
                    .camera
                    .ray((k % 16) as f32 / 16.0, (k / 16) as f32 / 16.0)
            })
            .collect();
        g.bench_function(format!("brute/{n}"), |b| {
            b.iter(|| {
                rays.iter()
                    .filter(|r| brute.intersect(r, f32::INFINITY).is_some())
                    .count()
            })
        });
        g.bench_function(format!("bvh/{n}"), |b| {
            b.iter(|| {
                rays.iter()
                    .filter(|r| bvh.intersect(r, f32::INFINITY).is_some())
                    .count()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, pruned_vs_full, crossover);
criterion_main!(benches);
