//! `raysched compare A B`: how each configuration changed between two results folders (two
//! commits, two machines, two days).
//!
//! Per configuration: the ratio of median wall times B / A with a bootstrap interval (the two
//! runs are independent, so each is resampled on its own), the p-value of a two-sided
//! Mann–Whitney U test on the wall times, and the speedup of each run with the change between
//! them. The rank test is used rather than Welch's t because run times are skewed (a sample can
//! only be slowed down) and carry outliers; it assumes neither normality nor equal spread, and
//! a single slow sample moves it by one rank, not by its size. The verdict
//! ([`super::verdict`]) is *faster* or *slower* when the change is both significant
//! (p < `alpha`) and beyond `threshold`, *equivalent within ±margin* when two one-sided tests
//! reject a change as large as the margin (default: the experiment's precision target), and
//! otherwise *undecided*, naming the runs per side that could decide.
//!
//! Drift of the machine between two runs is a change to the test. Runs measured in alternated
//! rounds (`raysched compare --interleave`, see `app::compare`) see the same drift, so it
//! cancels; two runs measured one after the other do not.
//!
//! A shared machine also drifts as a whole between runs (10 % within minutes on the 2-core VM
//! raysched is developed on). When both folders carry the machine-speed probe
//! ([`super::speed`]), B's walls are divided by the ratio of the two runs' median probe times
//! before anything is computed, so that common drift cancels and a change of raysched's own
//! code (which the probe does not run) remains; `raw` turns this off. The factor's own
//! uncertainty (the median of one probe per round, ~30 rounds) is not in the intervals.

use super::meta::Meta;
use super::results::{read_runs, RunRow};
use super::stats::{median, paired_ratio_change, unpaired_ratio, Ratio};
use super::summary::{pair_by_rep, seed_of, summarize, Summary};
pub use super::verdict::Verdict;
use super::verdict::{decide, Rule};
use crate::util::one_line::escape_controls;
use serde::Serialize;
use std::collections::BTreeSet;
use std::fmt::Write;
use std::path::Path;

/// When a change counts.
#[derive(Clone, Copy, Debug)]
pub struct Criteria {
    /// Smallest relative change of the median wall time that counts (0.05 = 5 %); `None`: the
    /// margin.
    pub threshold: Option<f64>,
    /// Equivalence margin (a fraction); `None`: A's precision target (`ci_target`), else 5 %.
    pub margin: Option<f64>,
    /// Largest p-value that counts as significant (each one-sided test of TOST included).
    pub alpha: f64,
    /// Compare raw wall times even when both runs carry machine-speed probes.
    pub raw: bool,
}

impl Default for Criteria {
    fn default() -> Self {
        Self {
            threshold: None,
            margin: None,
            alpha: 0.01,
            raw: false,
        }
    }
}

/// The margin where neither the flags nor the folder name one.
pub const DEFAULT_MARGIN: f64 = 0.05;

/// A ratio with its interval, as serialised.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Interval {
    /// The point estimate.
    pub value: f64,
    /// 2.5 % bound.
    pub lo: f64,
    /// 97.5 % bound.
    pub hi: f64,
}

impl From<Ratio> for Interval {
    fn from(r: Ratio) -> Self {
        Self {
            value: r.value,
            lo: r.lo,
            hi: r.hi,
        }
    }
}

/// One configuration in both folders.
#[derive(Clone, Debug, Serialize)]
pub struct Change {
    /// The configuration id.
    pub config: String,
    /// Scene, settings and tracer.
    pub group: String,
    /// The scheduler label.
    pub label: String,
    /// Workers.
    pub workers: usize,
    /// Samples in A and in B.
    pub n: (usize, usize),
    /// Median wall time in A and in B, seconds.
    pub wall_median_s: (f64, f64),
    /// median wall B / median wall A, B's walls divided by the machine factor when there is one.
    pub wall_ratio: Interval,
    /// median wall B / median wall A of the raw walls.
    pub raw_wall_ratio: f64,
    /// Two-sided Mann–Whitney U p-value of the wall times.
    pub p_value: f64,
    /// The larger one-sided p of the equivalence test at the margin.
    pub p_equivalence: f64,
    /// Speedup over serial in A and in B (paired within each run).
    pub speedup: (Option<f64>, Option<f64>),
    /// speedup B / speedup A.
    pub speedup_ratio: Option<Interval>,
    /// faster, slower, equivalent or undecided.
    pub verdict: Verdict,
    /// Undecided: the runs per side that could decide (see [`super::verdict::Decision`]).
    pub runs_needed: Option<usize>,
    /// The verdict in words: "equivalent within ±2.0 %", "undecided (need ≥ 6 runs per side)".
    pub verdict_text: String,
}

/// The comparison of two folders.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    /// Folder A (the reference).
    pub a: String,
    /// Folder B.
    pub b: String,
    /// The commit and machine of each, from meta.toml.
    pub provenance: (String, String),
    /// The change threshold used.
    pub threshold: f64,
    /// The equivalence margin used, and where it came from.
    pub margin: f64,
    /// `flag`, `precision target of A` or `default`.
    pub margin_from: &'static str,
    /// The significance level used.
    pub alpha: f64,
    /// The test behind `p_value`.
    pub test: &'static str,
    /// Median machine-speed probe of A and of B, seconds, where the rows carry one.
    pub probe_median_s: (Option<f64>, Option<f64>),
    /// What B's walls were divided by: median probe B / median probe A (`None`: raw walls).
    pub machine_factor: Option<f64>,
    /// Configurations in both.
    pub changes: Vec<Change>,
    /// Configuration ids only in A, then only in B.
    pub unmatched: (Vec<String>, Vec<String>),
}

impl Comparison {
    /// How many configurations got each verdict: (faster, slower, equivalent, undecided).
    pub fn counts(&self) -> (usize, usize, usize, usize) {
        let c = |v| self.changes.iter().filter(|x| x.verdict == v).count();
        (
            c(Verdict::Faster),
            c(Verdict::Slower),
            c(Verdict::Equivalent),
            c(Verdict::Undecided),
        )
    }
}

/// Why two folders cannot be compared.
#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    /// A folder is no results folder, or its runs.csv cannot be read.
    #[error("{0}")]
    Folder(String),
    /// The folders share no configuration, so every verdict would be vacuous.
    #[error(
        "{a} and {b} have no configuration in common: {why}; compare pairs rows by configuration \
         (scene, settings, tracer, scheduler, workers), so measure one experiment file into both \
         folders (raysched run FILE --out DIR) to compare across them"
    )]
    NothingInCommon {
        /// Folder A.
        a: String,
        /// Folder B.
        b: String,
        /// Different experiments, scenes or grids, as found.
        why: String,
    },
}

/// One folder's summaries, its provenance line, its median probe time and its precision target.
type Loaded = (Vec<Summary>, String, Option<f64>, Option<f64>);

/// Why folders with rows `a` and `b` share no configuration: their experiments, their scenes
/// (names, then content) or, failing both, their grids.
fn why_disjoint(a: &[RunRow], b: &[RunRow]) -> String {
    let set = |rows: &[RunRow], f: fn(&RunRow) -> String| -> BTreeSet<String> {
        rows.iter().map(f).collect()
    };
    let list = |s: &BTreeSet<String>| s.iter().cloned().collect::<Vec<_>>().join(", ");
    if a.is_empty() || b.is_empty() {
        let which = if a.is_empty() { "A" } else { "B" };
        return format!("{which} holds no measured rows");
    }
    let (ea, eb) = (
        set(a, |r| r.experiment.clone()),
        set(b, |r| r.experiment.clone()),
    );
    if ea.is_disjoint(&eb) {
        return format!("different experiments ({} vs {})", list(&ea), list(&eb));
    }
    let (sa, sb) = (set(a, |r| r.scene.clone()), set(b, |r| r.scene.clone()));
    if sa.is_disjoint(&sb) {
        return format!("different scenes ({} vs {})", list(&sa), list(&sb));
    }
    let key = |r: &RunRow| format!("{} {}", r.scene, r.scene_hash);
    let (ha, hb) = (set(a, key), set(b, key));
    if ha.is_disjoint(&hb) {
        return format!(
            "the same scene names with different content (scene hash {} vs {})",
            list(&ha),
            list(&hb)
        );
    }
    let key = |r: &RunRow| {
        format!(
            "{}×{} spp {} depth {}",
            r.width, r.height, r.spp, r.max_depth
        )
    };
    let (ga, gb) = (set(a, key), set(b, key));
    if ga.is_disjoint(&gb) {
        return format!("different render settings ({} vs {})", list(&ga), list(&gb));
    }
    "different grids (tracers, schedulers, chunks or workers: no configuration id in both)".into()
}

fn load(dir: &Path) -> Result<(Loaded, Vec<RunRow>), CompareError> {
    let runs = dir.join("runs.csv");
    if !runs.exists() {
        // A folder name may hold a tab or a newline: the error stays one line and names it.
        let shown = |p: &Path| escape_controls(&p.to_string_lossy()).into_owned();
        return Err(CompareError::Folder(format!(
            "{}: not found (is {} a results folder?)",
            shown(&runs),
            shown(dir)
        )));
    }
    let (rows, _) = read_runs(&runs).map_err(|e| CompareError::Folder(e.to_string()))?;
    let meta: Option<Meta> = std::fs::read_to_string(dir.join("meta.toml"))
        .ok()
        .and_then(|t| toml::from_str(&t).ok());
    let (rows, _) = super::meta::current_rows(meta.as_ref(), rows);
    let target = meta
        .as_ref()
        .and_then(|m| m.history.last())
        .map(|h| h.stats.ci_target)
        .filter(|t| *t > 0.0);
    let prov = meta.map_or("meta.toml unreadable".into(), |m| {
        format!(
            "`{}` on {} ({} cores)",
            m.git_commit, m.machine.cpu_model, m.machine.cores
        )
    });
    let probes: Vec<f64> = rows
        .iter()
        .filter_map(|r| r.probe_s)
        .filter(|p| p.is_finite() && *p > 0.0)
        .collect();
    let probe = (!probes.is_empty()).then(|| median(&probes));
    Ok(((summarize(&rows), prov, probe, target), rows))
}

/// The serial baseline walls of `s`'s group in `sums`.
fn serial_of<'a>(sums: &'a [Summary], s: &Summary) -> Option<&'a Summary> {
    sums.iter()
        .find(|x| x.row.is_serial() && x.group() == s.group())
}

/// Compare every configuration of `a` with the same configuration (same id) of `b`.
/// Folders without a configuration in common are refused ([`CompareError::NothingInCommon`]).
pub fn compare(a: &Path, b: &Path, crit: Criteria) -> Result<Comparison, CompareError> {
    let ((sa, pa, probe_a, target_a), rows_a) = load(a)?;
    let ((sb, pb, probe_b, _), rows_b) = load(b)?;
    if !sa
        .iter()
        .any(|x| sb.iter().any(|y| y.row.config == x.row.config))
    {
        return Err(CompareError::NothingInCommon {
            a: a.display().to_string(),
            b: b.display().to_string(),
            why: why_disjoint(&rows_a, &rows_b),
        });
    }
    let factor = match (probe_a, probe_b) {
        (Some(x), Some(y)) if !crit.raw => Some(y / x),
        _ => None,
    };
    let (margin, margin_from) = match (crit.margin, target_a) {
        (Some(m), _) => (m, "flag"),
        (None, Some(t)) => (t, "precision target of A"),
        (None, None) => (DEFAULT_MARGIN, "default"),
    };
    let rule = Rule {
        margin,
        threshold: crit.threshold.unwrap_or(margin),
        alpha: crit.alpha,
    };
    let mut changes = Vec::new();
    let mut only_a = Vec::new();
    for x in &sa {
        let Some(y) = sb.iter().find(|y| y.row.config == x.row.config) else {
            only_a.push(x.row.config.clone());
            continue;
        };
        let wa: Vec<f64> = x.walls.iter().map(|w| w.1).collect();
        let wb_raw: Vec<f64> = y.walls.iter().map(|w| w.1).collect();
        let wb: Vec<f64> = wb_raw.iter().map(|w| w / factor.unwrap_or(1.0)).collect();
        let seed = seed_of(&x.row.config);
        let ratio = unpaired_ratio(&wb, &wa, seed);
        let raw_wall_ratio = median(&wb_raw) / median(&wa);
        let d = decide(&wa, &wb, &rule);
        let speedup_ratio = match (serial_of(&sa, x), serial_of(&sb, y)) {
            (Some(ba), Some(bb)) if !x.row.is_serial() => {
                let (na, da) = pair_by_rep(&ba.walls, &x.walls);
                let (nb, db) = pair_by_rep(&bb.walls, &y.walls);
                (!na.is_empty() && !nb.is_empty())
                    .then(|| paired_ratio_change((&na, &da), (&nb, &db), seed).into())
            }
            _ => None,
        };
        changes.push(Change {
            config: x.row.config.clone(),
            group: x.group(),
            label: x.row.label.clone(),
            workers: x.row.workers,
            n: (x.n, y.n),
            wall_median_s: (x.wall_median, y.wall_median),
            wall_ratio: ratio.into(),
            raw_wall_ratio,
            p_value: d.p_difference,
            p_equivalence: d.p_equivalence,
            speedup: (x.speedup.map(|r| r.value), y.speedup.map(|r| r.value)),
            speedup_ratio,
            verdict: d.verdict,
            runs_needed: d.runs_needed,
            verdict_text: d.phrase(),
        });
    }
    let only_b = sb
        .iter()
        .filter(|y| !sa.iter().any(|x| x.row.config == y.row.config))
        .map(|y| y.row.config.clone())
        .collect();
    Ok(Comparison {
        a: a.display().to_string(),
        b: b.display().to_string(),
        provenance: (pa, pb),
        threshold: rule.threshold,
        margin,
        margin_from,
        alpha: crit.alpha,
        test: "two-sided Mann–Whitney U (normal approximation, tie-corrected)",
        probe_median_s: (probe_a, probe_b),
        machine_factor: factor,
        changes,
        unmatched: (only_a, only_b),
    })
}

fn pct(r: f64) -> String {
    format!("{:+.1} %", (r - 1.0) * 100.0)
}

/// The comparison as a markdown report.
pub fn markdown(c: &Comparison) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "# {} → {}\n", c.a, c.b);
    let _ = writeln!(md, "- A: {}\n- B: {}", c.provenance.0, c.provenance.1);
    let _ = writeln!(
        md,
        "- change = median wall B / median wall A − 1, 95 % CI by bootstrap (each run resampled on its own); p: {} on the wall times\n- verdict: faster/slower when p < {} and the change exceeds ±{:.1} %; equivalent when two one-sided Mann–Whitney tests (TOST) at level {} both reject a change of ±{:.1} % (the margin: {}); otherwise undecided, with the runs per side that could decide (≥: fewer than the test can ever decide with; ≈: estimated from this spread)\n",
        c.test,
        c.alpha,
        c.threshold * 100.0,
        c.alpha,
        c.margin * 100.0,
        c.margin_from
    );
    let ms = |p: Option<f64>| p.map_or("none".into(), |p| format!("{:.2} ms", p * 1e3));
    let _ = match c.machine_factor {
        Some(f) => writeln!(
            md,
            "- machine speed: median probe A {}, B {}; B's walls divided by {f:.3} before comparing (raw walls: `--raw`; the raw change is in the last column)\n",
            ms(c.probe_median_s.0),
            ms(c.probe_median_s.1)
        ),
        None => writeln!(
            md,
            "- machine speed: median probe A {}, B {}; raw walls compared\n",
            ms(c.probe_median_s.0),
            ms(c.probe_median_s.1)
        ),
    };
    let (f, s, e, u) = c.counts();
    let need = c.changes.iter().filter_map(|x| x.runs_needed).max();
    let _ = writeln!(
        md,
        "**{} configurations: {f} faster, {s} slower, {e} equivalent within ±{:.1} %, {u} undecided{}.**\n",
        c.changes.len(),
        c.margin * 100.0,
        need.map_or(String::new(), |k| format!(" (up to {k} runs per side needed)"))
    );
    let _ = writeln!(md, "| group | configuration | workers | runs A/B | median A (ms) | median B (ms) | change (95 % CI) | p | speedup A → B | speedup change (95 % CI) | verdict | raw change |");
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|---|---|---|");
    for x in &c.changes {
        let sp = match x.speedup {
            (Some(a), Some(b)) => format!("{a:.2}× → {b:.2}×"),
            _ => "–".into(),
        };
        let spc = x.speedup_ratio.map_or("–".into(), |r| {
            format!("{} ({} – {})", pct(r.value), pct(r.lo), pct(r.hi))
        });
        let _ = writeln!(
            md,
            "| {} | `{}` | {} | {}/{} | {:.3} | {:.3} | {} ({} – {}) | {:.2e} | {sp} | {spc} | {} | {} |",
            x.group,
            x.label,
            x.workers,
            x.n.0,
            x.n.1,
            x.wall_median_s.0 * 1e3,
            x.wall_median_s.1 * 1e3,
            pct(x.wall_ratio.value),
            pct(x.wall_ratio.lo),
            pct(x.wall_ratio.hi),
            x.p_value,
            if matches!(x.verdict, Verdict::Faster | Verdict::Slower) {
                format!("**{}**", x.verdict_text)
            } else {
                x.verdict_text.clone()
            },
            pct(x.raw_wall_ratio)
        );
    }
    let (oa, ob) = &c.unmatched;
    if !oa.is_empty() || !ob.is_empty() {
        let _ = writeln!(
            md,
            "\nNot compared: {} configuration(s) only in A, {} only in B.",
            oa.len(),
            ob.len()
        );
    }
    md
}
