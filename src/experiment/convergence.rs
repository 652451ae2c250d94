//! The `convergence` experiment kind: error against run time for every (scene, tracer,
//! scheduler) of the plan, through [`crate::converge`]. Writes `convergence.csv`,
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

use super::plan::ExperimentPlan;
use crate::converge::{self, reference};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The plots written beside `convergence.csv` (and redrawn from it by `raysched plot`).
pub const PLOTS: [&str; 2] = ["convergence.png", "convergence.svg"];

/// Run a convergence plan; returns the results folder. References that are not analytic are
/// rendered once and cached under `<out>/refs/`, keyed by the scene's hash.
///
/// # Errors
/// A reference that cannot be rendered or cached, a scheduler failure, or an I/O error
/// writing the outputs.
pub fn run(plan: &ExperimentPlan, out: &Path) -> anyhow::Result<PathBuf> {
    let settings = plan
        .convergence
        .ok_or_else(|| anyhow::anyhow!("{} is not a convergence experiment", plan.name))?;
    let dir = out.join(&plan.name);
    std::fs::create_dir_all(&dir)?;
    let load_start = load_average();
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
        .map_err(|e| anyhow::anyhow!("reference for {}: {e}", scene.name))?;
        let line = format!("{}: {}", scene.name, r.kind.label());
        if !refs.contains(&line) {
            refs.push(line);
        }
        let specs: Vec<_> = plan
            .configs
            .iter()
            .filter(|c| c.baseline == bi)
            .filter_map(|c| c.spec.as_ref())
            .collect();
        if specs.is_empty() {
            rows.extend(converge::run_convergence(
                scene,
                b.tracer.as_ref(),
                &r,
                settings.max_spp,
                plan.max_workers,
            ));
        }
        for spec in specs {
            rows.extend(
                converge::run_convergence_scheduled(scene, &b.tracer, &r, settings.max_spp, spec)
                    .map_err(|e| {
                    anyhow::anyhow!("{} {} {}: {e}", scene.name, b.tracer_id, spec.label())
                })?,
            );
        }
    }
    let load_end = load_average();
    let csv = dir.join("convergence.csv");
    converge::write_csv(&csv, &rows)?;
    let from_csv = converge::read_csv(&csv)?;
    for p in PLOTS {
        converge::plot(&dir.join(p), &from_csv)?;
    }
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
    for r in &refs {
        let _ = writeln!(md, "- {r}");
    }
    let _ = writeln!(md, "\n## Same time budget: lowest error\n");
    for line in converge::budget_winners(&from_csv) {
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
    for s in converge::summarise(&from_csv) {
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
    std::fs::write(dir.join("report.md"), md)?;
    Ok(dir)
}

/// The 1-minute load average (Linux), or "unknown": how busy the machine was around the run.
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(str::to_string))
        .unwrap_or_else(|| "unknown".into())
}
