//! A researcher's own tracer, written outside the crate: it wraps the native BVH and counts
//! the queries it answers, closest-hit and occlusion apart. Any type with the paired queries
//! of [`Tracer`] renders through `render_job` and the one run path; the image is the native
//! tracer's bit for bit, because the answers are.
//!
//! ```sh
//! cargo run --release --example custom_tracer
//! ```

use raysched::geometry::{Hit, Ray};
use raysched::sched::{Policy, SchedulerKind};
use raysched::tracer::{BvhTracer, Tracer};
use std::sync::atomic::{AtomicU64, Ordering};

/// The native BVH, counting what it is asked.
pub struct Counting {
    inner: BvhTracer,
    /// Closest-hit queries answered.
    pub intersects: AtomicU64,
    /// Occlusion queries answered.
    pub occludeds: AtomicU64,
}

impl Counting {
    /// Count the queries `inner` answers.
    pub fn new(inner: BvhTracer) -> Self {
        Self {
            inner,
            intersects: AtomicU64::new(0),
            occludeds: AtomicU64::new(0),
        }
    }
}

impl Tracer for Counting {
    fn id(&self) -> &'static str {
        "counting_bvh"
    }

    fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        self.intersects.fetch_add(1, Ordering::Relaxed);
        self.inner.intersect(ray, t_max)
    }

    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        self.occludeds.fetch_add(1, Ordering::Relaxed);
        self.inner.occluded(ray, t_max)
    }
}

#[allow(dead_code)]
fn main() {
    use raysched::render::Image;
    use raysched::scene::{load_scene, SceneOverrides};
    use raysched::sched::{render_scene, Chunk, RenderOn, RunOptions, SchedulerSpec};
    use std::sync::Arc;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box.toml");
    let o = SceneOverrides {
        width: Some(64),
        height: Some(64),
        spp: Some(4),
        ..Default::default()
    };
    let scene = Arc::new(load_scene(&path, &o).expect("scenes/cornell_box.toml loads"));
    let spec = SchedulerSpec::new(SchedulerKind::SelfScheduling, Chunk::Tile { w: 4, h: 4 }, 2);
    let native = Arc::new(BvhTracer::new(&scene.geometry));
    let counting = Arc::new(Counting::new(BvhTracer::new(&scene.geometry)));
    let on = RenderOn::threads();
    let opts = RunOptions::default();
    let (a, _) = render_scene(&spec, &scene, &native, &on, &opts).expect("renders");
    let (b, stats) = render_scene(&spec, &scene, &counting, &on, &opts).expect("renders");
    println!(
        "{}: {} closest-hit and {} occlusion queries for {} rays; image {} the native one",
        Policy::defaults(SchedulerKind::SelfScheduling).kind().id(),
        counting.intersects.load(Ordering::Relaxed),
        counting.occludeds.load(Ordering::Relaxed),
        stats.rays,
        if Image::stack(a).hash() == Image::stack(b).hash() {
            "is"
        } else {
            "DIFFERS from"
        }
    );
}
