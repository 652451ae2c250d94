//! `summary.csv`: per configuration, the median, mean, σ, min and max wall time with a seeded
//! bootstrap interval of the median, the speedup over the serial baseline with an interval from
//! the paired samples, outliers, and the median overhead parts. Always recomputed from
//! `runs.csv`.

use super::results::RunRow;
use crate::sched::param_columns;
use std::path::Path;

/// Statistics of one configuration's repetitions.
#[derive(Clone, Debug)]
pub struct Summary {
    /// The first row of the configuration (its config columns).
    pub row: RunRow,
    /// Repetitions summarised.
    pub n: usize,
    /// Median wall time, seconds.
    pub wall_median: f64,
    /// Shortest wall time, seconds.
    pub wall_min: f64,
    /// Longest wall time, seconds.
    pub wall_max: f64,
    /// Mean wall time, seconds.
    pub wall_mean: f64,
    /// Student-t 95 % interval of the mean (equal to the mean when n = 1).
    pub wall_ci95: (f64, f64),
    /// Sample standard deviation of the wall time, seconds.
    pub wall_sd: f64,
    /// Seeded bootstrap 95 % interval of the median wall time.
    pub wall_median_ci: (f64, f64),
    /// Half that interval's width over the median: the median's relative precision.
    pub ci_half_rel: f64,
    /// Samples with a modified z-score above 3.5 (median/MAD rule).
    pub outliers: usize,
    /// Speedup as median(serial) / median(this) with its bootstrap interval, over samples
    /// paired by repetition (measured in the same round) where they share [`MIN_PAIRS`]
    /// rounds, else unpaired ([`ratio_by_round`]); `None` for the baseline itself or without
    /// samples.
    pub speedup: Option<Ratio>,
    /// Renders per timed sample (the largest of the configuration's rows).
    pub inner: u32,
    /// The highest 1-minute load average seen before or after a sample (`None`: not recorded).
    pub load_max: Option<f64>,
    /// (repetition, wall time) of every sample, in repetition order: what pairs are made of.
    pub walls: Vec<(u32, f64)>,
    /// (repetition, Σ worker busy time) of every sample, in repetition order, paired like
    /// `walls`: the row's `work_s`, which is the last render's where a sample repeats its
    /// render (`inner`), while its wall time is their mean.
    pub busy: Vec<(u32, f64)>,
    /// Median speedup (serial median / wall).
    pub speedup_median: f64,
    /// Lowest speedup.
    pub speedup_min: f64,
    /// Highest speedup.
    pub speedup_max: f64,
    /// Median efficiency (speedup / workers).
    pub efficiency_median: f64,
    /// Median overhead (workers · wall − serial), seconds.
    pub overhead_s_median: f64,
    /// Median Σ worker busy time, seconds.
    pub work_s_median: f64,
    /// Median master time spent handing out and collecting, seconds.
    pub dispatch_s_median: f64,
    /// Median Σ worker idle time, seconds.
    pub idle_s_median: f64,
    /// Median idle time caused by uneven work, seconds.
    pub imbalance_s_median: f64,
    /// Median max busy / mean busy (1 = balanced).
    pub imbalance_median: f64,
    /// Every repetition's image was identical to the serial baseline's.
    pub identical: bool,
    /// Configurations with a GPU source: every repetition's image agreed with the serial one
    /// within 3σ (`None` elsewhere).
    pub agrees: Option<bool>,
    /// Who rendered what, per kind in `SourceKind::ALL` order (`None`: the kind did not
    /// render).
    pub shares: Vec<Option<ShareSummary>>,
    /// Where the workers' time went: `workers × wall_median` split into its parts.
    pub lanes: Lanes,
}

/// `workers × wall_median` (the worker lanes' seconds) split into busy time, idle time caused
/// by uneven work, idle time the master's dispatch explains and the rest: the overhead chart's
/// bar. Each part is the median over the repetitions of its share of that run's lanes
/// ([`Lanes::shares_of`]), the shares scaled to sum to 1, times
/// `workers × wall_median`: the parts add up to the lanes by construction, on the median that
/// every other reading of the time uses. The dispatch part is the master's dispatch time
/// counted inside the workers' idle time it can explain (waiting for a hand-out), at most
/// their idle time after imbalance: one rule whether the master has its own thread or its
/// passes are run by the workers.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Lanes {
    /// Σ worker busy seconds.
    pub busy_s: f64,
    /// Idle seconds caused by uneven work (Σ max busy − busy).
    pub imbalance_s: f64,
    /// Idle seconds the master's dispatch explains.
    pub dispatch_s: f64,
    /// The rest of the idle seconds.
    pub other_idle_s: f64,
}

impl Lanes {
    /// The parts in the order they are stacked: busy, imbalance, other idle, dispatch.
    pub fn parts(&self) -> [f64; 4] {
        [
            self.busy_s,
            self.imbalance_s,
            self.other_idle_s,
            self.dispatch_s,
        ]
    }

    /// Their sum: `workers × wall_median`.
    pub fn total(&self) -> f64 {
        self.parts().iter().sum()
    }

    /// One run's shares of its lanes (busy, imbalance, other idle, dispatch); `None` where its
    /// lanes hold no time. Its lanes are `workers × wall_s`, or the busy and idle time the
    /// workers recorded where that is more (a sample that repeats its render has the mean
    /// wall of its renders but the last one's busy time); lane time the workers did not
    /// record (before their start, after their end) is idle: other.
    fn shares_of(r: &RunRow) -> Option<[f64; 4]> {
        let busy = r.work_s.max(0.0);
        let idle = r.idle_s.max(0.0);
        let total = (r.workers as f64 * r.wall_s).max(busy + idle);
        if total <= 0.0 || !total.is_finite() {
            return None;
        }
        let imb = r.imbalance_s.clamp(0.0, idle);
        let disp = r.dispatch_s.clamp(0.0, idle - imb);
        let other = total - busy - imb - disp;
        Some([busy, imb, other, disp].map(|x| x / total))
    }

    /// The lanes of a configuration of `rows` with median wall `wall` on `workers` workers.
    fn of(rows: &[&RunRow], workers: usize, wall: f64) -> Self {
        let shares: Vec<[f64; 4]> = rows.iter().filter_map(|r| Self::shares_of(r)).collect();
        if shares.is_empty() {
            return Self::default();
        }
        let m: [f64; 4] =
            std::array::from_fn(|k| median(&shares.iter().map(|s| s[k]).collect::<Vec<f64>>()));
        let sum: f64 = m.iter().sum();
        let lanes = workers as f64 * wall;
        let [busy_s, imbalance_s, other_idle_s, dispatch_s] = m.map(|x| x / sum * lanes);
        Self {
            busy_s,
            imbalance_s,
            dispatch_s,
            other_idle_s,
        }
    }
}

impl RunRow {
    /// Fill the columns a run's statistics give (wall, busy, idle, the master's dispatch,
    /// imbalance and who rendered what): the ones [`Lanes`] splits a configuration's lanes
    /// from, written by a measured run and by a simulated one
    /// (`studies::simulate::hetero::Outcome::stats`) alike.
    pub fn set_stats(&mut self, s: &crate::core::metrics::RunStats) {
        self.wall_s = s.wall_s;
        self.work_s = s.busy_s();
        self.dispatch_s = s.dispatch_s();
        self.idle_s = s.idle_s();
        self.imbalance = s.imbalance();
        let max_busy = s.workers.iter().map(|w| w.busy_s).fold(0.0, f64::max);
        self.imbalance_s = s.workers.iter().map(|w| max_busy - w.busy_s).sum();
        self.items = s.items;
        self.issued = s.issued;
        self.reissued = s.reissued;
        self.duplicates = s.duplicates;
        self.bytes = s.bytes;
        self.rays = s.rays;
        self.nonfinite = s.nonfinite;
        self.features_used = s.features_used.join("+");
        self.features_left_out = s.features_left_out.join("+");
        let skip = crate::sched::source_params().len();
        let shares = crate::sched::Share::cells(&crate::sched::Share::of(s));
        for (cell, v) in self.sourcing[skip..].iter_mut().zip(shares) {
            *cell = v;
        }
    }
}

/// What one kind of source did over a configuration's repetitions (medians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShareSummary {
    /// Median fraction of the image's pixels the kind rendered.
    pub pixel_share: f64,
    /// Median items it rendered.
    pub items: f64,
    /// Median busy seconds summed over its sources.
    pub busy_s: f64,
}

impl Summary {
    /// The speedup every reading states: median(serial) / median(this) over samples paired
    /// by round ([`Summary::speedup`]), exactly 1 for the serial baseline itself, NaN where
    /// the group has no baseline.
    pub fn speedup_ci(&self) -> Ratio {
        let one = |v: f64| Ratio {
            value: v,
            lo: v,
            hi: v,
            n: self.n,
        };
        match self.speedup {
            Some(r) => r,
            None if self.row.is_serial() => one(1.0),
            None => one(f64::NAN),
        }
    }

    /// Efficiency = [`Summary::speedup_ci`] / workers: the same paired samples, the same
    /// interval, so a row's speedup and efficiency never disagree.
    pub fn efficiency_ci(&self) -> Ratio {
        let r = self.speedup_ci();
        let w = self.row.workers.max(1) as f64;
        Ratio {
            value: r.value / w,
            lo: r.lo / w,
            hi: r.hi / w,
            n: r.n,
        }
    }

    /// Did every repetition give the serial image: bit for bit, or (a GPU source) within 3σ?
    pub fn image_ok(&self) -> bool {
        self.identical || self.agrees == Some(true)
    }
}

/// The per-kind medians of `rows`' shares ([`RunRow::shares`]).
fn share_summaries(rows: &[&RunRow]) -> Vec<Option<ShareSummary>> {
    let per_row: Vec<Vec<Option<crate::sched::Share>>> = rows.iter().map(|r| r.shares()).collect();
    (0..crate::sched::SourceKind::ALL.len())
        .map(|k| {
            let got: Vec<(crate::sched::Share, u64)> = per_row
                .iter()
                .filter_map(|sh| {
                    let total: u64 = sh.iter().flatten().map(|s| s.pixels).sum();
                    Some((sh.get(k).copied().flatten()?, total))
                })
                .collect();
            if got.is_empty() {
                return None;
            }
            let m = |f: &dyn Fn(&(crate::sched::Share, u64)) -> f64| {
                median(&got.iter().map(f).collect::<Vec<f64>>())
            };
            Some(ShareSummary {
                pixel_share: m(&|(s, t)| s.pixels as f64 / (*t).max(1) as f64),
                items: m(&|(s, _)| s.items as f64),
                busy_s: m(&|(s, _)| s.busy_s),
            })
        })
        .collect()
}

impl Summary {
    /// Scene + render settings + tracer: what a plot or a report table is about.
    pub fn group(&self) -> String {
        group_of(&self.row)
    }
}

/// A configuration's label without the parameters at their kind's default (`master chunk=16
/// B=2 requeue=never wait=block returns=item passes=thread` → `master chunk=16`): what tables
/// and legends show. The chunk is always kept; the full label stays in runs.csv, the
/// configuration's identity in its `config` id. A label of no known kind stays as it is.
pub fn short_label(r: &RunRow) -> String {
    let Ok(kind) = crate::sched::SchedulerKind::from_id(&r.scheduler) else {
        return r.label.clone();
    };
    let policy = crate::sched::Policy::defaults(kind);
    let defaults: Vec<String> = policy
        .info()
        .iter()
        .filter_map(|p| Some(format!("{}={}", p.label?, policy.params()?.get(p.name)?)))
        .collect();
    r.label
        .split(' ')
        .filter(|t| !defaults.iter().any(|d| d == t))
        .collect::<Vec<_>>()
        .join(" ")
}

/// A row's group label: scene, size, spp, the generator count if overridden, and tracer.
pub fn group_of(r: &RunRow) -> String {
    let mut g = format!("{} {}×{} {} spp", r.scene, r.width, r.height, r.spp);
    if let Some(n) = r.generator_count {
        g += &format!(" {n} prims");
    }
    g + &format!(" {}", r.tracer)
}

pub use super::stats::median;
use super::stats::{mad_outliers, median_ci, paired_ratio, std_dev, unpaired_ratio, Ratio};

/// The bootstrap seed of a configuration: fixed by its id, so a summary is reproducible.
pub fn seed_of(config: &str) -> u64 {
    crate::util::hash::fnv(config.as_bytes())
}

/// Pairs fewer than this fall back to an unpaired ratio over every sample. With n pairs, one
/// wild pair moves the median of a resample (alone, or by half in an even one) when it is
/// drawn ⌈n/2⌉ times or more: 5.8 % of resamples at n = 5, beyond the interval's 2.5 % tail,
/// so one preempted sample made a configuration twice as slow as the best look tied with it
/// (a `quick` run on the 2-core Xeon beside another process: 5 pairs, ratio 1.97, interval
/// from 0.94); 1.0–1.1 % at n = 7–8, 0.16 % at n = 10.
pub const MIN_PAIRS: usize = 10;

/// median(num) / median(den) with its 95 % interval: over samples paired by repetition (the
/// same round, so drift shared by a round cancels) where at least [`MIN_PAIRS`] pairs exist,
/// else over every sample of each side, unpaired. `None` where a side has no sample.
pub fn ratio_by_round(num: &[(u32, f64)], den: &[(u32, f64)], seed: u64) -> Option<Ratio> {
    if num.is_empty() || den.is_empty() {
        return None;
    }
    let (x, y) = pair_by_rep(num, den);
    Some(if x.len() >= MIN_PAIRS {
        paired_ratio(&x, &y, seed)
    } else {
        let all = |v: &[(u32, f64)]| v.iter().map(|w| w.1).collect::<Vec<f64>>();
        unpaired_ratio(&all(num), &all(den), seed)
    })
}

/// Pair two (repetition, value) lists on their common repetitions: (a values, b values).
pub fn pair_by_rep(a: &[(u32, f64)], b: &[(u32, f64)]) -> (Vec<f64>, Vec<f64>) {
    let bm: std::collections::HashMap<u32, f64> = b.iter().copied().collect();
    a.iter()
        .filter_map(|(r, x)| bm.get(r).map(|y| (*x, *y)))
        .unzip()
}

/// Two-sided 97.5 % Student-t quantile for `df` degrees of freedom.
fn t975(df: usize) -> f64 {
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    if df == 0 {
        f64::NAN
    } else {
        T.get(df - 1).copied().unwrap_or(1.96)
    }
}

/// Student-t 95 % confidence interval `(lo, hi)` of the mean of `v`; `(mean, mean)` for fewer
/// than two values.
pub fn ci95(v: &[f64]) -> (f64, f64) {
    let n = v.len();
    let mean = v.iter().sum::<f64>() / n as f64;
    if n < 2 {
        return (mean, mean);
    }
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    let h = t975(n - 1) * (var / n as f64).sqrt();
    (mean - h, mean + h)
}

/// One summary per configuration, in the order configurations first appear.
pub fn summarize(rows: &[RunRow]) -> Vec<Summary> {
    let mut order: Vec<&str> = Vec::new();
    let mut groups: std::collections::HashMap<&str, Vec<&RunRow>> = Default::default();
    for r in rows {
        groups
            .entry(&r.config)
            .or_insert_with(|| {
                order.push(&r.config);
                vec![]
            })
            .push(r);
    }
    let by_rep = |rs: &[&RunRow], f: fn(&RunRow) -> f64| {
        let mut w: Vec<(u32, f64)> = rs.iter().map(|r| (r.repetition, f(r))).collect();
        w.sort_by_key(|x| x.0);
        w
    };
    let walls_of = |rs: &[&RunRow]| by_rep(rs, |r| r.wall_s);
    // The serial baseline of each group (scene, settings, tracer), by repetition.
    let serial: std::collections::HashMap<String, Vec<(u32, f64)>> = order
        .iter()
        .filter(|c| groups[*c][0].is_serial())
        .map(|c| (group_of(groups[c][0]), walls_of(&groups[c])))
        .collect();
    order
        .into_iter()
        .map(|c| {
            let rs = &groups[c];
            let col = |f: fn(&RunRow) -> f64| rs.iter().map(|r| f(r)).collect::<Vec<f64>>();
            let wall = col(|r| r.wall_s);
            let speed = col(|r| r.speedup);
            let walls = walls_of(rs);
            let seed = seed_of(c);
            let wall_median_ci = median_ci(&wall, seed);
            let speedup = match serial.get(&group_of(rs[0])) {
                Some(base) if !rs[0].is_serial() => ratio_by_round(base, &walls, seed),
                _ => None,
            };
            let loads = rs
                .iter()
                .flat_map(|r| [r.load_before, r.load_after])
                .flatten();
            Summary {
                wall_sd: std_dev(&wall),
                ci_half_rel: 0.5 * (wall_median_ci.1 - wall_median_ci.0) / median(&wall),
                wall_median_ci,
                outliers: mad_outliers(&wall),
                speedup,
                inner: rs.iter().map(|r| r.inner).max().unwrap_or(1),
                load_max: loads.reduce(f64::max),
                walls,
                busy: by_rep(rs, |r| r.work_s),
                row: RunRow {
                    label: short_label(rs[0]),
                    ..rs[0].clone()
                },
                n: rs.len(),
                wall_median: median(&wall),
                wall_min: wall.iter().cloned().fold(f64::INFINITY, f64::min),
                wall_max: wall.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
                wall_mean: wall.iter().sum::<f64>() / wall.len() as f64,
                wall_ci95: ci95(&wall),
                speedup_median: median(&speed),
                speedup_min: speed.iter().cloned().fold(f64::INFINITY, f64::min),
                speedup_max: speed.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
                efficiency_median: median(&col(|r| r.efficiency)),
                overhead_s_median: median(&col(|r| r.overhead_s)),
                work_s_median: median(&col(|r| r.work_s)),
                dispatch_s_median: median(&col(|r| r.dispatch_s)),
                idle_s_median: median(&col(|r| r.idle_s)),
                imbalance_s_median: median(&col(|r| r.imbalance_s)),
                imbalance_median: median(&col(|r| r.imbalance)),
                identical: rs.iter().all(|r| r.identical),
                agrees: rs
                    .iter()
                    .map(|r| r.agrees)
                    .reduce(|a, b| a.zip(b).map(|(a, b)| a && b))
                    .flatten(),
                shares: share_summaries(rs),
                lanes: Lanes::of(rs, rs[0].workers, median(&wall)),
            }
        })
        .collect()
}

/// A ratio as shortest round-trip text (the report formats the same f64); empty where it is
/// not a number (no serial baseline).
fn ratio4(x: f64) -> String {
    if x.is_finite() {
        format!("{x}")
    } else {
        String::new()
    }
}

/// The configuration columns of `summary.csv`, before the parameter columns.
const HEAD_COLUMNS: [&str; 14] = [
    "experiment",
    "config",
    "scene",
    "width",
    "height",
    "spp",
    "max_depth",
    "generator_count",
    "tracer",
    "scheduler",
    "label",
    "chunk",
    "chunk_px",
    "order",
];

/// The statistics columns of `summary.csv`, after the parameter columns.
const TAIL_COLUMNS: [&str; 44] = [
    "workers",
    "n",
    "wall_median_s",
    "wall_min_s",
    "wall_max_s",
    "wall_mean_s",
    "wall_ci95_lo_s",
    "wall_ci95_hi_s",
    "speedup_median",
    "speedup_min",
    "speedup_max",
    "efficiency_median",
    "overhead_s_median",
    "work_s_median",
    "dispatch_s_median",
    "idle_s_median",
    "imbalance_s_median",
    "imbalance_median",
    "identical",
    "sources",
    "ranks",
    "transport",
    "wall_sd_s",
    "wall_median_ci_lo_s",
    "wall_median_ci_hi_s",
    "ci_half_rel",
    "outliers",
    "speedup",
    "speedup_ci_lo",
    "speedup_ci_hi",
    "inner",
    "load_max",
    "agrees",
    "efficiency",
    "efficiency_ci_lo",
    "efficiency_ci_hi",
    "lanes_busy_s",
    "lanes_imbalance_s",
    "lanes_other_idle_s",
    "lanes_dispatch_s",
    "predicted_wall_s",
    "predicted_handout_s",
    "predicted_refill_s",
    "predicted_imbalance_s",
];

/// Write `summary.csv` to `path`: one row per summary, config and parameter columns first,
/// then the statistics (seconds with 6 decimals).
pub fn write_summary(path: &Path, sums: &[Summary]) -> Result<(), csv::Error> {
    let mut w = csv::Writer::from_path(path)?;
    let kinds = crate::sched::SourceKind::ALL;
    let share_names: Vec<String> = kinds
        .iter()
        .flat_map(|k| {
            ["pixel_share", "items_median", "busy_s_median"].map(|p| format!("{}_{p}", k.id()))
        })
        .collect();
    let params = param_columns().iter().map(|p| p.name);
    w.write_record(
        HEAD_COLUMNS
            .into_iter()
            .chain(params)
            .chain(TAIL_COLUMNS)
            .chain(share_names.iter().map(String::as_str)),
    )?;
    for s in sums {
        let r = &s.row;
        let shares = s.shares.iter().flat_map(|sh| match sh {
            Some(x) => [
                format!("{:.4}", x.pixel_share),
                format!("{}", x.items),
                shortest(x.busy_s),
            ],
            None => Default::default(),
        });
        let params = r.params.iter().map(opt_text);
        w.write_record(
            head_cells(r)
                .into_iter()
                .chain(params)
                .chain(tail_cells(s))
                .chain(shares),
        )?;
    }
    w.flush()?;
    Ok(())
}

/// An optional text cell: empty when absent.
fn opt_text(v: &Option<String>) -> String {
    v.clone().unwrap_or_default()
}

/// Shortest round-trip text: the report and charts, which format the in-memory value, then
/// agree digit for digit with a figure read back from `summary.csv` (no double rounding).
fn shortest(x: f64) -> String {
    format!("{x}")
}

/// The configuration cells of one summary row, in [`HEAD_COLUMNS`] order.
fn head_cells(r: &RunRow) -> [String; 14] {
    let o = opt_text;
    [
        r.experiment.clone(),
        r.config.clone(),
        r.scene.clone(),
        r.width.to_string(),
        r.height.to_string(),
        r.spp.to_string(),
        r.max_depth.to_string(),
        r.generator_count.map(|g| g.to_string()).unwrap_or_default(),
        r.tracer.clone(),
        r.scheduler.clone(),
        r.label.clone(),
        o(&r.chunk),
        r.chunk_px.map(|c| c.to_string()).unwrap_or_default(),
        o(&r.order),
    ]
}

/// The statistics cells of one summary row, in [`TAIL_COLUMNS`] order.
fn tail_cells(s: &Summary) -> [String; 44] {
    let r = &s.row;
    let (f, o) = (shortest, opt_text);
    let n = |v: Option<usize>| v.map(|x| x.to_string()).unwrap_or_default();
    [
        r.workers.to_string(),
        s.n.to_string(),
        f(s.wall_median),
        f(s.wall_min),
        f(s.wall_max),
        f(s.wall_mean),
        f(s.wall_ci95.0),
        f(s.wall_ci95.1),
        f(s.speedup_median),
        f(s.speedup_min),
        f(s.speedup_max),
        f(s.efficiency_median),
        f(s.overhead_s_median),
        f(s.work_s_median),
        f(s.dispatch_s_median),
        f(s.idle_s_median),
        f(s.imbalance_s_median),
        f(s.imbalance_median),
        s.identical.to_string(),
        r.sources.clone(),
        n(r.ranks),
        o(&r.transport),
        f(s.wall_sd),
        f(s.wall_median_ci.0),
        f(s.wall_median_ci.1),
        format!("{:.5}", s.ci_half_rel),
        s.outliers.to_string(),
        ratio4(s.speedup_ci().value),
        ratio4(s.speedup_ci().lo),
        ratio4(s.speedup_ci().hi),
        s.inner.to_string(),
        s.load_max.map(|l| format!("{l:.2}")).unwrap_or_default(),
        s.agrees.map(|a| a.to_string()).unwrap_or_default(),
        ratio4(s.efficiency_ci().value),
        ratio4(s.efficiency_ci().lo),
        ratio4(s.efficiency_ci().hi),
        f(s.lanes.busy_s),
        f(s.lanes.imbalance_s),
        f(s.lanes.other_idle_s),
        f(s.lanes.dispatch_s),
        r.predicted_wall_s.map(f).unwrap_or_default(),
        r.predicted_handout_s.map(f).unwrap_or_default(),
        r.predicted_refill_s.map(f).unwrap_or_default(),
        r.predicted_imbalance_s.map(f).unwrap_or_default(),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_and_interval() {
        let (lo, hi) = ci95(&[1.0, 2.0, 3.0]);
        // mean 2, sd 1, t(2) = 4.303: 2 ± 4.303/√3
        assert!((lo - (2.0 - 4.303 / 3f64.sqrt())).abs() < 1e-9);
        assert!((hi - (2.0 + 4.303 / 3f64.sqrt())).abs() < 1e-9);
        assert_eq!(ci95(&[5.0]), (5.0, 5.0));
    }

    /// The `quick` run that showed the need for [`MIN_PAIRS`]: the best configuration's 30
    /// samples (round 1 preempted, twice as long), one twice as slow stopped after 5 rounds.
    /// Over its 5 pairs the interval reaches down to 1 (it would look tied); unpaired over
    /// every sample it does not.
    #[test]
    fn few_pairs_fall_back_to_every_sample() {
        let best: Vec<(u32, f64)> = (0..30)
            .map(|r| {
                (
                    r,
                    if r == 1 {
                        46.6
                    } else {
                        21.6 + 0.05 * (r % 7) as f64
                    },
                )
            })
            .collect();
        let slow: Vec<(u32, f64)> = [42.96, 44.19, 43.09, 43.21, 43.81]
            .into_iter()
            .zip(0..)
            .map(|(w, r)| (r, w))
            .collect();
        let (x, y) = pair_by_rep(&slow, &best);
        assert!(
            paired_ratio(&x, &y, 1).lo <= 1.0,
            "the fragile interval, shown"
        );
        let r = ratio_by_round(&slow, &best, 1).unwrap();
        assert!(r.lo > 1.8 && r.value > 1.9, "{r:?}");
        // With enough rounds the pairs are used: drift shared by a round cancels.
        let drift = |r: u32| 1.0 + 0.3 * (r % 4) as f64;
        let a: Vec<(u32, f64)> = (0..12).map(|r| (r, 10.0 * drift(r))).collect();
        let b: Vec<(u32, f64)> = (0..12).map(|r| (r, 11.0 * drift(r))).collect();
        let r = ratio_by_round(&b, &a, 1).unwrap();
        assert!(
            (r.lo - 1.1).abs() < 1e-9 && (r.hi - 1.1).abs() < 1e-9,
            "{r:?}"
        );
        assert_eq!(r.n, 12);
        assert!(ratio_by_round(&b, &[], 1).is_none());
    }
}
