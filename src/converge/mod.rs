//! Error against run time: render progressively (samples 0..1, 1..2, 2..4, …, reusing every
//! earlier sample: samples are counter-based, so the sum over 0..N is exactly the sum of the
//! steps) and after each step record wall time and the error against a [`reference`].
//!
//! Plain Monte Carlo error falls as spp^−½, hence as time^−½ at a fixed ray cost: the log-log
//! slope of RMSE against wall time should be −½; a configuration is better than another when
//! it reaches a lower error for the same time budget ([`error_at_budget`]).

pub mod reference;

pub use reference::{Reference, ReferenceKind};

use crate::render::Moments;
use crate::scene::Scene;
use crate::tracer::Tracer;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::Instant;

/// One step of a progressive render: the image after `spp` samples against the reference.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ConvergenceRow {
    pub scene: String,
    pub tracer: String,
    pub scheduler: String,
    pub threads: usize,
    pub reference: String,
    pub step: u32,
    pub spp: u32,
    /// Cumulative render time of all steps so far (reference and setup excluded).
    pub wall_s: f64,
    pub rmse: f64,
    /// Mean of (x − r)²/(r² + 0.01) over pixels and channels.
    pub rel_mse: f64,
    pub mae: f64,
    pub max_err: f64,
    /// Pixels with at least one NaN/Inf sample so far (those samples are dropped, counted).
    pub nonfinite_pixels: u64,
    pub nonfinite_samples: u64,
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
/// row-parallel workers, and compare each cumulative image with `reference`.
pub fn run_convergence<T: Tracer + ?Sized>(
    scene: &Scene,
    tracer: &T,
    reference: &Reference,
    max_spp: u32,
    threads: usize,
) -> Vec<ConvergenceRow> {
    let n = scene.pixel_count();
    let mut acc = Moments {
        sums: vec![[0.0; 3]; n],
        counts: vec![0; n],
        ..Default::default()
    };
    let mut rows = Vec::new();
    let mut wall = 0.0;
    let (mut lo, mut step) = (0u32, 0u32);
    // One pool for the whole run: building it per step would be timed as rendering.
    let pool = match rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
    {
        Ok(p) => p,
        Err(_) => return rows,
    };
    while lo < max_spp.max(1) {
        let hi = if lo == 0 { 1 } else { (lo * 2).min(max_spp) };
        let t0 = Instant::now();
        let m = reference::image_moments_in(&pool, scene, tracer, lo..hi, false);
        wall += t0.elapsed().as_secs_f64();
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
        let (rmse, rel_mse, mae, max_err) = errors(&est, &reference.image.data);
        rows.push(ConvergenceRow {
            scene: scene.name.clone(),
            tracer: tracer.id().to_string(),
            scheduler: "rows_rayon".into(),
            threads,
            reference: reference.kind.label(),
            step,
            spp: hi,
            wall_s: wall,
            rmse,
            rel_mse,
            mae,
            max_err,
            nonfinite_pixels: acc.counts.iter().filter(|&&c| c < hi).count() as u64,
            nonfinite_samples: acc.nonfinite,
            rays: acc.rays,
        });
        lo = hi;
        step += 1;
    }
    rows
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
    pub scene: String,
    pub config: String,
    pub slope: Option<f64>,
    pub budget_s: f64,
    pub rmse_at_budget: Option<f64>,
}

fn config_key(r: &ConvergenceRow) -> (String, String) {
    (
        r.scene.clone(),
        format!("{}/{}/{}t", r.tracer, r.scheduler, r.threads),
    )
}

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

/// Write rows as CSV (one row per step, fixed units: seconds).
///
/// # Errors
/// I/O or CSV errors.
pub fn write_csv(path: &Path, rows: &[ConvergenceRow]) -> anyhow::Result<()> {
    crate::csv_out::write_rows(path, rows)
}

/// Read rows back (plots are drawn from the CSV, never from memory).
///
/// # Errors
/// I/O or CSV errors.
pub fn read_csv(path: &Path) -> anyhow::Result<Vec<ConvergenceRow>> {
    let mut r = csv::Reader::from_path(path)?;
    Ok(r.deserialize().collect::<Result<_, _>>()?)
}

static FONT: std::sync::Once = std::sync::Once::new();

fn register_font() {
    FONT.call_once(|| {
        let _ = plotters::style::register_font(
            "sans-serif",
            plotters::style::FontStyle::Normal,
            include_bytes!("../../assets/fonts/DejaVuSans.ttf"),
        );
    });
}

/// Log-log plot of RMSE against wall time, one series per configuration, each with its fitted
/// slope in the legend, plus a dashed −½ guide through the first point. `.png` or `.svg`.
///
/// # Errors
/// Drawing errors, or no rows with positive time and error.
pub fn plot(path: &Path, rows: &[ConvergenceRow]) -> anyhow::Result<()> {
    use plotters::prelude::*;
    register_font();
    let pts: Vec<&ConvergenceRow> = rows
        .iter()
        .filter(|r| r.wall_s > 0.0 && r.rmse > 0.0)
        .collect();
    anyhow::ensure!(
        !pts.is_empty(),
        "no rows with positive wall time and error to plot"
    );
    if let Some(d) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d)?;
    }
    match path.extension().and_then(|e| e.to_str()) {
        Some("svg") => draw_plot(SVGBackend::new(path, (800, 600)).into_drawing_area(), rows),
        _ => draw_plot(
            BitMapBackend::new(path, (800, 600)).into_drawing_area(),
            rows,
        ),
    }
}

fn draw_plot<DB: plotters::prelude::DrawingBackend>(
    root: plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    rows: &[ConvergenceRow],
) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let pts: Vec<&ConvergenceRow> = rows
        .iter()
        .filter(|r| r.wall_s > 0.0 && r.rmse > 0.0)
        .collect();
    let (x0, x1) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| {
        (a.min(r.wall_s), b.max(r.wall_s))
    });
    let (y0, y1) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| {
        (a.min(r.rmse), b.max(r.rmse))
    });
    root.fill(&WHITE).map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut scenes: Vec<&str> = pts.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    scenes.sort_unstable();
    scenes.dedup();
    let title = format!("RMSE vs wall time ({})", scenes.join(", "));
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(
            (x0 / 1.5..x1 * 1.5).log_scale(),
            (y0 / 1.5..y1 * 1.5).log_scale(),
        )
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    chart
        .configure_mesh()
        .x_desc("wall time [s]")
        .y_desc("RMSE")
        .x_label_formatter(&|v| format!("{v:.2e}"))
        .y_label_formatter(&|v| format!("{v:.2e}"))
        .draw()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut groups: std::collections::BTreeMap<(String, String), Vec<ConvergenceRow>> =
        Default::default();
    for r in rows {
        groups.entry(config_key(r)).or_default().push(r.clone());
    }
    for (k, ((scene, config), g)) in groups.iter().enumerate() {
        let colour = Palette99::pick(k).to_rgba();
        let series: Vec<(f64, f64)> = g
            .iter()
            .filter(|r| r.wall_s > 0.0 && r.rmse > 0.0)
            .map(|r| (r.wall_s, r.rmse))
            .collect();
        let slope = fitted_slope(g).map_or("n/a".into(), |s| format!("{s:.2}"));
        chart
            .draw_series(LineSeries::new(series.clone(), colour.stroke_width(2)))
            .map_err(|e| anyhow::anyhow!("{e}"))?
            .label(format!("{scene} {config}: slope {slope}"))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], colour));
        chart
            .draw_series(series.iter().map(|&p| Circle::new(p, 3, colour.filled())))
            .map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    // The −½ guide through the first point of the first series.
    let (gx, gy) = (pts[0].wall_s, pts[0].rmse);
    let guide: Vec<(f64, f64)> = (0..=20)
        .map(|i| {
            let x = x0 * (x1 / x0).powf(i as f64 / 20.0);
            (x, gy * (x / gx).powf(-0.5))
        })
        .collect();
    chart
        .draw_series(DashedLineSeries::new(guide, 6, 4, BLACK.stroke_width(1)))
        .map_err(|e| anyhow::anyhow!("{e}"))?
        .label("slope −½ guide")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], BLACK));
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    root.present().map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok(())
}
