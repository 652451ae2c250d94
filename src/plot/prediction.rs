//! The cost model against the measurements (experiments with `predict = true`): per group,
//! each configuration's predicted and measured wall time and the error, the model's pick
//! against the measured best, and the parts the model splits a prediction into.

use super::report::{tied_with_best, wall_ratio, with_ci};
use crate::experiment::summary::Summary;
use std::fmt::Write;

/// Predicted / measured − 1 of a configuration's median, when it has a prediction.
pub fn error(s: &Summary) -> Option<f64> {
    let p = s.row.predicted_wall_s?;
    (s.wall_median > 0.0).then(|| p / s.wall_median - 1.0)
}

/// "predicted 12.3 ms = work 10.1 + hand-out 1.2 (h × items / P) + refill waiting 0.4 +
/// imbalance 0.6": a prediction's parts, or `None` without one.
pub fn decomposition(s: &Summary) -> Option<String> {
    let wall = s.row.predicted_wall_s?;
    let h = s.row.predicted_handout_s.unwrap_or(0.0);
    let r = s.row.predicted_refill_s.unwrap_or(0.0);
    let i = s.row.predicted_imbalance_s.unwrap_or(0.0);
    let work = wall - h - r - i;
    Some(format!(
        "predicted {:.2} ms = work {:.2} + hand-out {:.2} (h × items / P) + refill waiting {:.2} + imbalance {:.2}",
        wall * 1e3,
        work * 1e3,
        h * 1e3,
        r * 1e3,
        i * 1e3
    ))
}

/// The per-ray master's gap to `best` in the model's terms: how much of the predicted
/// difference is hand-out cost, refill waiting and imbalance.
pub fn gap_clause(per_ray: &Summary, best: &Summary) -> Option<String> {
    let parts = |s: &Summary| -> Option<(f64, f64, f64, f64)> {
        Some((
            s.row.predicted_wall_s?,
            s.row.predicted_handout_s.unwrap_or(0.0),
            s.row.predicted_refill_s.unwrap_or(0.0),
            s.row.predicted_imbalance_s.unwrap_or(0.0),
        ))
    };
    let (pw, ph, pr, pi) = parts(per_ray)?;
    let (bw, bh, br, bi) = parts(best)?;
    let gap = pw - bw;
    Some(format!(
        " The cost model predicts the per-ray master at {:.2} ms against {:.2} ms (measured {:.2} and {:.2}): of the predicted gap of {:.2} ms, {:.2} ms is hand-out cost (h × items / P), {:.2} ms waiting for refills and {:.2} ms imbalance.",
        pw * 1e3,
        bw * 1e3,
        per_ray.wall_median * 1e3,
        best.wall_median * 1e3,
        gap * 1e3,
        (ph - bh) * 1e3,
        (pr - br) * 1e3,
        (pi - bi) * 1e3
    ))
}

/// The configurations of `at` within `tol` of the fastest measured median.
fn within<'a>(at: &[&'a Summary], best: &Summary, tol: f64) -> Vec<&'a Summary> {
    at.iter()
        .copied()
        .filter(|s| s.wall_median <= best.wall_median * (1.0 + tol))
        .collect()
}

/// The "Cost model" section of `report.md` for one group's rows at its most workers (only
/// the configurations with a prediction), or `None` when none has one.
pub fn section(group: &str, at: &[&Summary]) -> Option<String> {
    let with: Vec<&Summary> = at
        .iter()
        .copied()
        .filter(|s| s.row.predicted_wall_s.is_some() && s.row.scheduler != "serial")
        .collect();
    if with.is_empty() {
        return None;
    }
    let mut md = String::new();
    let _ = writeln!(md, "### {group}\n");
    let _ = writeln!(
        md,
        "| configuration | workers | measured median (ms) | predicted (ms) | error | hand-out (ms) | refill (ms) | imbalance (ms) |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|");
    for s in &with {
        let _ = writeln!(
            md,
            "| `{}` | {} | {:.3} | {:.3} | {:+.1} % | {:.3} | {:.3} | {:.3} |",
            s.row.label,
            s.row.workers,
            s.wall_median * 1e3,
            s.row.predicted_wall_s.unwrap_or(0.0) * 1e3,
            error(s).unwrap_or(0.0) * 100.0,
            s.row.predicted_handout_s.unwrap_or(0.0) * 1e3,
            s.row.predicted_refill_s.unwrap_or(0.0) * 1e3,
            s.row.predicted_imbalance_s.unwrap_or(0.0) * 1e3
        );
    }
    let (best, tied) = tied_with_best(&with)?;
    let pick = with.iter().copied().min_by(|a, b| {
        a.row
            .predicted_wall_s
            .unwrap_or(f64::INFINITY)
            .total_cmp(&b.row.predicted_wall_s.unwrap_or(f64::INFINITY))
    })?;
    let verdict = if pick.row.config == best.row.config {
        "is the measured best".to_string()
    } else {
        let r = wall_ratio(pick, best);
        let tie = if tied.iter().any(|t| t.row.config == pick.row.config) {
            "statistically tied with it"
        } else {
            "not tied with it"
        };
        format!(
            "took {} the wall time of the measured best `{}` ({}; {} the 3 % goal)",
            with_ci(&r),
            best.row.label,
            tie,
            if r.value <= 1.03 { "within" } else { "outside" }
        )
    };
    let mut errs: Vec<(f64, &Summary)> = with
        .iter()
        .filter_map(|s| Some((error(s)?.abs(), *s)))
        .collect();
    errs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let median_err = errs[errs.len() / 2].0;
    let (max_err, worst) = errs[errs.len() - 1];
    let flat = within(&with, best, 0.03);
    let _ = writeln!(
        md,
        "\nThe model's pick `{}` (predicted {:.3} ms) {verdict}. Error at the measured best `{}`: {:+.1} %; across the {} configurations: median |error| {:.1} %, largest {:.1} % (`{}`). Measured within 3 % of the best: {} configuration{}{}.\n",
        pick.row.label,
        pick.row.predicted_wall_s.unwrap_or(0.0) * 1e3,
        best.row.label,
        error(best).unwrap_or(0.0) * 100.0,
        with.len(),
        median_err * 100.0,
        max_err * 100.0,
        worst.row.label,
        flat.len(),
        if flat.len() == 1 { "" } else { "s" },
        if flat.len() > 1 { " (a flat optimum)" } else { "" }
    );
    Some(md)
}
