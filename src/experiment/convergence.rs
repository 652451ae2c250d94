//! The `convergence` experiment kind: error against run time for every (scene, tracer) of the
//! plan, through [`crate::converge`]. Writes `convergence.csv`, `convergence.png` and a
//! `report.md` with the fitted slopes (expected −½) and the lowest error at equal time.

use super::plan::ExperimentPlan;
use crate::converge::{self, reference};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Run a convergence plan; returns the results folder. References that are not analytic are
/// rendered once and cached under `<out>/refs/`, keyed by the scene's hash.
///
/// # Errors
/// A reference that cannot be rendered or cached, or an I/O error writing the outputs.
pub fn run(plan: &ExperimentPlan, out: &Path) -> anyhow::Result<PathBuf> {
    let settings = plan
        .convergence
        .ok_or_else(|| anyhow::anyhow!("{} is not a convergence experiment", plan.name))?;
    let dir = out.join(&plan.name);
    std::fs::create_dir_all(&dir)?;
    let mut rows = Vec::new();
    let mut refs = Vec::new();
    for b in &plan.baselines {
        let scene = &plan.scenes[b.scene].scene;
        let r = reference::reference(
            scene,
            b.tracer.as_ref(),
            &out.join("refs"),
            settings.ref_spp,
            plan.max_workers,
        )
        .map_err(|e| anyhow::anyhow!("reference for {}: {e}", scene.name))?;
        refs.push(format!("{}: {}", scene.name, r.kind.label()));
        rows.extend(converge::run_convergence(
            scene,
            b.tracer.as_ref(),
            &r,
            settings.max_spp,
            plan.max_workers,
        ));
    }
    let csv = dir.join("convergence.csv");
    converge::write_csv(&csv, &rows)?;
    let from_csv = converge::read_csv(&csv)?;
    converge::plot(&dir.join("convergence.png"), &from_csv)?;
    let mut md = format!(
        "# Experiment `{}` (convergence)\n\n{}\n\nProgressive render 1, 2, 4 … {} spp on {} threads; \
         error against the reference after each step.\n\n## References\n\n",
        plan.name, plan.description, settings.max_spp, plan.max_workers
    );
    for r in &refs {
        let _ = writeln!(md, "- {r}");
    }
    let _ = writeln!(
        md,
        "\n## Fitted slopes (log RMSE vs log time; −½ expected)\n\n| scene | configuration | slope | time budget (s) | RMSE at budget |\n|---|---|---|---|---|"
    );
    for s in converge::summarise(&from_csv) {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.3} | {} |",
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
