//! `report.md`: what ran, on what machine, the plots, the best configuration per scheduler, and
//! one plain sentence comparing the per-ray master with the best scheduler.

use super::Figure;
use crate::experiment::meta::Meta;
use crate::experiment::summary::Summary;
use std::fmt::Write;

fn best_by<'a>(v: impl Iterator<Item = &'a Summary>) -> Option<&'a Summary> {
    v.min_by(|a, b| a.wall_median.total_cmp(&b.wall_median))
}

/// The comparison sentence for one group at its largest worker count, if it has a per-ray
/// master (master with 1-pixel items) and some other configuration.
pub fn per_ray_sentence(group: &str, sums: &[&Summary]) -> Option<String> {
    let max_w = sums
        .iter()
        .filter(|s| s.row.scheduler != "serial")
        .map(|s| s.row.workers)
        .max()?;
    let at: Vec<&Summary> = sums
        .iter()
        .copied()
        .filter(|s| s.row.workers == max_w && s.row.scheduler != "serial")
        .collect();
    let per_ray = best_by(
        at.iter()
            .copied()
            .filter(|s| s.row.scheduler == "master" && s.row.chunk_px == Some(1)),
    )?;
    let best = best_by(
        at.iter()
            .copied()
            .filter(|s| s.row.config != per_ray.row.config),
    )?;
    let ratio = per_ray.wall_median / best.wall_median;
    let verdict = if ratio >= 1.0 {
        format!("{ratio:.2}× faster than")
    } else {
        format!("{:.2}× slower than", 1.0 / ratio)
    };
    Some(format!(
        "On {group} with {max_w} workers, the best scheduler (`{}`, speedup {:.2}×) was {verdict} the per-ray master (`{}`, speedup {:.2}×).",
        best.row.label, best.speedup_median, per_ray.row.label, per_ray.speedup_median
    ))
}

/// The text of `report.md`: `meta` (if readable) for the run and machine sections, `sums` for
/// the results, `figs` for the plots; `runs` is the number of timed runs.
pub fn render(meta: Option<&Meta>, sums: &[Summary], figs: &[Figure], runs: usize) -> String {
    let mut md = String::new();
    let name = sums
        .first()
        .map_or("experiment", |s| s.row.experiment.as_str());
    let _ = writeln!(md, "# Experiment `{name}`\n");
    let mismatched: Vec<&Summary> = sums.iter().filter(|s| !s.identical).collect();
    if !mismatched.is_empty() {
        let _ = writeln!(
            md,
            "**{} configuration(s) produced an image different from the serial baseline** (rows with `identical=false` in runs.csv): {}.\n",
            mismatched.len(),
            mismatched.iter().map(|s| format!("`{}` ×{}", s.row.label, s.row.workers)).collect::<Vec<_>>().join(", ")
        );
    }
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
    let groups: Vec<String> = {
        let mut g: Vec<String> = Vec::new();
        for s in sums {
            if !g.contains(&s.group()) {
                g.push(s.group());
            }
        }
        g
    };
    let _ = writeln!(
        md,
        "- {} configurations, {runs} timed runs, over: {}",
        sums.len(),
        groups.join("; ")
    );
    // What each scene's render path pays for (from the serial baseline row of each group).
    for g in &groups {
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
    let _ = writeln!(md, "- Speedup = t_serial / t (serial = one thread, no scheduler, same scene, tracer and settings); every image is compared bit for bit with the serial one.\n");
    if let Some(m) = meta {
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
            "- raysched {} at `{}`, {}, features: [{}]\n",
            m.raysched_version,
            m.git_commit,
            m.rustc,
            m.features.join(", ")
        );
    }
    let _ = writeln!(md, "## Result\n");
    let mut any = false;
    for g in &groups {
        // Thread schedulers only: MPI rows have their own section.
        let in_g: Vec<&Summary> = sums
            .iter()
            .filter(|s| &s.group() == g && s.row.sources != "mpi")
            .collect();
        if let Some(sentence) = per_ray_sentence(g, &in_g) {
            let _ = writeln!(md, "{sentence}\n");
            any = true;
        }
    }
    if !any {
        let _ = writeln!(
            md,
            "(No per-ray master configuration in this experiment, so no per-ray comparison.)\n"
        );
    }
    md += &mpi_section(&groups, sums);
    let _ = writeln!(md, "## Best configuration per scheduler\n");
    for g in &groups {
        // Thread schedulers only: MPI rows have their own section.
        let in_g: Vec<&Summary> = sums
            .iter()
            .filter(|s| &s.group() == g && s.row.sources != "mpi")
            .collect();
        let _ = writeln!(md, "### {g}\n");
        let _ = writeln!(md, "| scheduler | best configuration | workers | median wall (s) | 95 % CI of mean (s) | speedup | efficiency | runs |");
        let _ = writeln!(md, "|---|---|---|---|---|---|---|---|");
        let mut kinds: Vec<&str> = Vec::new();
        for s in &in_g {
            if !kinds.contains(&s.row.scheduler.as_str()) {
                kinds.push(&s.row.scheduler);
            }
        }
        for k in kinds {
            // Best = highest median speedup (at any worker count).
            let Some(b) = in_g
                .iter()
                .copied()
                .filter(|s| s.row.scheduler == k)
                .max_by(|a, b| a.speedup_median.total_cmp(&b.speedup_median))
            else {
                continue;
            };
            let _ = writeln!(
                md,
                "| {k} | `{}` | {} | {:.4} | {:.4} – {:.4} | {:.2}× | {:.0} % | {} |",
                b.row.label,
                b.row.workers,
                b.wall_median,
                b.wall_ci95.0,
                b.wall_ci95.1,
                b.speedup_median,
                b.efficiency_median * 100.0,
                b.n
            );
        }
        let _ = writeln!(md);
    }
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

/// Tiles of at least 16×16 pixels count as "per block" in the MPI comparison.
pub const BLOCK_PX: u64 = 256;

/// For an MPI experiment: per chunk size, the throughput of each transport against the
/// local-thread baseline of the same launch size and scheduler (best buffer each), and the
/// per-block ratio against its goal (MPI ranks at ≥ 90 % of local threads).
pub fn mpi_section(groups: &[String], sums: &[Summary]) -> String {
    use super::throughput;
    let mut md = String::new();
    if !sums.iter().any(|s| s.row.sources == "mpi") {
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
                if s.row.sources == "mpi" && !lines.contains(&k) {
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
                                s.row.sources == "mpi" && s.row.transport.as_deref() == Some(t)
                            } else {
                                s.row.sources == "local"
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
