//! Plots drawn from `runs.csv` (and `timelines/*.csv`) alone, never from in-memory state, so any
//! old run can be re-plotted with `raysched plot results/<experiment>`. Every figure is written
//! as PNG (bitmap backend) and SVG, with the bundled DejaVu Sans (no system fonts needed).

mod charts;
pub mod report;

pub use charts::{mpi_line, throughput, Figure};

use crate::experiment::summary::{self, Summary};
use crate::experiment::{convergence, meta, results};
use std::path::{Path, PathBuf};
use std::sync::Once;

static FONT: Once = Once::new();

/// Register the bundled font as "sans-serif" (once per process).
pub fn register_font() {
    FONT.call_once(|| {
        let bytes: &'static [u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
        plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, bytes)
            .unwrap_or_else(|_| panic!("the bundled DejaVuSans.ttf is a valid font"));
    });
}

/// Draw every figure the data supports into `dir/plots/`; returns them for `report.md`.
pub fn draw_all(dir: &Path, sums: &[Summary]) -> Result<Vec<Figure>, String> {
    register_font();
    let plots = dir.join("plots");
    std::fs::create_dir_all(&plots).map_err(|e| format!("{}: {e}", plots.display()))?;
    charts::draw_all(dir, &plots, sums)
}

/// The warnings of the run in `dir` (see [`report::warnings`]), from its CSV and meta alone.
pub fn warnings_of(dir: &Path) -> Vec<String> {
    let Ok((rows, _)) = results::read_runs(&dir.join("runs.csv")) else {
        return vec![];
    };
    let meta: Option<meta::Meta> = std::fs::read_to_string(dir.join("meta.toml"))
        .ok()
        .and_then(|t| toml::from_str(&t).ok());
    report::warnings(meta.as_ref(), &summary::summarize(&rows))
}

/// Recompute `summary.csv`, every plot and `report.md` in `dir` from `dir/runs.csv` (for a
/// convergence experiment: its plot from `convergence.csv`). Returns the paths written.
pub fn redraw(dir: &Path) -> Result<Vec<PathBuf>, String> {
    let runs = dir.join("runs.csv");
    let convergence = dir.join("convergence.csv");
    if !runs.exists() && convergence.exists() {
        // A convergence experiment: its plots are drawn from its CSV alone too.
        let rows = crate::converge::read_csv(&convergence)
            .map_err(|e| format!("{}: {e}", convergence.display()))?;
        let plots = convergence::PLOTS.map(|p| dir.join(p));
        for p in &plots {
            crate::converge::plot(p, &rows).map_err(|e| format!("{}: {e}", p.display()))?;
        }
        return Ok(plots.to_vec());
    }
    if !runs.exists() {
        return Err(format!(
            "{}: not found (is {} an experiment results folder?)",
            runs.display(),
            dir.display()
        ));
    }
    let (rows, _) = results::read_runs(&runs).map_err(|e| e.to_string())?;
    let sums = summary::summarize(&rows);
    let summary_path = dir.join("summary.csv");
    summary::write_summary(&summary_path, &sums)
        .map_err(|e| format!("{}: {e}", summary_path.display()))?;
    let json = crate::experiment::export::write_json(dir, &rows, &sums)?;
    let figs = draw_all(dir, &sums)?;
    let meta: Option<meta::Meta> = std::fs::read_to_string(dir.join("meta.toml"))
        .ok()
        .and_then(|t| toml::from_str(&t).ok());
    let report = report::render(meta.as_ref(), &sums, &figs, rows.len());
    let report_path = dir.join("report.md");
    std::fs::write(&report_path, report).map_err(|e| format!("{}: {e}", report_path.display()))?;
    let mut out = vec![summary_path, report_path];
    out.extend(json);
    out.extend(figs.iter().map(|f| dir.join(&f.file)));
    Ok(out)
}
