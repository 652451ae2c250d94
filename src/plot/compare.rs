//! Wall times of two configurations compared for the reports: their ratio paired by round,
//! its text, and the fastest configuration with those statistically tied with it.

use crate::studies::experiment::stats::Ratio;
use crate::studies::experiment::summary::{ratio_by_round, seed_of, Summary};

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

/// The fastest configuration of `at` and every other one not shown slower than it: those whose
/// 95 % interval of wall(other) / wall(best) reaches down to 1.
pub fn tied_with_best<'a>(at: &[&'a Summary]) -> Option<(&'a Summary, Vec<&'a Summary>)> {
    let best = best_by(at.iter().copied())?;
    let tied = at
        .iter()
        .copied()
        .filter(|s| s.row.config != best.row.config && wall_ratio(s, best).lo <= 1.0)
        .collect();
    Some((best, tied))
}
