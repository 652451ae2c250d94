//! `raysched simulate EXPERIMENT.toml`: every scheduler simulated with SimGrid (feature
//! `simgrid`), and the hidden child command that runs one simulation.

use super::error::CliError;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub(crate) struct SimulateArgs {
    /// Simulation experiment file (`kind = "simulation"`), see experiments/simulation.toml.
    pub(crate) experiment: PathBuf,
    /// No progress lines.
    #[arg(long)]
    pub(crate) quiet: bool,
    /// Results root; the experiment writes to OUT/<experiment name>/.
    #[arg(long, default_value = "results/runs")]
    pub(crate) out: PathBuf,
}

#[derive(clap::Args, Debug)]
pub(crate) struct ChildArgs {
    /// `inspect PLATFORM.xml` or `run JOB.toml`.
    pub(crate) what: String,
    pub(crate) path: PathBuf,
}

/// An `auto_verdict` experiment runs in-process (no SimGrid); any other goes to SimGrid.
pub(crate) fn simulate(args: SimulateArgs) -> Result<(), CliError> {
    let verdict = std::fs::read_to_string(&args.experiment)
        .is_ok_and(|t| raysched::studies::simulate::auto_judge::is_verdict(&t));
    if verdict {
        auto_verdict(args)
    } else {
        simgrid_sweep(args)
    }
}

/// `raysched simulate experiments/auto.toml`: `auto` against the best fixed configuration of
/// every cell of the corpus (`simulate::auto_judge`).
fn auto_verdict(args: SimulateArgs) -> Result<(), CliError> {
    use raysched::studies::simulate::auto_judge;
    super::out_path::check("--out", &args.out, super::out_path::Kind::Folder)?;
    super::out_path::check_input("EXPERIMENT", &args.experiment)?;
    let (plan, maps) = auto_judge::load(&args.experiment).map_err(CliError::input)?;
    let name = args
        .experiment
        .file_stem()
        .map_or_else(|| "auto".into(), |s| s.to_string_lossy().into_owned());
    let dir = args.out.join(name);
    let w = auto_judge::run(&plan, &maps, &dir, !args.quiet)
        .map_err(|e| CliError::runtime(anyhow::anyhow!(e)))?;
    out!("{}", w.summary);
    for f in &w.files {
        out!("wrote {}", f.display());
    }
    Ok(())
}

#[cfg(not(feature = "simgrid"))]
fn simgrid_sweep(args: SimulateArgs) -> Result<(), CliError> {
    Err(CliError::input(anyhow::anyhow!(
        "{}: raysched was built without feature `simgrid` (install Debian's libsimgrid-dev, then cargo build --release --features simgrid)",
        args.experiment.display()
    )))
}

#[cfg(not(feature = "simgrid"))]
pub(crate) fn child(_: ChildArgs) -> Result<(), CliError> {
    Err(CliError::input(anyhow::anyhow!(
        "built without feature `simgrid` (libsimgrid-dev)"
    )))
}

#[cfg(feature = "simgrid")]
fn simgrid_sweep(args: SimulateArgs) -> Result<(), CliError> {
    use raysched::studies::simulate;
    super::out_path::check("--out", &args.out, super::out_path::Kind::Folder)?;
    super::out_path::check_input("EXPERIMENT", &args.experiment)?;
    let exe = std::env::current_exe().map_err(|e| CliError::runtime(anyhow::anyhow!(e)))?;
    let plan = simulate::config::load(&args.experiment, &exe).map_err(CliError::input)?;
    let dir =
        simulate::sweep::run(&plan, &exe, &args.out, args.quiet).map_err(CliError::runtime)?;
    if !args.quiet {
        println!("{}: wrote {}", plan.name, dir.join("report.md").display());
    }
    Ok(())
}

#[cfg(feature = "simgrid")]
pub(crate) fn child(args: ChildArgs) -> Result<(), CliError> {
    use raysched::studies::simulate::job::SimJob;
    let fail = |m: String| CliError::input(anyhow::anyhow!(m));
    let text = match args.what.as_str() {
        "inspect" => toml::to_string(
            &raysched::studies::simulate::simgrid::inspect_platform(&args.path.to_string_lossy())
                .map_err(|e| fail(e.to_string()))?,
        ),
        "run" => {
            let job_text = std::fs::read_to_string(&args.path)
                .map_err(|e| fail(format!("{}: {e}", args.path.display())))?;
            let job: SimJob = toml::from_str(&job_text)
                .map_err(|e| fail(format!("{}: {e}", args.path.display())))?;
            toml::to_string(
                &raysched::studies::simulate::simgrid::simulate(job)
                    .map_err(|e| fail(e.to_string()))?,
            )
        }
        w => return Err(fail(format!("{w}: expected inspect or run"))),
    }
    .map_err(|e| CliError::runtime(anyhow::anyhow!(e)))?;
    print!("{text}");
    Ok(())
}
