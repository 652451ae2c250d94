//! `raysched run` and `raysched plot`: an experiment measured (locally or, under `mpirun`, on
//! MPI ranks), its summary, plots and report redrawn from its CSV files.

use super::error::CliError;
use raysched::studies::experiment::config::Isolation;
use raysched::studies::experiment::{
    self, isolate, ExperimentPlan, RunError, RunOptions, RunOutcome,
};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub(crate) struct RunArgs {
    /// Experiment file (TOML), see experiments/.
    pub(crate) experiment: PathBuf,
    /// Discard earlier results of this experiment and start over.
    #[arg(long)]
    pub(crate) fresh: bool,
    /// No progress bar or lines (for scripts).
    #[arg(long)]
    pub(crate) quiet: bool,
    /// Results root; the experiment writes to OUT/<experiment name>/. The published snapshots
    /// under results/published/ are never the default.
    #[arg(long, default_value = DEFAULT_OUT)]
    pub(crate) out: PathBuf,
    /// Print the plan (configurations, runs, estimated time from one probe render per scene
    /// and tracer) and measure nothing.
    #[arg(long)]
    pub(crate) dry_run: bool,
    /// Relative 95 % CI half-width of each median to reach (overrides ci_target; 0: fixed
    /// `repetitions`).
    #[arg(long, value_parser = super::real::<f64>())]
    pub(crate) ci_target: Option<f64>,
    /// Most timed runs per configuration (overrides max_repetitions).
    #[arg(long, value_parser = super::whole::<u32>(1, 10_000))]
    pub(crate) max_runs: Option<u32>,
    /// Most seconds of timed runs per configuration (overrides budget_s).
    #[arg(long, value_parser = super::real::<f64>())]
    pub(crate) budget_s: Option<f64>,
    /// Which process takes the timed samples: `round` (a fresh one per round) or `none` (this
    /// one); overrides isolation.
    #[arg(long, value_parser = parse_isolation)]
    pub(crate) isolation: Option<Isolation>,
}

fn parse_isolation(s: &str) -> Result<Isolation, String> {
    Isolation::parse(s).ok_or_else(|| format!("must be one of {}", Isolation::NAMES.join(", ")))
}

/// `raysched round-child JOB`: one round of an isolated run, started by the run's process.
#[derive(clap::Args, Debug)]
pub(crate) struct RoundChildArgs {
    /// The round's job as JSON ([`raysched::studies::experiment::isolate::RoundJob`]).
    pub(crate) job: String,
}

pub(crate) fn round_child(args: RoundChildArgs) -> Result<(), CliError> {
    let job: isolate::RoundJob = serde_json::from_str(&args.job)
        .map_err(|e| CliError::input(anyhow::anyhow!("round job: {e}")))?;
    isolate::child_main(&job).map_err(|e| match e {
        RunError::Refused(_) => CliError::input(e),
        _ => CliError::runtime(e),
    })
}

/// Where `raysched run` writes by default: ignored by git, never the published snapshots.
pub(crate) const DEFAULT_OUT: &str = "results/runs";

/// Apply `--ci-target`, `--max-runs` and `--budget-s` to the plan's settings, checked like
/// the experiment file's keys.
pub(crate) fn apply_stats_flags(plan: &mut ExperimentPlan, args: &RunArgs) -> Result<(), CliError> {
    let st = &mut plan.stats;
    let bad = |flag: &str, msg: String| CliError::input(anyhow::anyhow!("{flag}: {msg}"));
    if let Some(t) = args.ci_target {
        if !(0.0..=0.5).contains(&t) {
            return Err(bad("--ci-target", format!("must be in [0, 0.5] (got {t})")));
        }
        st.ci_target = t;
        if t == 0.0 && args.max_runs.is_none() {
            st.max_runs = st.min_runs;
        }
    }
    if let Some(m) = args.max_runs {
        if m == 0 || m > 10_000 {
            return Err(bad("--max-runs", format!("must be in 1..=10000 (got {m})")));
        }
        st.max_runs = m;
        st.min_runs = st.min_runs.min(m);
    }
    if let Some(b) = args.budget_s {
        if !(b > 0.0 && b <= 86_400.0) {
            return Err(bad(
                "--budget-s",
                format!("must be in (0, 86400] (got {b})"),
            ));
        }
        st.budget_s = b;
    }
    if let Some(i) = args.isolation {
        st.isolation = i;
    }
    Ok(())
}

#[derive(clap::Args, Debug)]
pub(crate) struct PlotArgs {
    /// A results folder, e.g. results/runs/quick.
    pub(crate) dir: PathBuf,
    /// Rasterise every PNG from its SVG at this scale (1–8; 2 or 3 for print).
    #[arg(long, default_value_t = 1.0, value_parser = super::real::<f32>())]
    pub(crate) png_scale: f32,
}

pub(crate) fn plot(args: PlotArgs) -> Result<(), CliError> {
    let scale = raysched::plot::raster::PngScale::new(args.png_scale)
        .map_err(|m| CliError::input(anyhow::anyhow!("--png-scale: {m}")))?;
    // Quoted: a name of spaces would vanish from the library's one-line message.
    if !args.dir.is_dir() {
        return Err(CliError::message(format!(
            "DIR '{}': not a folder (expected a results folder, e.g. results/runs/quick)",
            raysched::util::one_line::escape_controls(&args.dir.to_string_lossy())
        )));
    }
    super::out_path::check("DIR", &args.dir, super::out_path::Kind::Folder)?;
    nested_results_hint(&args.dir)?;
    let written = raysched::plot::redraw_scaled(&args.dir, scale).map_err(CliError::message)?;
    out!("wrote {} files under {}", written.len(), args.dir.display());
    Ok(())
}

/// `plot results/runs`, where the experiment's folder is `results/runs/quick`: the error names
/// the folders one level down that hold results, rather than only "runs.csv not found".
fn nested_results_hint(dir: &std::path::Path) -> Result<(), CliError> {
    let holds =
        |d: &std::path::Path| d.join("runs.csv").is_file() || d.join("convergence.csv").is_file();
    if holds(dir) {
        return Ok(());
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    let mut found: Vec<String> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.is_dir() && holds(p.as_path()))
        .map(|p| raysched::util::one_line::escape_controls(&p.to_string_lossy()).into_owned())
        .collect();
    found.sort();
    let shown = raysched::util::one_line::escape_controls(&dir.to_string_lossy()).into_owned();
    match found.as_slice() {
        [] => Ok(()),
        [one] => Err(CliError::message(format!(
            "DIR {shown}: holds no runs.csv, but {one} does: raysched plot {one}"
        ))),
        many => Err(CliError::message(format!(
            "DIR {shown}: holds no runs.csv, but {} results folders inside it do: {} (plot one of them)",
            many.len(),
            many.join(", ")
        ))),
    }
}

pub(crate) fn run(args: RunArgs) -> Result<(), CliError> {
    // With feature `mpi`, a launch under mpirun is dispatched to the MPI front-end before this.
    if super::under_mpirun() {
        return Err(CliError::input(anyhow::anyhow!(
            "{}: started by mpirun, but this raysched was built without feature `mpi` (cargo build --features mpi)",
            args.experiment.display()
        )));
    }
    super::gpu::quiet_vulkan_loader();
    if !args.dry_run {
        super::out_path::check("--out", &args.out, super::out_path::Kind::Folder)?;
    }
    super::out_path::check_input("EXPERIMENT", &args.experiment)?;
    let mut plan = experiment::load_plan(&args.experiment).map_err(CliError::input)?;
    apply_stats_flags(&mut plan, &args)?;
    if plan.mpi.is_some() {
        return Err(CliError::input(anyhow::anyhow!(
            "{}: mpi: this experiment needs `mpirun -n K raysched run {}` with K in mpi.ranks (this process was not started by mpirun)",
            args.experiment.display(),
            args.experiment.display()
        )));
    }
    if plan.convergence.is_some() {
        if args.dry_run {
            let text =
                experiment::convergence::plan_text(&plan, &args.out).map_err(CliError::runtime)?;
            super::write_stdout(format_args!("{text}"));
            return Ok(());
        }
        let dir = experiment::convergence::run(&plan, &args.out).map_err(CliError::runtime)?;
        if !args.quiet {
            let rows = raysched::studies::converge::read_csv(&dir.join("convergence.csv"))
                .map_err(CliError::runtime)?;
            for line in raysched::studies::converge::budget_winners(&rows) {
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
        child_round: None,
    };
    if args.dry_run {
        let text = experiment::dry_run::plan_text(&plan, &opts).map_err(CliError::runtime)?;
        super::write_stdout(format_args!("{text}"));
        return Ok(());
    }
    let exe = std::env::current_exe().map_err(|e| CliError::runtime(anyhow::anyhow!(e)))?;
    let outcome = experiment::run_experiment_isolated(&plan, &opts, &exe);
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
            format!(
                ", {} configurations left to other mpirun launches",
                outcome.other_launches
            )
        } else {
            String::new()
        };
        out!(
            "{}: {} runs measured ({} untimed warm-ups and probes), {} already done{others}; wrote {} files (report: {})",
            plan.name,
            outcome.measured,
            outcome.untimed,
            outcome.skipped,
            written.len(),
            outcome.dir.join("report.md").display()
        );
    }
    // Warnings go to stderr even with --quiet: they say whether the numbers can be trusted.
    for w in raysched::plot::warnings_of(&outcome.dir) {
        eprintln!("warning: {w}");
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
