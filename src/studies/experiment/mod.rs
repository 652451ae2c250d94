//! The experiment runner: an experiment file in, `runs.csv` + `summary.csv` + plots + a report out.
//!
//! Two stages, as in ripgrep's LowArgs → HiArgs: [`config`] is the raw TOML, [`plan`] the
//! validated [`plan::ExperimentPlan`] with scenes loaded and tracers built before any timing
//! starts. [`run`] measures (resumably, see [`results`]); `crate::plot::redraw` derives everything
//! else from the CSV alone, so `raysched plot` can redo it for any old run.

pub mod compare;
pub mod config;
pub mod convergence;
pub mod dry_run;
pub mod export;
pub mod image_check;
pub mod isolate;
pub mod lock;
pub mod meta;
pub mod plan;
pub mod progress;
pub mod results;
pub mod run;
pub mod speed;
pub mod stats;
pub mod summary;
pub mod verdict;

pub use isolate::run_experiment_isolated;
pub use plan::{ConfigError, ExperimentPlan, Launch, Sources};
pub use run::{run_experiment, run_experiment_with, Remote, RunError, RunOptions, RunOutcome};

/// Parse and validate an experiment file (scenes loaded, tracers built) and key each
/// configuration by its CSV columns: the plan a run executes.
pub fn load_plan(path: &std::path::Path) -> Result<ExperimentPlan, ConfigError> {
    let mut plan = plan::plan_file(path)?;
    results::assign_ids(&mut plan);
    Ok(plan)
}
