//! `raysched stability`: the numerical stability suite.

use super::error::CliError;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub(crate) struct StabilityArgs {
    /// Only the fast subset (what `cargo test` runs).
    #[arg(long)]
    pub(crate) quick: bool,
    /// Image side of every case.
    #[arg(long, default_value_t = 48, value_parser = super::whole::<u32>(1, 4096))]
    pub(crate) size: u32,
    #[arg(long, default_value_t = 32, value_parser = super::spp_arg())]
    pub(crate) spp: u32,
    #[arg(long, default_value_t = raysched::util::host::available_threads(), value_parser = super::threads_arg(1))]
    pub(crate) threads: usize,
    /// Output folder for stability.csv and stability.md.
    #[arg(short, long, default_value = "results/runs/stability")]
    pub(crate) output: PathBuf,
    /// Replace a stability.csv with more cases than this run (a full suite by --quick).
    #[arg(long)]
    pub(crate) force: bool,
}

pub(crate) fn stability(args: StabilityArgs) -> Result<(), CliError> {
    use raysched::studies::stability::{self as st, Budget};
    if args.threads == 0 || args.size == 0 || args.spp < 2 {
        return Err(CliError::input(anyhow::anyhow!(
            "--threads and --size must be ≥ 1, --spp ≥ 2"
        )));
    }
    let budget = if args.quick {
        Budget {
            threads: args.threads,
            ..Budget::QUICK
        }
    } else {
        Budget {
            size: args.size,
            spp: args.spp,
            threads: args.threads,
            quick: false,
        }
    };
    super::out_path::check("--output", &args.output, super::out_path::Kind::Folder)?;
    let rows = st::cases::run_suite(&budget);
    let table = st::markdown(&rows);
    let csv = args.output.join("stability.csv");
    super::refuse_partial_overwrite(&csv, rows.len(), args.force)?;
    // Both files or neither: a failed write leaves the previous pair.
    let staging = raysched::util::staging::Staging::new(&args.output)
        .map_err(|e| CliError::runtime(anyhow::anyhow!("{}: {e}", args.output.display())))?;
    st::write_csv(&staging.path("stability.csv"), &rows).map_err(CliError::runtime)?;
    std::fs::write(staging.path("stability.md"), &table).map_err(CliError::runtime)?;
    staging
        .commit()
        .map_err(|e| CliError::runtime(anyhow::anyhow!("{}: {e}", args.output.display())))?;
    out!("{table}");
    let failed = rows.iter().filter(|r| r.required && !r.pass).count();
    out!(
        "wrote {} ({} cases, {} required failures)",
        csv.display(),
        rows.len(),
        failed
    );
    if failed > 0 {
        return Err(CliError::runtime(anyhow::anyhow!(
            "{failed} stability case(s) failed"
        )));
    }
    Ok(())
}
