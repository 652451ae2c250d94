//! The check behind `tests/embree_threads.rs` (Embree 3) and `tests/embree4_threads.rs`
//! (Embree 4). Each runs in a test binary of its own, so that no other test creates threads
//! or devices meanwhile.

use raysched::scene::{load_scene, SceneOverrides};
use raysched::sched::render_parallel;
use raysched::tracer::{AnyTracer, Tracer, TracerKind};
use raysched::util::host::os_thread_count;
use std::sync::Arc;

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

/// The Embree backend `kind` creates a device only when a run uses it, starts no thread of
/// its own at `threads=1` and at most one for its build at `threads=2`, and traces from our
/// own workers. `devices_created` is the backend's device counter, `threads_after_build` reads
/// the OS thread count its tracer recorded after the build.
pub(crate) fn devices_and_os_threads_are_what_the_run_asked_for(
    kind: TracerKind,
    devices_created: fn() -> usize,
    threads_after_build: fn(&AnyTracer) -> Option<usize>,
) {
    let o = SceneOverrides {
        spp: Some(1),
        width: Some(16),
        height: Some(16),
        ..Default::default()
    };
    let scene = Arc::new(load_scene(std::path::Path::new("scenes/cornell_box.toml"), &o).unwrap());

    // A run that does not use this backend never creates a device.
    let bvh = Arc::new(AnyTracer::build(TracerKind::Bvh, &scene, 2).unwrap());
    let brute = Arc::new(AnyTracer::build(TracerKind::Brute, &scene, 2).unwrap());
    render_parallel(&scene, &bvh, 1).unwrap();
    render_parallel(&scene, &brute, 1).unwrap();
    assert_eq!(devices_created(), 0);

    // `threads=1`: the commit starts no worker thread, the process keeps its threads.
    let before = settled_thread_count();
    let e = Arc::new(AnyTracer::build(kind, &scene, 1).unwrap());
    assert_eq!(devices_created(), 1);
    assert_eq!(
        threads_after_build(&e),
        Some(before),
        "threads=1 must not start workers"
    );
    eprintln!("threads=1: {before} OS threads before and after the build");
    assert_eq!(os_thread_count(), Some(before));
    // Tracing from our own (rayon) workers is fine.
    let (img, counters) = render_parallel(&scene, &e, 2).unwrap();
    assert!(counters.rays > 0 && img.data.iter().any(|p| p[0] > 0.0));
    assert_eq!(e.id(), kind.id());
    drop(e);
    let before = settled_thread_count();

    // `threads=2`: the backend may start one TBB worker for its build, never more than that.
    let e = AnyTracer::build(kind, &scene, 2).unwrap();
    let after = threads_after_build(&e).unwrap();
    eprintln!("threads=2: {before} → {after} OS threads");
    assert!(
        after <= before + 1,
        "threads=2: {before} → {after} OS threads"
    );
}
