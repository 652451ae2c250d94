//! Wall times of two configurations compared for the reports: their ratio paired by round,
//! its text, and the fastest configuration with those not shown slower than it, each read as
//! *equivalent within ±X %* (two one-sided tests) or *not shown slower* — never both, and
//! never "tied" ([`crate::studies::experiment::verdict`]).

use crate::studies::experiment::compare::DEFAULT_MARGIN;
use crate::studies::experiment::meta::Meta;
use crate::studies::experiment::stats::Ratio;
use crate::studies::experiment::summary::{ratio_by_round, seed_of, Summary};
use crate::studies::experiment::verdict::{decide, Rule, Verdict};

/// The configuration of `v` with the smallest median wall time.
pub fn best_by<'a>(v: impl Iterator<Item = &'a Summary>) -> Option<&'a Summary> {
    v.min_by(|a, b| a.wall_median.total_cmp(&b.wall_median))
}

/// wall(a) / wall(b) as a ratio of medians ([`ratio_by_round`]: paired by repetition where
/// they share enough rounds, else unpaired).
pub fn wall_ratio(a: &Summary, b: &Summary) -> Ratio {
    ratio_of(a, b, |s| &s.walls)
}

/// Σ busy(a) / Σ busy(b), the workers' busy time summed per sample, paired as [`wall_ratio`].
pub fn busy_ratio(a: &Summary, b: &Summary) -> Ratio {
    ratio_of(a, b, |s| &s.busy)
}

fn ratio_of(a: &Summary, b: &Summary, of: fn(&Summary) -> &[(u32, f64)]) -> Ratio {
    let seed = seed_of(&a.row.config) ^ seed_of(&b.row.config).rotate_left(1);
    ratio_by_round(of(a), of(b), seed).unwrap_or(Ratio {
        value: f64::NAN,
        lo: f64::NAN,
        hi: f64::NAN,
        n: 0,
    })
}

/// "1.99× (95 % CI 1.95–2.03)".
pub fn with_ci(r: &Ratio) -> String {
    format!("{:.2}× (95 % CI {:.2}–{:.2})", r.value, r.lo, r.hi)
}

/// A configuration's speedup over serial with its interval where it has one.
/// ([`Summary::speedup_ci`]: the paired ratio, 1 for the baseline, "—" without one).
pub fn speedup_text(s: &Summary) -> String {
    let r = s.speedup_ci();
    if !r.value.is_finite() {
        "—".into()
    } else if r.lo < r.hi {
        with_ci(&r)
    } else {
        format!("{:.2}×", r.value)
    }
}

/// A configuration's efficiency (its speedup over workers, [`Summary::efficiency_ci`]) in
/// whole percent, "—" without a baseline.
pub fn efficiency_text(s: &Summary) -> String {
    let e = s.efficiency_ci().value;
    if e.is_finite() {
        format!("{:.0} %", e * 100.0)
    } else {
        "—".into()
    }
}

/// Level of every test the reports state: each one-sided equivalence test, and the 95 %
/// intervals.
pub const ALPHA: f64 = 0.05;

/// The equivalence margin a report tests: the experiment's precision target (`ci_target`),
/// else `compare`'s default.
pub fn margin_of(meta: Option<&Meta>) -> f64 {
    meta.and_then(|m| m.history.last())
        .map(|h| h.stats.ci_target)
        .filter(|t| *t > 0.0)
        .unwrap_or(DEFAULT_MARGIN)
}

/// How a configuration reads beside the fastest one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reading {
    /// Two one-sided Mann–Whitney tests at [`ALPHA`] reject a change beyond ±margin.
    Equivalent,
    /// The 95 % interval of wall / best wall reaches down to 1; equivalence not shown, with
    /// the runs per side that could decide where the test names them (and whether that is the
    /// test's exact minimum rather than an estimate).
    NotShownSlower(Option<(usize, bool)>),
}

/// `s` beside the fastest `best`: [`Reading::Equivalent`] where two one-sided tests on the
/// runs' wall times show it within ±`margin`, else [`Reading::NotShownSlower`] where the 95 %
/// interval of wall(s) / wall(best) reaches down to 1, else `None` (shown slower).
pub fn reading(s: &Summary, best: &Summary, margin: f64) -> Option<Reading> {
    let walls = |x: &Summary| x.walls.iter().map(|w| w.1).collect::<Vec<f64>>();
    let d = decide(&walls(best), &walls(s), &Rule::with_margin(margin, ALPHA));
    if d.verdict == Verdict::Equivalent {
        return Some(Reading::Equivalent);
    }
    (wall_ratio(s, best).lo <= 1.0).then_some(Reading::NotShownSlower(
        d.runs_needed.map(|k| (k, d.too_few)),
    ))
}

/// The fastest configuration of `at` and every other one not shown slower than it, each with
/// its [`Reading`].
pub fn near_best<'a>(
    at: &[&'a Summary],
    margin: f64,
) -> Option<(&'a Summary, Vec<(&'a Summary, Reading)>)> {
    let best = best_by(at.iter().copied())?;
    let near = at
        .iter()
        .copied()
        .filter(|s| s.row.config != best.row.config)
        .filter_map(|s| Some((s, reading(s, best, margin)?)))
        .collect();
    Some((best, near))
}

/// ", need ≈ 12 runs per side" (one estimate), ", need ≥ 4 …" (the test's exact minimum),
/// ", need ≈ 12–30 …" (several): the runs per side the undecided equivalence tests name.
fn need_words(need: &[(usize, bool)]) -> String {
    let (Some(lo), Some(hi)) = (
        need.iter().map(|n| n.0).min(),
        need.iter().map(|n| n.0).max(),
    ) else {
        return String::new();
    };
    if lo == hi {
        let exact = need.iter().all(|n| n.1);
        format!(
            ", need {} {lo} runs per side",
            if exact { "≥" } else { "≈" }
        )
    } else {
        format!(", need ≈ {lo}–{hi} runs per side")
    }
}

/// The configurations of `near` in words, by reading: "equivalent within ±2.0 % (two one-sided
/// tests at 95 %): a, b; not shown slower (its 95 % interval reaches 1), equivalence undecided
/// (need ≈ 12 runs per side): c"; `item` names one. Empty when `near` is.
pub fn near_words(
    near: &[(&Summary, Reading)],
    margin: f64,
    item: impl Fn(&Summary) -> String,
) -> String {
    let eq: Vec<String> = near
        .iter()
        .filter(|n| n.1 == Reading::Equivalent)
        .map(|n| item(n.0))
        .collect();
    let (mut not, mut need) = (Vec::new(), Vec::new());
    for (s, r) in near {
        if let Reading::NotShownSlower(k) = r {
            not.push(item(s));
            need.extend(*k);
        }
    }
    let mut parts = Vec::new();
    if !eq.is_empty() {
        parts.push(format!(
            "equivalent within ±{:.1} % (two one-sided tests at 95 %): {}",
            margin * 100.0,
            eq.join(", ")
        ));
    }
    if !not.is_empty() {
        let need = need_words(&need);
        parts.push(format!(
            "not shown slower (the 95 % interval of the wall-time ratio reaches 1; equivalence within ±{:.1} % undecided{need}): {}",
            margin * 100.0,
            not.join(", ")
        ));
    }
    parts.join("; ")
}
