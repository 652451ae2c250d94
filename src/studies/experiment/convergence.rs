//! The `convergence` experiment kind: error against run time for every (scene, tracer,
//! scheduler) of the plan, through [`crate::studies::converge`]. Writes `convergence.csv`,
//! `convergence.png`/`.svg` and a `report.md` with the fitted slopes (expected −½) and which
//! configuration reaches the lowest error in the same time.
//!
//! ```toml
//! kind = "convergence"
//! max_spp = 64
//! workers = 2
//! tracers = ["bvh"]
//! [[schedulers]]          # optional; none = one row-parallel rayon pool (`rows_rayon`)
//! kind = "master"
//! chunk = "1"
//! ```

use super::plan::{ConvergenceSettings, ExperimentPlan};
use crate::studies::converge::{self, reference, ConvergenceRow};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The plots written beside `convergence.csv` (and redrawn from it by `raysched plot`).
pub const PLOTS: [&str; 2] = ["convergence.png", "convergence.svg"];

/// Why a convergence experiment stopped.
#[derive(Debug, thiserror::Error)]
pub enum ConvergenceError {
    /// The plan is of another kind.
    #[error("{0} is not a convergence experiment")]
    NotConvergence(String),
    /// A scene's reference could not be rendered or cached.
    #[error("reference for {scene}: {msg}")]
    Reference {
        /// The scene.
        scene: String,
        /// The reference's error.
        msg: String,
    },
    /// A configuration's scheduler failed: `<scene> <tracer> <label>: <error>`, one message
    /// (the error is shown in it, not chained below it).
    #[error("{config}: {error}")]
    Sched {
        /// The scene, tracer and configuration label.
        config: String,
        /// The scheduler's error.
        error: crate::sched::SchedError,
    },
    /// Writing or reading `convergence.csv`.
    #[error(transparent)]
    Csv(#[from] crate::util::csv_out::CsvError),
    /// Drawing a plot.
    #[error(transparent)]
    Plot(#[from] converge::PlotError),
    /// Creating the folder or writing `report.md`.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// Run a convergence plan; returns the results folder. References that are not analytic are
/// rendered once and cached under `<out>/refs/`, keyed by the scene's hash.
///
/// # Errors
/// A reference that cannot be rendered or cached, a scheduler failure, or an I/O error
/// writing the outputs.
pub fn run(plan: &ExperimentPlan, out: &Path) -> Result<PathBuf, ConvergenceError> {
    let settings = plan
        .convergence
        .ok_or_else(|| ConvergenceError::NotConvergence(plan.name.clone()))?;
    let dir = out.join(&plan.name);
    std::fs::create_dir_all(&dir)?;
    let load_start = load_average();
    let (rows, refs) = render_all(plan, &settings, out)?;
    let load_end = load_average();
    let csv = dir.join("convergence.csv");
    converge::write_csv(&csv, &rows)?;
    let from_csv = converge::read_csv(&csv)?;
    for p in PLOTS {
        converge::plot(&dir.join(p), &from_csv)?;
    }
    let md = report_text(plan, &settings, &refs, &from_csv, (load_start, load_end));
    std::fs::write(dir.join("report.md"), md)?;
    Ok(dir)
}

/// Every baseline's progressive renders under each of its configurations, and one line per
/// distinct reference (`scene: kind`).
fn render_all(
    plan: &ExperimentPlan,
    settings: &ConvergenceSettings,
    out: &Path,
) -> Result<(Vec<ConvergenceRow>, Vec<String>), ConvergenceError> {
    let mut rows = Vec::new();
    let mut refs: Vec<String> = Vec::new();
    for (bi, b) in plan.baselines.iter().enumerate() {
        let scene = &plan.scenes[b.scene].scene;
        let r = reference::reference(
            scene,
            b.tracer.as_ref(),
            &out.join("refs"),
            settings.ref_spp,
            plan.max_workers,
            &mut |_, _| {},
        )
        .map_err(|e| ConvergenceError::Reference {
            scene: scene.name.clone(),
            msg: e.0,
        })?;
        let line = format!("{}: {}", scene.name, r.kind.label());
        if !refs.contains(&line) {
            refs.push(line);
        }
        let specs = specs_of(plan, bi);
        if specs.is_empty() {
            rows.extend(
                converge::run_convergence(scene, &b.tracer, &r, settings.max_spp, plan.max_workers)
                    .map_err(|error| ConvergenceError::Sched {
                        config: format!("{} {} {}", scene.name, b.tracer_id, converge::ROWS_RAYON),
                        error,
                    })?,
            );
        }
        for spec in specs {
            rows.extend(
                converge::run_convergence_scheduled(scene, &b.tracer, &r, settings.max_spp, spec)
                    .map_err(|error| ConvergenceError::Sched {
                    config: format!("{} {} {}", scene.name, b.tracer_id, spec.label()),
                    error,
                })?,
            );
        }
    }
    Ok((rows, refs))
}

/// `report.md`: the references, the lowest error per time budget and the fitted slopes, with
/// the load average at the start and end of the renders.
fn report_text(
    plan: &ExperimentPlan,
    settings: &ConvergenceSettings,
    refs: &[String],
    from_csv: &[ConvergenceRow],
    (load_start, load_end): (String, String),
) -> String {
    let machine = super::meta::machine();
    let mut md = format!(
        "# Experiment `{}` (convergence)\n\n{}\n\nProgressive render 1, 2, 4 … {} spp; error against \
         the reference after each step. A step's wall time is the whole image's samples `lo..hi` \
         under the configuration's scheduler (threads started and joined included); `rows_rayon` \
         is one row-parallel rayon pool built once. Images are bit-identical across schedulers, \
         so only the times differ between them.\n\n\
         Timings were taken on {} ({} logical CPUs) while other work (builds) may have been running \
         on it: load average {} at the start, {} at the end. Read small differences as noise.\n\n\
         ## References\n\n",
        plan.name,
        plan.description,
        settings.max_spp,
        machine.cpu_model,
        machine.cores,
        load_start,
        load_end,
    );
    for r in refs {
        let _ = writeln!(md, "- {r}");
    }
    let _ = writeln!(md, "\n## Same time budget: lowest error\n");
    for line in converge::budget_winners(from_csv) {
        let _ = writeln!(md, "- {line}.");
    }
    let _ = writeln!(
        md,
        "\n## Fitted slopes (log RMSE vs log time; −½ expected)\n\nConfiguration = \
         tracer/scheduler/workers. Best first per scene.\n\n\
         A slope steeper than −½ means the early, small steps are dominated by a per-step cost \
         (threads started, items handed out) that the later, larger steps amortise: the \
         configuration pays a constant price per step, not per sample. On a run of a few tens of \
         milliseconds (the furnace) the slope is mostly that overhead and the machine's noise.\n\n\
         | scene | configuration | slope | time budget (s) | RMSE at budget |\n|---|---|---|---|---|"
    );
    for s in converge::summarise(from_csv) {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.4} | {} |",
            s.scene,
            s.config,
            s.slope.map_or("n/a".into(), |v| format!("{v:.3}")),
            s.budget_s,
            s.rmse_at_budget.map_or("n/a".into(), |v| format!("{v:.5}"))
        );
    }
    let _ = writeln!(md, "\n![error vs time](convergence.png)");
    md
}

/// The scheduler configurations of baseline `bi` (a scene and tracer); none: `rows_rayon`.
fn specs_of(plan: &ExperimentPlan, bi: usize) -> Vec<&crate::sched::SchedulerSpec> {
    plan.configs
        .iter()
        .filter(|c| c.baseline == bi)
        .filter_map(|c| c.spec.as_ref())
        .collect()
}

/// What [`run`] would do, measuring nothing: the progression, each scene's reference (analytic,
/// cached under `<out>/refs/` or to be rendered) and every configuration, with a time estimate
/// from one probe render per (scene, tracer) ([`super::dry_run::probe_render_s`]) scaled to a
/// sample per pixel (a configuration of w workers at 1 / min(w, cores) of it). Writes no file.
pub fn plan_text(plan: &ExperimentPlan, out: &Path) -> Result<String, ConvergenceError> {
    let settings = plan
        .convergence
        .ok_or_else(|| ConvergenceError::NotConvergence(plan.name.clone()))?;
    let steps = settings.max_spp.ilog2() + 1;
    // 1 + 2 + 4 + … + max_spp samples per pixel, the progression's last step included.
    let samples = 2.0 * f64::from(settings.max_spp) - 1.0;
    let cores = crate::util::host::available_threads();
    let mut text = String::new();
    let _ = writeln!(
        text,
        "experiment {} (convergence) → {}\nprogressive 1, 2, 4 … {} spp ({steps} steps, \
         {samples:.0} samples per pixel per configuration)\n",
        plan.name,
        out.join(&plan.name).display(),
        settings.max_spp,
    );
    let (mut total, mut probe_total) = (0.0, 0.0);
    // References this run would render: the first tracer of a scene renders it, the next
    // finds it cached.
    let mut rendered: Vec<PathBuf> = Vec::new();
    for (bi, b) in plan.baselines.iter().enumerate() {
        let scene = plan.scenes[b.scene].scene.as_ref();
        let probe = super::dry_run::probe_render_s(scene, b.tracer.as_ref());
        probe_total += probe;
        let per_spp = probe / f64::from(scene.settings.spp.max(1));
        let cached = reference::cache_path(&out.join("refs"), scene, settings.ref_spp);
        let refs = if let Some(r) = reference::analytic(scene) {
            r.kind.label()
        } else if cached.exists() {
            format!("cached {}", cached.display())
        } else if rendered.contains(&cached) {
            "rendered above, then cached".into()
        } else {
            rendered.push(cached);
            let t =
                per_spp * f64::from(settings.ref_spp) / plan.max_workers.min(cores).max(1) as f64;
            total += t;
            format!("rendered at {} spp, est. {t:.1} s", settings.ref_spp)
        };
        let _ = writeln!(text, "{} · {}: reference {refs}", scene.name, b.tracer_id);
        let specs = specs_of(plan, bi);
        let mut line = |label: String, workers: usize| {
            let t = per_spp * samples / workers.min(cores).max(1) as f64;
            total += t;
            let _ = writeln!(text, "  {label} ×{workers}: est. {t:.1} s");
        };
        if specs.is_empty() {
            line("rows_rayon".into(), plan.max_workers);
        }
        for spec in specs {
            line(spec.label(), spec.workers);
        }
    }
    let _ = writeln!(
        text,
        "\nestimated {total:.0} s of rendering ({}). Nothing was measured.",
        super::dry_run::probe_label(probe_total)
    );
    Ok(text)
}

/// The 1-minute load average (Linux), or "unknown": how busy the machine was around the run.
fn load_average() -> String {
    let all = crate::util::host::load_average_text();
    all.split_whitespace()
        .next()
        .map_or_else(|| "unknown".into(), str::to_string)
}
