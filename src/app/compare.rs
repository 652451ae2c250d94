//! `raysched compare A B`: per-configuration change between two results folders, and
//! `compare --interleave EXPERIMENT A B`: measure two builds (or one build under two
//! environments) into A and B in alternated rounds first, so drift of the machine hits both
//! alike and cancels.

use super::error::CliError;
use raysched::studies::experiment::compare::{self, Criteria};
use std::path::{Path, PathBuf};
use std::process::Command;

#[derive(clap::Args, Debug)]
pub(crate) struct CompareArgs {
    /// The reference results folder (e.g. results/runs/quick of the old commit); with
    /// --interleave, the results root build A measures into.
    pub(crate) a: PathBuf,
    /// The results folder compared with it; with --interleave, build B's results root.
    pub(crate) b: PathBuf,
    /// Equivalence margin in percent: "equivalent" when two one-sided tests reject a change
    /// this large [default: A's precision target (ci_target), else 5].
    #[arg(long, value_parser = super::real::<f64>())]
    pub(crate) margin_pct: Option<f64>,
    /// Smallest change of a median that counts as faster or slower, in percent [default: the
    /// margin].
    #[arg(long, value_parser = super::real::<f64>())]
    pub(crate) threshold_pct: Option<f64>,
    /// Largest p-value that counts as significant (each one-sided equivalence test too).
    #[arg(long, default_value_t = 0.01, value_parser = super::real::<f64>())]
    pub(crate) alpha: f64,
    /// JSON on stdout instead of markdown.
    #[arg(long)]
    pub(crate) json: bool,
    /// Compare raw wall times, not walls divided by the two runs' machine-speed ratio (always
    /// so with --interleave, whose alternated rounds cancel drift).
    #[arg(long)]
    pub(crate) raw: bool,
    /// Exit with code 1 when any configuration is slower.
    #[arg(long)]
    pub(crate) fail_on_regression: bool,
    /// Measure this experiment file into A and B first, one round of each at a time in
    /// alternated order (A B, B A, …), each start resuming its folder with one more run per
    /// configuration; then compare A/<name> with B/<name>.
    #[arg(long, value_name = "EXPERIMENT")]
    pub(crate) interleave: Option<PathBuf>,
    /// With --interleave: the raysched binary that measures A [default: this one].
    #[arg(long)]
    pub(crate) build_a: Option<PathBuf>,
    /// With --interleave: the raysched binary that measures B [default: this one].
    #[arg(long)]
    pub(crate) build_b: Option<PathBuf>,
    /// With --interleave: KEY=VALUE set for B's runs only (repeatable), e.g.
    /// RAYSCHED_EXTRA_WORK=0.1 for a known 10 % slowdown.
    #[arg(long, value_name = "KEY=VALUE")]
    pub(crate) env_b: Vec<String>,
    /// With --interleave: rounds, one timed run per configuration and side each [default:
    /// the experiment's repetitions, at least the runs the difference test needs].
    #[arg(long, value_parser = super::whole::<u32>(1, 1000))]
    pub(crate) rounds: Option<u32>,
}

fn pct_flag(name: &str, v: Option<f64>) -> Result<Option<f64>, CliError> {
    match v {
        Some(p) if !(0.0..1000.0).contains(&p) => Err(CliError::input(anyhow::anyhow!(
            "{name}: must be in [0, 1000) (got {p})"
        ))),
        v => Ok(v.map(|p| p / 100.0)),
    }
}

pub(crate) fn compare(args: CompareArgs) -> Result<(), CliError> {
    // Checked here rather than by clap's `requires`, whose message names only the flag missing,
    // not the one given.
    if args.interleave.is_none() {
        let given = [
            ("--build-a", args.build_a.is_some()),
            ("--build-b", args.build_b.is_some()),
            ("--env-b", !args.env_b.is_empty()),
            ("--rounds", args.rounds.is_some()),
        ];
        if let Some((flag, _)) = given.iter().find(|(_, set)| *set) {
            return Err(CliError::input(anyhow::anyhow!(
                "{flag}: only with --interleave EXPERIMENT"
            )));
        }
    }
    let threshold = pct_flag("--threshold-pct", args.threshold_pct)?;
    let margin = pct_flag("--margin-pct", args.margin_pct)?;
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        return Err(CliError::input(anyhow::anyhow!(
            "--alpha: must be in (0, 1) (got {})",
            args.alpha
        )));
    }
    // Interleaved, drift hits both sides alike and cancels without the probe's factor (itself
    // a noisy estimate); the margin is the experiment's own target, not the unreachable one the
    // rounds ran under.
    let (a, b, margin, raw) = match &args.interleave {
        Some(exp) => {
            let (a, b, target) = interleave(exp, &args)?;
            (a, b, margin.or(target), true)
        }
        None => (args.a.clone(), args.b.clone(), margin, args.raw),
    };
    // Named here, quoted: the library's message names the folder bare, and a name of spaces
    // would vanish from the one-line error.
    for (name, dir) in [("A", &a), ("B", &b)] {
        if !dir.is_dir() {
            return Err(CliError::message(format!(
                "{name} '{}': not a folder (expected a results folder, e.g. results/runs/quick)",
                raysched::util::one_line::escape_controls(&dir.to_string_lossy())
            )));
        }
    }
    let crit = Criteria {
        threshold,
        margin,
        alpha: args.alpha,
        raw,
    };
    let c = compare::compare(&a, &b, crit).map_err(|e| CliError::input(anyhow::anyhow!(e)))?;
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
            c.threshold * 100.0,
            args.alpha
        )));
    }
    Ok(())
}

/// `--interleave`: round r runs A then B (r even) or B then A (r odd), each start resuming its
/// folder up to r + 1 runs per configuration (`--max-runs r+1` with an unreachable CI target,
/// so exactly one more), and returns the two experiment folders. Every start is a child of
/// this process; the first of each side starts its folder afresh. Also returns the
/// experiment's precision target (`None`: none set).
fn interleave(exp: &Path, args: &CompareArgs) -> Result<(PathBuf, PathBuf, Option<f64>), CliError> {
    super::out_path::check_input("--interleave", exp)?;
    let plan = raysched::studies::experiment::load_plan(exp)
        .map_err(|e| CliError::input(anyhow::anyhow!("--interleave: {e:#}")))?;
    for (flag, root) in [("A", &args.a), ("B", &args.b)] {
        super::out_path::check(flag, root, super::out_path::Kind::Folder)?;
    }
    let mut env_b = Vec::new();
    for kv in &args.env_b {
        match kv.split_once('=') {
            Some((k, v)) if !k.is_empty() => env_b.push((k.to_string(), v.to_string())),
            _ => {
                return Err(CliError::input(anyhow::anyhow!(
                    "--env-b: expected KEY=VALUE (got '{}')",
                    raysched::util::one_line::escape_controls(kv)
                )))
            }
        }
    }
    let me = std::env::current_exe().map_err(|e| CliError::runtime(anyhow::anyhow!(e)))?;
    let bin_a = args.build_a.clone().unwrap_or_else(|| me.clone());
    let bin_b = args.build_b.clone().unwrap_or(me);
    for (flag, bin) in [("--build-a", &bin_a), ("--build-b", &bin_b)] {
        if !bin.is_file() {
            return Err(CliError::input(anyhow::anyhow!(
                "{flag} '{}': no such file (a raysched binary, e.g. target/release/raysched)",
                raysched::util::one_line::escape_controls(&bin.to_string_lossy())
            )));
        }
    }
    let need = raysched::studies::experiment::verdict::min_runs(args.alpha).0 as u32;
    let rounds = args.rounds.unwrap_or_else(|| plan.stats.min_runs.max(need));
    let sides = [
        ("A", &bin_a, &args.a, &[][..]),
        ("B", &bin_b, &args.b, &env_b[..]),
    ];
    for r in 0..rounds {
        let order = if r % 2 == 0 { [0, 1] } else { [1, 0] };
        for i in order {
            let (name, bin, root, env) = sides[i];
            eprintln!("round {}/{rounds}: {name}", r + 1);
            let mut cmd = Command::new(bin);
            cmd.arg("run")
                .arg(exp)
                .arg("--out")
                .arg(root)
                .arg("--quiet")
                .args(["--max-runs", &(r + 1).to_string()])
                .args(["--ci-target", "1e-9", "--budget-s", "86400"]);
            if r == 0 {
                cmd.arg("--fresh");
            }
            cmd.envs(env.iter().map(|(k, v)| (k, v)));
            let out = cmd
                .output()
                .map_err(|e| CliError::runtime(anyhow::anyhow!("{}: {e}", bin.display())))?;
            if !out.status.success() {
                let err = String::from_utf8_lossy(&out.stderr);
                return Err(CliError::runtime(anyhow::anyhow!(
                    "round {} of {name} ({} run {}) failed: {}",
                    r + 1,
                    bin.display(),
                    exp.display(),
                    err.trim().lines().last().unwrap_or("no message")
                )));
            }
        }
    }
    let target = Some(plan.stats.ci_target).filter(|t| *t > 0.0);
    Ok((args.a.join(&plan.name), args.b.join(&plan.name), target))
}
