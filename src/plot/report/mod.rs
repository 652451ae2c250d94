//! `report.md`: what ran, on what machine, the plots, the best configuration per scheduler, and
//! one plain sentence comparing the per-ray master with the best scheduler.

mod answer;

pub use answer::{answer, chunk_curves, chunk_words_pub, per_ray_sentence};

use super::compare::{best_by, efficiency_text, margin_of, speedup_text};
use super::Figure;
use crate::studies::experiment::meta::Meta;
use crate::studies::experiment::summary::Summary;
use answer::{answer_section, chunk_words};
use std::fmt::Write;

/// How the model's inputs were measured, for the report.
const PROBE_NOTE: &str = "probe of per-pixel costs at ≤ 4 spp on the run's workers and zero-work hand-outs per scheduler";

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
    let margin = margin_of(meta);
    md += &answer_section(sums, &groups, margin);
    md += &mpi_section(&groups, sums);
    md += &model_section(sums, &groups, margin);
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
/// The cost model's predictions against the measured medians.
fn model_section(sums: &[Summary], groups: &[String], margin: f64) -> String {
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
        if let Some(sec) = super::prediction::section(g, &at, serial, margin) {
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
mod tests;
