//! The cost model against the measurements (experiments with `predict = true`): per group,
//! each configuration's predicted and measured wall time and the error, the model's pick
//! against the measured best, and the parts the model splits a prediction into.

use super::compare::{near_best, reading, wall_ratio, with_ci, Reading};
use crate::studies::experiment::summary::Summary;
use std::fmt::Write;

/// Predicted / measured − 1 of a configuration's median, when it has a prediction.
pub fn error(s: &Summary) -> Option<f64> {
    let p = s.row.predicted_wall_s?;
    (s.wall_median > 0.0).then(|| p / s.wall_median - 1.0)
}

/// A prediction's wall time and its parts: (wall, hand-out cost, refill waiting, imbalance);
/// the rest of the wall is work / P. `None` without a prediction.
fn parts(s: &Summary) -> Option<(f64, f64, f64, f64)> {
    Some((
        s.row.predicted_wall_s?,
        s.row.predicted_handout_s.unwrap_or(0.0),
        s.row.predicted_refill_s.unwrap_or(0.0),
        s.row.predicted_imbalance_s.unwrap_or(0.0),
    ))
}

/// "predicted 12.3 ms = work 10.1 + hand-out 1.2 (h × items / P) + refill waiting 0.4 +
/// imbalance 0.6": a prediction's parts, or `None` without one.
pub fn decomposition(s: &Summary) -> Option<String> {
    let (wall, h, r, i) = parts(s)?;
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

/// How far the probe's level of the work was from the rounds': the serial baseline's median
/// over the image's work as the probe put it (P × the prediction's work part), the median over
/// `with`'s configurations without a slow worker (with one, the work part is not W / P).
///
/// The probe times the image in a few seconds before the first round, while a 2-core VM
/// drifts from second to second, so one probe's level can sit well off the rounds' (M-133).
/// Set to the serial level, the rest of an error is the model's shape. The serial render runs
/// on one core and the probe on P, so where busy cores slow each other the two levels also
/// differ for that reason.
pub fn level(with: &[&Summary], serial_median: f64) -> Option<f64> {
    let mut k: Vec<f64> = with
        .iter()
        .filter(|s| s.row.equal_workers())
        .filter_map(|s| {
            let (wall, h, r, i) = parts(s)?;
            let work = (wall - h - r - i) * s.row.workers as f64;
            (work > 0.0).then(|| serial_median / work)
        })
        .filter(|k| k.is_finite() && *k > 0.0)
        .collect();
    if k.is_empty() {
        return None;
    }
    k.sort_by(f64::total_cmp);
    Some(k[k.len() / 2])
}

/// [`error`] with the prediction's work and imbalance (the parts the item costs set) scaled
/// by `k` ([`level`]); hand-out cost and refill waiting are measured apart and stay.
pub fn error_at_level(s: &Summary, k: f64) -> Option<f64> {
    let (wall, h, r, _) = parts(s)?;
    let fixed = h + r;
    let p = (wall - fixed) * k + fixed;
    (s.wall_median > 0.0).then(|| p / s.wall_median - 1.0)
}

/// The per-ray master's gap to `best` in the model's terms: how much of the predicted
/// difference is hand-out cost, refill waiting and imbalance.
pub fn gap_clause(per_ray: &Summary, best: &Summary) -> Option<String> {
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

/// One scheduler's chunk curve against the model: the configurations that differ only in
/// their chunk, at least three of them.
#[derive(Clone, Debug, PartialEq)]
pub struct ChunkCheck {
    /// The curve's label without its chunk (`self_scheduling slow=1:3`).
    pub curve: String,
    /// Pixels per item of each point, smallest first.
    pub px: Vec<u64>,
    /// Pixels per item of the fastest measured median.
    pub measured_px: u64,
    /// Each neighbour of the measured best (one at an end of the sweep, else two):
    /// wall(neighbour) / wall(best) with its 95 % interval.
    pub neighbours: Vec<(u64, crate::studies::experiment::stats::Ratio)>,
    /// Pixels per item of the fastest prediction on the curve.
    pub predicted_px: u64,
}

impl ChunkCheck {
    /// A clear optimum: every neighbour of the measured best is slower beyond its interval.
    pub fn clear(&self) -> bool {
        !self.neighbours.is_empty() && self.neighbours.iter().all(|(_, r)| r.lo > 1.0)
    }

    /// The predicted best chunk within ×2 (in pixels per item) of the measured best.
    pub fn within_x2(&self) -> bool {
        let (m, p) = (
            self.measured_px.max(1) as f64,
            self.predicted_px.max(1) as f64,
        );
        (m / p).max(p / m) <= 2.0
    }

    /// One line of the report.
    pub fn sentence(&self) -> String {
        let px: Vec<String> = self.px.iter().map(u64::to_string).collect();
        let nb: Vec<String> = self
            .neighbours
            .iter()
            .map(|(px, r)| format!("{px} px {}", with_ci(r)))
            .collect();
        let verdict = if !self.clear() {
            "no clear optimum (a neighbour is not shown slower than it), so the ×2 check does not apply"
                .to_string()
        } else if self.within_x2() {
            format!(
                "a clear optimum; predicted best {} px: within ×2",
                self.predicted_px
            )
        } else {
            format!(
                "a clear optimum; predicted best {} px: outside ×2",
                self.predicted_px
            )
        };
        format!(
            "- `{}` over {} px per item: measured best {} px (neighbours {}): {verdict}.",
            self.curve,
            px.join(", "),
            self.measured_px,
            nb.join("; ")
        )
    }
}

/// The label without its `chunk=…` word: what the points of one chunk curve share.
fn curve_of(label: &str) -> String {
    label
        .split_whitespace()
        .filter(|w| !w.starts_with("chunk="))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The chunk curves of `with` (configurations with a prediction) that have three points or
/// more, each checked against the model's best chunk on the same curve.
pub fn chunk_checks(with: &[&Summary]) -> Vec<ChunkCheck> {
    let mut curves: Vec<(String, Vec<&Summary>)> = Vec::new();
    for s in with {
        let (Some(_), Some(_)) = (s.row.chunk_px, s.row.predicted_wall_s) else {
            continue;
        };
        let key = curve_of(&s.row.label);
        match curves.iter_mut().find(|(k, _)| *k == key) {
            Some((_, v)) => v.push(s),
            None => curves.push((key, vec![s])),
        }
    }
    curves
        .into_iter()
        .filter(|(_, v)| v.len() >= 3)
        .filter_map(|(curve, mut v)| {
            v.sort_by_key(|s| s.row.chunk_px);
            let best =
                (0..v.len()).min_by(|&a, &b| v[a].wall_median.total_cmp(&v[b].wall_median))?;
            let pred = (0..v.len()).min_by(|&a, &b| {
                let p = |i: usize| v[i].row.predicted_wall_s.unwrap_or(f64::INFINITY);
                p(a).total_cmp(&p(b))
            })?;
            let neighbours = [best.checked_sub(1), Some(best + 1).filter(|&i| i < v.len())]
                .into_iter()
                .flatten()
                .map(|i| (v[i].row.chunk_px.unwrap_or(0), wall_ratio(v[i], v[best])))
                .collect();
            Some(ChunkCheck {
                curve,
                px: v.iter().map(|s| s.row.chunk_px.unwrap_or(0)).collect(),
                measured_px: v[best].row.chunk_px.unwrap_or(0),
                neighbours,
                predicted_px: v[pred].row.chunk_px.unwrap_or(0),
            })
        })
        .collect()
}

/// How the model's pick `pick` fared against the measured best `best`: "is the measured best",
/// or its wall-time ratio with the interval, read as equivalent within ±`margin`, not shown
/// slower or shown slower ([`reading`]), and within or outside the 3 % goal.
fn pick_verdict(pick: &Summary, best: &Summary, margin: f64) -> String {
    if pick.row.config == best.row.config {
        return "is the measured best".to_string();
    }
    let r = wall_ratio(pick, best);
    let reads = match reading(pick, best, margin) {
        Some(Reading::Equivalent) => format!("equivalent within ±{:.1} %", margin * 100.0),
        Some(Reading::NotShownSlower(_)) => "not shown slower".to_string(),
        None => "shown slower".to_string(),
    };
    format!(
        "took {} the wall time of the measured best `{}` ({}; {} the 3 % goal)",
        with_ci(&r),
        best.row.label,
        reads,
        if r.value <= 1.03 { "within" } else { "outside" }
    )
}

/// The probe's level paragraph: the errors again with the prediction's work scaled by `k` to
/// the serial median `s` (empty where no configuration has an error at that level).
fn level_paragraph(with: &[&Summary], best: &Summary, k: f64, s: f64) -> String {
    let mut md = String::new();
    let mut errs: Vec<f64> = with
        .iter()
        .filter_map(|s| error_at_level(s, k))
        .map(f64::abs)
        .collect();
    errs.sort_by(f64::total_cmp);
    if let (Some(&largest), Some(at_best)) = (errs.last(), error_at_level(best, k)) {
        let _ = writeln!(
            md,
            "The probe's level: it put the image's work at {:.3} ms, {:+.1} % off the serial baseline's median in the rounds ({:.3} ms). With the prediction's work and imbalance scaled to the serial level, the error at the measured best is {:+.1} %, median |error| {:.1} %, largest {:.1} %: what remains is the model's shape rather than the machine's speed while it probed (the serial render ran on one core and the runs on {}, so where busy cores slow each other the runs sit above the serial level by that much too).\n",
            s / k * 1e3,
            (1.0 / k - 1.0) * 100.0,
            s * 1e3,
            at_best * 100.0,
            errs[errs.len() / 2] * 100.0,
            largest * 100.0,
            best.row.workers
        );
    }
    md
}

/// The "Cost model" section of `report.md` for one group's rows at its most workers (only
/// the configurations with a prediction), or `None` when none has one. `serial` is the
/// group's serial median, for the level check ([`level`]); `margin` the equivalence margin the
/// pick is tested at ([`reading`]).
pub fn section(group: &str, at: &[&Summary], serial: Option<f64>, margin: f64) -> Option<String> {
    let with: Vec<&Summary> = at
        .iter()
        .copied()
        .filter(|s| s.row.predicted_wall_s.is_some() && !s.row.is_serial())
        .collect();
    if with.is_empty() {
        return None;
    }
    let k = serial.and_then(|m| level(&with, m));
    let at_level = |s: &Summary| match k.and_then(|k| error_at_level(s, k)) {
        Some(e) => format!("{:+.1} %", e * 100.0),
        None => "–".to_string(),
    };
    let mut md = String::new();
    let _ = writeln!(md, "### {group}\n");
    let _ = writeln!(
        md,
        "| configuration | workers | measured median (ms) | predicted (ms) | error | error at the serial level | hand-out (ms) | refill (ms) | imbalance (ms) |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|");
    for s in &with {
        let _ = writeln!(
            md,
            "| `{}` | {} | {:.3} | {:.3} | {:+.1} % | {} | {:.3} | {:.3} | {:.3} |",
            s.row.label,
            s.row.workers,
            s.wall_median * 1e3,
            s.row.predicted_wall_s.unwrap_or(0.0) * 1e3,
            error(s).unwrap_or(0.0) * 100.0,
            at_level(s),
            s.row.predicted_handout_s.unwrap_or(0.0) * 1e3,
            s.row.predicted_refill_s.unwrap_or(0.0) * 1e3,
            s.row.predicted_imbalance_s.unwrap_or(0.0) * 1e3
        );
    }
    let (best, _) = near_best(&with, margin)?;
    let pick = with.iter().copied().min_by(|a, b| {
        a.row
            .predicted_wall_s
            .unwrap_or(f64::INFINITY)
            .total_cmp(&b.row.predicted_wall_s.unwrap_or(f64::INFINITY))
    })?;
    let verdict = pick_verdict(pick, best, margin);
    let mut errs: Vec<(f64, &Summary)> = with
        .iter()
        .filter_map(|s| Some((error(s)?.abs(), *s)))
        .collect();
    errs.sort_by(|a, b| a.0.total_cmp(&b.0));
    // No configuration with a finite error (a non-positive measured time): no summary line.
    let (Some(&(median_err, _)), Some(&(max_err, worst))) = (errs.get(errs.len() / 2), errs.last())
    else {
        return Some(md);
    };
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
    if let (Some(k), Some(s)) = (k, serial) {
        md += &level_paragraph(&with, best, k, s);
    }
    let checks = chunk_checks(&with);
    if !checks.is_empty() {
        let clear: Vec<&ChunkCheck> = checks.iter().filter(|c| c.clear()).collect();
        let _ = writeln!(
            md,
            "The ×2 best-chunk check (where a chunk curve has a clear optimum, its neighbours slower beyond their 95 % intervals, the predicted best chunk within ×2 of it in pixels per item): {} of {} clear optima within ×2; {} of {} curves without a clear optimum.\n",
            clear.iter().filter(|c| c.within_x2()).count(),
            clear.len(),
            checks.len() - clear.len(),
            checks.len()
        );
        for c in &checks {
            let _ = writeln!(md, "{}", c.sentence());
        }
        let _ = writeln!(md);
    }
    Some(md)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::studies::experiment::results::RunRow;
    use crate::studies::experiment::summary::summarize;

    /// Eight repetitions of a self-scheduling chunk of `side`² at `wall` seconds (±1 %),
    /// predicted at `predicted`.
    fn point(side: u64, wall: f64, predicted: f64) -> Vec<RunRow> {
        (0..8)
            .map(|rep| {
                let mut r = RunRow::example();
                r.config = format!("ss{side}");
                r.scheduler = "self_scheduling".into();
                r.label = format!("self_scheduling chunk={side} slow=1:3");
                r.chunk = Some(side.to_string());
                r.chunk_px = Some(side * side);
                r.workers = 2;
                r.repetition = rep;
                // ±1 % noise, in a different pattern for each chunk (paired ratios keep it).
                let k = (rep as u64 * 3 + side) % 5;
                r.wall_s = wall * (1.0 + 0.005 * (k as f64 - 2.0));
                r.predicted_wall_s = Some(predicted);
                r
            })
            .collect()
    }

    fn checks(points: &[(u64, f64, f64)]) -> Vec<ChunkCheck> {
        let rows: Vec<RunRow> = points
            .iter()
            .flat_map(|&(s, w, p)| point(s, w, p))
            .collect();
        let sums = summarize(&rows);
        chunk_checks(&sums.iter().collect::<Vec<_>>())
    }

    #[test]
    fn the_probe_level_is_the_serial_median_over_the_predicted_work_and_rescales_work_only() {
        // Two workers, predicted 60 ms of which 10 ms hand-out and 5 ms refill waiting: work
        // part 45 ms, so the probe put the image's work at 90 ms; the serial median is 72 ms.
        let row = |config: &str, slow: Option<&str>, wall: f64| {
            let mut r = RunRow::example();
            r.config = config.into();
            r.scheduler = "master".into();
            r.label = config.into();
            r.workers = 2;
            r.slow = slow.map(str::to_string);
            r.wall_s = wall;
            r.predicted_wall_s = Some(0.060);
            r.predicted_handout_s = Some(0.010);
            r.predicted_refill_s = Some(0.005);
            r.predicted_imbalance_s = Some(0.0);
            r
        };
        let rows = [
            row("a", None, 0.051),
            row("b", Some("none"), 0.051),
            // A slow worker's prediction is not W / P: left out of the level.
            row("c", Some("1:3"), 0.051),
        ];
        let mut rows = rows.to_vec();
        rows[2].predicted_wall_s = Some(0.2);
        let sums = summarize(&rows);
        let with: Vec<&Summary> = sums.iter().collect();
        let k = level(&with, 0.072).unwrap();
        assert!((k - 0.8).abs() < 1e-12, "{k}");
        // 45 ms × 0.8 + 15 ms = 51 ms: exactly the measured median.
        let e = error_at_level(with[0], k).unwrap();
        assert!(e.abs() < 1e-9, "{e}");
        assert!((error(with[0]).unwrap() - (0.060 / 0.051 - 1.0)).abs() < 1e-12);
        // No usable configuration, no level.
        assert_eq!(level(&with[2..], 0.072), None);
        assert_eq!(level(&with, f64::NAN), None);
    }

    #[test]
    fn a_clear_optimum_is_checked_against_the_predicted_best_chunk_and_a_flat_one_is_not() {
        // Measured best 4² (16 px), both neighbours 10 % slower: a clear optimum.
        let c = checks(&[
            (1, 0.11, 0.12),
            (4, 0.10, 0.10),
            (16, 0.11, 0.105),
            (64, 0.2, 0.2),
        ]);
        assert_eq!(c.len(), 1);
        assert_eq!(c[0].curve, "self_scheduling slow=1:3");
        assert_eq!(c[0].px, [1, 16, 256, 4096]);
        assert_eq!((c[0].measured_px, c[0].predicted_px), (16, 16));
        assert!(c[0].clear() && c[0].within_x2(), "{c:?}");
        assert_eq!(c[0].neighbours.len(), 2);
        // The model prefers 16² (256 px): 16× off, outside ×2.
        let c = checks(&[
            (1, 0.11, 0.12),
            (4, 0.10, 0.11),
            (16, 0.11, 0.105),
            (64, 0.2, 0.2),
        ]);
        assert!(c[0].clear() && !c[0].within_x2(), "{c:?}");
        assert!(
            c[0].sentence().contains("outside ×2"),
            "{}",
            c[0].sentence()
        );
        // 16² as fast as 4² within the noise: no clear optimum, whatever the model says.
        let c = checks(&[
            (1, 0.11, 0.12),
            (4, 0.10, 0.11),
            (16, 0.1001, 0.105),
            (64, 0.2, 0.2),
        ]);
        assert!(!c[0].clear(), "{c:?}");
        assert!(c[0].sentence().contains("does not apply"));
        // Two points are no curve.
        assert!(checks(&[(1, 0.11, 0.12), (4, 0.10, 0.11)]).is_empty());
    }
}
