//! Plots of a simulation: speedup against simulated workers, efficiency against chunk size per
//! worker count, the master's saturation against its analytic limit 1/h, and the validation.

use super::error::SimError;
use super::rows::{Inputs, SimRow};
use super::validate::Validation;
use crate::plot::axes::Scale;
use crate::sched::Chunk;
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;

type Series = Vec<(String, Vec<(f64, f64)>)>;

fn e<T: std::fmt::Display>(err: T) -> String {
    err.to_string()
}

/// A line chart; `hlines` are dashed horizontal references (the analytic limits). `data`'s x
/// is log₂ of the value where `log2_x` holds.
#[allow(
    clippy::too_many_arguments,
    reason = "one call per figure, each naming its axes"
)]
fn chart(
    path: &Path,
    title: &str,
    x: &str,
    y: &str,
    data: &Series,
    log2_x: bool,
    hlines: &[(f64, String)],
    log_y: bool,
) -> Result<(), String> {
    crate::plot::font::register_font();
    if data.iter().all(|d| d.1.is_empty()) {
        return Ok(());
    }
    let lines: crate::plot::Series = data
        .iter()
        .map(|(n, pts)| {
            let pts = pts
                .iter()
                .map(|&(a, b)| (if log2_x { a.exp2() } else { a }, b, b, b))
                .collect();
            (n.clone(), pts)
        })
        .collect();
    let refs: Vec<(f64, &str)> = hlines.iter().map(|(v, n)| (*v, n.as_str())).collect();
    let spec = crate::plot::Lines {
        title,
        x_desc: x,
        y_desc: y,
        x: if log2_x { Scale::Log2 } else { Scale::Linear },
        y: if log_y { Scale::Log10 } else { Scale::Linear },
        ideal: false,
        refs: &refs,
        y_range: None,
        legend_w: 0,
    };
    let root = BitMapBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    crate::plot::line_chart(&root, &spec, &lines)?;
    root.present().map_err(e)?;
    Ok(())
}

fn slug(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

/// The label of `row`'s configuration without its chunk (the lines of the efficiency plot).
fn without_chunk(row: &SimRow) -> String {
    let mut s = row.spec.clone();
    s.chunk = Chunk::Frame;
    s.label().replace(" chunk=frame", "")
}

/// The per-ray master's analytic limits for the speedup plot: one master hands out at most
/// 1/h items per second, so speedup ≤ c̄ / h (c̄ the mean item cost), reached at c̄ / h workers
/// (where the workers' demand, W / c̄ items per second, meets 1/h).
fn master_limits(rows: &[&&SimRow], inputs: &Inputs) -> Vec<(f64, String)> {
    let mut out: Vec<(f64, String)> = Vec::new();
    for r in rows {
        if let Some(b) = r.spec.policy.needs().outstanding {
            let Some(h) = inputs.master_h_s.get(&b) else {
                continue;
            };
            let limit = analytic_master_speedup(r.serial_s, r.items, *h);
            let name = format!(
                "1/h limit of {}: speedup {limit:.0}, reached at {limit:.0} workers",
                r.spec.label()
            );
            if !out.iter().any(|l| l.1 == name) {
                out.push((limit, name));
            }
        }
    }
    out
}

/// c̄ / h: the speedup a single master with cost `h` per hand-out cannot exceed over `items`
/// items costing `serial_s` in all (= the worker count at which it saturates).
pub fn analytic_master_speedup(serial_s: f64, items: usize, h: f64) -> f64 {
    serial_s / items.max(1) as f64 / h.max(1e-300)
}

/// Every simulation plot into `dir`; returns their file names.
///
/// # Errors
/// A chart that could not be drawn or written ([`SimError::Failed`], its message).
pub fn draw(dir: &Path, rows: &[SimRow], inputs: &Inputs) -> Result<Vec<String>, SimError> {
    draw_charts(dir, rows, inputs).map_err(SimError::Failed)
}

fn draw_charts(dir: &Path, rows: &[SimRow], inputs: &Inputs) -> Result<Vec<String>, String> {
    let mut files = Vec::new();
    let ok: Vec<&SimRow> = rows.iter().filter(|r| r.out.error.is_none()).collect();
    let platforms: Vec<String> = {
        let mut p: Vec<String> = rows.iter().map(|r| r.platform.clone()).collect();
        p.dedup();
        p
    };
    for p in &platforms {
        let on: Vec<&&SimRow> = ok.iter().filter(|r| &r.platform == p).collect();
        // Speedup vs workers.
        let mut by_label: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
        for r in &on {
            by_label
                .entry(r.spec.label())
                .or_default()
                .push(((r.spec.workers as f64).log2(), r.speedup()));
        }
        let f = format!("speedup_vs_workers_{}.png", slug(p));
        chart(
            &dir.join(&f),
            &format!("{p}: simulated speedup"),
            "simulated workers (log₂)",
            "speedup over serial",
            &by_label.into_iter().collect(),
            true,
            &master_limits(&on, inputs),
            true,
        )?;
        files.push(f);
        // Efficiency vs chunk, one plot per configuration without chunk, a line per worker count.
        let mut groups: BTreeMap<String, BTreeMap<usize, Vec<(f64, f64)>>> = BTreeMap::new();
        for r in &on {
            groups
                .entry(without_chunk(r))
                .or_default()
                .entry(r.spec.workers)
                .or_default()
                .push(((r.chunk_px as f64).log2(), r.efficiency()));
        }
        for (g, lines) in groups {
            if lines.values().all(|v| v.len() < 2) {
                continue;
            }
            let data: Series = lines
                .into_iter()
                .map(|(w, mut v)| {
                    v.sort_by(|a, b| a.0.total_cmp(&b.0));
                    (format!("{w} workers"), v)
                })
                .collect();
            let f = format!("efficiency_vs_chunk_{}_{}.png", slug(p), slug(&g));
            chart(
                &dir.join(&f),
                &format!("{p}: {g}"),
                "pixels per item (log₂)",
                "efficiency (speedup / workers)",
                &data,
                true,
                &[],
                false,
            )?;
            files.push(f);
        }
        // Master saturation: items per second against the analytic 1/h.
        let mut sat: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
        let mut limits = Vec::new();
        for r in &on {
            if let Some(b) = r.spec.policy.needs().outstanding {
                sat.entry(r.spec.label()).or_default().push((
                    (r.spec.workers as f64).log2(),
                    r.items as f64 / r.out.wall_s,
                ));
                if let Some(h) = inputs.master_h_s.get(&b) {
                    let line = (1.0 / h, format!("1/h at B={} ({:.0} ns)", b, h * 1e9));
                    if !limits.iter().any(|l: &(f64, String)| l.1 == line.1) {
                        limits.push(line);
                    }
                }
            }
        }
        if !sat.is_empty() {
            let f = format!("master_saturation_{}.png", slug(p));
            chart(
                &dir.join(&f),
                &format!("{p}: master throughput vs its limit 1/h"),
                "simulated workers (log₂)",
                "items per second",
                &sat.into_iter().collect(),
                true,
                &limits,
                true,
            )?;
            files.push(f);
        }
    }
    Ok(files)
}

/// Simulated against measured wall time, one point per configuration, with y = x.
///
/// # Errors
/// The chart could not be drawn or written ([`SimError::Failed`], its message).
pub fn validation(dir: &Path, v: &Validation) -> Result<Vec<String>, SimError> {
    validation_chart(dir, v).map_err(SimError::Failed)
}

fn validation_chart(dir: &Path, v: &Validation) -> Result<Vec<String>, String> {
    let group =
        |c: &crate::studies::simulate::validate::Comparison| (c.sources.clone(), c.spec.workers);
    let mut by_workers: BTreeMap<(String, usize), Vec<(f64, f64)>> = BTreeMap::new();
    for c in &v.rows {
        by_workers
            .entry(group(c))
            .or_default()
            .push((c.measured.0, c.simulated));
    }
    crate::plot::font::register_font();
    let f = "validation.png".to_string();
    let path = dir.join(&f);
    let groups: Vec<crate::plot::ScatterGroup> = by_workers
        .keys()
        .map(|w| {
            let pts = v
                .rows
                .iter()
                .filter(|r| group(r) == *w)
                .map(|r| (r.measured.0, r.measured.1, r.measured.2, r.simulated))
                .collect();
            (format!("{}, {} worker(s)", w.0, w.1), pts)
        })
        .collect();
    let root = BitMapBackend::new(&path, (900, 700)).into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    crate::plot::scatter_vs(
        &root,
        &format!("simulated ({}) vs measured wall time", v.platform),
        (
            "measured wall, s (median; bar: min–max)",
            "simulated wall, s",
        ),
        &groups,
    )?;
    root.present().map_err(e)?;
    Ok(vec![f])
}

/// The masters' saturation per platform: the analytic limit 1/h against the highest simulated
/// hand-out rate (items / wall), and the first worker count reaching 95 % of 1/h.
pub fn saturation_markdown(rows: &[SimRow], inputs: &Inputs) -> String {
    let mut groups: BTreeMap<(String, String), (f64, Vec<&SimRow>)> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.out.error.is_none()) {
        if let Some(b) = r.spec.policy.needs().outstanding {
            if let Some(&h) = inputs.master_h_s.get(&b) {
                groups
                    .entry((r.platform.clone(), r.spec.label()))
                    .or_insert((h, Vec::new()))
                    .1
                    .push(r);
            }
        }
    }
    if groups.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "## The master's saturation\n\nOne master hands out at most 1/h items per second; the simulated rate is items / wall.\n\n| platform | configuration | h ns | 1/h items/s | c̄/h workers | simulated peak items/s (at workers) | peak × h | first workers ≥ 95 % of 1/h |\n|---|---|---|---|---|---|---|---|\n",
    );
    for ((p, label), (h, mut rs)) in groups {
        rs.sort_by_key(|r| r.spec.workers);
        let rate = |r: &SimRow| r.items as f64 / r.out.wall_s;
        let Some(peak) = rs.iter().max_by(|a, b| rate(a).total_cmp(&rate(b))) else {
            continue;
        };
        let from = rs
            .iter()
            .find(|r| rate(r) * h >= 0.95)
            .map(|r| r.spec.workers.to_string())
            .unwrap_or_else(|| "not reached".into());
        s += &format!(
            "| {p} | {label} | {:.1} | {:.3e} | {:.0} | {:.3e} ({}) | {:.3} | {from} |\n",
            h * 1e9,
            1.0 / h,
            analytic_master_speedup(peak.serial_s, peak.items, h),
            rate(peak),
            peak.spec.workers,
            rate(peak) * h,
        );
    }
    s + "\n"
}

/// The simulated rows as a markdown table, with the measured inputs.
pub fn summary_markdown(rows: &[SimRow], inputs: &Inputs) -> String {
    let mut s = format!(
        "## Simulated runs\n\nInputs (measured): probe {}×{} px, serial {:.4} s; shared counter {:.1} ns per grab; master h {}. Network: `fine` is SimGrid's, `coarse` the FIFO links of `simgrid::protocols::Wires`.\n\n| platform | configuration | workers | network | wall s | speedup | efficiency | dispatch s | imbalance | messages | bytes | note |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        inputs.pixels.width,
        inputs.pixels.height,
        inputs.pixels.serial_s(),
        inputs.counter_s * 1e9,
        super::rows::master_h_text(&inputs.master_h_s)
    );
    for r in rows {
        s += &format!(
            "| {} | {} | {} | {} | {:.5} | {:.2} | {:.3} | {:.5} | {:.3} | {} | {} | {} |\n",
            r.platform,
            r.spec.label(),
            r.spec.workers,
            r.network.id(),
            r.out.wall_s,
            r.speedup(),
            r.efficiency(),
            r.out.dispatch_s,
            r.imbalance(),
            r.out.messages,
            r.out.bytes,
            r.out.error.as_deref().unwrap_or("")
        );
    }
    s
}
