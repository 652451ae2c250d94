//! `render_item`: the pure function every scheduler and compute source calls.
//!
//! A pixel's value depends only on (scene, tracer, frame, pixel, seed): each sample draws from
//! a counter-based [`Sampler`] keyed by ([`frame_seed`]`(seed, frame)`, pixel, sample), and
//! samples are summed in a fixed order. Who renders a pixel, when, and with which other pixels never changes its bits.

pub mod image;
pub mod integrator;

pub use image::Image;

use crate::core::scene::{Camera, Scene};
use crate::core::tracer::Tracer;
use crate::util::rng::{frame_seed, Sampler};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// Calls `$f::<…, Feats<…>>($args)` with the scene's feature set ([`integrator::feature_flags`],
/// a few field reads): one monomorphised path per feature combination, chosen once per item
/// and never per ray. `_` in the turbofish stands for the feature set.
macro_rules! with_features {
    ($scene:expr, $f:ident::<$t:ty, _>($($arg:expr),*)) => {
        with_features!(@arms $scene, $f, $t, ($($arg),*);
            false false false false, false false false true, false false true false, false false true true,
            false true false false, false true false true, false true true false, false true true true,
            true false false false, true false false true, true false true false, true false true true,
            true true false false, true true false true, true true true false, true true true true)
    };
    (@arms $scene:expr, $f:ident, $t:ty, $args:tt; $($e:literal $a:literal $p:literal $s:literal),*) => {
        match integrator::feature_flags($scene) {
            $([$e, $a, $p, $s] => with_features!(@call $f, $t, integrator::Feats<$e, $a, $p, $s>, $args),)*
        }
    };
    (@call $f:ident, $t:ty, $feats:ty, ($($arg:expr),*)) => {
        $f::<$t, $feats>($($arg),*)
    };
}

/// A set of pixels handed out as one unit of work.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Region {
    /// An axis-aligned block: one pixel (1×1), a tile, a band of rows, or the whole frame.
    Rect {
        /// Left column, in pixels.
        x: u32,
        /// Top row, in pixels (row 0 is the top of the image).
        y: u32,
        /// Width, in pixels.
        w: u32,
        /// Height, in pixels.
        h: u32,
    },
    /// Any set of pixel indices (`y·width + x`), in the order they are rendered.
    Pixels(Vec<u32>),
}

/// A region of one frame of the scene (frame 0 for a static scene).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct WorkItem {
    /// Identifies the item; copied into its [`TileResult::item`].
    pub id: u32,
    /// The pixels to render.
    pub region: Region,
    /// Animation frame the region belongs to.
    #[serde(default)]
    pub frame: u32,
}

impl WorkItem {
    /// A rectangle of frame 0.
    pub fn rect(id: u32, x: u32, y: u32, w: u32, h: u32) -> Self {
        Self {
            id,
            region: Region::Rect { x, y, w, h },
            frame: 0,
        }
    }

    /// The same region in frame `frame`.
    pub fn in_frame(self, frame: u32) -> Self {
        Self { frame, ..self }
    }

    /// Number of pixels in the region.
    pub fn pixel_count(&self) -> usize {
        match &self.region {
            Region::Rect { w, h, .. } => *w as usize * *h as usize,
            Region::Pixels(p) => p.len(),
        }
    }

    /// Pixel indices (`y·width + x`) in render order.
    pub fn pixels(&self, width: u32) -> Pixels<'_> {
        match &self.region {
            Region::Rect { x, y, w, h } => Pixels::Rect {
                x0: *x,
                x1: x + w,
                x: *x,
                row: *y,
                row_end: if *w == 0 { *y } else { y + h },
                width,
            },
            Region::Pixels(p) => Pixels::List(p.iter()),
        }
    }
}

/// The pixel indices of a [`WorkItem`] in render order ([`WorkItem::pixels`]): a concrete
/// type, so the per-pixel loop of every item is inlined rather than called through a box.
#[derive(Clone, Debug)]
pub enum Pixels<'a> {
    /// Row by row through a rectangle.
    Rect {
        /// Left column.
        x0: u32,
        /// One past the right column.
        x1: u32,
        /// Next column.
        x: u32,
        /// Current row.
        row: u32,
        /// One past the bottom row (the top row when the rectangle is empty).
        row_end: u32,
        /// Image width, in pixels.
        width: u32,
    },
    /// An explicit list.
    List(std::slice::Iter<'a, u32>),
}

impl Iterator for Pixels<'_> {
    type Item = u32;

    #[inline]
    fn next(&mut self) -> Option<u32> {
        match self {
            Pixels::Rect {
                x0,
                x1,
                x,
                row,
                row_end,
                width,
            } => {
                if *x == *x1 {
                    *x = *x0;
                    *row += 1;
                }
                if *row >= *row_end {
                    return None;
                }
                let idx = *row * *width + *x;
                *x += 1;
                Some(idx)
            }
            Pixels::List(it) => it.next().copied(),
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = match self {
            Pixels::Rect {
                x0,
                x1,
                x,
                row,
                row_end,
                ..
            } => {
                if *row >= *row_end {
                    0
                } else {
                    let w = (*x1 - *x0) as usize;
                    (*row_end - *row) as usize * w - (*x - *x0) as usize
                }
            }
            Pixels::List(it) => it.len(),
        };
        (n, Some(n))
    }
}

impl ExactSizeIterator for Pixels<'_> {}

/// An item's pixel values: one pixel inline, more on the heap. A one-pixel item's result then
/// needs no allocation of its own, kept live until the frame is assembled. Measured: M-113.
pub type PixelValues = smallvec::SmallVec<[[f32; 3]; 1]>;

/// The result of rendering one item: pixels in the item's order plus counters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TileResult {
    /// [`WorkItem::id`] of the item rendered.
    pub item: u32,
    /// Linear RGB value of each pixel (its sample mean), in [`WorkItem::pixels`] order.
    pub pixels: PixelValues,
    /// Tracer queries (closest-hit and occlusion).
    pub rays: u64,
    /// Samples whose radiance came out NaN or infinite; they are dropped, never averaged in.
    pub nonfinite: u64,
}

/// One radiance sample of pixel `idx` (`y·width + x`) of frame 0: jittered camera ray, then a
/// path. Its value depends only on (scene, tracer, pixel, sample, seed).
#[inline]
pub fn sample_pixel<T: Tracer + ?Sized>(
    scene: &Scene,
    tracer: &T,
    idx: u32,
    sample: u32,
    rays: &mut u64,
) -> Vec3 {
    sample_pixel_with::<T, integrator::FullFeatures>(
        scene,
        tracer,
        &scene.camera,
        scene.settings.seed,
        idx,
        sample,
        rays,
    )
}

/// [`sample_pixel`] of the frame seen by `cam` and sampled with `seed` (its
/// [`frame_seed`]) through the path specialised to `F`.
#[inline(always)]
fn sample_pixel_with<T: Tracer + ?Sized, F: integrator::FeatureSet>(
    scene: &Scene,
    tracer: &T,
    cam: &Camera,
    seed: u64,
    idx: u32,
    sample: u32,
    rays: &mut u64,
) -> Vec3 {
    let width = scene.width();
    let mut s = Sampler::new(seed, idx as u64, sample as u64);
    let (jx, jy) = s.next2();
    let ray = cam.pixel_ray(idx % width, idx / width, jx, jy);
    integrator::radiance_with::<T, F>(scene, tracer, ray, &mut s, rays)
}

/// Sum of the radiance samples `samples` of every pixel of `item` (f64 sums, fixed order).
/// Runs the path specialised to the scene's features ([`integrator::feature_flags`]); the
/// image is bit-identical to [`render_sums_full`].
pub fn render_sums<T: Tracer + ?Sized>(
    scene: &Scene,
    tracer: &T,
    item: &WorkItem,
    samples: Range<u32>,
) -> (Vec<[f64; 3]>, u64, u64) {
    let m = render_moments(scene, tracer, item, samples, false);
    (m.sums, m.rays, m.nonfinite)
}

/// [`render_sums`] through the forced-full path (every feature compiled in): the baseline the
/// pruned path is tested and benchmarked against.
pub fn render_sums_full<T: Tracer + ?Sized>(
    scene: &Scene,
    tracer: &T,
    item: &WorkItem,
    samples: Range<u32>,
) -> (Vec<[f64; 3]>, u64, u64) {
    let m = render_moments(scene, tracer, item, samples, true);
    (m.sums, m.rays, m.nonfinite)
}

/// Per-pixel first and second moments of a sample range (f64, fixed order), for error bars.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Moments {
    /// Per pixel (item order), the sum of its finite RGB samples.
    pub sums: Vec<[f64; 3]>,
    /// Per pixel (item order), the sum of its finite RGB samples squared, channel by channel.
    pub sq_sums: Vec<[f64; 3]>,
    /// Finite samples per pixel (NaN/Inf samples are dropped and counted in `nonfinite`).
    pub counts: Vec<u32>,
    /// Tracer queries (closest-hit and occlusion).
    pub rays: u64,
    /// Samples dropped because their radiance was NaN or infinite.
    pub nonfinite: u64,
}

/// Sums and squared sums of samples `samples` of every pixel of `item`. `full` forces the
/// all-features path; otherwise the feature set is chosen here, once per item.
pub fn render_moments<T: Tracer + ?Sized>(
    scene: &Scene,
    tracer: &T,
    item: &WorkItem,
    samples: Range<u32>,
    full: bool,
) -> Moments {
    if full {
        return moments_with::<T, integrator::FullFeatures>(scene, tracer, item, samples);
    }
    with_features!(scene, moments_with::<T, _>(scene, tracer, item, samples))
}

fn moments_with<T: Tracer + ?Sized, F: integrator::FeatureSet>(
    scene: &Scene,
    tracer: &T,
    item: &WorkItem,
    samples: Range<u32>,
) -> Moments {
    let n = item.pixel_count();
    let mut m = Moments {
        sums: Vec::with_capacity(n),
        sq_sums: Vec::with_capacity(n),
        counts: Vec::with_capacity(n),
        ..Default::default()
    };
    let cam = scene.frame_camera(item.frame);
    let seed = frame_seed(scene.settings.seed, item.frame);
    for idx in item.pixels(scene.width()) {
        let mut sum = [0.0f64; 3];
        let mut sq = [0.0f64; 3];
        let mut count = 0u32;
        for sample in samples.clone() {
            let l = sample_pixel_with::<T, F>(scene, tracer, cam, seed, idx, sample, &mut m.rays);
            if l.is_finite() {
                for c in 0..3 {
                    let v = l[c] as f64;
                    sum[c] += v;
                    sq[c] += v * v;
                }
                count += 1;
            } else {
                m.nonfinite += 1;
            }
        }
        m.sums.push(sum);
        m.sq_sums.push(sq);
        m.counts.push(count);
    }
    m
}

/// Render every pixel of `item` with the scene's sample count: the pure per-item function.
// Never inlined: the serial baseline and every scheduler then run the same machine code, so a
// speedup measures scheduling, not where the optimiser happened to inline the renderer.
#[inline(never)]
pub fn render_item<T: Tracer + ?Sized>(scene: &Scene, tracer: &T, item: &WorkItem) -> TileResult {
    let spp = scene.settings.spp;
    let Some(extra) = extra_work() else {
        return render_item_spp(scene, tracer, item, spp);
    };
    let t0 = std::time::Instant::now();
    let r = render_item_spp(scene, tracer, item, spp);
    let until = t0.elapsed().mul_f64(1.0 + extra);
    while t0.elapsed() < until {
        std::hint::spin_loop();
    }
    r
}

/// A testing aid for the measurement pipeline: with `RAYSCHED_EXTRA_WORK=F` (0 < F ≤ 10) in
/// the environment, every work item spins for F times its own render time after rendering,
/// a known slowdown that `raysched compare` must flag. The image is unchanged.
pub fn extra_work() -> Option<f64> {
    static EXTRA: std::sync::OnceLock<Option<f64>> = std::sync::OnceLock::new();
    *EXTRA.get_or_init(|| {
        std::env::var("RAYSCHED_EXTRA_WORK")
            .ok()
            .and_then(|v| v.trim().parse::<f64>().ok())
            .filter(|f| *f > 0.0 && *f <= 10.0)
    })
}

/// [`render_item`]'s pure body with the first `spp` samples of each pixel (the scene's count
/// there; fewer in probes that time a short render of a scene without copying it: the same
/// samples a scene of `spp` renders).
#[inline(always)]
pub fn render_item_spp<T: Tracer + ?Sized>(
    scene: &Scene,
    tracer: &T,
    item: &WorkItem,
    spp: u32,
) -> TileResult {
    with_features!(scene, tile_with::<T, _>(scene, tracer, item, spp))
}

/// Each pixel's sample mean straight into the item's result, at most one allocation per item
/// (its pixels; none for one pixel). The sums are [`moments_with`]'s, in the same order, so the
/// bits are the same.
// What a one-pixel item costs beyond its pixel (`cargo bench --bench render -- item_cost`,
// skewed_low at 1 spp, one thread) fell to 0.11–0.21× of the path through three moment Vecs
// and a boxed pixel iterator (13–18 ns against 63–167 ns, 2-core Xeon VM, binaries alternated).
fn tile_with<T: Tracer + ?Sized, F: integrator::FeatureSet>(
    scene: &Scene,
    tracer: &T,
    item: &WorkItem,
    spp: u32,
) -> TileResult {
    let inv = 1.0 / spp as f64;
    let cam = scene.frame_camera(item.frame);
    let seed = frame_seed(scene.settings.seed, item.frame);
    let mut r = TileResult {
        item: item.id,
        pixels: PixelValues::with_capacity(item.pixel_count()),
        rays: 0,
        nonfinite: 0,
    };
    for idx in item.pixels(scene.width()) {
        let mut sum = [0.0f64; 3];
        for sample in 0..spp {
            let l = sample_pixel_with::<T, F>(scene, tracer, cam, seed, idx, sample, &mut r.rays);
            if l.is_finite() {
                for c in 0..3 {
                    sum[c] += l[c] as f64;
                }
            } else {
                r.nonfinite += 1;
            }
        }
        r.pixels.push([
            (sum[0] * inv) as f32,
            (sum[1] * inv) as f32,
            (sum[2] * inv) as f32,
        ]);
    }
    r
}

/// Counters of a whole-image render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RenderCounters {
    /// Tracer queries (closest-hit and occlusion), summed over every item.
    pub rays: u64,
    /// NaN or infinite samples dropped, summed over every item.
    pub nonfinite: u64,
}

/// Serial reference render: one item per row, on the calling thread. An animation's frames
/// come back as one film strip ([`Image::stack`]); [`render_serial_frames`] keeps them apart.
pub fn render_serial<T: Tracer + ?Sized>(scene: &Scene, tracer: &T) -> (Image, RenderCounters) {
    let (frames, counters) = render_serial_frames(scene, tracer);
    (Image::stack(frames), counters)
}

/// Serial reference render of every frame, one image per frame.
pub fn render_serial_frames<T: Tracer + ?Sized>(
    scene: &Scene,
    tracer: &T,
) -> (Vec<Image>, RenderCounters) {
    let mut counters = RenderCounters::default();
    let mut frames = Vec::with_capacity(scene.frames() as usize);
    for f in 0..scene.frames() {
        let mut image = Image::new(scene.width(), scene.height());
        for item in serial_rows(scene, f) {
            let r = render_item(scene, tracer, &item);
            counters.rays += r.rays;
            counters.nonfinite += r.nonfinite;
            image.put(&item, &r.pixels);
        }
        frames.push(image);
    }
    (frames, counters)
}

/// The items of the serial render of frame `f`: its rows, top first, ids counted over frames.
pub fn serial_rows(scene: &Scene, f: u32) -> impl Iterator<Item = WorkItem> + '_ {
    (0..scene.height())
        .map(move |y| WorkItem::rect(f * scene.height() + y, 0, y, scene.width(), 1).in_frame(f))
}
