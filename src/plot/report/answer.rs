//! The report's answer: per scene the fastest configuration and those beside it (equivalent
//! within the margin or not shown slower, [`super::super::compare::near_best`]), each
//! scheduler's wall time against its chunk, and the per-ray master against the best.

use super::super::compare::{best_by, near_best, near_words, speedup_text, wall_ratio, with_ci};
use crate::studies::experiment::stats::Ratio;
use crate::studies::experiment::summary::Summary;
use std::fmt::Write;

/// The parallel configurations at the group's largest worker count (`None`: only serial rows).
fn at_most_workers<'a>(sums: &[&'a Summary]) -> Option<Vec<&'a Summary>> {
    let max_w = sums
        .iter()
        .filter(|s| !s.row.is_serial())
        .map(|s| s.row.workers)
        .max()?;
    Some(
        sums.iter()
            .copied()
            .filter(|s| s.row.workers == max_w && !s.row.is_serial())
            .collect(),
    )
}

/// The comparison sentence for one group at its largest worker count, if it has a per-ray
/// master (master with 1-pixel items) and some other configuration: the fastest one, those
/// equivalent to it within ±`margin` or not shown slower ([`near_best`]), and the ratio to
/// the per-ray master with its interval.
pub fn per_ray_sentence(group: &str, sums: &[&Summary], margin: f64) -> Option<String> {
    let at = at_most_workers(sums)?;
    let max_w = at.first()?.row.workers;
    let per_ray = best_by(at.iter().copied().filter(|s| {
        let hand_out_thread = crate::sched::SchedulerKind::from_id(&s.row.scheduler)
            .is_ok_and(|k| crate::sched::Policy::defaults(k).needs().hand_out_thread);
        hand_out_thread && s.row.chunk_px == Some(1)
    }))?;
    let others: Vec<&Summary> = at
        .iter()
        .copied()
        .filter(|s| s.row.config != per_ray.row.config)
        .collect();
    let (best, near) = near_best(&others, margin)?;
    let r = wall_ratio(per_ray, best);
    let verdict = if r.value >= 1.0 {
        format!("{} faster than", with_ci(&r))
    } else {
        let inv = Ratio {
            value: 1.0 / r.value,
            lo: 1.0 / r.hi,
            hi: 1.0 / r.lo,
            n: r.n,
        };
        format!("{} slower than", with_ci(&inv))
    };
    let ties = if near.is_empty() {
        "every other configuration is shown slower than it".to_string()
    } else {
        format!(
            "beside it, {}",
            near_words(&near, margin, |s| format!(
                "`{}` ({})",
                s.row.label,
                speedup_text(s)
            ))
        )
    };
    Some(format!(
        "On {group} with {max_w} workers, the fastest configuration (`{}`, speedup {}) was {verdict} the per-ray master (`{}`, speedup {}); {ties}.{}",
        best.row.label,
        speedup_text(best),
        per_ray.row.label,
        speedup_text(per_ray),
        crate::plot::prediction::gap_clause(per_ray, best).unwrap_or_default()
    ))
}

pub(super) fn answer_section(sums: &[Summary], groups: &[String], margin: f64) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "## Answer\n");
    let _ = writeln!(md, "Beside the fastest configuration another reads *equivalent within ±{:.1} %* where two one-sided Mann–Whitney tests at 95 % on the runs' wall times reject a change beyond that margin (the experiment's precision target, else {:.0} %), else *not shown slower* where the 95 % interval of its wall time over the fastest's reaches 1; otherwise it is slower. \"Not shown slower\" is no claim of equivalence.\n", margin * 100.0, crate::studies::experiment::compare::DEFAULT_MARGIN * 100.0);
    for g in groups {
        // Thread schedulers only: MPI rows have their own section.
        let in_g: Vec<&Summary> = sums
            .iter()
            .filter(|s| &s.group() == g && !s.row.on_mpi())
            .collect();
        if let Some(a) = answer(g, &in_g, margin) {
            let _ = writeln!(md, "{a}\n");
        }
        let curves = chunk_curves(&in_g);
        if !curves.is_empty() {
            let _ = writeln!(md, "Wall time against chunk size, per scheduler (its fastest configuration at each chunk; flat = not shown slower than its best at 95 %):\n");
            for c in curves {
                let _ = writeln!(md, "{c}");
            }
            let _ = writeln!(md);
        }
        // Only where a per-ray master ran.
        if let Some(sentence) = per_ray_sentence(g, &in_g, margin) {
            let _ = writeln!(md, "{sentence}\n");
        }
    }
    md
}

/// "chunk 4 (16 px)", "frame (65536 px)": a configuration's chunk as its file wrote it.
pub fn chunk_words_pub(s: &Summary) -> String {
    chunk_words(s)
}

pub(super) fn chunk_words(s: &Summary) -> String {
    match (&s.row.chunk, s.row.chunk_px) {
        (Some(c), Some(px)) if c.parse::<u64>().is_ok() => format!("chunk {c} ({px} px)"),
        (Some(c), Some(px)) => format!("{c} ({px} px)"),
        (Some(c), None) => c.clone(),
        _ => "—".into(),
    }
}

/// Per scene: the fastest configuration at the most workers and every one equivalent to it
/// within ±`margin` or not shown slower ([`near_best`]).
pub fn answer(group: &str, sums: &[&Summary], margin: f64) -> Option<String> {
    let at = at_most_workers(sums)?;
    let max_w = at.first()?.row.workers;
    let (best, near) = near_best(&at, margin)?;
    let mut md = format!(
        "**{group}, {max_w} workers:** fastest `{}` ({}), median {:.4} s (95 % CI {:.4}–{:.4}), speedup {}.",
        best.row.label,
        chunk_words(best),
        best.wall_median,
        best.wall_median_ci.0,
        best.wall_median_ci.1,
        speedup_text(best)
    );
    if near.is_empty() {
        md += " Every other configuration is shown slower than it.";
    } else {
        let _ = write!(
            md,
            " Beside it, {} of {}: {}.",
            near.len(),
            at.len() - 1,
            near_words(&near, margin, |s| format!(
                "`{}` ({:.4} s)",
                s.row.label, s.wall_median
            ))
        );
    }
    Some(md)
}

/// Each scheduler's wall time against its chunk in words, at the most workers: where its
/// optimum lies and over which chunks it is flat (not shown slower than its own best), from its fastest
/// configuration at each chunk. Schedulers with one chunk are left out.
pub fn chunk_curves(sums: &[&Summary]) -> Vec<String> {
    let Some(max_w) = sums
        .iter()
        .filter(|s| !s.row.is_serial())
        .map(|s| s.row.workers)
        .max()
    else {
        return vec![];
    };
    let at: Vec<&Summary> = sums
        .iter()
        .copied()
        .filter(|s| s.row.workers == max_w && !s.row.is_serial() && s.row.chunk_px.is_some())
        .collect();
    let mut kinds: Vec<&str> = Vec::new();
    for s in &at {
        if !kinds.contains(&s.row.scheduler.as_str()) {
            kinds.push(&s.row.scheduler);
        }
    }
    let mut out = Vec::new();
    for k in kinds {
        // The fastest configuration of `k` at each chunk, smallest chunk first.
        let mut curve: Vec<&Summary> = Vec::new();
        for s in at.iter().copied().filter(|s| s.row.scheduler == k) {
            match curve.iter_mut().find(|c| c.row.chunk_px == s.row.chunk_px) {
                Some(c) if s.wall_median < c.wall_median => *c = s,
                Some(_) => {}
                None => curve.push(s),
            }
        }
        if curve.len() < 2 {
            continue;
        }
        curve.sort_by_key(|s| s.row.chunk_px);
        let Some(bi) =
            (0..curve.len()).min_by(|&a, &b| curve[a].wall_median.total_cmp(&curve[b].wall_median))
        else {
            continue;
        };
        let best = curve[bi];
        let near = |s: &Summary| s.row.config == best.row.config || wall_ratio(s, best).lo <= 1.0;
        // The run of chunks around the optimum not shown slower than it.
        let (mut lo, mut hi) = (bi, bi);
        while lo > 0 && near(curve[lo - 1]) {
            lo -= 1;
        }
        while hi + 1 < curve.len() && near(curve[hi + 1]) {
            hi += 1;
        }
        let shape = if lo == hi {
            format!("optimum at {}", chunk_words(best))
        } else if lo == 0 && hi == curve.len() - 1 {
            format!(
                "flat: no chunk from {} to {} is shown slower than its best, {}",
                chunk_words(curve[lo]),
                chunk_words(curve[hi]),
                chunk_words(best)
            )
        } else {
            format!(
                "flat from {} to {} (fastest at {})",
                chunk_words(curve[lo]),
                chunk_words(curve[hi]),
                chunk_words(best)
            )
        };
        let ends: Vec<String> = [0, curve.len() - 1]
            .into_iter()
            .filter(|&i| i < lo || i > hi)
            .map(|i| {
                format!(
                    "{:.1}× slower at {}",
                    curve[i].wall_median / best.wall_median,
                    chunk_words(curve[i])
                )
            })
            .collect();
        let ends = if ends.is_empty() {
            String::new()
        } else {
            format!("; {}", ends.join(", "))
        };
        out.push(format!(
            "- **{k}**: {shape}, median {:.4} s{ends}.",
            best.wall_median
        ));
    }
    out
}
