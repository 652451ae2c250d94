//! The experiment runner: an experiment file in, `runs.csv` + `summary.csv` + plots + a report out.
//!
//! Two stages, as in ripgrep's LowArgs → HiArgs: [`config`] is the raw TOML, [`plan`] the
//! validated [`plan::ExperimentPlan`] with scenes loaded and tracers built before any timing
//! starts. [`run`] measures (resumably, see [`results`]); [`finish`] derives everything else from
//! the CSV alone, so `raysched plot` can redo it for any old run.

pub mod config;
pub mod convergence;
pub mod meta;
pub mod plan;
pub mod report;
pub mod results;
pub mod run;
pub mod summary;

pub use plan::{load_plan, ConfigError, ExperimentPlan, Launch, Sources};
pub use run::{run_experiment, run_experiment_with, Remote, RunError, RunOptions, RunOutcome};

use std::path::{Path, PathBuf};

/// Recompute `summary.csv`, every plot and `report.md` in `dir` from `dir/runs.csv` (for a
/// convergence experiment: its plot from `convergence.csv`). Returns the paths written.
pub fn finish(dir: &Path) -> Result<Vec<PathBuf>, String> {
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
    let figs = crate::plot::draw_all(dir, &sums)?;
    let meta: Option<meta::Meta> = std::fs::read_to_string(dir.join("meta.toml"))
        .ok()
        .and_then(|t| toml::from_str(&t).ok());
    let report = report::render(meta.as_ref(), &sums, &figs, rows.len());
    let report_path = dir.join("report.md");
    std::fs::write(&report_path, report).map_err(|e| format!("{}: {e}", report_path.display()))?;
    let mut out = vec![summary_path, report_path];
    out.extend(figs.iter().map(|f| dir.join(&f.file)));
    Ok(out)
}
