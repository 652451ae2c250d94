//! `raysched run` and `raysched plot`: an experiment measured (locally or, under `mpirun`, on
//! MPI ranks), its summary, plots and report redrawn from its CSV files.

use super::error::CliError;
use raysched::experiment::{self, ExperimentPlan, RunError, RunOptions, RunOutcome};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub(crate) struct RunArgs {
    /// Experiment file (TOML), see experiments/.
    pub(crate) experiment: PathBuf,
    /// Discard earlier results of this experiment and start over.
    #[arg(long)]
    pub(crate) fresh: bool,
    /// No progress bar (for scripts).
    #[arg(long)]
    pub(crate) quiet: bool,
    /// Results root; the experiment writes to OUT/<experiment name>/.
    #[arg(long, default_value = "results")]
    pub(crate) out: PathBuf,
}

#[derive(clap::Args, Debug)]
pub(crate) struct PlotArgs {
    /// A results folder, e.g. results/quick.
    pub(crate) dir: PathBuf,
}

pub(crate) fn plot(args: PlotArgs) -> Result<(), CliError> {
    let written = raysched::plot::redraw(&args.dir).map_err(CliError::message)?;
    out!("wrote {} files under {}", written.len(), args.dir.display());
    Ok(())
}

pub(crate) fn run(args: RunArgs) -> Result<(), CliError> {
    // With feature `mpi`, a launch under mpirun is dispatched to the MPI front-end before this.
    if super::under_mpirun() {
        return Err(CliError::input(anyhow::anyhow!(
            "{}: started by mpirun, but this raysched was built without feature `mpi` (cargo build --features mpi)",
            args.experiment.display()
        )));
    }
    let plan = experiment::load_plan(&args.experiment).map_err(CliError::input)?;
    if plan.mpi.is_some() {
        return Err(CliError::input(anyhow::anyhow!(
            "{}: mpi: this experiment needs `mpirun -n K raysched run {}` with K in mpi.ranks (this process was not started by mpirun)",
            args.experiment.display(),
            args.experiment.display()
        )));
    }
    if plan.convergence.is_some() {
        let dir = experiment::convergence::run(&plan, &args.out).map_err(CliError::runtime)?;
        if !args.quiet {
            let rows = raysched::converge::read_csv(&dir.join("convergence.csv"))
                .map_err(CliError::runtime)?;
            for line in raysched::converge::budget_winners(&rows) {
                out!("{line}");
            }
            out!("{}: wrote {}", plan.name, dir.join("report.md").display());
        }
        return Ok(());
    }
    let opts = RunOptions {
        out: args.out.clone(),
        fresh: args.fresh,
        quiet: args.quiet,
    };
    let outcome = experiment::run_experiment(&plan, &opts);
    finish_experiment(&plan, outcome, args.quiet)
}

/// Plots, report and the closing line of `raysched run` (also under mpirun, on rank 0).
pub(crate) fn finish_experiment(
    plan: &ExperimentPlan,
    outcome: Result<RunOutcome, RunError>,
    quiet: bool,
) -> Result<(), CliError> {
    let outcome = outcome.map_err(|e| match e {
        RunError::Refused(_) => CliError::input(e),
        _ => CliError::runtime(e),
    })?;
    let written =
        raysched::plot::redraw(&outcome.dir).map_err(|e| CliError::runtime(anyhow::anyhow!(e)))?;
    if !quiet {
        let others = if outcome.other_launches > 0 {
            format!(", {} left to other mpirun launches", outcome.other_launches)
        } else {
            String::new()
        };
        out!(
            "{}: {} runs measured, {} already done{others}; wrote {} files (report: {})",
            plan.name,
            outcome.measured,
            outcome.skipped,
            written.len(),
            outcome.dir.join("report.md").display()
        );
    }
    if outcome.mismatches > 0 {
        return Err(CliError::runtime(anyhow::anyhow!(
            "{} run(s) produced an image different from the serial baseline (identical=false in {})",
            outcome.mismatches,
            outcome.dir.join("runs.csv").display()
        )));
    }
    Ok(())
}
