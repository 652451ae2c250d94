//! `report.md`: what ran, on what machine, the plots, the best configuration per scheduler, and
//! one plain sentence comparing the per-ray master with the best scheduler.

use super::compare::{best_by, efficiency_text, speedup_text, tied_with_best, wall_ratio, with_ci};
use super::Figure;
use crate::studies::experiment::meta::Meta;
use crate::studies::experiment::stats::Ratio;
use crate::studies::experiment::summary::Summary;
use std::fmt::Write;

/// How the model's inputs were measured, for the report.
const PROBE_NOTE: &str = "probe of per-pixel costs at ≤ 4 spp on the run's workers and zero-work hand-outs per scheduler";

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
/// statistically tied with it, and the ratio to the per-ray master with its interval.
pub fn per_ray_sentence(group: &str, sums: &[&Summary]) -> Option<String> {
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
    let (best, tied) = tied_with_best(&others)?;
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
    let ties = if tied.is_empty() {
        "no other configuration is statistically tied with it".to_string()
    } else {
        format!(
            "statistically tied with it (not shown slower at 95 %): {}",
            tied.iter()
                .map(|s| format!("`{}` ({})", s.row.label, speedup_text(s)))
                .collect::<Vec<_>>()
                .join(", ")
        )
    };
    Some(format!(
        "On {group} with {max_w} workers, the fastest configuration (`{}`, speedup {}) was {verdict} the per-ray master (`{}`, speedup {}); {ties}.{}",
        best.row.label,
        speedup_text(best),
        per_ray.row.label,
        speedup_text(per_ray),
        super::prediction::gap_clause(per_ray, best).unwrap_or_default()
    ))
}

/// What a reader must know before trusting the numbers: efficiency above 100 % beyond noise,
/// a fastest configuration slower than serial, medians less precise than the target (their
/// budget ran out), and a load average above the core count while measuring.
pub fn warnings(meta: Option<&Meta>, sums: &[Summary]) -> Vec<String> {
    let mut out = Vec::new();
    // A GPU is not one worker's worth: its rows' efficiency says nothing.
    for s in sums.iter().filter(|s| !s.row.sources.contains("gpu")) {
        if let Some(r) = &s.speedup {
            let w = s.row.workers as f64;
            if r.lo / w > 1.0 {
                out.push(format!(
                    "`{}` ×{}: efficiency {:.0} % (95 % CI {:.0}–{:.0} %) is above 100 % beyond noise; suspect the serial baseline (code placement, frequency) before the scheduler",
                    s.row.label,
                    s.row.workers,
                    r.value / w * 100.0,
                    r.lo / w * 100.0,
                    r.hi / w * 100.0
                ));
            }
        }
    }
    let mut groups: Vec<String> = Vec::new();
    for s in sums {
        if !groups.contains(&s.group()) {
            groups.push(s.group());
        }
    }
    for g in &groups {
        let in_g: Vec<&Summary> = sums
            .iter()
            .filter(|s| &s.group() == g && !s.row.is_serial() && !s.row.on_mpi())
            .collect();
        if let Some(b) = best_by(in_g.iter().copied()) {
            let slower = b.speedup_ci().hi < 1.0;
            if slower {
                out.push(format!(
                    "{g}: the fastest configuration `{}` ×{} is slower than serial (speedup {})",
                    b.row.label,
                    b.row.workers,
                    speedup_text(b)
                ));
            }
        }
    }
    let target = meta
        .and_then(|m| m.history.last())
        .map(|h| h.stats.ci_target)
        .unwrap_or(0.0);
    if target > 0.0 {
        let mut wide: Vec<&Summary> = sums.iter().filter(|s| s.ci_half_rel > target).collect();
        // The widest first, five named: a list of fifty fits neither a terminal line nor a
        // reader's attention; summary.csv has every half-width.
        wide.sort_by(|a, b| b.ci_half_rel.total_cmp(&a.ci_half_rel));
        const NAMED: usize = 5;
        let named: Vec<String> = wide
            .iter()
            .take(NAMED)
            .map(|s| {
                format!(
                    "`{}` ×{} ({}, ±{:.1} % after {} runs)",
                    s.row.label,
                    s.row.workers,
                    s.group(),
                    s.ci_half_rel * 100.0,
                    s.n
                )
            })
            .collect();
        if let (Some(first), Some(last)) = (wide.first(), wide.last()) {
            let rest = if wide.len() > NAMED {
                format!(
                    "; and {} more (see summary.csv, `ci_half_rel`)",
                    wide.len() - NAMED
                )
            } else {
                String::new()
            };
            out.push(format!(
                "{} configuration(s) stopped with a median CI wider than the ±{:.1} % target (their runs or seconds ran out; half-widths ±{:.1}–{:.1} %), widest: {}{rest}",
                wide.len(),
                target * 100.0,
                last.ci_half_rel * 100.0,
                first.ci_half_rel * 100.0,
                named.join(", ")
            ));
        }
    }
    if let Some(m) = meta {
        let cores = m.machine.cores as f64;
        let load = sums.iter().filter_map(|s| s.load_max).reduce(f64::max);
        if let Some(l) = load.filter(|&l| l > cores) {
            out.push(format!(
                "the 1-minute load average reached {l:.1} on {} cores while measuring: other work shared the CPUs, so wall times include waiting",
                m.machine.cores
            ));
        }
    }
    out
}

/// "Who rendered what": for every configuration whose sources are more than threads, each
/// kind's share of the pixels, its items and its busy time (medians over the repetitions);
/// empty when every configuration ran on threads alone.
pub fn shares_section(sums: &[Summary]) -> String {
    let mixed: Vec<&Summary> = sums
        .iter()
        .filter(|s| !s.row.on_threads_alone() && !s.row.on_mpi())
        .collect();
    if mixed.is_empty() {
        return String::new();
    }
    let mut md = String::from("## Who rendered what\n\n");
    md += "Per configuration with other sources than threads, each kind's share of the image's pixels, its items and its busy seconds summed over its sources (medians over the repetitions; `<kind>_pixels`, `<kind>_items`, `<kind>_busy_s` in runs.csv).\n\n";
    md += "| configuration | workers | wall (median) | ";
    let kinds = crate::sched::SourceKind::ALL;
    let present: Vec<usize> = (0..kinds.len())
        .filter(|&k| {
            mixed
                .iter()
                .any(|s| s.shares.get(k).copied().flatten().is_some())
        })
        .collect();
    md += &present
        .iter()
        .map(|&k| format!("{} (pixels · items · busy)", kinds[k].id()))
        .collect::<Vec<_>>()
        .join(" | ");
    md += " |\n|---|---|---|";
    md += &"---|".repeat(present.len());
    md += "\n";
    for s in mixed {
        let cells: Vec<String> = present
            .iter()
            .map(|&k| match s.shares.get(k).copied().flatten() {
                Some(x) => format!(
                    "{:.1} % · {:.0} · {:.3} s",
                    100.0 * x.pixel_share,
                    x.items,
                    x.busy_s
                ),
                None => "—".into(),
            })
            .collect();
        let _ = writeln!(
            md,
            "| `{}` | {} | {:.4} s | {} |",
            s.row.label,
            s.row.workers,
            s.wall_median,
            cells.join(" | ")
        );
    }
    md.push('\n');
    md
}

/// Group names (scene + settings + tracer) in the order they first appear.
fn group_names(sums: &[Summary]) -> Vec<String> {
    let mut g: Vec<String> = Vec::new();
    for s in sums {
        if !g.contains(&s.group()) {
            g.push(s.group());
        }
    }
    g
}

/// The text of `report.md`: `meta` (if readable) for the run and machine sections, `sums` for
/// the results, `figs` for the plots; `runs` is the number of timed runs. Every figure it
/// states is a column of `summary.csv` (`tests/it/readings.rs` checks), and `report.html`
/// is this text as a page.
pub fn render(meta: Option<&Meta>, sums: &[Summary], figs: &[Figure], runs: usize) -> String {
    let groups = group_names(sums);
    let mut md = head_section(meta, sums);
    md += &what_ran_section(meta, sums, &groups, runs);
    if let Some(m) = meta {
        md += &machine_section(m, sums);
    }
    md += &shares_section(sums);
    md += &answer_section(sums, &groups);
    md += &mpi_section(&groups, sums);
    md += &model_section(sums, &groups);
    md += &tuning_section(sums, &groups);
    md += &best_section(sums, &groups);
    md += &every_section(sums, &groups);
    let _ = writeln!(md, "## Plots\n");
    for f in figs {
        let _ = writeln!(
            md,
            "### {}\n\n![{}]({})\n\n{}\n",
            f.title, f.title, f.file, f.caption
        );
    }
    let _ = writeln!(md, "Data: `runs.csv` (one row per run), `summary.csv` (per configuration), `meta.toml` (machine and build). Regenerate plots and this report with `raysched plot <this folder>`.");
    md
}

/// The title, the image mismatches and the warnings.
fn head_section(meta: Option<&Meta>, sums: &[Summary]) -> String {
    let mut md = String::new();
    let name = sums
        .first()
        .map_or("experiment", |s| s.row.experiment.as_str());
    let _ = writeln!(md, "# Experiment `{name}`\n");
    let mismatched: Vec<&Summary> = sums.iter().filter(|s| !s.image_ok()).collect();
    if !mismatched.is_empty() {
        let _ = writeln!(
            md,
            "**{} configuration(s) produced an image different from the serial baseline** (rows with `identical=false` in runs.csv, and for a GPU source `agrees=false`): {}.\n",
            mismatched.len(),
            mismatched.iter().map(|s| format!("`{}` ×{}", s.row.label, s.row.workers)).collect::<Vec<_>>().join(", ")
        );
    }
    let warns = warnings(meta, sums);
    if !warns.is_empty() {
        let _ = writeln!(md, "## Warnings\n");
        for w in &warns {
            let _ = writeln!(md, "- {w}");
        }
        let _ = writeln!(md);
    }
    md
}

/// What ran: the experiment file, its start, the configurations and what each scene uses.
fn what_ran_section(
    meta: Option<&Meta>,
    sums: &[Summary],
    groups: &[String],
    runs: usize,
) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "## What ran\n");
    if let Some(m) = meta {
        let _ = writeln!(
            md,
            "- Experiment file: `{}` (hash `{}`)",
            m.experiment_file, m.experiment_hash
        );
        let _ = writeln!(
            md,
            "- Started {}{}",
            m.started,
            m.resumed
                .as_ref()
                .map(|r| format!(", last resumed {r}"))
                .unwrap_or_default()
        );
    }
    let _ = writeln!(
        md,
        "- {} configurations, {runs} timed runs, over: {}",
        sums.len(),
        groups.join("; ")
    );
    // What each scene's render path pays for (from the serial baseline row of each group).
    for g in groups {
        if let Some(s) = sums
            .iter()
            .find(|s| &s.group() == g && !s.row.features_used.is_empty())
        {
            let _ = writeln!(
                md,
                "- {g}: features used `{}`, left out `{}`",
                s.row.features_used, s.row.features_left_out
            );
        }
    }
    let _ = writeln!(md, "- Speedup = median serial wall time / median wall time, over samples paired by round (serial = one thread, no scheduler, same scene, tracer and settings); efficiency = speedup / workers; every figure below is a column of summary.csv; every image is compared bit for bit with the serial one, except where a GPU rendered: its kernel rounds differently, so those images must agree with the serial one within 3σ of the paired per-pixel differences (`agrees`, `image_z` in runs.csv).\n");
    md
}

/// The machine, the build, every start on the folder and the statistics rule.
fn machine_section(m: &Meta, sums: &[Summary]) -> String {
    let mut md = String::new();
    let c = &m.machine;
    let _ = writeln!(md, "## Machine\n");
    let _ = writeln!(
        md,
        "- CPU: {} ({} logical cores available), {:.1} GiB memory",
        c.cpu_model, c.cores, c.memory_gib
    );
    let _ = writeln!(md, "- OS: {} (kernel {}, {})", c.os, c.kernel, c.arch);
    let _ = writeln!(
        md,
        "- raysched {} at `{}`, {}, features: [{}]",
        m.raysched_version,
        m.git_commit,
        m.rustc,
        m.features.join(", ")
    );
    if let Some(b) = &m.build {
        let _ = writeln!(md, "- build: {} profile, target {}", b.profile, b.target);
    }
    if let Some(g) = &m.gpu {
        let _ = writeln!(
            md,
            "- GPU: {} ({}, driver {}, {})",
            g.name, g.device_type, g.driver, g.backend
        );
    }
    if !m.history.is_empty() {
        let _ = writeln!(
            md,
            "- starts on this folder (time, host, commit, load, rows already there):"
        );
        for h in &m.history {
            let _ = writeln!(
                md,
                "  - {} on {} at `{}`, load {:.2}, {} rows",
                h.time, h.host, h.commit, h.load1, h.rows_before
            );
        }
    }
    if let Some(h) = m.history.last() {
        let st = &h.stats;
        let rule = if st.fixed() {
            format!("{} timed runs per configuration", st.min_runs)
        } else {
            format!(
                "{}–{} timed runs per configuration, until the median's 95 % CI is within ±{:.1} % or {:.0} s are spent",
                st.min_runs, st.max_runs, st.ci_target * 100.0, st.budget_s
            )
        };
        // What each configuration got, which a resumed or cut-short run may not match.
        let ns = sums.iter().map(|s| s.n);
        let rule = match (ns.clone().min(), ns.max()) {
            (Some(lo), Some(hi)) if lo == hi => format!("{rule} (measured: {lo} per configuration)"),
            (Some(lo), Some(hi)) => format!("{rule} (measured: {lo}–{hi} per configuration, each one's in its table's runs column)"),
            _ => rule,
        };
        let _ = writeln!(md, "- statistics: {rule}; renders under {:.0} ms repeated inside one sample; rounds in a shuffled order (seed {}); intervals: seeded percentile bootstrap of the median, speedups from samples paired by round", st.min_sample_s * 1e3, st.seed);
    }
    let _ = writeln!(md);
    md
}

/// Per scene: the answer, the chunk curves in words and the per-ray master's sentence.
fn answer_section(sums: &[Summary], groups: &[String]) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "## Answer\n");
    for g in groups {
        // Thread schedulers only: MPI rows have their own section.
        let in_g: Vec<&Summary> = sums
            .iter()
            .filter(|s| &s.group() == g && !s.row.on_mpi())
            .collect();
        if let Some(a) = answer(g, &in_g) {
            let _ = writeln!(md, "{a}\n");
        }
        let curves = chunk_curves(&in_g);
        if !curves.is_empty() {
            let _ = writeln!(md, "Wall time against chunk size, per scheduler (its fastest configuration at each chunk; flat = tied with its best at 95 %):\n");
            for c in curves {
                let _ = writeln!(md, "{c}");
            }
            let _ = writeln!(md);
        }
        // Only where a per-ray master ran.
        if let Some(sentence) = per_ray_sentence(g, &in_g) {
            let _ = writeln!(md, "{sentence}\n");
        }
    }
    md
}

/// The cost model's predictions against the measured medians.
fn model_section(sums: &[Summary], groups: &[String]) -> String {
    let mut md = String::new();
    let mut model = String::new();
    for g in groups {
        let in_g: Vec<&Summary> = sums
            .iter()
            .filter(|s| &s.group() == g && s.row.on_threads_alone() && !s.row.is_serial())
            .collect();
        let Some(max_w) = in_g.iter().map(|s| s.row.workers).max() else {
            continue;
        };
        let at: Vec<&Summary> = in_g
            .into_iter()
            .filter(|s| s.row.workers == max_w)
            .collect();
        let serial = sums
            .iter()
            .find(|s| &s.group() == g && s.row.is_serial())
            .map(|s| s.wall_median);
        if let Some(sec) = super::prediction::section(g, &at, serial) {
            model += &sec;
        }
    }
    if !model.is_empty() {
        let _ = writeln!(md, "## Cost model: predicted against measured\n");
        let _ = writeln!(md, "Each configuration's wall time as the cost model predicted it before the first round (`raysched::studies::model`: work / P + hand-out cost + refill waiting + imbalance, from a {PROBE_NOTE}) beside its measured median; error = predicted / measured − 1.\n");
        md += &model;
    }
    md
}

/// The self-sizing rules against the best fixed chunk.
fn tuning_section(sums: &[Summary], groups: &[String]) -> String {
    let mut md = String::new();
    let mut tuning = String::new();
    for g in groups {
        let at: Vec<&Summary> = sums
            .iter()
            .filter(|s| &s.group() == g && s.row.on_threads_alone())
            .collect();
        if let Some(sec) = super::self_tuning::section(g, &at) {
            tuning += &sec;
        }
    }
    if !tuning.is_empty() {
        let _ = writeln!(md, "## Self-sizing rules against the best fixed chunk\n");
        let _ = writeln!(md, "{}\n", super::self_tuning::PREAMBLE);
        md += &tuning;
    }
    md
}

/// Per scene and scheduler, its fastest configuration at any worker count.
fn best_section(sums: &[Summary], groups: &[String]) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "## Best configuration per scheduler\n");
    for g in groups {
        // Thread schedulers only: MPI rows have their own section.
        let in_g: Vec<&Summary> = sums
            .iter()
            .filter(|s| &s.group() == g && !s.row.on_mpi())
            .collect();
        let _ = writeln!(md, "### {g}\n");
        let _ = writeln!(md, "| scheduler | best configuration | workers | median wall (s) | 95 % CI of median (s) | speedup (95 % CI) | efficiency | runs |");
        let _ = writeln!(md, "|---|---|---|---|---|---|---|---|");
        let mut kinds: Vec<&str> = Vec::new();
        for s in &in_g {
            if !kinds.contains(&s.row.scheduler.as_str()) {
                kinds.push(&s.row.scheduler);
            }
        }
        for k in kinds {
            // Best = the shortest median wall time (at any worker count): the column the
            // "Every configuration" table sorts by.
            let Some(b) = best_by(in_g.iter().copied().filter(|s| s.row.scheduler == k)) else {
                continue;
            };
            let _ = writeln!(
                md,
                "| {k} | `{}` | {} | {:.4} | {:.4} – {:.4} | {} | {} | {} |",
                b.row.label,
                b.row.workers,
                b.wall_median,
                b.wall_median_ci.0,
                b.wall_median_ci.1,
                speedup_text(b),
                efficiency_text(b),
                b.n
            );
        }
        let _ = writeln!(md);
    }
    md
}

/// Per scene, every configuration.
fn every_section(sums: &[Summary], groups: &[String]) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "## Every configuration\n");
    for g in groups {
        let in_g: Vec<&Summary> = sums
            .iter()
            .filter(|s| &s.group() == g && !s.row.on_mpi() && !s.row.is_serial())
            .collect();
        if in_g.is_empty() {
            continue;
        }
        let _ = writeln!(md, "### {g}\n");
        md += &full_table(&in_g);
        let _ = writeln!(md);
    }
    md
}

/// Tiles of at least 16×16 pixels count as "per block" in the MPI comparison.
pub const BLOCK_PX: u64 = 256;

/// For an MPI experiment: per chunk size, the throughput of each transport against the
/// local-thread baseline of the same launch size and scheduler (best buffer each), and the
/// per-block ratio against its goal (MPI ranks at ≥ 90 % of local threads).
pub fn mpi_section(groups: &[String], sums: &[Summary]) -> String {
    use super::throughput;
    let mut md = String::new();
    if !sums.iter().any(|s| s.row.on_mpi()) {
        return md;
    }
    let _ = writeln!(md, "## MPI ranks vs local threads\n");
    let _ = writeln!(md, "Throughput = rays / median wall time of the scheduler run (rank 0's clock; MPI start-up and scene shipping excluded), best buffer B per chunk. Local = the same scheduler on ranks − 1 threads of rank 0's process, measured in the same launch while the worker ranks slept.\n");
    for g in groups {
        let in_g: Vec<&Summary> = sums
            .iter()
            .filter(|s| &s.group() == g && s.row.ranks.is_some())
            .collect();
        // (scheduler, ranks, transport) of every MPI line.
        let mut lines: Vec<(String, usize, String)> = Vec::new();
        for s in &in_g {
            if let (Some(r), Some(t)) = (s.row.ranks, &s.row.transport) {
                let k = (s.row.scheduler.clone(), r, t.clone());
                if s.row.on_mpi() && !lines.contains(&k) {
                    lines.push(k);
                }
            }
        }
        if lines.is_empty() {
            continue;
        }
        let _ = writeln!(md, "### {g}\n");
        let _ = writeln!(md, "| scheduler | ranks | transport | chunk (px) | MPI Mrays/s | local Mrays/s | MPI / local | MPI items/s |");
        let _ = writeln!(md, "|---|---|---|---|---|---|---|---|");
        for (kind, ranks, t) in &lines {
            let best = |mpi: bool, px: u64| {
                in_g.iter()
                    .copied()
                    .filter(|s| {
                        s.row.scheduler == *kind
                            && s.row.ranks == Some(*ranks)
                            && s.row.chunk_px == Some(px)
                            && if mpi {
                                s.row.on_mpi() && s.row.transport.as_deref() == Some(t)
                            } else {
                                s.row.on_threads_alone()
                            }
                    })
                    .max_by(|a, b| throughput(a).0.total_cmp(&throughput(b).0))
            };
            let mut chunks: Vec<u64> = in_g.iter().filter_map(|s| s.row.chunk_px).collect();
            chunks.sort_unstable();
            chunks.dedup();
            let mut block_ratios = Vec::new();
            for px in chunks {
                let Some(m) = best(true, px) else { continue };
                let (mr, mi) = throughput(m);
                let (lr, ratio) = match best(false, px) {
                    Some(l) => {
                        let lr = throughput(l).0;
                        (format!("{lr:.3}"), Some(mr / lr))
                    }
                    None => ("–".into(), None),
                };
                if let (Some(r), true) = (ratio, px >= BLOCK_PX) {
                    block_ratios.push(r);
                }
                let _ = writeln!(
                    md,
                    "| {kind} | {ranks} | {t} | {px} | {mr:.3} | {lr} | {} | {mi:.0} |",
                    ratio.map_or("–".into(), |r| format!("{:.0} %", r * 100.0))
                );
            }
            if !block_ratios.is_empty() {
                let min = block_ratios.iter().cloned().fold(f64::INFINITY, f64::min);
                let med = super::summary::median(&block_ratios);
                let _ = writeln!(
                    md,
                    "| **{kind}, {t}: per block (≥ 16² px)** | | | | | | **min {:.0} %, median {:.0} %** (goal ≥ 90 %) | |",
                    min * 100.0,
                    med * 100.0
                );
            }
        }
        let _ = writeln!(md);
    }
    md
}

/// "chunk 4 (16 px)", "frame (65536 px)": a configuration's chunk as its file wrote it.
pub fn chunk_words_pub(s: &Summary) -> String {
    chunk_words(s)
}

fn chunk_words(s: &Summary) -> String {
    match (&s.row.chunk, s.row.chunk_px) {
        (Some(c), Some(px)) if c.parse::<u64>().is_ok() => format!("chunk {c} ({px} px)"),
        (Some(c), Some(px)) => format!("{c} ({px} px)"),
        (Some(c), None) => c.clone(),
        _ => "—".into(),
    }
}

/// Per scene: the fastest configuration at the most workers and every one not shown slower.
pub fn answer(group: &str, sums: &[&Summary]) -> Option<String> {
    let at = at_most_workers(sums)?;
    let max_w = at.first()?.row.workers;
    let (best, tied) = tied_with_best(&at)?;
    let mut md = format!(
        "**{group}, {max_w} workers:** fastest `{}` ({}), median {:.4} s (95 % CI {:.4}–{:.4}), speedup {}.",
        best.row.label,
        chunk_words(best),
        best.wall_median,
        best.wall_median_ci.0,
        best.wall_median_ci.1,
        speedup_text(best)
    );
    if tied.is_empty() {
        md += " No other configuration is statistically tied with it.";
    } else {
        let _ = write!(
            md,
            " Tied with it (not shown slower at 95 %), {} of {}: {}.",
            tied.len(),
            at.len() - 1,
            tied.iter()
                .map(|s| format!("`{}` ({:.4} s)", s.row.label, s.wall_median))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Some(md)
}

/// Each scheduler's wall time against its chunk in words, at the most workers: where its
/// optimum lies and over which chunks it is flat (tied with its own best), from its fastest
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
        let tied = |s: &Summary| s.row.config == best.row.config || wall_ratio(s, best).lo <= 1.0;
        // The run of chunks around the optimum tied with it.
        let (mut lo, mut hi) = (bi, bi);
        while lo > 0 && tied(curve[lo - 1]) {
            lo -= 1;
        }
        while hi + 1 < curve.len() && tied(curve[hi + 1]) {
            hi += 1;
        }
        let shape = if lo == hi {
            format!("optimum at {}", chunk_words(best))
        } else if lo == 0 && hi == curve.len() - 1 {
            format!(
                "flat: every chunk from {} to {} is tied with its best, {}",
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

/// Every configuration of a group: median wall time with its interval, speedup, efficiency,
/// runs; sorted by workers, then wall time.
pub fn full_table(sums: &[&Summary]) -> String {
    let mut v: Vec<&Summary> = sums.to_vec();
    v.sort_by(|a, b| {
        a.row
            .workers
            .cmp(&b.row.workers)
            .then(a.wall_median.total_cmp(&b.wall_median))
    });
    let mut md = String::from("| configuration | scheduler | chunk | workers | median wall (s) | 95 % CI of median (s) | speedup (95 % CI) | efficiency | runs |\n|---|---|---|---|---|---|---|---|---|\n");
    for s in v {
        let _ = writeln!(
            md,
            "| `{}` | {} | {} | {} | {:.4} | {:.4} – {:.4} | {} | {} | {} |",
            s.row.label,
            s.row.scheduler,
            chunk_words(s),
            s.row.workers,
            s.wall_median,
            s.wall_median_ci.0,
            s.wall_median_ci.1,
            speedup_text(s),
            efficiency_text(s),
            s.n
        );
    }
    md
}

#[cfg(test)]
mod tests {
    use crate::studies::experiment::results::RunRow;

    /// `reps` rows of one configuration; round r scales every wall time by the same drift.
    fn rows(kind: &str, chunk: &str, px: u64, wall: f64) -> Vec<RunRow> {
        (0..12u32)
            .map(|rep| {
                let mut r = RunRow::example();
                r.experiment = "synthetic".into();
                r.scene = "box".into();
                r.width = 64;
                r.height = 64;
                r.spp = 1;
                r.tracer = "bvh".into();
                r.config = format!("{kind}-{chunk}");
                r.scheduler = kind.into();
                r.label = if kind == "serial" {
                    "serial".into()
                } else {
                    format!("{kind} chunk={chunk}")
                };
                r.chunk = (kind != "serial").then(|| chunk.into());
                r.chunk_px = (kind != "serial").then_some(px);
                r.workers = if kind == "serial" { 1 } else { 4 };
                r.repetition = rep;
                let drift = 1.0 + 0.05 * ((rep * 7 % 5) as f64 - 2.0);
                r.wall_s = wall * drift;
                r.serial_s = 1.0;
                r.rays = 4096;
                r.items = 4096 / px.max(1);
                r
            })
            .collect()
    }

    /// Writes `rows` as runs.csv in a fresh folder and redraws it; returns report.md.
    fn report_of(rows: &[RunRow]) -> (tempfile::TempDir, String) {
        let dir = tempfile::tempdir().expect("temp dir");
        let mut csv = RunRow::header().join(",").into_bytes();
        csv.push(b'\n');
        for r in rows {
            csv.extend(r.to_line());
        }
        std::fs::write(dir.path().join("runs.csv"), csv).expect("written");
        crate::plot::redraw(dir.path()).expect("redrawn");
        let md = std::fs::read_to_string(dir.path().join("report.md")).expect("report.md");
        (dir, md)
    }

    #[test]
    fn report_answers_without_a_per_ray_master() {
        let mut all = rows("serial", "", 0, 1.0);
        // self_scheduling: a clear optimum at chunk 4; static: flat from 4 to 16, slower at 1.
        for (c, px, w) in [("1", 1, 0.9), ("4", 16, 0.30), ("16", 256, 0.6)] {
            all.extend(rows("self_scheduling", c, px, w));
        }
        for (c, px, w) in [("1", 1, 0.8), ("4", 16, 0.40), ("16", 256, 0.40)] {
            all.extend(rows("static", c, px, w));
        }
        let (dir, md) = report_of(&all);
        assert!(
            !md.contains("the per-ray master"),
            "no per-ray master ran:\n{md}"
        );
        assert!(
            md.contains("fastest `self_scheduling chunk=4` (chunk 4 (16 px))"),
            "{md}"
        );
        assert!(
            md.contains("- **self_scheduling**: optimum at chunk 4 (16 px)"),
            "{md}"
        );
        assert!(
            md.contains("- **static**: flat from chunk 4 (16 px) to chunk 16 (256 px)"),
            "{md}"
        );
        assert!(md.contains("2.0× slower at chunk 1 (1 px)"), "{md}");
        // The full table: every configuration with its median and interval.
        let table = &md[md.find("## Every configuration").expect("full table")..];
        for label in [
            "self_scheduling chunk=1",
            "static chunk=16",
            "static chunk=1",
        ] {
            assert!(
                table.contains(&format!("| `{label}` |")),
                "{label}: {table}"
            );
        }
        assert!(dir.path().join("report.html").exists());
    }

    #[test]
    fn warnings_come_first_and_the_per_ray_master_is_compared_where_it_ran() {
        let mut all = rows("serial", "", 0, 1.0);
        // Every configuration slower than serial: a warning.
        all.extend(rows("master", "1", 1, 3.0));
        for r in all.iter_mut().filter(|r| r.scheduler == "master") {
            r.params = crate::sched::param_columns()
                .iter()
                .map(|p| (p.name == "buffer").then(|| "2".to_string()))
                .collect();
        }
        all.extend(rows("self_scheduling", "4", 16, 1.5));
        let (_dir, md) = report_of(&all);
        let warn = md.find("## Warnings").expect("a warning");
        let answer = md.find("## Answer").expect("an answer");
        assert!(warn < answer, "{md}");
        assert!(md.contains("the per-ray master"), "{md}");
    }
}
