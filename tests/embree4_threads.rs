//! Embree 4 thread control, in its own test binary so no other test creates threads or devices
//! meanwhile.
#![cfg(feature = "embree4")]

use raysched::embree4::devices_created;
use raysched::host::os_thread_count;
use raysched::render::render_parallel;
use raysched::scene::{load_scene, SceneOverrides};
use raysched::tracer::{AnyTracer, Tracer, TracerKind};

/// The OS thread count once it has stayed the same for 100 ms: rayon's pool threads exit
/// asynchronously after a pool is dropped.
fn settled_thread_count() -> usize {
    let start = std::time::Instant::now();
    let mut last = os_thread_count().expect("/proc/self/status");
    let mut stable_since = std::time::Instant::now();
    while stable_since.elapsed().as_millis() < 100 && start.elapsed().as_secs() < 10 {
        std::thread::sleep(std::time::Duration::from_millis(5));
        let now = os_thread_count().unwrap();
        if now != last {
            (last, stable_since) = (now, std::time::Instant::now());
        }
    }
    last
}

#[test]
fn embree4_devices_and_os_threads_are_what_the_run_asked_for() {
    let o = SceneOverrides {
        spp: Some(1),
        width: Some(16),
        height: Some(16),
        ..Default::default()
    };
    let scene = load_scene(std::path::Path::new("scenes/cornell_box.toml"), &o).unwrap();

    // A run that does not use Embree 4 never creates a device.
    let bvh = AnyTracer::build(TracerKind::Bvh, &scene, 2).unwrap();
    let brute = AnyTracer::build(TracerKind::Brute, &scene, 2).unwrap();
    render_parallel(&scene, &bvh, 1).unwrap();
    render_parallel(&scene, &brute, 1).unwrap();
    assert_eq!(devices_created(), 0);

    // `threads=1`: Embree's commit starts no worker thread, the process keeps its threads.
    let before = settled_thread_count();
    let e = AnyTracer::build(TracerKind::Embree4, &scene, 1).unwrap();
    assert_eq!(devices_created(), 1);
    let AnyTracer::Embree4(inner) = &e else {
        panic!("not embree4")
    };
    assert_eq!(
        inner.os_threads_after_build,
        Some(before),
        "threads=1 must not start workers"
    );
    eprintln!("threads=1: {before} OS threads before and after the build");
    assert_eq!(os_thread_count(), Some(before));
    // Tracing from our own (rayon) workers is fine.
    let (img, counters) = render_parallel(&scene, &e, 2).unwrap();
    assert!(counters.rays > 0 && img.data.iter().any(|p| p[0] > 0.0));
    assert_eq!(e.id(), "embree4");
    drop(e);
    let before = settled_thread_count();

    // `threads=2`: Embree 4 may start one TBB worker for its build, never more than that.
    let e = AnyTracer::build(TracerKind::Embree4, &scene, 2).unwrap();
    let AnyTracer::Embree4(inner) = &e else {
        panic!("not embree4")
    };
    let after = inner.os_threads_after_build.unwrap();
    eprintln!("threads=2: {before} → {after} OS threads");
    assert!(
        after <= before + 1,
        "threads=2: {before} → {after} OS threads"
    );
}
