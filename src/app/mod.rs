//! The command line: typed arguments, one module per command family, errors printed once with
//! their chain and mapped to exit codes (bad input 2, other failures 1). The library never
//! sees a clap struct: each command turns its arguments into the library's typed specs.

/// `println!` for the command's report on stdout. A closed stdout (`raysched … | head -1`)
/// ends the process quietly with status 0, as ripgrep does; any other write error is a
/// one-line error with status 1. (`println!` would panic in both cases.)
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::app::write_stdout(format_args!("{}\n", format_args!($($arg)*)))
    };
}

mod advise;
mod compare;
mod converge;
mod error;
mod experiment;
mod gpu;
#[cfg(feature = "mpi")]
mod mpi_render;
#[cfg(feature = "mpi")]
mod mpi_run;
mod out_path;
mod profile;
mod render;
mod sched_flags;
mod simulate;
mod stability;
mod usage;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use error::CliError;
use raysched::util::limits::{MAX_SPP, MAX_THREADS};
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
    /// Per-pixel and per-item cost distribution (μ, σ, CV, max/mean) and a heat map PNG of
    /// cost per pixel, from a per-pixel render on one worker.
    Profile(profile::ProfileArgs),
    /// Predict the wall time of every scheduler × chunk from a probe of a few seconds (the cost
    /// model: work/P + hand-out cost + refill waiting + imbalance) and name the best.
    Advise(advise::AdviseArgs),
    /// Simulate every scheduler with SimGrid on platform XML files (feature `simgrid`): rows
    /// like a measured run's, plots, and a validation against measured runs.
    Simulate(simulate::SimulateArgs),
    /// Measure one round of an isolated `run` (what `run` starts in a fresh process per round).
    #[command(name = "round-child", hide = true)]
    RoundChild(experiment::RoundChildArgs),
    /// Run one SimGrid simulation (what `simulate` starts in a child process).
    #[command(name = "simgrid-child", hide = true)]
    SimgridChild(simulate::ChildArgs),
    /// Print every command and its arguments as JSON (what the CLI fuzzer enumerates).
    #[command(name = "cli-spec", hide = true)]
    CliSpec,
}

/// `raysched --version`: the version and the build's provenance.
fn long_version() -> &'static str {
    static TEXT: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    TEXT.get_or_init(|| raysched::util::provenance::Build::current().long_version())
}

/// Parse the command line, run it, print an error once with its chain. A usage error is one
/// line too (clap's tips and usage lines are left out), with exit code 2.
pub(crate) fn main() -> ExitCode {
    use clap::error::ErrorKind;
    // A negative number after a flag is that flag's (bad) value, so the error names the flag
    // instead of calling `-3` an unknown argument.
    let mut cmd = Cli::command();
    let names: Vec<String> = cmd
        .get_subcommands()
        .map(|c| c.get_name().to_string())
        .collect();
    for name in names {
        cmd = cmd.mut_subcommand(name, |c| c.allow_negative_numbers(true));
    }
    let argv: Vec<std::ffi::OsString> = std::env::args_os().collect();
    let parsed = cmd
        .clone()
        .try_get_matches_from(&argv)
        .and_then(|m| Cli::from_arg_matches(&m));
    let cli = match parsed {
        Ok(cli) => cli,
        Err(e)
            if e.exit_code() == 0
                || e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand =>
        {
            e.exit()
        }
        Err(e) => {
            eprintln!("{}", usage::one_line(&e, &cmd, &argv));
            return ExitCode::from(2);
        }
    };
    // The last safety net, not a way of reporting bad input: a panic left anywhere is one
    // line on stderr (the hook, whatever the thread) and exit code 2 here.
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_default();
        let at = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        let msg = msg.split_whitespace().collect::<Vec<_>>().join(" ");
        eprintln!("error: internal error{at}: {msg} (a bug: please report it)");
    }));
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run(cli))) {
        Ok(Ok(())) => ExitCode::SUCCESS,
        Ok(Err(e)) => {
            let msg = format!("{:#}", e.error);
            eprintln!(
                "error: {}",
                msg.split_whitespace().collect::<Vec<_>>().join(" ")
            );
            ExitCode::from(e.code)
        }
        Err(_) => ExitCode::from(2),
    }
}

fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        #[cfg(feature = "mpi")]
        Command::Render(args) if args.sources.has(raysched::sched::SourceKind::Mpi) => {
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
        Command::Profile(args) => profile::profile(args),
        Command::Advise(args) => advise::advise_cmd(args),
        Command::Simulate(args) => simulate::simulate(args),
        Command::SimgridChild(args) => simulate::child(args),
        Command::RoundChild(args) => experiment::round_child(args),
        Command::CliSpec => {
            out!("{}", usage::spec_json(&Cli::command()));
            Ok(())
        }
    }
}

/// Write one piece of the report to stdout: see [`out!`].
pub(crate) fn write_stdout(args: std::fmt::Arguments<'_>) {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    if let Err(e) = stdout.write_fmt(args).and_then(|()| stdout.flush()) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("error: cannot write to stdout: {e}");
        std::process::exit(1);
    }
}

/// A thread-count flag: `min..=`[`MAX_THREADS`], the limit named in the error. A count above
/// the cores this process may use is allowed (oversubscription is an experiment too) but
/// warned about, once per process: its wall times then measure the OS's time slicing as well.
pub(crate) fn threads_arg(min: u64) -> impl clap::builder::TypedValueParser<Value = usize> {
    use clap::builder::TypedValueParser;
    whole::<usize>(min, MAX_THREADS as u64).map(|n| {
        warn_oversubscribed(n);
        n
    })
}

/// The once-per-process warning of [`threads_arg`].
fn warn_oversubscribed(n: usize) {
    static WARNED: std::sync::Once = std::sync::Once::new();
    let cores = raysched::util::host::available_threads();
    if n > cores {
        WARNED.call_once(|| {
            eprintln!(
                "warning: {n} threads on {cores} cores: workers will share cores, so wall times include the OS's time slicing"
            )
        });
    }
}

/// A samples-per-pixel flag: `1..=`[`MAX_SPP`].
pub(crate) fn spp_arg() -> impl clap::builder::TypedValueParser<Value = u32> {
    whole(1, MAX_SPP as u64)
}

/// A whole-number flag in `min..=max`. The error says what the flag takes: clap's own parser
/// answers `--spp -4` with "invalid digit found in string".
pub(crate) fn whole<T>(min: u64, max: u64) -> impl clap::builder::TypedValueParser<Value = T>
where
    T: TryFrom<u64> + Clone + Send + Sync + 'static,
{
    move |s: &str| -> Result<T, String> {
        let takes = format!("expected a whole number from {min} to {max}");
        match s.trim().parse::<u64>() {
            Ok(v) if (min..=max).contains(&v) => T::try_from(v).map_err(|_| takes),
            Ok(v) => Err(format!("{takes} (got {v})")),
            Err(_) => Err(takes),
        }
    }
}

/// A `--chunk` value; a misspelt word gets the nearest (`frmae`: did you mean frame?).
pub(crate) fn parse_chunk(s: &str) -> Result<raysched::sched::Chunk, String> {
    raysched::sched::Chunk::parse(s).map_err(|e| {
        let word = s.split(':').next().unwrap_or_default().trim();
        let near = raysched::util::suggest::did_you_mean(word, ["frame", "frames", "rows"]);
        format!("{}{near}", e.msg)
    })
}

/// A decimal-number flag (its range is checked where it is used, with the range in the error).
pub(crate) fn real<T>() -> impl clap::builder::TypedValueParser<Value = T>
where
    T: std::str::FromStr + Clone + Send + Sync + 'static,
{
    |s: &str| -> Result<T, String> {
        s.trim()
            .parse::<T>()
            .map_err(|_| "expected a number, e.g. 2.5".to_string())
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
