//! The rules that size their own chunks against the best fixed chunk: per group, worker count
//! and `slow` setting, each guided or dynamic-loop-scheduling configuration's wall time over
//! that of the fastest `self_scheduling` chunk in scanline order (chunk self-scheduling with a
//! chunk tuned by hand, here by the sweep itself), paired by round, with its 95 % interval and
//! a verdict against a tolerance (issue goal: AF and AWF within 3 %).
//!
//! The best fixed chunk is the fastest of several noisy medians, so it is biased fast (the
//! winner's curse): that check leans against the self-tuning rules. A second, held-out check
//! plays the hand tuner, who picks a chunk from earlier runs and then uses it: the chunk is
//! picked on half of the rounds and judged on the other half ([`held_out_ratio`]).

use super::compare::{busy_ratio, wall_ratio, with_ci};
use crate::sched::{Order, SchedulerKind};
use crate::studies::experiment::stats::{median, paired_ratio, Ratio};
use crate::studies::experiment::summary::{seed_of, Summary, MIN_PAIRS};
use std::collections::HashMap;
use std::fmt::Write;

/// The tolerance of the check: a rule within 3 % of the best fixed chunk.
pub const TOLERANCE: f64 = 0.03;

/// Where a ratio's interval lies against `1 + tol`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// The whole interval is at or below `1 + tol`.
    Within,
    /// The whole interval is above `1 + tol`.
    Beyond,
    /// The interval straddles `1 + tol`: more rounds would decide.
    Undecided,
}

impl Verdict {
    /// The verdict of `r` against `1 + tol`.
    pub fn of(r: &Ratio, tol: f64) -> Self {
        if r.hi <= 1.0 + tol {
            Self::Within
        } else if r.lo > 1.0 + tol {
            Self::Beyond
        } else {
            Self::Undecided
        }
    }

    fn text(self, tol: f64) -> String {
        let pct = tol * 100.0;
        match self {
            Self::Within => format!("within {pct:.0} %"),
            Self::Beyond => format!("**beyond {pct:.0} %**"),
            Self::Undecided => format!("undecided ({pct:.0} % inside the interval)"),
        }
    }
}

fn kind(s: &Summary) -> Option<SchedulerKind> {
    SchedulerKind::from_id(&s.row.scheduler).ok()
}

/// A fixed-chunk configuration: `self_scheduling` in scanline order.
fn is_fixed(s: &Summary) -> bool {
    kind(s) == Some(SchedulerKind::SelfScheduling)
        && s.row.order.as_deref() == Some(Order::Scanline.id())
}

/// A rule that sizes its own chunks from what is left (and, for some, from measured times).
fn is_self_sizing(s: &Summary) -> bool {
    kind(s).is_some_and(SchedulerKind::sizes_own_hand_outs)
}

/// One rule's comparison with the best fixed chunk of its setting.
#[derive(Clone, Debug)]
pub struct Check<'a> {
    /// The rule's configuration.
    pub rule: &'a Summary,
    /// The fastest fixed chunk of the same workers and `slow` setting.
    pub best_fixed: &'a Summary,
    /// wall(rule) / wall(best fixed) ([`wall_ratio`]: paired by round from
    /// [`MIN_PAIRS`](crate::studies::experiment::summary::MIN_PAIRS) shared rounds, else unpaired).
    pub ratio: Ratio,
    /// `ratio` against the tolerance.
    pub verdict: Verdict,
    /// Σ busy(rule) / Σ busy(best fixed), paired as `ratio`: with equal workers only, since a
    /// slow worker's busy time also holds its spin, which grows with the share it takes.
    pub busy: Option<Ratio>,
    /// The held-out ratio ([`held_out_ratio`]) and its verdict, where the rounds allow one.
    pub held_out: Option<(HeldOut<'a>, Verdict)>,
}

/// wall(rule) / wall(fixed chunk picked without the round judged), with the picks.
#[derive(Clone, Debug)]
pub struct HeldOut<'a> {
    /// The ratio over every shared round, each against the pick of the other half.
    pub ratio: Ratio,
    /// The fastest fixed chunk on the even rounds (judged on the odd ones) and on the odd.
    pub picks: [&'a Summary; 2],
}

/// wall(rule) / wall(the fixed chunk a tuner would have picked without seeing this round).
/// The rounds that the rule and every candidate share split by parity; the fastest candidate
/// by median over the even rounds stands in for the odd rounds and the other way round
/// (two-fold cross-fitting), so no round both picks the chunk and judges it, and the luck of
/// the pick is not credited to the fixed chunk. Paired by round; `None` with fewer than
/// [`MIN_PAIRS`] shared rounds or fewer than two in a half.
pub fn held_out_ratio<'a>(rule: &Summary, fixed: &[&'a Summary]) -> Option<HeldOut<'a>> {
    let by_round: Vec<HashMap<u32, f64>> = fixed
        .iter()
        .map(|f| f.walls.iter().copied().collect())
        .collect();
    let shared: Vec<(u32, f64)> = rule
        .walls
        .iter()
        .copied()
        .filter(|(r, _)| by_round.iter().all(|m| m.contains_key(r)))
        .collect();
    let half = |h: u32| shared.iter().filter(move |(r, _)| r % 2 == h);
    if shared.len() < MIN_PAIRS || (0..2).any(|h| half(h).count() < 2) {
        return None;
    }
    // The candidate fastest by median over half `h`'s rounds (the first of equals).
    let pick = |h: u32| {
        let med: Vec<f64> = by_round
            .iter()
            .map(|m| median(&half(h).map(|(r, _)| m[r]).collect::<Vec<_>>()))
            .collect();
        (0..fixed.len()).min_by(|&a, &b| med[a].total_cmp(&med[b]))
    };
    let picks = [pick(0)?, pick(1)?];
    let (mut num, mut den) = (Vec::new(), Vec::new());
    for &(r, w) in &shared {
        // Judged against the pick of the other half.
        num.push(w);
        den.push(by_round[picks[1 - (r % 2) as usize]][&r]);
    }
    let seed = seed_of(&rule.row.config) ^ 0x68_656c_645f_6f75;
    Some(HeldOut {
        ratio: paired_ratio(&num, &den, seed),
        picks: picks.map(|k| fixed[k]),
    })
}

/// Every self-sizing rule of `at` (one group) against the best fixed chunk of its worker count
/// and `slow` setting, where that setting has at least two fixed chunks to choose from.
pub fn checks<'a>(at: &[&'a Summary], tol: f64) -> Vec<Check<'a>> {
    let mut out = Vec::new();
    for rule in at.iter().copied().filter(|s| is_self_sizing(s)) {
        let fixed: Vec<&Summary> = at
            .iter()
            .copied()
            .filter(|s| {
                is_fixed(s) && s.row.workers == rule.row.workers && s.row.slow == rule.row.slow
            })
            .collect();
        if fixed.len() < 2 {
            continue;
        }
        let Some(best_fixed) = fixed
            .iter()
            .copied()
            .min_by(|a, b| a.wall_median.total_cmp(&b.wall_median))
        else {
            continue;
        };
        let ratio = wall_ratio(rule, best_fixed);
        let held_out = held_out_ratio(rule, &fixed).map(|h| {
            let v = Verdict::of(&h.ratio, tol);
            (h, v)
        });
        out.push(Check {
            rule,
            best_fixed,
            busy: rule
                .row
                .equal_workers()
                .then(|| busy_ratio(rule, best_fixed)),
            verdict: Verdict::of(&ratio, tol),
            ratio,
            held_out,
        });
    }
    out
}

/// The section's table for one group, or `None` where it has nothing to compare.
pub fn section(group: &str, at: &[&Summary]) -> Option<String> {
    let checks = checks(at, TOLERANCE);
    if checks.is_empty() {
        return None;
    }
    let mut md = format!("### {group}\n\n");
    md += "| rule | workers | best fixed chunk | median (ms) rule / fixed | wall ratio (95 % CI) | busy ratio (95 % CI) | rounds | verdict | held-out picks (even / odd rounds) | held-out ratio (95 % CI) | held-out verdict |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
    for c in &checks {
        let (picks, held, held_verdict) = match &c.held_out {
            Some((h, v)) => (
                format!("`{}` / `{}`", h.picks[0].row.label, h.picks[1].row.label),
                with_ci(&h.ratio),
                v.text(TOLERANCE),
            ),
            None => ("–".into(), "–".into(), "–".into()),
        };
        let busy = c.busy.as_ref().map_or("–".into(), with_ci);
        let _ = writeln!(
            md,
            "| `{}` | {} | `{}` | {:.3} / {:.3} | {} | {busy} | {} | {} | {picks} | {held} | {held_verdict} |",
            c.rule.row.label,
            c.rule.row.workers,
            c.best_fixed.row.label,
            c.rule.wall_median * 1e3,
            c.best_fixed.wall_median * 1e3,
            with_ci(&c.ratio),
            c.ratio.n,
            c.verdict.text(TOLERANCE)
        );
    }
    let all: Vec<Verdict> = checks.iter().map(|c| c.verdict).collect();
    md += &tally("\nAgainst the best fixed chunk", &all);
    let held: Vec<Verdict> = checks
        .iter()
        .filter_map(|c| Some(c.held_out.as_ref()?.1))
        .collect();
    if !held.is_empty() {
        md += &tally("Held out", &held);
    }
    md += &excess_line(&checks);
    md += "\n";
    Some(md)
}

/// Where the rules' excess over the best fixed chunk lies, with equal workers: the medians of
/// their wall and busy ratios, a line (empty without such rows). Equal busy and wall excesses
/// put the extra time before the workers' last items end (rendering, hand-outs), not in the
/// wait at the end.
fn excess_line(checks: &[Check]) -> String {
    let (wall, busy): (Vec<f64>, Vec<f64>) = checks
        .iter()
        .filter_map(|c| Some((c.ratio.value, c.busy.as_ref()?.value)))
        .filter(|(w, b)| w.is_finite() && b.is_finite())
        .unzip();
    if wall.is_empty() {
        return String::new();
    }
    format!(
        "Equal workers ({} rows): median wall ratio {:.3}×, median busy ratio {:.3}× (Σ worker busy time, paired by round).\n",
        wall.len(),
        median(&wall),
        median(&busy)
    )
}

/// "{what}: 2 of 3 within 3 %, 1 beyond, 0 undecided.", a line.
fn tally(what: &str, verdicts: &[Verdict]) -> String {
    let count = |v: Verdict| verdicts.iter().filter(|&&x| x == v).count();
    format!(
        "{what}: {} of {} within {:.0} %, {} beyond, {} undecided.\n",
        count(Verdict::Within),
        verdicts.len(),
        TOLERANCE * 100.0,
        count(Verdict::Beyond),
        count(Verdict::Undecided)
    )
}

/// The section's preamble.
pub const PREAMBLE: &str = "Each configuration of a rule that sizes its own chunks (guided and the dynamic-loop-scheduling family) against the fastest `self_scheduling` chunk in scanline order of the same workers and `slow` setting: wall(rule) / wall(best fixed chunk), a ratio of medians over samples paired by round, with its seeded bootstrap 95 % interval. Verdict against 3 %: *within* when the whole interval is at or below 1.03, *beyond* when it is all above, *undecided* otherwise. The best fixed chunk is the fastest of several noisy medians, so it is biased fast: the check leans against the rules. The held-out columns play a hand tuner, who picks a chunk from earlier runs and then uses it: the fixed chunk fastest over the even rounds is judged on the odd rounds and the other way round, so the luck of the pick is not credited to the fixed chunk (paired by round, same interval and verdict). The busy ratio (equal workers only) is the workers' summed busy time under the rule over that under the best fixed chunk, paired by round. A worker of these schedulers is busy from its start to the end of its last item (rendering, and taking its hand-outs), idle only after it: where the busy ratio is as far above 1 as the wall ratio, the extra time went into rendering the rule's items (their size and order change what a pixel costs) or handing them out, not into the wait at the end. With a slow worker it is left out: that worker's busy time holds its spin, which grows with the share of items it takes.";

#[cfg(test)]
mod tests {
    use super::*;
    use crate::studies::experiment::results::RunRow;
    use crate::studies::experiment::summary::summarize;

    fn ratio(value: f64, lo: f64, hi: f64) -> Ratio {
        Ratio {
            value,
            lo,
            hi,
            n: 20,
        }
    }

    /// The check of rule `label` under `slow`.
    fn find<'c, 'a>(c: &'c [Check<'a>], label: &str, slow: Option<&str>) -> &'c Check<'a> {
        c.iter()
            .find(|c| c.rule.row.label == label && c.rule.row.slow.as_deref() == slow)
            .unwrap_or_else(|| panic!("{label} {slow:?} not checked: {c:?}"))
    }

    /// Twelve rounds of `label` at `wall` seconds; round r shifts every configuration by the
    /// same machine drift (up to ±20 %) plus ±0.5 % of its own.
    fn rows(label: &str, kind: &str, order: &str, slow: Option<&str>, wall: f64) -> Vec<RunRow> {
        (0..12u32)
            .map(|rep| {
                let mut r = RunRow::example();
                r.config = format!("{label} {slow:?}");
                r.scheduler = kind.into();
                r.label = label.into();
                r.order = Some(order.into());
                r.slow = slow.map(str::to_string);
                r.workers = 2;
                r.repetition = rep;
                let drift = 1.0 + 0.2 * ((rep * 7 % 5) as f64 - 2.0) / 2.0;
                let own = 1.0 + 0.005 * ((rep as usize + label.len()) % 3) as f64;
                r.wall_s = wall * drift * own;
                r
            })
            .collect()
    }

    #[test]
    fn rules_are_compared_with_the_fastest_fixed_chunk_of_their_own_setting() {
        let mut all = Vec::new();
        for (label, wall) in [("ss 1", 0.110), ("ss 4", 0.100), ("ss 16", 0.104)] {
            all.extend(rows(label, "self_scheduling", "scanline", None, wall));
        }
        // A fast self-scheduling run in another order is not a fixed chunk of the check.
        all.extend(rows(
            "ss 1 scatter",
            "self_scheduling",
            "scatter",
            None,
            0.090,
        ));
        all.extend(rows("af", "adaptive_factoring", "scatter", None, 0.101));
        all.extend(rows("awf", "awf", "scatter", None, 0.110));
        // Under slow=1:3 the fixed chunks are slower: AF there is compared with those.
        for (label, wall) in [("ss 1", 0.20), ("ss 4", 0.19)] {
            all.extend(rows(
                label,
                "self_scheduling",
                "scanline",
                Some("1:3"),
                wall,
            ));
        }
        all.extend(rows(
            "af",
            "adaptive_factoring",
            "scatter",
            Some("1:3"),
            0.19,
        ));
        // With one fixed chunk only, there is nothing to tune: no check.
        all.extend(rows(
            "ss 4",
            "self_scheduling",
            "scanline",
            Some("1:2"),
            0.15,
        ));
        all.extend(rows(
            "af",
            "adaptive_factoring",
            "scatter",
            Some("1:2"),
            0.15,
        ));
        let sums = summarize(&all);
        let at: Vec<&Summary> = sums.iter().collect();
        let c = checks(&at, TOLERANCE);
        let find = |label: &str, slow: Option<&str>| find(&c, label, slow);
        assert_eq!(c.len(), 3, "{c:?}");
        let af = find("af", None);
        assert_eq!(af.best_fixed.row.label, "ss 4");
        // Paired by round, the drift cancels: the interval is narrow around 1.01.
        assert!((af.ratio.value - 1.01).abs() < 0.01, "{:?}", af.ratio);
        assert!(af.ratio.hi - af.ratio.lo < 0.02, "{:?}", af.ratio);
        assert_eq!(af.verdict, Verdict::Within);
        assert_eq!(find("awf", None).verdict, Verdict::Beyond);
        let slow = find("af", Some("1:3"));
        assert_eq!(slow.best_fixed.row.slow.as_deref(), Some("1:3"));
        assert_eq!(slow.verdict, Verdict::Within);
        let md = section("g", &at).unwrap();
        assert!(
            md.contains("2 of 3 within 3 %, 1 beyond, 0 undecided"),
            "{md}"
        );
    }

    /// 20 rounds of `label` (no slow worker, 2 workers), round r taking `wall(r)` seconds.
    fn rounds(label: &str, kind: &str, order: &str, wall: impl Fn(u32) -> f64) -> Vec<RunRow> {
        (0..20u32)
            .map(|rep| {
                let mut r = RunRow::example();
                r.config = label.into();
                r.scheduler = kind.into();
                r.label = label.into();
                r.order = Some(order.into());
                r.slow = None;
                r.workers = 2;
                r.repetition = rep;
                r.wall_s = wall(rep);
                r
            })
            .collect()
    }

    #[test]
    fn the_held_out_check_does_not_credit_the_fixed_chunk_with_the_luck_of_its_pick() {
        // Two fixed chunks, each fast on one parity of rounds only, and a rule at 1.0 s in every
        // round. Over all rounds `x` has the lower median (0.99 s against 0.995 s), so the rule
        // looks 1.0 / 0.99 of the best. Picked on the even rounds, `x` is judged on the odd ones,
        // where it takes 1.08 s; picked on the odd rounds, `y` is judged on the even ones, also
        // 1.08 s: held out, the rule takes exactly 1 / 1.08 of the tuned chunk.
        let par = |even: f64, odd: f64| move |r: u32| if r.is_multiple_of(2) { even } else { odd };
        let mut all = rounds("x", "self_scheduling", "scanline", par(0.90, 1.08));
        all.extend(rounds("y", "self_scheduling", "scanline", par(1.08, 0.91)));
        all.extend(rounds("af", "adaptive_factoring", "scatter", |_| 1.0));
        let sums = summarize(&all);
        let at: Vec<&Summary> = sums.iter().collect();
        let c = checks(&at, TOLERANCE);
        assert_eq!(c.len(), 1, "{c:?}");
        assert_eq!(c[0].best_fixed.row.label, "x");
        assert!(
            (c[0].ratio.value - 1.0 / 0.99).abs() < 1e-9,
            "{:?}",
            c[0].ratio
        );
        let (h, v) = c[0]
            .held_out
            .as_ref()
            .expect("20 rounds allow a held-out check");
        assert_eq!(
            [h.picks[0].row.label.as_str(), h.picks[1].row.label.as_str()],
            ["x", "y"]
        );
        assert!((h.ratio.value - 1.0 / 1.08).abs() < 1e-9, "{:?}", h.ratio);
        assert_eq!(h.ratio.n, 20);
        // Every pair is 1 / 1.08, so the interval is that point and the verdict is firm.
        assert!((h.ratio.hi - 1.0 / 1.08).abs() < 1e-9, "{:?}", h.ratio);
        assert_eq!(*v, Verdict::Within);
        let md = section("g", &at).unwrap();
        assert!(
            md.contains("`x` / `y` | 0.93× (95 % CI 0.93–0.93) | within 3 %"),
            "{md}"
        );
        assert!(
            md.contains("Held out: 1 of 1 within 3 %, 0 beyond, 0 undecided."),
            "{md}"
        );
    }

    /// The busy ratio tells a rule whose items render slower (busy time up as much as the
    /// wall) from one whose workers wait (wall up, busy time not); with a slow worker it is
    /// left out.
    #[test]
    fn the_busy_ratio_tells_rendering_from_waiting() {
        // Two workers; a run's wall is (Σ busy + Σ idle) / 2. Round r drifts every
        // configuration alike.
        let run =
            |label: &str, kind: &str, order: &str, slow: Option<&str>, busy: f64, idle: f64| {
                let mut v = rounds(label, kind, order, |r| {
                    (busy + idle) / 2.0 * (1.0 + 0.01 * (r % 4) as f64)
                });
                for r in &mut v {
                    r.work_s = busy * (1.0 + 0.01 * (r.repetition % 4) as f64);
                    r.idle_s = idle * (1.0 + 0.01 * (r.repetition % 4) as f64);
                    r.slow = slow.map(str::to_string);
                    r.config = format!("{label} {slow:?}");
                }
                v
            };
        let mut all = Vec::new();
        for slow in [None, Some("1:3")] {
            for (label, busy, idle) in [("ss 8", 0.200, 0.002), ("ss 16", 0.201, 0.010)] {
                all.extend(run(label, "self_scheduling", "scanline", slow, busy, idle));
            }
        }
        // AF renders 4 % slower and waits as little; AWF renders as fast and waits 8 ms more.
        for (label, kind, slow, busy) in [
            ("af", "adaptive_factoring", None, 0.208),
            ("awf", "awf", None, 0.200),
            ("af", "adaptive_factoring", Some("1:3"), 0.208),
        ] {
            let idle = if kind == "awf" { 0.010 } else { 0.002 };
            all.extend(run(label, kind, "scatter", slow, busy, idle));
        }
        let sums = summarize(&all);
        let at: Vec<&Summary> = sums.iter().collect();
        let c = checks(&at, TOLERANCE);
        let find = |label: &str, slow: Option<&str>| find(&c, label, slow);
        // Both walls are 0.210 / 0.202 of the best fixed chunk's; only AF's busy time grew.
        for (label, busy) in [("af", 1.04), ("awf", 1.0)] {
            let c = find(label, None);
            assert_eq!(c.best_fixed.row.label, "ss 8");
            let b = c.busy.as_ref().expect("equal workers");
            assert!((b.value - busy).abs() < 1e-9, "{label}: {b:?}");
            let w = &c.ratio;
            assert!((w.value - 0.210 / 0.202).abs() < 1e-9, "{label}: {w:?}");
        }
        assert!(find("af", Some("1:3")).busy.is_none());
        let md = section("g", &at).unwrap();
        assert!(md.contains("| 1.04× (95 % CI 1.04–1.04) | 20 |"), "{md}");
        assert!(md.contains("| – | 20 |"), "{md}");
        assert!(
            md.contains(
                "Equal workers (2 rows): median wall ratio 1.040×, median busy ratio 1.020×"
            ),
            "{md}"
        );
    }

    #[test]
    fn too_few_rounds_give_no_held_out_check() {
        let few = |label: &str, kind: &str, order: &str, wall: f64| {
            let mut v = rounds(label, kind, order, |_| wall);
            v.truncate(MIN_PAIRS - 1);
            v
        };
        let mut all = few("x", "self_scheduling", "scanline", 1.0);
        all.extend(few("y", "self_scheduling", "scanline", 1.1));
        all.extend(few("af", "adaptive_factoring", "scatter", 1.0));
        let sums = summarize(&all);
        let at: Vec<&Summary> = sums.iter().collect();
        let c = checks(&at, TOLERANCE);
        assert_eq!(c.len(), 1);
        assert!(c[0].held_out.is_none());
        assert!(!section("g", &at).unwrap().contains("Held out:"));
    }

    #[test]
    fn verdicts_need_the_whole_interval_on_one_side() {
        assert_eq!(Verdict::of(&ratio(1.01, 0.99, 1.03), 0.03), Verdict::Within);
        assert_eq!(
            Verdict::of(&ratio(1.02, 0.99, 1.031), 0.03),
            Verdict::Undecided
        );
        assert_eq!(
            Verdict::of(&ratio(1.05, 1.031, 1.08), 0.03),
            Verdict::Beyond
        );
        assert_eq!(
            Verdict::of(&ratio(1.05, 1.03, 1.08), 0.03),
            Verdict::Undecided
        );
    }
}
