//! The command line: typed arguments, one module per command family, errors printed once with
//! their chain and mapped to exit codes (bad input 2, other failures 1). The library never
//! sees a clap struct: each command turns its arguments into the library's typed specs.

mod compare;
mod converge;
mod error;
mod experiment;
#[cfg(feature = "mpi")]
mod mpi_render;
#[cfg(feature = "mpi")]
mod mpi_run;
mod render;
mod sched_flags;
mod stability;

use clap::{Parser, Subcommand};
use error::CliError;
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(
    name = "raysched",
    version,
    long_version = long_version(),
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
    /// Compare two results folders configuration by configuration: change of median wall time
    /// and speedup with 95 % intervals, a Mann–Whitney p-value and a verdict.
    Compare(compare::CompareArgs),
    /// Error against run time: progressive render (1, 2, 4, … spp) vs a reference; CSV + plot.
    Converge(converge::ConvergeArgs),
    /// The numerical stability suite: CSV + markdown table of every case.
    Stability(stability::StabilityArgs),
}

/// `raysched --version`: the version and the build's provenance.
fn long_version() -> &'static str {
    static TEXT: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    TEXT.get_or_init(|| raysched::provenance::Build::current().long_version())
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
        Command::Compare(args) => compare::compare(args),
        Command::Converge(args) => converge::converge(args),
        Command::Stability(args) => stability::stability(args),
    }
}

/// Refuse to replace `csv` (a result with more rows than the `new_rows` about to be written)
/// unless `force`: a quick or partial run must not overwrite a full one.
pub(crate) fn refuse_partial_overwrite(
    csv: &std::path::Path,
    new_rows: usize,
    force: bool,
) -> Result<(), CliError> {
    let old_rows = std::fs::read_to_string(csv)
        .map(|t| t.lines().count().saturating_sub(1))
        .unwrap_or(0);
    if !force && old_rows > new_rows {
        return Err(CliError::input(anyhow::anyhow!(
            "{}: holds {old_rows} rows, this run only {new_rows}; it would replace a fuller result (write elsewhere with -o, or pass --force)",
            csv.display()
        )));
    }
    Ok(())
}

/// Was this process started by `mpirun`/`srun` (OpenMPI, PMI or PMIx set these)?
pub(crate) fn under_mpirun() -> bool {
    ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"]
        .iter()
        .any(|v| std::env::var_os(v).is_some())
}
