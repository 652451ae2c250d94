//! Error against run time: render progressively (samples 0..1, 1..2, 2..4, …, reusing every
//! earlier sample: samples are counter-based, so the sum over 0..N is exactly the sum of the
//! steps) and after each step record wall time and the error against a [`reference`].
//!
//! Plain Monte Carlo error falls as spp^−½, hence as time^−½ at a fixed ray cost: the log-log
//! slope of RMSE against wall time should be −½; a configuration is better than another when
//! it reaches a lower error for the same time budget ([`error_at_budget`]).

pub mod exact;
mod plot;
pub mod reference;

pub use plot::{plot, PlotError};

pub use reference::{Reference, ReferenceKind};

use crate::core::render::{render_moments, Moments, TileResult, WorkItem};
use crate::core::scene::Scene;
use crate::core::tracer::Tracer;
use crate::sched::{
    decompose, rows_spec, run, RunOptions, RunPlan, SchedError, SchedulerSpec, Sources,
};
use crate::source::Job;
use crate::util::csv_out::CsvError;
use serde::{Deserialize, Serialize};
use std::ops::Range;
use std::path::Path;
use std::sync::{Arc, OnceLock};
use std::time::Instant;

/// One step of a progressive render: the image after `spp` samples against the reference.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ConvergenceRow {
    /// Scene name.
    pub scene: String,
    /// Tracer id.
    pub tracer: String,
    /// Scheduler label ([`ROWS_RAYON`] for [`run_convergence`]).
    pub scheduler: String,
    /// Worker threads.
    pub threads: usize,
    /// How the reference image was obtained ([`ReferenceKind::label`]).
    pub reference: String,
    /// Step index, from 0.
    pub step: u32,
    /// Samples per pixel accumulated so far (1, 2, 4, … `max_spp`).
    pub spp: u32,
    /// Cumulative render time of all steps so far (reference and setup excluded).
    pub wall_s: f64,
    /// Root-mean-square error against the truth, over pixels and channels: the RMSE against
    /// the reference with the reference's own noise taken out, `√max(0, MSE − noise_mse)`
    /// (the reference is rendered with another seed, so the two errors add).
    pub rmse: f64,
    /// Root-mean-square error against the reference as it is (noise included).
    #[serde(default)]
    pub rmse_raw: f64,
    /// The reference's own noise as an RMSE (0 for analytic references).
    #[serde(default)]
    pub ref_noise_rmse: f64,
    /// Mean of (x − r)²/(r² + 0.01) over pixels and channels.
    pub rel_mse: f64,
    /// Mean absolute error over pixels and channels.
    pub mae: f64,
    /// Largest absolute error of any pixel channel.
    pub max_err: f64,
    /// Pixels with at least one NaN/Inf sample so far (those samples are dropped, counted).
    pub nonfinite_pixels: u64,
    /// NaN/Inf samples dropped so far, over all pixels.
    pub nonfinite_samples: u64,
    /// Tracer queries (closest-hit and occlusion) of all steps so far.
    pub rays: u64,
}

/// Error statistics of `estimate` against `reference` (f64, RGB interleaved).
fn errors(estimate: &[[f64; 3]], reference: &[[f32; 3]]) -> (f64, f64, f64, f64) {
    let (mut se, mut rel, mut ae, mut max) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (x, r) in estimate.iter().zip(reference) {
        for c in 0..3 {
            let r = r[c] as f64;
            let d = x[c] - r;
            se += d * d;
            rel += d * d / (r * r + 0.01);
            ae += d.abs();
            max = max.max(d.abs());
        }
    }
    let n = (estimate.len() * 3).max(1) as f64;
    ((se / n).sqrt(), rel / n, ae / n, max)
}

/// Render `scene` progressively up to `max_spp` (1, 2, 4, … and `max_spp` last) on `threads`
/// row-parallel workers ([`crate::sched::rows_spec`], through the one run path), and compare
/// each cumulative image with `reference`. The rows are labelled [`ROWS_RAYON`].
///
/// # Errors
/// The scheduler's error (a worker thread that panicked).
pub fn run_convergence<T: Tracer + 'static>(
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    reference: &Reference,
    max_spp: u32,
    threads: usize,
) -> Result<Vec<ConvergenceRow>, SchedError> {
    let spec = rows_spec(threads);
    let label = Label {
        tracer: tracer.id().to_string(),
        scheduler: ROWS_RAYON.into(),
        threads,
    };
    scheduled(scene, tracer, reference, max_spp, &spec, &label)
}

/// The scheduler label of [`run_convergence`]'s rows: the row-parallel baseline. It ran on a
/// rayon pool before it went through `sched::run`; the label stays, so that earlier
/// `convergence.csv` files compare with new ones (the errors are bit-identical).
pub const ROWS_RAYON: &str = "rows_rayon";

/// [`run_convergence`] with every step rendered under the scheduler `spec` (its workers, its
/// chunk, its hand-out): a step's wall time is that scheduler's time for samples `lo..hi` of
/// the whole image, threads and sources started and joined included, as in a timing run.
/// Pixel sums are the same f64 sums in the same sample order whoever renders them, so the
/// images, and every error column, are bit-identical to [`run_convergence`]'s.
///
/// # Errors
/// The scheduler's error (an invalid spec, a lost item).
pub fn run_convergence_scheduled<T: Tracer + 'static>(
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    reference: &Reference,
    max_spp: u32,
    spec: &SchedulerSpec,
) -> Result<Vec<ConvergenceRow>, SchedError> {
    let label = Label {
        tracer: tracer.id().to_string(),
        scheduler: spec.label(),
        threads: spec.workers,
    };
    scheduled(scene, tracer, reference, max_spp, spec, &label)
}

/// The progression under `spec`, its rows labelled `label`.
fn scheduled<T: Tracer + 'static>(
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    reference: &Reference,
    max_spp: u32,
    spec: &SchedulerSpec,
    label: &Label,
) -> Result<Vec<ConvergenceRow>, SchedError> {
    spec.validate()?;
    let items = decompose(scene.width(), scene.height(), spec.chunk, spec.order);
    // Per-step clocks off: the probe's clock reads would be timed as rendering.
    let opts = RunOptions {
        stats: false,
        ..RunOptions::default()
    };
    let width = scene.width() as usize;
    let n = scene.pixel_count();
    let step = |range: Range<u32>| -> Result<(Moments, f64), SchedError> {
        // The job hands back f32 means (what a source would send); the exact f64 moments go
        // to a per-item slot, first result wins (a re-issued item renders the same bits).
        let slots: Arc<Vec<OnceLock<Moments>>> =
            Arc::new((0..items.len()).map(|_| OnceLock::new()).collect());
        let job: Job = {
            let (scene, tracer, slots) = (scene.clone(), tracer.clone(), slots.clone());
            let range = range.clone();
            Arc::new(move |item: &WorkItem| {
                let m = render_moments(&scene, &*tracer, item, range.clone(), false);
                let r = TileResult {
                    item: item.id,
                    pixels: m
                        .sums
                        .iter()
                        .zip(&m.counts)
                        .map(|(s, &c)| s.map(|v| (v / c.max(1) as f64) as f32))
                        .collect(),
                    rays: m.rays,
                    nonfinite: m.nonfinite,
                };
                let _ = slots[item.id as usize].set(m);
                r
            })
        };
        let t0 = Instant::now();
        RunPlan::of(spec, &opts)
            .and_then(|plan| run(&plan, &items, Sources::threads(&job, spec)))?;
        let wall = t0.elapsed().as_secs_f64();
        let mut all = Moments {
            sums: vec![[0.0; 3]; n],
            counts: vec![0; n],
            ..Default::default()
        };
        for item in &items {
            let m = slots[item.id as usize]
                .get()
                .ok_or(SchedError::Missing { item: item.id })?;
            for (k, idx) in item.pixels(width as u32).enumerate() {
                all.sums[idx as usize] = m.sums[k];
                all.counts[idx as usize] = m.counts[k];
            }
            all.rays += m.rays;
            all.nonfinite += m.nonfinite;
        }
        Ok((all, wall))
    };
    progressive(scene, reference, max_spp, label, step)
}

/// Who rendered a progressive run (the CSV's configuration columns).
struct Label {
    tracer: String,
    scheduler: String,
    threads: usize,
}

/// The progression 1, 2, 4, … `max_spp`: `step(lo..hi)` renders samples `lo..hi` of every
/// pixel and returns their moments and its wall time; the sums accumulate across steps.
fn progressive<E>(
    scene: &Scene,
    reference: &Reference,
    max_spp: u32,
    label: &Label,
    mut step: impl FnMut(Range<u32>) -> Result<(Moments, f64), E>,
) -> Result<Vec<ConvergenceRow>, E> {
    let n = scene.pixel_count();
    let mut acc = Moments {
        sums: vec![[0.0; 3]; n],
        counts: vec![0; n],
        ..Default::default()
    };
    let mut rows = Vec::new();
    let mut wall = 0.0;
    let (mut lo, mut k) = (0u32, 0u32);
    while lo < max_spp.max(1) {
        let hi = if lo == 0 { 1 } else { (lo * 2).min(max_spp) };
        let (m, dt) = step(lo..hi)?;
        wall += dt;
        for i in 0..n {
            for c in 0..3 {
                acc.sums[i][c] += m.sums[i][c];
            }
            acc.counts[i] += m.counts[i];
        }
        acc.rays += m.rays;
        acc.nonfinite += m.nonfinite;
        let inv = 1.0 / hi as f64;
        let est: Vec<[f64; 3]> = acc.sums.iter().map(|s| s.map(|v| v * inv)).collect();
        let (rmse_raw, rel_mse, mae, max_err) = errors(&est, &reference.image.data);
        let rmse = (rmse_raw * rmse_raw - reference.noise_mse).max(0.0).sqrt();
        rows.push(ConvergenceRow {
            scene: scene.name.clone(),
            tracer: label.tracer.clone(),
            scheduler: label.scheduler.clone(),
            threads: label.threads,
            reference: reference.kind.label(),
            step: k,
            spp: hi,
            wall_s: wall,
            rmse,
            rmse_raw,
            ref_noise_rmse: reference.noise_mse.sqrt(),
            rel_mse,
            mae,
            max_err,
            nonfinite_pixels: acc.counts.iter().filter(|&&c| c < hi).count() as u64,
            nonfinite_samples: acc.nonfinite,
            rays: acc.rays,
        });
        lo = hi;
        k += 1;
    }
    Ok(rows)
}

/// Least-squares slope of log(rmse) against log(wall_s) over rows with both positive.
pub fn fitted_slope(rows: &[ConvergenceRow]) -> Option<f64> {
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.wall_s > 0.0 && r.rmse > 0.0)
        .map(|r| (r.wall_s.ln(), r.rmse.ln()))
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let k = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / k;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / k;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// RMSE at wall time `budget`, interpolated in log-log between the rows around it; `None`
/// when the run never reached that budget.
pub fn error_at_budget(rows: &[ConvergenceRow], budget: f64) -> Option<f64> {
    let pts: Vec<&ConvergenceRow> = rows
        .iter()
        .filter(|r| r.wall_s > 0.0 && r.rmse > 0.0)
        .collect();
    let first = pts.first()?;
    if budget < first.wall_s {
        return None;
    }
    for w in pts.windows(2) {
        let (a, b) = (w[0], w[1]);
        if budget <= b.wall_s {
            let f = (budget.ln() - a.wall_s.ln()) / (b.wall_s.ln() - a.wall_s.ln()).max(1e-300);
            return Some((a.rmse.ln() + f * (b.rmse.ln() - a.rmse.ln())).exp());
        }
    }
    (budget <= pts.last()?.wall_s)
        .then(|| pts.last().map(|r| r.rmse))
        .flatten()
}

/// Per configuration (scene, tracer, scheduler, threads): slope and the RMSE at the largest
/// budget every configuration of the same scene reached. Best (lowest error) first per scene.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ConvergenceSummary {
    /// Scene name.
    pub scene: String,
    /// The configuration, as `tracer/scheduler/<threads>t`.
    pub config: String,
    /// [`fitted_slope`] of the configuration's rows (`None`: fewer than two usable rows).
    pub slope: Option<f64>,
    /// The common budget, in seconds: the largest wall time every configuration of the scene
    /// reached.
    pub budget_s: f64,
    /// [`error_at_budget`] at `budget_s` (`None`: the first step took longer than the budget).
    pub rmse_at_budget: Option<f64>,
}

fn config_key(r: &ConvergenceRow) -> (String, String) {
    (
        r.scene.clone(),
        format!("{}/{}/{}t", r.tracer, r.scheduler, r.threads),
    )
}

/// Group `rows` by configuration and summarise each ([`ConvergenceSummary`]), sorted by scene,
/// then by RMSE at the budget (lowest first, configurations without one last).
pub fn summarise(rows: &[ConvergenceRow]) -> Vec<ConvergenceSummary> {
    let mut groups: std::collections::BTreeMap<(String, String), Vec<ConvergenceRow>> =
        Default::default();
    for r in rows {
        groups.entry(config_key(r)).or_default().push(r.clone());
    }
    let mut budget: std::collections::BTreeMap<String, f64> = Default::default();
    for ((scene, _), g) in &groups {
        let end = g.iter().map(|r| r.wall_s).fold(0.0, f64::max);
        let b = budget.entry(scene.clone()).or_insert(f64::INFINITY);
        *b = b.min(end);
    }
    let mut out: Vec<ConvergenceSummary> = groups
        .iter()
        .map(|((scene, config), g)| ConvergenceSummary {
            scene: scene.clone(),
            config: config.clone(),
            slope: fitted_slope(g),
            budget_s: budget[scene],
            rmse_at_budget: error_at_budget(g, budget[scene]),
        })
        .collect();
    out.sort_by(|a, b| {
        a.scene.cmp(&b.scene).then(
            a.rmse_at_budget
                .unwrap_or(f64::INFINITY)
                .total_cmp(&b.rmse_at_budget.unwrap_or(f64::INFINITY)),
        )
    });
    out
}

/// Per scene, one sentence answering "given the same time budget, which configuration gives
/// the lowest error?": the budget is the largest wall time every configuration of the scene
/// reached, each curve read there by log-log interpolation ([`error_at_budget`]).
pub fn budget_winners(rows: &[ConvergenceRow]) -> Vec<String> {
    let summary = summarise(rows);
    let mut out = Vec::new();
    let mut scenes: Vec<&str> = summary.iter().map(|s| s.scene.as_str()).collect();
    scenes.dedup();
    for scene in scenes {
        let g: Vec<&ConvergenceSummary> = summary.iter().filter(|s| s.scene == scene).collect();
        let reached: Vec<&&ConvergenceSummary> =
            g.iter().filter(|s| s.rmse_at_budget.is_some()).collect();
        let (Some(best), Some(worst)) = (reached.first(), reached.last()) else {
            out.push(format!(
                "{scene}: no configuration has an error at a common time budget"
            ));
            continue;
        };
        let (b, w) = (
            best.rmse_at_budget.unwrap_or(0.0),
            worst.rmse_at_budget.unwrap_or(0.0),
        );
        let mut line = format!(
            "{scene}: at a time budget of {:.4} s (the largest time all {} configurations \
             reached) the lowest RMSE is {} ({b:.5})",
            best.budget_s,
            g.len(),
            best.config
        );
        if reached.len() > 1 {
            line += &format!(
                "; the highest is {} ({w:.5}, {:.2}× the lowest)",
                worst.config,
                w / b.max(f64::MIN_POSITIVE)
            );
        }
        let late: Vec<&str> = g
            .iter()
            .filter(|s| s.rmse_at_budget.is_none())
            .map(|s| s.config.as_str())
            .collect();
        if !late.is_empty() {
            line += &format!(
                "; no image yet at that time (first step slower than the budget): {}",
                late.join(", ")
            );
        }
        out.push(line);
    }
    out
}

/// Write rows as CSV (one row per step, fixed units: seconds).
///
/// # Errors
/// I/O or CSV errors.
pub fn write_csv(path: &Path, rows: &[ConvergenceRow]) -> Result<(), CsvError> {
    crate::util::csv_out::write_rows(path, rows)
}

/// Read rows back (plots are drawn from the CSV, never from memory).
///
/// # Errors
/// I/O or CSV errors.
pub fn read_csv(path: &Path) -> Result<Vec<ConvergenceRow>, CsvError> {
    let mut r = csv::Reader::from_path(path)?;
    Ok(r.deserialize().collect::<Result<_, _>>()?)
}
