//! Helpers shared by the integration tests.
#![allow(dead_code)]

use raysched::render::sample_pixel;
use raysched::scene::{load_scene, load_scene_str, Scene, SceneOverrides};
use raysched::tracer::Tracer;
use std::path::{Path, PathBuf};
use std::process::Output;

/// An 8×8, 1-spp scene text: a white diffuse sphere of radius 1 seen from (0, 0, 4), and a
/// `glass` material for the tests that add shapes (a literal, so `concat!` can extend it).
macro_rules! sphere_scene_8x8 {
    () => {
        r#"
[camera]
origin = [0, 0, 4]
target = [0, 0, 0]
up = [0, 1, 0]
fov_deg = 40
width = 8
height = 8

[render]
spp = 1

[materials.white]
type = "diffuse"
reflectance = [0.8, 0.8, 0.8]

[materials.glass]
type = "dielectric"
ior = 1.5

[[shapes]]
type = "sphere"
material = "white"
radius = 1
"#
    };
}
pub(crate) use sphere_scene_8x8;

/// Assert that a run of the binary succeeded, showing its stderr where it did not.
#[track_caller]
pub(crate) fn assert_ok(out: &Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A 4×4 camera at (0, 0, 10) looking at the origin, for scenes that are only ray-cast.
pub(crate) const CAMERA_4X4: &str = "[camera]\norigin = [0, 0, 10]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov_deg = 40\nwidth = 4\nheight = 4\n";

/// One grey diffuse material, `m`.
pub(crate) const GREY_M: &str =
    "[materials.m]\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n";

pub(crate) fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

pub(crate) fn load(name: &str, overrides: SceneOverrides) -> Scene {
    load_scene(&scene_path(name), &overrides).unwrap_or_else(|e| panic!("{e}"))
}

pub(crate) fn load_str(text: &str) -> Scene {
    load_scene_str(
        text,
        "test",
        Path::new("."),
        "test",
        &SceneOverrides::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// Mean and standard error of the mean of channel `c` over every sample of every pixel given.
pub(crate) struct Estimate {
    pub mean: f64,
    pub se: f64,
    pub n: usize,
    pub nonfinite: usize,
}

impl Estimate {
    /// |mean − expected| within 3 standard errors (plus a float-rounding floor for σ = 0).
    pub(crate) fn assert_within_3se(&self, expected: f64, what: &str) {
        let tol = 3.0 * self.se + 1e-5 * expected.abs().max(1.0);
        assert!(
            (self.mean - expected).abs() <= tol,
            "{what}: mean {:.6} expected {:.6} (±{:.6}, se {:.2e}, n {})",
            self.mean,
            expected,
            tol,
            self.se,
            self.n
        );
        assert_eq!(self.nonfinite, 0, "{what}: non-finite samples");
    }
}

pub(crate) fn estimate<T: Tracer>(
    scene: &Scene,
    tracer: &T,
    pixels: &[u32],
    spp: u32,
    c: usize,
) -> Estimate {
    let (mut sum, mut sum2, mut n, mut bad) = (0.0f64, 0.0f64, 0usize, 0usize);
    let mut rays = 0;
    for &p in pixels {
        for s in 0..spp {
            let l = sample_pixel(scene, tracer, p, s, &mut rays);
            if !l.is_finite() {
                bad += 1;
                continue;
            }
            let v = l[c] as f64;
            sum += v;
            sum2 += v * v;
            n += 1;
        }
    }
    let mean = sum / n as f64;
    let var = (sum2 / n as f64 - mean * mean).max(0.0) * n as f64 / (n as f64 - 1.0).max(1.0);
    Estimate {
        mean,
        se: (var / n as f64).sqrt(),
        n,
        nonfinite: bad,
    }
}

/// `scene` rendered under `spec` on local threads, its frames stacked into one image.
pub(crate) fn render<T: Tracer + 'static>(
    spec: &raysched::sched::SchedulerSpec,
    scene: &std::sync::Arc<Scene>,
    tracer: &std::sync::Arc<T>,
) -> Result<(raysched::render::Image, raysched::metrics::RunStats), raysched::sched::SchedError> {
    render_with(spec, scene, tracer, &raysched::sched::RunOptions::default())
}

/// [`render`] with run options.
pub(crate) fn render_with<T: Tracer + 'static>(
    spec: &raysched::sched::SchedulerSpec,
    scene: &std::sync::Arc<Scene>,
    tracer: &std::sync::Arc<T>,
    opts: &raysched::sched::RunOptions,
) -> Result<(raysched::render::Image, raysched::metrics::RunStats), raysched::sched::SchedError> {
    use raysched::sched::{render_scene, RenderOn};
    let (frames, stats) = render_scene(spec, scene, tracer, &RenderOn::threads(), opts)?;
    Ok((raysched::render::Image::stack(frames), stats))
}
