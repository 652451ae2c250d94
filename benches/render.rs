//! Cornell box 128², max_depth 8, one thread: CPU milliseconds per sample per pixel (one
//! iteration = one full-image pass at 1 spp). Issue target: ≤ 9 ms per spp on one core.

#![allow(
    missing_docs,
    reason = "`criterion_group!` expands to an undocumented `pub fn`, and an attribute on the macro call is ignored"
)]

use criterion::{criterion_group, criterion_main, Criterion};
use raysched::render::render_serial;
use raysched::scene::{load_scene, SceneOverrides};
use raysched::tracer::{AnyTracer, TracerKind};
use std::path::Path;

fn cornell_ms_per_spp(c: &mut Criterion) {
    let scene = load_scene(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box.toml"),
        &SceneOverrides {
            spp: Some(1),
            ..Default::default()
        },
    )
    .unwrap();
    let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
    let mut g = c.benchmark_group("cornell_128_depth8");
    g.sample_size(20);
    g.bench_function("bvh_1spp_1thread", |b| {
        b.iter(|| render_serial(&scene, &tracer))
    });
    g.finish();
}

criterion_group!(benches, cornell_ms_per_spp);
criterion_main!(benches);
