//! Issue 6: the fast subset of the stability suite, the pruned-vs-full path identity, the
//! progressive-render reuse and the convergence slope.

use raysched::converge::{self, reference};
use raysched::render::{self, WorkItem};
use raysched::scene::{load_scene, SceneOverrides};
use raysched::stability::{self, cases, Budget};
use raysched::tracer::AnyTracer;
use std::path::Path;

#[test]
fn stability_quick_suite_passes() {
    let rows = cases::run_suite(&Budget::QUICK);
    let table = stability::markdown(&rows);
    println!("{table}");
    assert!(rows.len() >= 20, "{table}");
    let failed: Vec<_> = rows.iter().filter(|r| r.required && !r.pass).collect();
    assert!(failed.is_empty(), "failed cases:\n{table}");
    assert!(rows.iter().all(|r| r.nonfinite == 0), "{table}");
}

/// The BVH must find the same closest hits as brute force on a scene shrunk to 1e-6.
#[test]
fn bvh_matches_brute_at_tiny_scale() {
    let text = std::fs::read_to_string("scenes/cornell_box.toml").unwrap();
    for s in [1e-6, 1.0, 1e6] {
        let scene = stability::transform::load_transformed(
            &text, "cornell", Path::new("."), s, 0.0, &SceneOverrides::default()).unwrap();
        let bvh = raysched::tracer::BvhTracer::forced(&scene.geometry);
        let brute = raysched::tracer::BruteTracer::new(&scene.geometry);
        let mut misses = 0;
        for k in 0..256u32 {
            let ray = scene.camera.ray((k % 16) as f32 / 16.0 + 0.03, (k / 16) as f32 / 16.0 + 0.03);
            use raysched::tracer::Tracer;
            // Same distance (a tie on a shared edge may name either triangle).
            let a = bvh.intersect(&ray, f32::INFINITY).map(|h| h.t);
            let b = brute.intersect(&ray, f32::INFINITY).map(|h| h.t);
            if a != b { misses += 1; }
        }
        assert_eq!(misses, 0, "scale {s}: {misses}/256 rays differ between bvh and brute");
    }
}
