//! One verdict on two samples of wall times, for `raysched compare` and the report: *faster*,
//! *slower*, *equivalent within ±X %* or *undecided (need ≥ k runs)*.
//!
//! "No significant difference" is not equivalence: with 3 runs a side the Mann–Whitney test
//! cannot reach p < 0.05 whatever the data (its smallest two-sided p, at complete separation,
//! is 0.081), so a rank test alone reads every change of a short run as "no change". Here a
//! difference is claimed only when the two-sided rank test is significant and the change of the
//! medians passes the threshold, and equivalence only when two one-sided tests (TOST, Schuirmann
//! 1987) both reject a change as large as the margin: B·(1+m)⁻¹ < A < B·(1+m), each a one-sided
//! Mann–Whitney test of the shifted sample at level α (a multiplicative shift, since a slower
//! machine or build scales run times). Everything else is undecided, with the runs per side the
//! data would need: exactly the smallest count at which the test can reach α at all when there
//! are fewer, else an estimate from the observed rank statistic, which grows with √n at a
//! fixed effect.
//!
//! A verdict is never both: the report's former "tied with the best" (an interval reaching 1,
//! that is "not shown slower") becomes "equivalent within ±X %" where TOST shows it and "not
//! shown slower" where it does not: `plot::compare::reading` for the report (its "not shown
//! slower" is the paired interval every ratio of the report states), and
//! [`Decision::relative_phrase`] on this rank test alone.

use super::stats::{mann_whitney_p, mann_whitney_z, median, normal_cdf};
use serde::Serialize;

/// When a difference or an equivalence counts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rule {
    /// Equivalence margin: changes within ±margin (a fraction, 0.02 = 2 %) are negligible.
    pub margin: f64,
    /// Smallest change of the medians that counts as faster or slower (a fraction).
    pub threshold: f64,
    /// Level of the two-sided difference test and of each one-sided equivalence test.
    pub alpha: f64,
}

impl Rule {
    /// A rule whose threshold is its margin, so that the verdicts cover every change size.
    pub fn with_margin(margin: f64, alpha: f64) -> Self {
        Self {
            margin,
            threshold: margin,
            alpha,
        }
    }
}

/// The verdict on B against A.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// B's wall times are significantly lower, its median by more than the threshold.
    Faster,
    /// B's wall times are significantly higher, its median by more than the threshold.
    Slower,
    /// Both one-sided tests reject a change as large as the margin.
    Equivalent,
    /// Neither: the data cannot tell.
    Undecided,
}

impl Verdict {
    /// The bare word.
    pub fn word(self) -> &'static str {
        match self {
            Self::Faster => "faster",
            Self::Slower => "slower",
            Self::Equivalent => "equivalent",
            Self::Undecided => "undecided",
        }
    }
}

/// A verdict with what it rests on.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Decision {
    /// The verdict.
    pub verdict: Verdict,
    /// median(B) / median(A).
    pub ratio: f64,
    /// Two-sided Mann–Whitney p of the difference.
    pub p_difference: f64,
    /// The larger of the two one-sided TOST p-values (equivalent when below α).
    pub p_equivalence: f64,
    /// The margin tested, a fraction.
    pub margin: f64,
    /// Undecided: the runs per side that could decide (`None`: a change at the margin, or
    /// between the margin and the threshold, where more runs need not settle it).
    pub runs_needed: Option<usize>,
    /// Undecided with fewer runs than the test can decide with at any data: `runs_needed` is
    /// that exact minimum, not an estimate.
    pub too_few: bool,
}

impl Decision {
    /// "faster", "slower", "equivalent within ±2.0 %", "undecided (need ≥ 6 runs per side)".
    pub fn phrase(&self) -> String {
        let m = self.margin * 100.0;
        match self.verdict {
            Verdict::Equivalent => format!("equivalent within ±{m:.1} %"),
            Verdict::Undecided => match self.runs_needed {
                Some(k) if self.too_few => format!("undecided (need ≥ {k} runs per side)"),
                Some(k) => format!("undecided (need ≈ {k} runs per side)"),
                None => format!(
                    "undecided (its change sits too near ±{m:.1} % to estimate the runs needed)"
                ),
            },
            v => v.word().to_string(),
        }
    }

    /// The phrase for B set beside a reference A it is not shown slower than, on the rank
    /// tests alone: "equivalent within ±X %" or "not shown slower"; `None` where B is slower.
    pub fn relative_phrase(&self) -> Option<String> {
        match self.verdict {
            Verdict::Slower => None,
            Verdict::Equivalent => Some(self.phrase()),
            Verdict::Faster | Verdict::Undecided => Some("not shown slower".into()),
        }
    }
}

/// Φ⁻¹(p) for p in (0.5, 1), by bisection on [`normal_cdf`] (to 1e-9: far below any α used).
fn normal_quantile(p: f64) -> f64 {
    let (mut lo, mut hi) = (0.0_f64, 10.0_f64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if normal_cdf(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The largest rank score `n1` against `n2` samples can reach (complete separation, no ties).
fn max_z(n1: usize, n2: usize) -> f64 {
    let (a, b) = (n1 as f64, n2 as f64);
    if n1 == 0 || n2 == 0 {
        return 0.0;
    }
    (a * b / 2.0 - 0.5) / (a * b * (a + b + 1.0) / 12.0).sqrt()
}

/// The smallest runs per side at which a rank test needing score `z` can pass at all.
fn min_runs_for(z: f64) -> usize {
    (1..10_000).find(|&n| max_z(n, n) > z).unwrap_or(10_000)
}

/// The fewest runs per side at which (the two-sided difference test, each one-sided
/// equivalence test) can reach `alpha` with any data: 6 and 5 at α = 0.01, 4 and 3 at 0.05.
pub fn min_runs(alpha: f64) -> (usize, usize) {
    (
        min_runs_for(normal_quantile(1.0 - alpha / 2.0)),
        min_runs_for(normal_quantile(1.0 - alpha)),
    )
}

/// Runs estimated to lift score `z` (positive, from `n` runs a side) to `need`.
fn scaled_runs(n: usize, z: f64, need: f64) -> usize {
    ((n as f64) * (need / z).powi(2)).ceil().min(100_000.0) as usize
}

/// The verdict on wall times `b` against `a` (non-finite values are left out).
pub fn decide(a: &[f64], b: &[f64], rule: &Rule) -> Decision {
    let clean = |v: &[f64]| -> Vec<f64> { v.iter().copied().filter(|x| x.is_finite()).collect() };
    let (a, b) = (clean(a), clean(b));
    let ratio = median(&b) / median(&a);
    let z = mann_whitney_z(&a, &b);
    let p_difference = mann_whitney_p(&a, &b);
    let up = 1.0 + rule.margin;
    // B below A·(1+m), and B above A/(1+m): both positive toward equivalence.
    let shifted = |f: f64| a.iter().map(|x| x * f).collect::<Vec<f64>>();
    let z_below = mann_whitney_z(&b, &shifted(up));
    let z_above = mann_whitney_z(&shifted(1.0 / up), &b);
    let z_eq = z_below.min(z_above);
    let p_equivalence = (1.0 - normal_cdf(z_eq)).clamp(0.0, 1.0);
    let beyond = ratio >= 1.0 + rule.threshold || ratio <= 1.0 / (1.0 + rule.threshold);
    let verdict = if p_difference < rule.alpha && beyond {
        if ratio > 1.0 {
            Verdict::Slower
        } else {
            Verdict::Faster
        }
    } else if p_equivalence < rule.alpha {
        Verdict::Equivalent
    } else {
        Verdict::Undecided
    };
    let (mut runs_needed, mut too_few) = (None, false);
    if verdict == Verdict::Undecided {
        let (z2, z1) = (
            normal_quantile(1.0 - rule.alpha / 2.0),
            normal_quantile(1.0 - rule.alpha),
        );
        let (k_diff, k_eq) = (min_runs_for(z2), min_runs_for(z1));
        let n = a.len().min(b.len());
        let mut candidates = Vec::new();
        if z_eq > 0.0 {
            candidates.push(scaled_runs(n, z_eq, z1).max(k_eq).max(n + 1));
        }
        if beyond && z.abs() > 0.0 {
            candidates.push(scaled_runs(n, z.abs(), z2).max(k_diff).max(n + 1));
        }
        // Too few for the test the data point to, whatever the data: its exact minimum.
        let floor = if beyond { k_diff } else { k_eq };
        if n < floor {
            candidates = vec![floor];
            too_few = true;
        }
        runs_needed = candidates.into_iter().min();
    }
    Decision {
        verdict,
        ratio,
        p_difference,
        p_equivalence,
        margin: rule.margin,
        runs_needed,
        too_few,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic sample of `n` walls around `centre`, spread ±`spread` (a fraction),
    /// in a scrambled order.
    fn sample(n: usize, centre: f64, spread: f64, phase: usize) -> Vec<f64> {
        (0..n)
            .map(|i| {
                let k = (i * 7 + phase) % n;
                centre * (1.0 + spread * (2.0 * k as f64 / (n.max(2) - 1) as f64 - 1.0))
            })
            .collect()
    }

    const RULE: Rule = Rule {
        margin: 0.02,
        threshold: 0.02,
        alpha: 0.01,
    };

    #[test]
    fn minimum_runs_are_those_where_complete_separation_first_passes() {
        // Two-sided at 0.05 with 3 a side: p = 0.081 at best, so 4 are needed.
        assert_eq!(min_runs(0.05), (4, 3));
        assert_eq!(min_runs(0.01), (6, 5));
        assert!(max_z(3, 3) < normal_quantile(0.975));
        assert!((normal_quantile(0.975) - 1.95996).abs() < 1e-4);
    }

    #[test]
    fn identical_distributions_are_equivalent_or_undecided_never_different() {
        for n in [3, 5, 8, 12, 20, 30] {
            for spread in [0.0, 0.005, 0.01, 0.05, 0.2] {
                for phase in 0..4 {
                    let a = sample(n, 1.0, spread, phase);
                    let b = sample(n, 1.0, spread, phase + 3);
                    let d = decide(&a, &b, &RULE);
                    assert!(
                        matches!(d.verdict, Verdict::Equivalent | Verdict::Undecided),
                        "n {n} spread {spread}: {d:?}"
                    );
                }
            }
        }
        // Tight and plentiful: shown equivalent.
        let a = sample(20, 1.0, 0.005, 0);
        let d = decide(&a, &sample(20, 1.0, 0.005, 5), &RULE);
        assert_eq!(d.verdict, Verdict::Equivalent, "{d:?}");
        assert_eq!(d.phrase(), "equivalent within ±2.0 %");
        assert_eq!(
            d.relative_phrase().as_deref(),
            Some("equivalent within ±2.0 %")
        );
    }

    #[test]
    fn ten_percent_more_work_is_slower_and_faster_the_other_way() {
        for n in [6, 8, 12, 30] {
            let a = sample(n, 1.0, 0.03, 1);
            let b = sample(n, 1.1, 0.03, 2);
            let d = decide(&a, &b, &RULE);
            assert_eq!(d.verdict, Verdict::Slower, "n {n}: {d:?}");
            assert!(d.relative_phrase().is_none());
            assert_eq!(decide(&b, &a, &RULE).verdict, Verdict::Faster);
        }
    }

    #[test]
    fn three_runs_are_undecided_and_name_the_runs_needed() {
        // Even a clear +89 % with 3 runs a side: the rank test cannot reach α = 0.01.
        let a = [1.0, 1.02, 0.99];
        let b = [1.89, 1.9, 1.88];
        let d = decide(&a, &b, &RULE);
        assert_eq!(d.verdict, Verdict::Undecided, "{d:?}");
        assert!(d.too_few);
        assert_eq!(d.runs_needed, Some(6));
        assert_eq!(d.phrase(), "undecided (need ≥ 6 runs per side)");
        assert_eq!(d.relative_phrase().as_deref(), Some("not shown slower"));
        // With enough runs but a spread wider than the margin: an estimate beyond n.
        let a = sample(8, 1.0, 0.1, 0);
        let d = decide(&a, &sample(8, 1.0, 0.1, 3), &RULE);
        assert_eq!(d.verdict, Verdict::Undecided, "{d:?}");
        assert!(!d.too_few && d.runs_needed.is_some_and(|k| k > 8), "{d:?}");
    }

    #[test]
    fn a_change_between_margin_and_threshold_needs_no_more_runs() {
        let rule = Rule {
            margin: 0.02,
            threshold: 0.05,
            alpha: 0.01,
        };
        let a = sample(30, 1.0, 0.002, 0);
        let d = decide(&a, &sample(30, 1.035, 0.002, 4), &rule);
        assert_eq!(
            (d.verdict, d.runs_needed),
            (Verdict::Undecided, None),
            "{d:?}"
        );
    }
}
