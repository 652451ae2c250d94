//! Plots drawn from `runs.csv` (and `timelines/*.csv`) alone, never from in-memory state, so any
//! old run can be re-plotted with `raysched plot results/<experiment>`. Every figure is written
//! as PNG (bitmap backend) and SVG, with the bundled DejaVu Sans (no system fonts needed).

#[cfg(test)]
mod audit;
pub mod axes;
mod charts;
pub mod compare;
pub mod font;
pub mod html;
pub mod prediction;
pub mod raster;
pub mod report;
pub mod self_tuning;
pub mod style;

pub(crate) use charts::{line_chart, scatter_vs, Lines, ScatterGroup, Series};
pub use charts::{mpi_line, palette, throughput, Figure};
pub use font::register_font;

use crate::studies::experiment::summary::{self, Summary};
use crate::studies::experiment::{convergence, meta, results};
use crate::util::one_line::escape_controls;
use crate::util::staging::Staging;
use std::path::{Path, PathBuf};

/// Why a results folder's summary, charts or report were not drawn, in one line.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// A file or folder could not be read, written or understood.
    #[error("{}: {msg}", escape_controls(&path.to_string_lossy()))]
    File {
        /// The file or folder.
        path: PathBuf,
        /// What went wrong with it.
        msg: String,
    },
    /// A chart could not be drawn (the message names the chart).
    #[error("{0}")]
    Chart(String),
    /// `runs.csv` could not be read (the message names it).
    #[error(transparent)]
    Runs(#[from] results::ResultsError),
}

impl PlotError {
    fn at(path: &Path, e: impl std::fmt::Display) -> Self {
        PlotError::File {
            path: path.to_path_buf(),
            msg: e.to_string(),
        }
    }
}

/// Draw every figure the data supports into `dir/plots/`; returns them for `report.md`.
pub fn draw_all(dir: &Path, sums: &[Summary]) -> Result<Vec<Figure>, PlotError> {
    register_font();
    let plots = dir.join("plots");
    std::fs::create_dir_all(&plots).map_err(|e| PlotError::at(&plots, e))?;
    charts::draw_all(dir, &plots, &plots, true, sums).map_err(PlotError::Chart)
}

/// The largest magnitude a plotted value may have: plotters computes its tick marks in loops
/// that never end on an infinite or NaN range (and overflow on ranges near f64's limits).
const PLOTTABLE: f64 = 1e15;

/// Is every measured value of `r` finite and within [`PLOTTABLE`]?
fn plottable(r: &results::RunRow) -> bool {
    [
        r.wall_s,
        r.serial_s,
        r.speedup,
        r.efficiency,
        r.overhead_s,
        r.work_s,
        r.dispatch_s,
        r.idle_s,
        r.imbalance,
        r.imbalance_s,
    ]
    .iter()
    .all(|v| v.is_finite() && v.abs() <= PLOTTABLE)
        && r.chunk_px != Some(0)
}

/// The first row holding a negative time (a wall time, a serial time or a part of one), as
/// "line N: wall_s = -0.1 is negative": no clock gives one, so the file was edited or
/// damaged, and no reading of it can be trusted. Lines count the header as line 1.
fn negative_time(rows: &[results::RunRow]) -> Option<String> {
    rows.iter().enumerate().find_map(|(i, r)| {
        let cols = [
            ("wall_s", r.wall_s),
            ("serial_s", r.serial_s),
            ("work_s", r.work_s),
            ("dispatch_s", r.dispatch_s),
            ("idle_s", r.idle_s),
            ("imbalance_s", r.imbalance_s),
        ];
        let (name, v) = cols.into_iter().find(|(_, v)| *v < 0.0)?;
        Some(format!(
            "line {}, column {name}: {v} is negative (a time cannot be); fix or remove the row",
            i + 2
        ))
    })
}

/// The warnings of the run in `dir` (see [`report::warnings`]), from its CSV and meta alone.
pub fn warnings_of(dir: &Path) -> Vec<String> {
    let Ok((rows, _)) = results::read_runs(&dir.join("runs.csv")) else {
        return vec![];
    };
    let (rows, _) = meta::current_rows_in(dir, rows);
    let meta: Option<meta::Meta> = std::fs::read_to_string(dir.join("meta.toml"))
        .ok()
        .and_then(|t| toml::from_str(&t).ok());
    report::warnings(meta.as_ref(), &summary::summarize(&rows))
}

/// Recompute `summary.csv`, every plot and `report.md` in `dir` from `dir/runs.csv` (for a
/// convergence experiment: its plot from `convergence.csv`). Returns the paths written.
/// Rows holding an infinite, NaN or absurd value are left out (and counted in the report and
/// on stderr). Everything is written to a staging folder and moved into place at the end, so a
/// failure leaves the previous files.
pub fn redraw(dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    redraw_scaled(dir, raster::PngScale::ONE)
}

/// [`redraw`], with every PNG rasterised from its SVG at `png_scale` when that is not 1:
/// print-quality figures.
pub fn redraw_scaled(dir: &Path, png_scale: raster::PngScale) -> Result<Vec<PathBuf>, PlotError> {
    let runs = dir.join("runs.csv");
    let convergence = dir.join("convergence.csv");
    let staging = Staging::new(dir).map_err(|e| PlotError::at(dir, e))?;
    if !runs.exists() && convergence.exists() {
        // A convergence experiment: its plots are drawn from its CSV alone too.
        return redraw_convergence(dir, &convergence, staging, png_scale);
    }
    if !runs.exists() {
        let msg = format!(
            "not found (is {} an experiment results folder?)",
            escape_controls(&dir.to_string_lossy())
        );
        return Err(PlotError::at(&runs, msg));
    }
    let rows = plottable_rows(dir, &runs)?;
    let sums = summary::summarize(&rows.rows);
    summary::write_summary(&staging.path("summary.csv"), &sums)
        .map_err(|e| PlotError::at(&dir.join("summary.csv"), e))?;
    register_font();
    let real_plots = dir.join("plots");
    let plots = staging
        .dir("plots")
        .map_err(|e| PlotError::at(&real_plots, e))?;
    let json = crate::studies::experiment::export::write_json(dir, &rows.rows, &sums)
        .map_err(|e| PlotError::at(dir, e))?;
    let bitmap = png_scale == raster::PngScale::ONE;
    let figs =
        charts::draw_all(dir, &plots, &real_plots, bitmap, &sums).map_err(PlotError::Chart)?;
    if !bitmap {
        rasterise_figures(dir, &plots, &figs, png_scale)?;
    }
    write_reports(dir, &staging, &plots, &rows, &sums, &figs)?;
    staging.commit().map_err(|e| PlotError::at(dir, e))?;
    let mut out = vec![
        dir.join("summary.csv"),
        dir.join("report.md"),
        dir.join("report.html"),
    ];
    out.extend(json);
    out.extend(figs.iter().map(|f| dir.join(&f.file)));
    Ok(out)
}

/// A convergence experiment's plots, from its `convergence.csv` alone; at a PNG scale other
/// than 1, every PNG rasterised from its SVG.
fn redraw_convergence(
    dir: &Path,
    csv: &Path,
    staging: Staging,
    png_scale: raster::PngScale,
) -> Result<Vec<PathBuf>, PlotError> {
    let bitmap = png_scale == raster::PngScale::ONE;
    let rows = crate::studies::converge::read_csv(csv).map_err(|e| PlotError::at(csv, e))?;
    for p in convergence::PLOTS
        .iter()
        .filter(|p| bitmap || !p.ends_with(".png"))
    {
        let staged = staging.path(p);
        if let Some(d) = staged.parent() {
            std::fs::create_dir_all(d).map_err(|e| PlotError::at(d, e))?;
        }
        crate::studies::converge::plot(&staged, &rows)
            .map_err(|e| PlotError::at(&dir.join(p), e))?;
    }
    for p in convergence::PLOTS
        .iter()
        .filter(|p| !bitmap && p.ends_with(".png"))
    {
        let png = staging.path(p);
        raster::svg_to_png(&png.with_extension("svg"), &png, png_scale)
            .map_err(|e| PlotError::at(&png, e))?;
    }
    staging.commit().map_err(|e| PlotError::at(dir, e))?;
    Ok(convergence::PLOTS.map(|p| dir.join(p)).to_vec())
}

/// The rows of `runs.csv` that the summary, plots and report read, and what was left out.
struct Plottable {
    rows: Vec<results::RunRow>,
    /// Rows holding an infinite, NaN or absurd value.
    bad: usize,
    /// Rows of configurations the experiment file no longer names.
    retired: usize,
}

/// Reads `runs`: a negative time is an error; rows of retired configurations stay in
/// runs.csv only, and rows with a value no chart can hold are counted and left out.
fn plottable_rows(dir: &Path, runs: &Path) -> Result<Plottable, PlotError> {
    let (all, _) = results::read_runs(runs)?;
    if let Some(msg) = negative_time(&all) {
        return Err(PlotError::at(runs, msg));
    }
    let (all, retired) = meta::current_rows_in(dir, all);
    let (rows, bad): (Vec<_>, Vec<_>) = all.into_iter().partition(plottable);
    if !bad.is_empty() {
        eprintln!(
            "warning: {}: {} row(s) hold an infinite, NaN or out-of-range value (|x| > {PLOTTABLE:e}) and are left out of summary, plots and report",
            runs.display(),
            bad.len()
        );
    }
    Ok(Plottable {
        rows,
        bad: bad.len(),
        retired,
    })
}

/// Every figure's PNG rasterised from its SVG at `png_scale` (print quality).
fn rasterise_figures(
    dir: &Path,
    plots: &Path,
    figs: &[Figure],
    png_scale: raster::PngScale,
) -> Result<(), PlotError> {
    for f in figs {
        let rel = Path::new(&f.file);
        let png = plots.join(rel.strip_prefix("plots").unwrap_or(rel));
        // A Gantt chart kept from an earlier drawing (its timeline is gone) was not staged:
        // its SVG beside the kept PNG is rasterised, and one without an SVG stays as it is.
        let svg = [
            png.with_extension("svg"),
            dir.join(rel).with_extension("svg"),
        ]
        .into_iter()
        .find(|p| p.exists());
        if let Some(svg) = svg {
            raster::svg_to_png(&svg, &png, png_scale).map_err(|e| PlotError::at(&png, e))?;
        }
    }
    Ok(())
}

/// `report.md` and `report.html` into the staging folder, saying what was left out.
fn write_reports(
    dir: &Path,
    staging: &Staging,
    plots: &Path,
    rows: &Plottable,
    sums: &[Summary],
    figs: &[Figure],
) -> Result<(), PlotError> {
    let meta: Option<meta::Meta> = std::fs::read_to_string(dir.join("meta.toml"))
        .ok()
        .and_then(|t| toml::from_str(&t).ok());
    let mut report = report::render(meta.as_ref(), sums, figs, rows.rows.len());
    if rows.bad > 0 {
        report += &format!(
            "\n{} row(s) of runs.csv hold an infinite, NaN or out-of-range value and are left \
             out of this report.\n",
            rows.bad
        );
    }
    if rows.retired > 0 {
        report += &format!(
            "\n{} row(s) of runs.csv belong to configurations the experiment file no \
             longer names and are left out of this report, its summary and plots.\n",
            rows.retired
        );
    }
    std::fs::write(staging.path("report.md"), &report)
        .map_err(|e| PlotError::at(&dir.join("report.md"), e))?;
    let html = html::render(dir, plots, &report);
    std::fs::write(staging.path("report.html"), html)
        .map_err(|e| PlotError::at(&dir.join("report.html"), e))
}
