//! The command line: typed arguments, one module per command family, errors printed once with
//! their chain and mapped to exit codes (bad input 2, other failures 1). The library never
//! sees a clap struct: each command turns its arguments into the library's typed specs.

mod converge;
mod error;
mod experiment;
#[cfg(feature = "mpi")]
mod mpi_render;
#[cfg(feature = "mpi")]
mod mpi_run;
mod render;
mod sched_flags;
mod simulate;
mod stability;

use clap::{Parser, Subcommand};
use error::CliError;
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(
    name = "raysched",
    version,
    about = "Measure how parallel ray-tracing work should be handed out, and by whom"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render one scene and write OUT (.exr or .pfm, linear) plus an sRGB .png preview beside it.
    Render(render::RenderArgs),
    /// Run an experiment (experiments/*.toml): runs.csv, summary.csv, plots and report.md under
    /// OUT/<experiment>/. Resumes where a previous run stopped.
    Run(experiment::RunArgs),
    /// Regenerate summary.csv, every plot and report.md of a results folder from its CSV files.
    Plot(experiment::PlotArgs),
    /// Error against run time: progressive render (1, 2, 4, … spp) vs a reference; CSV + plot.
    Converge(converge::ConvergeArgs),
    /// The numerical stability suite: CSV + markdown table of every case.
    Stability(stability::StabilityArgs),
    /// Simulate every scheduler with SimGrid on platform XML files (feature `simgrid`): rows
    /// like a measured run's, plots, and a validation against measured runs.
    Simulate(simulate::SimulateArgs),
    /// Run one SimGrid simulation (what `simulate` starts in a child process).
    #[command(name = "simgrid-child", hide = true)]
    SimgridChild(simulate::ChildArgs),
}

/// Parse the command line, run it, print an error once with its chain. A usage error is one
/// line too (clap's tips and usage lines are left out), with exit code 2.
pub(crate) fn main() -> ExitCode {
    use clap::error::ErrorKind;
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e)
            if e.exit_code() == 0
                || e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand =>
        {
            e.exit()
        }
        Err(e) => {
            let text = e.to_string();
            eprintln!("{}", text.lines().next().unwrap_or("error: bad arguments"));
            return ExitCode::from(2);
        }
    };
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {:#}", e.error);
            ExitCode::from(e.code)
        }
    }
}

fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        #[cfg(feature = "mpi")]
        Command::Render(args) if args.sources == render::SourcesArg::Mpi => {
            mpi_render::render(args)
        }
        Command::Render(args) => render::render(args),
        // Every rank lands here; rank 0 runs the experiment, the others render for it.
        #[cfg(feature = "mpi")]
        Command::Run(args) if under_mpirun() => mpi_run::run(args),
        Command::Run(args) => experiment::run(args),
        Command::Plot(args) => experiment::plot(args),
        Command::Converge(args) => converge::converge(args),
        Command::Stability(args) => stability::stability(args),
        Command::Simulate(args) => simulate::simulate(args),
        Command::SimgridChild(args) => simulate::child(args),
    }
}

/// Was this process started by `mpirun`/`srun` (OpenMPI, PMI or PMIx set these)?
pub(crate) fn under_mpirun() -> bool {
    ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"]
        .iter()
        .any(|v| std::env::var_os(v).is_some())
}
