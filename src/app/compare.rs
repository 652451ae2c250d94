//! `raysched compare A B`: per-configuration change between two results folders.

use super::error::CliError;
use raysched::experiment::compare::{self, Criteria};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub(crate) struct CompareArgs {
    /// The reference results folder (e.g. results/runs/quick of the old commit).
    pub(crate) a: PathBuf,
    /// The results folder compared with it.
    pub(crate) b: PathBuf,
    /// Smallest relative change of a median that counts, in percent.
    #[arg(long, default_value_t = 5.0, value_parser = super::real::<f64>())]
    pub(crate) threshold_pct: f64,
    /// Largest p-value that counts as significant.
    #[arg(long, default_value_t = 0.01, value_parser = super::real::<f64>())]
    pub(crate) alpha: f64,
    /// JSON on stdout instead of markdown.
    #[arg(long)]
    pub(crate) json: bool,
    /// Compare raw wall times, not walls divided by the two runs' machine-speed ratio.
    #[arg(long)]
    pub(crate) raw: bool,
    /// Exit with code 1 when any configuration is slower.
    #[arg(long)]
    pub(crate) fail_on_regression: bool,
}

pub(crate) fn compare(args: CompareArgs) -> Result<(), CliError> {
    if !(args.threshold_pct >= 0.0 && args.threshold_pct < 1000.0) {
        return Err(CliError::input(anyhow::anyhow!(
            "--threshold-pct: must be in [0, 1000) (got {})",
            args.threshold_pct
        )));
    }
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        return Err(CliError::input(anyhow::anyhow!(
            "--alpha: must be in (0, 1) (got {})",
            args.alpha
        )));
    }
    // Named here, quoted: the library's message names the folder bare, and a name of spaces
    // would vanish from the one-line error.
    for (name, dir) in [("A", &args.a), ("B", &args.b)] {
        if !dir.is_dir() {
            return Err(CliError::message(format!(
                "{name} '{}': not a folder (expected a results folder, e.g. results/runs/quick)",
                raysched::util::one_line::escape_controls(&dir.to_string_lossy())
            )));
        }
    }
    let crit = Criteria {
        threshold: args.threshold_pct / 100.0,
        alpha: args.alpha,
        raw: args.raw,
    };
    let c = compare::compare(&args.a, &args.b, crit)
        .map_err(|e| CliError::input(anyhow::anyhow!(e)))?;
    if args.json {
        let text = serde_json::to_string_pretty(&c).map_err(CliError::runtime)?;
        out!("{text}");
    } else {
        super::write_stdout(format_args!("{}", compare::markdown(&c)));
    }
    let slower = c.counts().1;
    if args.fail_on_regression && slower > 0 {
        return Err(CliError::runtime(anyhow::anyhow!(
            "{slower} configuration(s) slower beyond {:.1} % at p < {}",
            args.threshold_pct,
            args.alpha
        )));
    }
    Ok(())
}
