//! The model's measured inputs, from a short probe: every pixel's cost (a low-spp render on
//! the run's P workers, so the pixels are timed while the other cores are busy too, as in the
//! run), the run-to-run noise of those costs, and each scheduler's hand-out costs from
//! items that do no work (as `benches/dispatch.rs` measures them).

use super::Overheads;
use crate::core::metrics::RunStats;
use crate::core::render::{TileResult, WorkItem};
use crate::core::scene::Scene;
use crate::core::tracer::Tracer;
use crate::sched::{
    decompose, render_job, run, Chunk, Order, Policy, RunOptions, RunPlan, SchedError,
    SchedulerKind, SchedulerSpec, Sources,
};
use crate::source::Job;
use crate::studies::profile::Profile;
use std::sync::Arc;

/// Every pixel's cost at the probe's samples per pixel, and their noise.
#[derive(Clone, Debug)]
pub struct PixelProbe {
    /// Each pixel's cost: its median span over the passes (a pixel whose thread was
    /// preempted in a minority of passes is out-voted), scaled so that the pixels sum to
    /// `bulk_s` ([`calibrate`]).
    pub profile: Profile,
    /// v: the coefficient of variation of a pixel's time between two passes (the rendering
    /// is deterministic, so this is timing noise alone).
    pub noise_cv: f64,
    /// Σ of the pixels' median spans as timed one pixel at a time, before [`calibrate`].
    pub timed_s: f64,
    /// Σ seconds of the same image rendered in rows on the same workers, each row's median
    /// over the bulk passes: what the pixels cost when nothing times them one by one.
    pub bulk_s: f64,
    /// The fastest and slowest bulk pass (Σ of its rows): how far the machine's speed moved
    /// while the probe ran.
    pub bulk_range_s: (f64, f64),
    /// c: each item's own cost beyond its pixels ([`per_item_cost`] of the two renders).
    pub per_item_s: f64,
    /// a: each pixel's cost that does not grow with its samples ([`fixed_per_pixel`] of
    /// bulk renders at the probe's spp and at 1 spp); 0 for a 1-spp probe.
    pub fixed_pixel_s: f64,
}

/// One pass: frame 0 pixel by pixel, item i to worker i mod P, each pixel's span kept.
fn pass<T: Tracer + 'static>(
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    workers: usize,
) -> Result<Vec<f64>, SchedError> {
    timed_pass(scene, tracer, workers, Chunk::Tile { w: 1, h: 1 })
}

/// Each row's seconds with frame 0 rendered one row per item, cyclically over `workers`: the
/// level of a run that does not time each pixel (one clock read per row).
fn bulk_pass<T: Tracer + 'static>(
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    workers: usize,
) -> Result<Vec<f64>, SchedError> {
    timed_pass(scene, tracer, workers, Chunk::Rows(1))
}

/// Each item's seconds with frame 0 cut into `chunk`s in scanline order, rendered cyclically
/// over `workers` (one timeline span per item).
fn timed_pass<T: Tracer + 'static>(
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    workers: usize,
    chunk: Chunk,
) -> Result<Vec<f64>, SchedError> {
    let (w, h) = (scene.width(), scene.height());
    let mut spec = SchedulerSpec::new(SchedulerKind::StaticCyclic, chunk, workers);
    spec.timeline = true;
    let items = decompose(w, h, spec.chunk, Order::Scanline);
    let stats = render_on_threads(&spec, scene, tracer, &items)?;
    let mut secs = vec![0.0; items.len()];
    for s in stats.timeline.unwrap_or_default() {
        if let Some(x) = secs.get_mut(s.item as usize) {
            *x = s.end_ns.saturating_sub(s.start_ns) as f64 * 1e-9;
        }
    }
    Ok(secs)
}

/// Per-pixel costs that keep the shape of `timed` (each pixel's share of the image) and sum
/// to `bulk_s`. A render timed one pixel at a time (a work item, a clock read and a timeline
/// entry per pixel) is not the render a run makes: on the 2-core dev box the sum of the
/// spans came out 5.7 % above the measured serial render, which put every simulated 1-worker
/// run 4–13 % above its measurement. The bulk render is timed only per row.
/// Without a usable bulk time (≤ 0 or not finite) the timed costs are kept.
pub fn calibrate(timed: &[f64], bulk_s: f64) -> Vec<f64> {
    let sum: f64 = timed.iter().sum();
    if !(bulk_s.is_finite() && bulk_s > 0.0 && sum > 0.0) {
        return timed.to_vec();
    }
    let k = bulk_s / sum;
    timed.iter().map(|t| t * k).collect()
}

/// c, what one item costs beyond its pixels: the timed render's excess over the bulk render,
/// spread over the items the timed render has more of (`pixels` one-pixel items against
/// `rows` rows), ≥ 0. The excess is each item's result and pixel buffer, the render job's
/// per-item setup and hand-out, and the timeline's clock read (~20 ns, kept: a run's items
/// read no clock, so c is high by that). Calibrating the pixels to the rows took c out of
/// them; one-pixel items pay it again per pixel.
pub fn per_item_cost(timed_s: f64, bulk_s: f64, pixels: usize, rows: usize) -> f64 {
    let extra = pixels.saturating_sub(rows);
    let c = (timed_s - bulk_s) / extra as f64;
    if extra == 0 || !c.is_finite() {
        0.0
    } else {
        c.max(0.0)
    }
}

/// a, the part of a pixel's cost that its samples do not multiply (its sampler and film
/// setup, storing it), from bulk renders of `pixels` pixels at `spp` (`bulk_s`) and at one
/// sample (`one_s`): bulk = pixels·a + b·spp, so a = (spp·one − bulk) / ((spp − 1)·pixels),
/// clamped to [0, one/pixels]. Scaling a whole pixel's cost by spp/probe-spp would scale a too:
/// on the dev box a Cornell-box prediction from a 2/4/8-spp probe came out 119/109/102 ms.
pub fn fixed_per_pixel(bulk_s: f64, one_s: f64, spp: u32, pixels: usize) -> f64 {
    if spp <= 1 || pixels == 0 || !(bulk_s.is_finite() && one_s.is_finite()) {
        return 0.0;
    }
    let n = pixels as f64;
    let a = (spp as f64 * one_s - bulk_s) / ((spp - 1) as f64 * n);
    a.clamp(0.0, (one_s / n).max(0.0))
}

/// The median (the mean of the middle two of an even count; NaN of none).
pub fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Each position's median over the passes.
fn medians(passes: &[Vec<f64>]) -> Vec<f64> {
    (0..passes.first().map_or(0, Vec::len))
        .map(|i| median(&mut passes.iter().map(|p| p[i]).collect::<Vec<_>>()))
        .collect()
}

/// Time every pixel of frame 0 of `scene` on `workers` workers, `passes` (≥ 2) times, each
/// pass followed by a bulk render (timed per row only) of the same image on the same workers; each
/// pixel's median span, calibrated to the bulk renders' median ([`calibrate`]). This is the
/// one probe of per-pixel costs: the cost model's and the simulation's.
pub fn pixels<T: Tracer + 'static>(
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    workers: usize,
    passes: u32,
) -> Result<PixelProbe, SchedError> {
    pixels_with(scene, tracer, workers, passes, passes)
}

/// How many bulk passes follow each of `pixel` pixel passes so that `bulk` are spread evenly
/// among them (every pixel pass is followed by at least one).
pub fn bulk_after(pixel: u32, bulk: u32) -> Vec<u32> {
    let pixel = pixel.max(1);
    let bulk = bulk.max(pixel);
    (0..pixel)
        .map(|i| (i + 1) * bulk / pixel - i * bulk / pixel)
        .collect()
}

/// [`pixels`] with `bulk_passes` bulk renders (≥ `pixel_passes`) spread among the pixel
/// passes. The shape needs few pixel passes; the level many bulk passes: on the 2-core dev
/// box one render of the validation scene varies by ±10 % from one second to the next, so a
/// level from the median of 3 moved 0.321–0.388 s between probes a minute apart.
pub fn pixels_with<T: Tracer + 'static>(
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    workers: usize,
    pixel_passes: u32,
    bulk_passes: u32,
) -> Result<PixelProbe, SchedError> {
    let mut spans: Vec<Vec<f64>> = Vec::new();
    let mut rows: Vec<Vec<f64>> = Vec::new();
    let mut rows_one: Vec<Vec<f64>> = Vec::new();
    let spp = scene.settings.spp;
    let one = (spp > 1).then(|| {
        let mut s = (**scene).clone();
        s.settings.spp = 1;
        Arc::new(s)
    });
    // One untimed render first: an experiment process's first probe read the image's work
    // well above the rounds' serial median without it (M-116).
    bulk_pass(scene, tracer, workers)?;
    for k in bulk_after(pixel_passes.max(2), bulk_passes) {
        spans.push(pass(scene, tracer, workers)?);
        for _ in 0..k {
            rows.push(bulk_pass(scene, tracer, workers)?);
        }
        if let Some(one) = &one {
            rows_one.push(bulk_pass(one, tracer, workers)?);
        }
    }
    let noise_cv = relative_spread(&spans[0], &spans[1]);
    let timed = medians(&spans);
    // Rows, like pixels, by their median pass: a row whose thread was preempted in a
    // minority of passes is out-voted (with busy time of whole passes instead, the bulk level
    // doubled on the dev box at load 8).
    let bulk_s = medians(&rows).iter().sum();
    let totals = rows.iter().map(|r| r.iter().sum::<f64>());
    let bulk_range_s = totals.fold((f64::INFINITY, 0.0_f64), |(lo, hi), t| {
        (lo.min(t), hi.max(t))
    });
    let timed_s: f64 = timed.iter().sum();
    let (w, h) = (scene.width() as usize, scene.height() as usize);
    let one_s: f64 = medians(&rows_one).iter().sum();
    Ok(PixelProbe {
        profile: Profile {
            width: scene.width(),
            height: scene.height(),
            pixel_s: calibrate(&timed, bulk_s),
        },
        noise_cv,
        timed_s,
        bulk_s,
        bulk_range_s,
        per_item_s: per_item_cost(timed_s, bulk_s, w * h, h),
        fixed_pixel_s: fixed_per_pixel(bulk_s, one_s, spp, w * h),
    })
}

/// Σ busy seconds of frame 0 cut into `chunk`s in `order`, dealt cyclically over `workers`
/// in that order, nothing timed per item beyond the run's own statistics.
/// Render `items` of `scene` under `spec` on its threads.
fn render_on_threads<T: Tracer + 'static>(
    spec: &SchedulerSpec,
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    items: &[WorkItem],
) -> Result<RunStats, SchedError> {
    let opts = RunOptions::default();
    let plan = RunPlan::of(spec, &opts)?;
    let job = render_job(scene, tracer);
    Ok(run(&plan, items, Sources::threads(&job, spec))?.1)
}

fn busy_pass<T: Tracer + 'static>(
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    workers: usize,
    chunk: Chunk,
    order: Order,
) -> Result<f64, SchedError> {
    let spec = SchedulerSpec::new(SchedulerKind::StaticCyclic, chunk, workers);
    let items = decompose(scene.width(), scene.height(), chunk, order);
    let stats = render_on_threads(&spec, scene, tracer, &items)?;
    Ok(stats.busy_s())
}

/// What the items of one layout (`chunk` in `order`) cost against the same pixels rendered
/// in rows, the level the pixel costs are calibrated to: the median over `pairs` adjacent
/// pairs of passes on `workers` workers of (layout's Σ busy) / (rows' Σ busy). Pixels taken
/// far apart cost more than in their neighbours' order, which summing the probe's pixels
/// misses (M-117). 1 for the rows themselves and for `pairs` = 0.
pub fn layout_factor<T: Tracer + 'static>(
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    workers: usize,
    layout: (Chunk, Order),
    pairs: u32,
) -> Result<f64, SchedError> {
    let rows = (Chunk::Rows(1), Order::Scanline);
    if pairs == 0 || layout == rows {
        return Ok(1.0);
    }
    let mut ratios = Vec::with_capacity(pairs as usize);
    for _ in 0..pairs {
        let r = busy_pass(scene, tracer, workers, rows.0, rows.1)?;
        let l = busy_pass(scene, tracer, workers, layout.0, layout.1)?;
        if r > 0.0 && l.is_finite() {
            ratios.push(l / r);
        }
    }
    let k = median(&mut ratios);
    Ok(if k.is_finite() && k > 0.0 { k } else { 1.0 })
}

/// The coefficient of variation of one measurement from two passes: the standard deviation
/// of (a − b)/mean(a, b) over the pixels, over √2 (a difference of two has twice the
/// variance). Pixels slower than 10× their other pass (a preemption) are left out.
pub fn relative_spread(a: &[f64], b: &[f64]) -> f64 {
    let d: Vec<f64> = a
        .iter()
        .zip(b)
        .filter(|(x, y)| **x > 0.0 && **y > 0.0 && x.max(**y) < 10.0 * x.min(**y))
        .map(|(x, y)| (x - y) / ((x + y) / 2.0))
        .collect();
    if d.len() < 2 {
        return 0.0;
    }
    let m = d.iter().sum::<f64>() / d.len() as f64;
    let var = d.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (d.len() - 1) as f64;
    (var / 2.0).sqrt()
}

fn nothing() -> Job {
    Arc::new(|it: &WorkItem| TileResult {
        item: it.id,
        pixels: Default::default(),
        rays: 0,
        nonfinite: 0,
    })
}

/// What zero-work runs of a scheduler measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZeroWork {
    /// Seconds of wall per item: the slope between runs of n and 2n one-pixel zero-work items.
    pub per_item_s: f64,
    /// Seconds per run that do not grow with the items (threads started and joined, the
    /// results gathered): the intercept of the same two runs, ≥ 0.
    pub fixed_s: f64,
}

/// Zero-work items: the fixed cost and per-item slope of `policy` on `workers` workers, from
/// runs of n and 2n one-pixel items, the median slope of `reps` pairs and the median
/// intercept. n is at most `items`, fewer where a pilot run shows dear items (a blocking
/// master on a loaded machine: milliseconds per item), so that one run stays near [`RUN_S`];
/// where no pair shows a per-item cost, n is doubled (twice at most), then
/// [`ZeroWork::or_origin_bound`] is taken.
pub fn zero_work(
    policy: Policy,
    items: u32,
    workers: usize,
    reps: u32,
) -> Result<ZeroWork, SchedError> {
    zero_work_for(policy, items, workers, reps, RUN_S)
}

/// [`zero_work`] with the shorter run aiming at `target_s` instead of [`RUN_S`]. Longer runs
/// for the simulation's inputs: with 20 ms runs the master's slope at B = 2 came out 0 (the
/// 2n run no slower than the n run) in one of three probes on the quiet dev box.
pub fn zero_work_for(
    policy: Policy,
    items: u32,
    workers: usize,
    reps: u32,
    target_s: f64,
) -> Result<ZeroWork, SchedError> {
    let mut spec = SchedulerSpec::new(policy.kind(), Chunk::Tile { w: 1, h: 1 }, workers);
    spec.policy = policy;
    let pilot = decompose(PILOT_ITEMS, 1, Chunk::Tile { w: 1, h: 1 }, Order::Scanline);
    let per = RunPlan::of(&spec, &RunOptions::default())
        .and_then(|plan| run(&plan, &pilot, Sources::threads(&nothing(), &spec)))?
        .1
        .wall_s
        / PILOT_ITEMS as f64;
    let mut items = ((target_s / per.max(1e-9)) as u32).clamp(PILOT_ITEMS, items);
    let mut retries = 0;
    loop {
        let pairs = zero_work_pairs(&spec, items, reps)?;
        let z = fit(&pairs, items);
        // No pair rose with the items: their cost is below the runs' noise. Twice the items,
        // twice the signal; after the last doubling, the bound through the origin.
        if z.per_item_s > 0.0 || retries == ZERO_SLOPE_RETRIES {
            return Ok(z.or_origin_bound(&pairs, items));
        }
        retries += 1;
        items = items.saturating_mul(2);
    }
}

/// Doublings of the items when no pair of zero-work runs shows a per-item cost.
const ZERO_SLOPE_RETRIES: u32 = 2;

/// `reps` pairs of walls (n one-pixel items, 2n) of `spec` doing nothing per item.
fn zero_work_pairs(
    spec: &SchedulerSpec,
    items: u32,
    reps: u32,
) -> Result<Vec<(f64, f64)>, SchedError> {
    let lists: Vec<Vec<WorkItem>> = [items, 2 * items]
        .iter()
        .map(|&n| decompose(n, 1, Chunk::Tile { w: 1, h: 1 }, Order::Scanline))
        .collect();
    let opts = RunOptions::default();
    let wall = |l: &[WorkItem]| -> Result<f64, SchedError> {
        Ok(RunPlan::of(spec, &opts)
            .and_then(|plan| run(&plan, l, Sources::threads(&nothing(), spec)))?
            .1
            .wall_s)
    };
    let mut pairs = Vec::new();
    for k in 0..reps.max(1) {
        // Alternately n first and 2n first, so that whatever the first run of a pair pays
        // (caches, a sleeping core) falls on both sides.
        let (a, b) = if k % 2 == 0 {
            let a = wall(&lists[0])?;
            (a, wall(&lists[1])?)
        } else {
            let b = wall(&lists[1])?;
            (wall(&lists[0])?, b)
        };
        pairs.push((a, b));
    }
    Ok(pairs)
}

impl ZeroWork {
    /// This fit, or where it found no per-item cost, the most the items can cost: the median
    /// 2n-item wall over 2n with no fixed part (a per-item cost of 0 would make every hand-out
    /// free in the simulation; the master at B = 2 fitted 0 in two of three probes).
    pub fn or_origin_bound(self, pairs: &[(f64, f64)], n: u32) -> Self {
        if self.per_item_s > 0.0 || pairs.is_empty() {
            return self;
        }
        let walls = &mut pairs.iter().map(|p| p.1).collect::<Vec<_>>();
        Self {
            per_item_s: median(walls).max(0.0) / (2.0 * f64::from(n.max(1))),
            fixed_s: 0.0,
        }
    }
}

/// Per-item slope and fixed cost from pairs of walls (n items, 2n items): the median slope
/// (≥ 0), and each pair's intercept under that one slope, median (≥ 0). An intercept under
/// the pair's own slope, clamped at 0 where the 2n run came out no slower, would be that
/// pair's whole wall: in one validation run on the dev box the master at B = 2 got h = 0 and
/// F ≈ a whole zero-work run that way, added to every simulated run of it (+81 % and +131 %
/// at chunk 16).
pub fn fit(pairs: &[(f64, f64)], n: u32) -> ZeroWork {
    let n = f64::from(n.max(1));
    let slope = median(&mut pairs.iter().map(|(a, b)| (b - a) / n).collect::<Vec<_>>()).max(0.0);
    let mut fixed: Vec<f64> = pairs.iter().map(|(a, _)| a - slope * n).collect();
    ZeroWork {
        per_item_s: slope,
        fixed_s: median(&mut fixed).max(0.0),
    }
}

/// A job whose items each spin for `secs` (a stand-in of known cost).
fn spinning(secs: f64) -> Job {
    let d = std::time::Duration::from_secs_f64(secs);
    Arc::new(move |it: &WorkItem| {
        let t0 = std::time::Instant::now();
        while t0.elapsed() < d {
            std::hint::spin_loop();
        }
        TileResult {
            item: it.id,
            pixels: Default::default(),
            rays: 0,
            nonfinite: 0,
        }
    })
}

/// Item costs above this are not probed under load: a woken master waits for a core at most
/// about one scheduler time slice (Linux: 0.75 ms × (1 + log₂ CPUs), up to 3 ms), which the
/// item a source holds in its buffer then hides. Below it the wait is real: with the limit at
/// 100 µs the master at 16² tiles (0.3 ms sky tiles) went unprobed and was predicted within
/// 0.1 % of self-scheduling on skewed_x100, measured 6–31 % slower.
const LOADED_MAX_S: f64 = 4e-3;

/// The fewest items of the shorter loaded run, so that items of a few ms still give a slope.
const LOADED_MIN_ITEMS: u32 = 16;

/// Items of the shorter loaded-refill run with items costing `item_s` on `workers` workers
/// (the longer has twice as many), aiming at `target_s`; `None` where the probe is skipped.
pub fn loaded_items(item_s: f64, zero_refill_s: f64, workers: usize, target_s: f64) -> Option<u32> {
    if item_s.is_nan() || item_s <= 0.0 || item_s > LOADED_MAX_S {
        return None;
    }
    // A source takes max(item cost, zero-work period) per item: the shorter run near target_s.
    let per = item_s.max(zero_refill_s);
    let most = (4096.0 * (target_s / RUN_S).max(1.0)) as u32;
    Some(((target_s * workers as f64 / per) as u32).clamp(LOADED_MIN_ITEMS, most))
}

/// The master's refill period per source with items that each cost `item_s`: a source's time
/// per item over spinning items, P × the slope of the wall between runs of n and 2n items, so
/// the master's wake-up latency between items (which zero-work items never show) is in it and
/// the run's fixed cost is not (M-118). `zero` is the zero-work r; the larger of the two is
/// kept. Median of `reps` pairs, the shorter run about 20 ms.
pub fn loaded_refill(
    policy: Policy,
    workers: usize,
    item_s: f64,
    zero: &Overheads,
    reps: u32,
) -> Result<f64, SchedError> {
    loaded_refill_for(policy, workers, item_s, zero, reps, RUN_S)
}

/// [`loaded_refill`] with the shorter run aiming at `target_s` instead of [`RUN_S`] (and up
/// to proportionally more items).
pub fn loaded_refill_for(
    policy: Policy,
    workers: usize,
    item_s: f64,
    zero: &Overheads,
    reps: u32,
    target_s: f64,
) -> Result<f64, SchedError> {
    let n = match loaded_items(item_s, zero.refill_s, workers, target_s) {
        Some(n) if policy.needs().hand_out_thread => n,
        _ => return Ok(zero.refill_s),
    };
    let mut spec = SchedulerSpec::new(policy.kind(), Chunk::Tile { w: 1, h: 1 }, workers);
    spec.policy = policy;
    let lists: Vec<Vec<WorkItem>> = [n, 2 * n]
        .iter()
        .map(|&k| decompose(k, 1, Chunk::Tile { w: 1, h: 1 }, Order::Scanline))
        .collect();
    let job = spinning(item_s);
    let wall = |l: &[WorkItem]| -> Result<f64, SchedError> {
        Ok(RunPlan::of(&spec, &RunOptions::default())
            .and_then(|plan| run(&plan, l, Sources::threads(&job, &spec)))?
            .1
            .wall_s)
    };
    let mut per: Vec<f64> = Vec::new();
    for _ in 0..reps.max(1) {
        let a = wall(&lists[0])?;
        let b = wall(&lists[1])?;
        per.push(workers as f64 * (b - a).max(0.0) / n as f64);
    }
    Ok(median(&mut per).max(zero.refill_s))
}

/// Items of the pilot run that sizes the zero-work runs.
const PILOT_ITEMS: u32 = 128;

/// The wall time one probe run aims at.
pub const RUN_S: f64 = 20e-3;

/// Items per zero-work run: enough that the slope is well above the clock's resolution,
/// few enough that the probe takes well under a second per scheduler.
pub const PROBE_ITEMS: u32 = 8192;

/// The hand-out costs of `policy` on `workers` workers (see the module docs of
/// [`crate::studies::model`]): h = P × the zero-work slope, F the intercept; for the master r = P × its
/// slope at its buffer and h self-scheduling's.
pub fn overheads(policy: Policy, workers: usize, reps: u32) -> Result<Overheads, SchedError> {
    let p = workers as f64;
    let z = zero_work(policy, PROBE_ITEMS, workers, reps)?;
    let (fixed_s, slope) = (z.fixed_s, z.per_item_s);
    // Only a hand-out thread refills: its slope is r, and h is self-scheduling's.
    Ok(if policy.needs().hand_out_thread {
        let ss = Policy::defaults(SchedulerKind::SelfScheduling);
        let worker_slope = zero_work(ss, PROBE_ITEMS, workers, reps)?.per_item_s;
        Overheads {
            per_item_s: p * worker_slope,
            fixed_s,
            refill_s: p * slope,
        }
    } else {
        Overheads {
            per_item_s: p * slope,
            fixed_s,
            refill_s: 0.0,
        }
    })
}

/// Each item's cost in hand-out order under `spec` (its own layout), from per-pixel costs at
/// `probe_spp` scaled to `spp`: a pixel costing t keeps its fixed part `fixed_pixel_s` (a)
/// and has the rest, t − a ≥ 0, scaled by spp / probe-spp.
pub fn item_costs(
    profile: &Profile,
    spec: &SchedulerSpec,
    probe_spp: u32,
    spp: u32,
    fixed_pixel_s: f64,
) -> Vec<f64> {
    let (chunk, order) = spec.layout(profile.width, profile.height);
    decompose(profile.width, profile.height, chunk, order)
        .iter()
        .map(|it| {
            it.pixels(profile.width)
                .map(|p| scaled_pixel(profile.pixel_s[p as usize], fixed_pixel_s, probe_spp, spp))
                .sum::<f64>()
        })
        .collect()
}

/// One pixel's cost `t` at `probe_spp` as it would be at `spp`: its fixed part a stays, the
/// rest (t − a ≥ 0) scales by spp / probe-spp.
pub fn scaled_pixel(t: f64, fixed_pixel_s: f64, probe_spp: u32, spp: u32) -> f64 {
    let a = fixed_pixel_s.max(0.0);
    a.min(t) + (t - a).max(0.0) * spp as f64 / probe_spp.max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rows_and_a_probe_without_passes_have_layout_factor_one() {
        let overrides = crate::core::scene::SceneOverrides {
            width: Some(4),
            height: Some(4),
            spp: Some(1),
            ..Default::default()
        };
        let scene = Arc::new(
            crate::core::scene::load_scene(
                std::path::Path::new("scenes/cornell_box.toml"),
                &overrides,
            )
            .unwrap(),
        );
        let tracer = Arc::new(
            crate::core::tracer::AnyTracer::build(crate::core::tracer::TracerKind::Bvh, &scene, 1)
                .unwrap(),
        );
        let rows = (Chunk::Rows(1), Order::Scanline);
        let pixels = (Chunk::Tile { w: 1, h: 1 }, Order::Scatter);
        assert_eq!(layout_factor(&scene, &tracer, 1, rows, 5).unwrap(), 1.0);
        assert_eq!(layout_factor(&scene, &tracer, 1, pixels, 0).unwrap(), 1.0);
        // Measured: some positive ratio of two renders of the same 16 pixels.
        let k = layout_factor(&scene, &tracer, 2, pixels, 1).unwrap();
        assert!(k.is_finite() && k > 0.0, "{k}");
    }

    #[test]
    fn relative_spread_of_a_known_ratio() {
        // Every pair differs by ±10 % of its mean, alternating: d = ±0.1, sd 0.1 (n−1: ≈),
        // v = sd/√2.
        let a: Vec<f64> = (0..1000)
            .map(|i| if i % 2 == 0 { 1.05 } else { 0.95 })
            .collect();
        let b: Vec<f64> = (0..1000)
            .map(|i| if i % 2 == 0 { 0.95 } else { 1.05 })
            .collect();
        let v = relative_spread(&a, &b);
        assert!((v - 0.1 / 2f64.sqrt()).abs() < 1e-3, "{v}");
        assert_eq!(relative_spread(&a, &a), 0.0);
        // A preempted pixel (50×) is left out.
        let mut c = a.clone();
        c[0] = 50.0;
        assert_eq!(relative_spread(&a, &c), 0.0);
    }

    #[test]
    fn calibrated_pixels_keep_their_shares_and_sum_to_the_bulk_render() {
        // Spans inflated by a per-pixel timing cost: the sum is the bulk render's, each
        // pixel's share of it is its timed share.
        let timed = [3e-6, 1e-6, 6e-6, 2e-6];
        let bulk = 10e-6;
        let c = calibrate(&timed, bulk);
        let sum: f64 = c.iter().sum();
        assert!((sum - bulk).abs() < 1e-18, "{sum}");
        for (a, t) in c.iter().zip(&timed) {
            assert!((a / bulk - t / 12e-6).abs() < 1e-12);
        }
        // No bulk measurement: the timed costs stay.
        assert_eq!(calibrate(&timed, 0.0), timed);
        assert_eq!(calibrate(&timed, f64::NAN), timed);
    }

    #[test]
    fn bulk_passes_are_spread_evenly_after_the_pixel_passes() {
        assert_eq!(bulk_after(3, 3), [1, 1, 1]);
        assert_eq!(bulk_after(3, 15), [5, 5, 5]);
        assert_eq!(bulk_after(4, 10), [2, 3, 2, 3]);
        // Never fewer bulk passes than pixel passes, never a pixel pass without one.
        assert_eq!(bulk_after(3, 1), [1, 1, 1]);
        assert_eq!(bulk_after(0, 0), [1]);
        for (p, b) in [(2, 7), (5, 16), (3, 100)] {
            let v = bulk_after(p, b);
            assert_eq!(v.iter().sum::<u32>(), b);
            assert!(v.iter().all(|&k| k >= 1));
        }
    }

    #[test]
    fn the_fixed_cost_is_taken_under_the_median_slope() {
        // F = 1 ms, h = 1 µs per item at n = 1000; one pair whose 2n run came out faster.
        let pairs = [(2.0e-3, 3.0e-3), (2.1e-3, 2.0e-3), (2.0e-3, 3.1e-3)];
        let z = fit(&pairs, 1000);
        assert!((z.per_item_s - 1.0e-6).abs() < 1e-12, "{z:?}");
        assert!((z.fixed_s - 1.0e-3).abs() < 1e-9, "{z:?}");
        // No pair shows a per-item cost: slope 0 and F the runs' wall, not more.
        let flat = [(2.0e-3, 1.9e-3), (2.0e-3, 1.8e-3), (2.0e-3, 2.0e-3)];
        let z = fit(&flat, 1000);
        assert_eq!(z.per_item_s, 0.0);
        assert!((z.fixed_s - 2.0e-3).abs() < 1e-12);
        // ... which, kept after the retries, becomes the bound through the origin: the
        // median 2n wall (1.9 ms) over 2000 items, nothing fixed.
        let b = z.or_origin_bound(&flat, 1000);
        assert!((b.per_item_s - 0.95e-6).abs() < 1e-15, "{b:?}");
        assert_eq!(b.fixed_s, 0.0);
        // A fit that found a slope is kept as it is.
        let z = fit(&pairs, 1000);
        assert_eq!(z.or_origin_bound(&pairs, 1000), z);
    }

    #[test]
    fn the_per_item_cost_is_the_timed_excess_over_the_items_the_rows_do_not_have() {
        // 100×10 pixels timed one by one sum to 1.1 ms, the 10 rows to 1.0 ms: the 990
        // extra items cost 0.1 ms, c ≈ 101 ns.
        let c = per_item_cost(1.1e-3, 1.0e-3, 1000, 10);
        assert!((c - 1e-4 / 990.0).abs() < 1e-15, "{c}");
        // A timed render below the bulk one (noise) or no extra items: no cost.
        assert_eq!(per_item_cost(0.9e-3, 1.0e-3, 1000, 10), 0.0);
        assert_eq!(per_item_cost(1.1e-3, 1.0e-3, 10, 10), 0.0);
        assert_eq!(per_item_cost(f64::NAN, 1.0e-3, 1000, 10), 0.0);
    }

    #[test]
    fn the_loaded_refill_is_probed_up_to_items_of_a_time_slice() {
        // 0.3 ms sky tiles (a 16² tile of skewed_x100 at 16 spp) are probed: 20 ms of them
        // per worker on 2 workers; 4 ms items get the fewest items; 10 ms items are skipped.
        assert_eq!(loaded_items(300e-6, 1e-6, 2, RUN_S), Some(133));
        assert_eq!(loaded_items(4e-3, 1e-6, 2, RUN_S), Some(LOADED_MIN_ITEMS));
        assert_eq!(loaded_items(10e-3, 1e-6, 2, RUN_S), None);
        // Cheap items: the zero-work period sets the pace, up to the cap.
        assert_eq!(loaded_items(1e-6, 100e-6, 2, RUN_S), Some(400));
        assert_eq!(loaded_items(1e-9, 1e-9, 2, RUN_S), Some(4096));
        assert_eq!(loaded_items(f64::NAN, 1e-6, 2, RUN_S), None);
        assert_eq!(loaded_items(0.0, 1e-6, 2, RUN_S), None);
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&mut []).is_nan());
    }

    #[test]
    fn item_costs_sum_pixels_in_hand_out_order_and_scale_with_spp() {
        let p = Profile {
            width: 4,
            height: 2,
            pixel_s: vec![1.0, 1.0, 3.0, 3.0, 1.0, 1.0, 3.0, 3.0],
        };
        let s = SchedulerSpec::new(SchedulerKind::SelfScheduling, Chunk::Tile { w: 2, h: 2 }, 2);
        assert_eq!(item_costs(&p, &s, 1, 1, 0.0), [4.0, 12.0]);
        assert_eq!(item_costs(&p, &s, 2, 8, 0.0), [16.0, 48.0]);
        // A fixed part of 0.5 per pixel stays: a 1-pixel is 0.5 + 0.5·4, a 3-pixel 0.5 + 2.5·4.
        assert_eq!(item_costs(&p, &s, 2, 8, 0.5), [4.0 * 2.5, 4.0 * 10.5]);
    }

    #[test]
    fn the_fixed_part_of_a_pixel_solves_two_sample_counts() {
        // 1000 pixels of a = 1 µs and b = 2 µs per sample: 4 spp → 9 ms, 1 spp → 3 ms.
        let a = fixed_per_pixel(9e-3, 3e-3, 4, 1000);
        assert!((a - 1e-6).abs() < 1e-15, "{a}");
        // Costs that scale exactly with spp have no fixed part; noise below zero is clamped,
        // and a 1-spp probe has nothing to split.
        assert_eq!(fixed_per_pixel(12e-3, 3e-3, 4, 1000), 0.0);
        assert_eq!(fixed_per_pixel(13e-3, 3e-3, 4, 1000), 0.0);
        assert_eq!(fixed_per_pixel(3e-3, 3e-3, 1, 1000), 0.0);
        // At most the whole 1-spp pixel.
        assert!((fixed_per_pixel(3e-3, 3e-3, 4, 1000) - 3e-6).abs() < 1e-15);
    }
}
