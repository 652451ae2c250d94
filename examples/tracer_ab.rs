//! Interleaved A/B of tracers on one scene: primary rays through every pixel centre, each
//! tracer timed in turn for `rounds` rounds on one thread; prints the best and median ray rate.
//! The best of interleaved rounds is what survives a loaded machine.
//!
//! `cargo run --release --features embree --example tracer_ab -- complex 1000000 256 9 bvh embree`

use raysched::geometry::Ray;
use raysched::scene::{load_scene, SceneOverrides};
use raysched::tracer::{AnyTracer, Tracer, TracerKind};
use std::path::Path;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().map_or("complex", |s| s.as_str());
    let count: u64 = args
        .get(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let side: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(256);
    let rounds: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(9);
    let ids: Vec<&str> = if args.len() > 4 {
        args[4..].iter().map(|s| s.as_str()).collect()
    } else {
        vec!["bvh", "embree"]
    };
    let o = SceneOverrides {
        width: Some(side),
        height: Some(side),
        generator_count: Some(count),
        ..Default::default()
    };
    let scene = match load_scene(Path::new(&format!("scenes/{name}.toml")), &o) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    let rays: Vec<Ray> = (0..side * side)
        .map(|i| scene.camera.pixel_ray(i % side, i / side, 0.5, 0.5))
        .collect();
    let tracers: Vec<AnyTracer> = ids
        .iter()
        .map(|id| {
            let t0 = Instant::now();
            let t = TracerKind::from_id(id)
                .and_then(|kind| AnyTracer::build(kind, &scene, 1))
                .unwrap_or_else(|e| {
                    eprintln!("{e}");
                    std::process::exit(2)
                });
            println!("build {id}: {:.3} s", t0.elapsed().as_secs_f64());
            t
        })
        .collect();
    let mut times = vec![Vec::new(); tracers.len()];
    let mut hits = vec![0usize; tracers.len()];
    for _ in 0..rounds {
        for (k, t) in tracers.iter().enumerate() {
            let t0 = Instant::now();
            hits[k] = rays
                .iter()
                .filter(|r| t.intersect(r, f32::INFINITY).is_some())
                .count();
            times[k].push(t0.elapsed().as_secs_f64());
        }
    }
    for (k, id) in ids.iter().enumerate() {
        let mut v = times[k].clone();
        v.sort_by(f64::total_cmp);
        let rate = |s: f64| rays.len() as f64 / s / 1e6;
        println!(
            "{name} {} prims, {side}², {id}: best {:.2} Mrays/s, median {:.2} ({} hits)",
            scene.geometry.len(),
            rate(v[0]),
            rate(v[v.len() / 2]),
            hits[k]
        );
    }
}
