//! A deterministic discrete-event simulation of the master handing out to CPU threads and one
//! GPU, at rates measured on a machine: the check that the balancer (`sched::rule::Balance`)
//! reaches the summed throughput without hand-picked grains, runnable in the normal test
//! suite (no SimGrid, no GPU, no clock).
//!
//! The master here is a second executor of the rule the thread master (`sched::exec::master`)
//! plays: at every event it tells the rule what each source has done and holds and what is
//! queued, and hands out what the rule grants, from the FIFO queue in order. It costs no
//! time itself. A thread renders its items one by one and returns each; the GPU renders each
//! hand-out as one dispatch ([`GpuModel::dispatch_s`]) and returns it whole. Busy time, as
//! in the master, is the time a source holds work.
//!
//! Each run also reports its lanes in the terms of a measured run ([`Outcome::stats`], a
//! [`RunStats`]): per source (the threads and the GPU lane) its busy and idle seconds, items
//! and pixels, and the master's dispatch seconds, so the summary's overhead breakdown
//! (`Lanes`: busy, imbalance, other idle, dispatch) and its chart read a simulated run as they
//! read a measured one. Idle time is summed from the spans a source holds nothing, not taken
//! as wall less busy, so busy + idle = wall per lane is a check of the event loop. The master
//! costs no time here, so its dispatch part is 0.

use crate::core::metrics::{MasterStats, RunStats, SourceKind, WorkerStats};
use crate::sched::rule::{Balance, Facts, MasterQueue, Shape, Take, GPU_DISPATCH};
use crate::sched::{decompose, Chunk, Order, Requeue};
use std::collections::VecDeque;
use std::time::Duration;

/// A GPU's dispatch time for `n` pixels at `spp` samples: `o + b·n + a·spp·max(n, F)`, the
/// fixed cost, a per-pixel cost (the result's way back) and the paths, which run no faster
/// than a full device's worth (`F` pixels) however few pixels a dispatch holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuModel {
    /// `o`, seconds per dispatch.
    pub overhead_s: f64,
    /// `b`, seconds per pixel.
    pub per_px_s: f64,
    /// `a`, seconds per path (pixel-sample) on a full device.
    pub per_path_s: f64,
    /// `F`, pixels that fill the device.
    pub fill_px: f64,
}

impl GpuModel {
    /// The H200's, fitted to `results/published/gpu/README.md` (M-150): 105 µs per empty
    /// dispatch; Cornell 512² at 1 spp, 38 M px/s at the whole image (262 144 px) and
    /// 2.5 M px/s at 1 024 px per dispatch; Cornell 1024² at 512 spp, 320 M paths/s (the
    /// middle of 300–341 M). Three equations in `a`, `b`, `F` (the 512-spp rate taken where
    /// `o` is negligible): a = 3.08 ns, b = 22.8 ns, F = 91 k px. The fit gives 21.5 M px/s
    /// at 16 384 px (measured 20 M) and 34.8 M at 65 536 (measured 31 M).
    pub fn h200() -> Self {
        let o = 105e-6;
        let whole = 262_144.0;
        // b + a: the whole image at 1 spp, less the fixed cost.
        let one_spp = (whole / 38e6 - o) / whole;
        // b + 512·a: one pixel's 512 paths at 320 M paths/s.
        let at_512 = 512.0 / 320e6;
        let a = (at_512 - one_spp) / 511.0;
        let b = one_spp - a;
        let f = (1024.0 / 2.5e6 - o - 1024.0 * b) / a;
        Self {
            overhead_s: o,
            per_px_s: b,
            per_path_s: a,
            fill_px: f,
        }
    }

    /// Seconds one dispatch of `px` pixels of `cost_px` cost-weighted pixels takes.
    pub fn dispatch_s(&self, px: u64, cost_px: f64, spp: u32) -> f64 {
        self.overhead_s
            + self.per_px_s * px as f64
            + self.per_path_s * f64::from(spp) * cost_px.max(self.fill_px)
    }

    /// Pixels per second at `spp` on dispatches large enough that `o` and the fill vanish.
    pub fn peak_px_s(&self, spp: u32) -> f64 {
        1.0 / (self.per_px_s + self.per_path_s * f64::from(spp))
    }
}

/// What is simulated: an image cut into square tiles, threads at their own rates, a GPU.
#[derive(Clone, Debug, PartialEq)]
pub struct Platform {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Paths per second of each CPU thread (a path: one pixel-sample).
    pub thread_paths_s: Vec<f64>,
    /// The GPU, if any.
    pub gpu: Option<GpuModel>,
    /// Cost of a pixel in the image's top sixteenth against the rest's (the Cornell box's
    /// ceiling rows are cheaper); the costs are scaled so a pixel costs 1 on average.
    pub top_cost: f64,
}

impl Platform {
    /// The H200 pair of `results/published/gpu/`: Cornell 1024² at 512 spp, 16 threads at
    /// 11 M paths/s together (measured 9.0–12.6 M), threads 8–15 at half the speed of
    /// threads 0–7 (they took twice as long per tile, sharing the 16 vCPUs), the top
    /// sixteenth's tiles at half the cost (its tiles took 0.27–0.67 s against ~0.8 s), and
    /// the GPU of [`GpuModel::h200`].
    pub fn h200_cornell() -> Self {
        // 8 threads at 2r and 8 at r: 24r = 11 M paths/s.
        let slow = 11e6 / 24.0;
        Self {
            width: 1024,
            height: 1024,
            spp: 512,
            thread_paths_s: (0..16)
                .map(|k| if k < 8 { 2.0 * slow } else { slow })
                .collect(),
            gpu: Some(GpuModel::h200()),
            top_cost: 0.5,
        }
    }

    /// Pixels per second of all sources together, each at its best: the threads' rates and
    /// the GPU's peak (no dispatch cost, no fill).
    pub fn summed_px_s(&self) -> f64 {
        let spp = f64::from(self.spp);
        let threads: f64 = self.thread_paths_s.iter().map(|r| r / spp).sum();
        threads + self.gpu.map_or(0.0, |g| g.peak_px_s(self.spp))
    }
}

/// How the simulated master hands out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Handing {
    /// The balancer with the master's B for the threads and nothing else given (the default
    /// run of `--sources threads,gpu`).
    Balanced {
        /// The master's B.
        buffer: usize,
    },
    /// Fixed settings, no balancer: the threads' B items each; the GPU `gpu_buffer`
    /// outstanding hand-outs of `gpu_grain` pixels, or with grain 0, `gpu_buffer` items
    /// outstanding, the missing ones sent together (the master before the balancer).
    Fixed {
        /// The threads' B.
        buffer: usize,
        /// The GPU's pixels per hand-out (0: item by item).
        gpu_grain: u64,
        /// The GPU's B.
        gpu_buffer: usize,
    },
}

/// What one simulated run gave.
#[derive(Clone, PartialEq)]
pub struct Outcome {
    /// When the last result came back.
    pub wall_s: f64,
    /// The wall at the summed rate ([`Platform::summed_px_s`]).
    pub ideal_s: f64,
    /// Pixels the GPU rendered.
    pub gpu_px: u64,
    /// Pixels the threads rendered.
    pub thread_px: u64,
    /// GPU dispatches.
    pub dispatches: u64,
    /// Longest a thread waited at the end (the wall less its last result).
    pub thread_idle_end_s: f64,
    /// Items rendered, each counted once per rendering.
    pub rendered: Vec<u32>,
    /// The run's lanes as a measured run records them: one [`WorkerStats`] per source (the
    /// threads in order, then the GPU), busy and idle seconds each, and the master's
    /// [`MasterStats`] (dispatch 0: the simulated master costs no time).
    pub stats: RunStats,
}

impl std::fmt::Debug for Outcome {
    /// Everything but the list of items rendered.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:.4} of the sum: wall {:.4} s, ideal {:.4} s, gpu {} px in {} dispatches, threads {} px, \
             longest thread wait at the end {:.4} s",
            self.of_sum(),
            self.wall_s,
            self.ideal_s,
            self.gpu_px,
            self.dispatches,
            self.thread_px,
            self.thread_idle_end_s
        )
    }
}

impl Outcome {
    /// The run's throughput against the summed throughput.
    pub fn of_sum(&self) -> f64 {
        self.ideal_s / self.wall_s
    }
}

struct Src {
    gpu: Option<GpuModel>,
    /// Seconds per cost-weighted pixel (threads).
    s_per_px: f64,
    /// Hand-outs not finished, each (group, items), in order.
    held: VecDeque<(u64, VecDeque<u32>)>,
    groups: u64,
    /// When what it renders now ends.
    ends: Option<f64>,
    done_px: u64,
    done_hand_outs: u64,
    busy_s: f64,
    busy_since: Option<f64>,
    /// Seconds it held nothing, summed span by span.
    idle_s: f64,
    /// When it last ran out of work (`Some(0)` at the start: nothing held yet).
    idle_since: Option<f64>,
    items: u64,
    last_result: f64,
}

impl Src {
    fn facts(&self, t: f64, px: &[u64]) -> Facts {
        Facts {
            alive: true,
            done_px: self.done_px,
            done_hand_outs: self.done_hand_outs,
            busy: Duration::from_secs_f64(self.busy_s + self.busy_since.map_or(0.0, |s| t - s)),
            held_px: self
                .held
                .iter()
                .flat_map(|(_, items)| items)
                .map(|&i| px[i as usize])
                .sum(),
            held: self.held.len(),
        }
    }

    fn held_items(&self) -> usize {
        self.held.iter().map(|(_, items)| items.len()).sum()
    }

    /// Its lane at the end of a run of `wall` seconds: busy, idle (the last idle span closed
    /// at the wall), items and pixels, its kind.
    fn lane(&self, wall: f64) -> WorkerStats {
        WorkerStats {
            busy_s: self.busy_s,
            idle_s: self.idle_s + self.idle_since.map_or(0.0, |s| wall - s),
            items: self.items,
            pixels: self.done_px,
            rays: 0,
            source: Some(match self.gpu {
                Some(_) => SourceKind::Gpu,
                None => SourceKind::Threads,
            }),
        }
    }
}

/// Simulate `platform` cut into `chunk`² tiles (scanline order) under `handing`.
pub fn simulate(platform: &Platform, chunk: u32, handing: Handing) -> Outcome {
    let mut sim = Sim::new(platform, chunk, handing);
    while sim.rendered.len() < sim.px.len() {
        // The master's pass: every source, hand-out by hand-out.
        let issued = sim.issued;
        for i in 0..sim.srcs.len() {
            while let Some(n) = sim.want(i).filter(|_| !sim.queue.is_empty()) {
                sim.hand_out(i, n);
            }
        }
        sim.passes += u64::from(sim.issued > issued);
        sim.start_idle();
        if !sim.next_event() {
            break; // nothing held, nothing queued: cannot happen while items are left
        }
    }
    sim.outcome()
}

/// One simulated run: the items' pixels and costs, the sources, the queue and the clock.
struct Sim<'p> {
    platform: &'p Platform,
    handing: Handing,
    px: Vec<u64>,
    cost: Vec<f64>,
    total_px: u64,
    item_px: u64,
    srcs: Vec<Src>,
    balance: Option<Balance>,
    /// The master's queue (`never`: every item goes out once, in order).
    queue: MasterQueue,
    unissued: u64,
    rendered: Vec<u32>,
    dispatches: u64,
    /// Hand-outs and the master's passes that handed something out.
    issued: u64,
    passes: u64,
    t: f64,
}

impl<'p> Sim<'p> {
    fn new(platform: &'p Platform, chunk: u32, handing: Handing) -> Self {
        let items = decompose(
            platform.width,
            platform.height,
            Chunk::Tile { w: chunk, h: chunk },
            Order::Scanline,
        );
        let px: Vec<u64> = items.iter().map(|i| i.pixel_count() as u64).collect();
        let top = platform.height / 16;
        let raw: Vec<f64> = items
            .iter()
            .map(|it| {
                let y = match &it.region {
                    crate::core::render::Region::Rect { y, .. } => *y,
                    crate::core::render::Region::Pixels(p) => {
                        p.first().map_or(0, |i| i / platform.width)
                    }
                };
                let f = if y < top { platform.top_cost } else { 1.0 };
                f * it.pixel_count() as f64
            })
            .collect();
        let total_px: u64 = px.iter().sum();
        let scale = total_px as f64 / raw.iter().sum::<f64>();
        let cost: Vec<f64> = raw.iter().map(|c| c * scale).collect();
        let spp = f64::from(platform.spp);
        let srcs: Vec<Src> = platform
            .thread_paths_s
            .iter()
            .map(|&r| (None, spp / r))
            .chain(platform.gpu.map(|g| (Some(g), 0.0)))
            .map(|(gpu, s_per_px)| Src {
                gpu,
                s_per_px,
                held: VecDeque::new(),
                groups: 0,
                ends: None,
                done_px: 0,
                done_hand_outs: 0,
                busy_s: 0.0,
                busy_since: None,
                idle_s: 0.0,
                idle_since: Some(0.0),
                items: 0,
                last_result: 0.0,
            })
            .collect();
        let item_px = total_px / items.len().max(1) as u64;
        let balance = match handing {
            Handing::Balanced { buffer } => Some(Balance::new(
                srcs.iter()
                    .map(|s| {
                        s.gpu
                            .map_or(Shape::Items, |_| Shape::Dispatch(GPU_DISPATCH))
                    })
                    .collect(),
                item_px,
                buffer,
            )),
            Handing::Fixed { .. } => None,
        };
        Self {
            platform,
            handing,
            queue: MasterQueue::new(items.len(), Requeue::Never),
            px,
            cost,
            total_px,
            item_px,
            srcs,
            balance,
            unissued: total_px,
            rendered: Vec::new(),
            dispatches: 0,
            issued: 0,
            passes: 0,
            t: 0.0,
        }
    }

    /// The pixels source `i` may be handed now (`None`: nothing).
    fn want(&self, i: usize) -> Option<u64> {
        match (&self.balance, self.handing) {
            (Some(b), _) => {
                let facts: Vec<Facts> = self
                    .srcs
                    .iter()
                    .map(|s| s.facts(self.t, &self.px))
                    .collect();
                b.grant(i, &facts, self.unissued).pixels()
            }
            (
                None,
                Handing::Fixed {
                    buffer,
                    gpu_grain,
                    gpu_buffer,
                },
            ) => {
                let s = &self.srcs[i];
                match (s.gpu, gpu_grain) {
                    (None, _) => (s.held_items() < buffer).then_some(1),
                    (Some(_), 0) => {
                        let room = gpu_buffer.saturating_sub(s.held_items());
                        (room > 0).then(|| room as u64 * self.item_px)
                    }
                    (Some(_), g) => (s.held.len() < gpu_buffer).then_some(g),
                }
            }
            (None, Handing::Balanced { .. }) => unreachable!("a balanced run has its rule"),
        }
    }

    /// Hand source `i` queued items until their pixels reach `n` (one item at least).
    fn hand_out(&mut self, i: usize, n: u64) {
        let mut got = VecDeque::new();
        let mut sum = 0;
        while sum < n.max(1) {
            let Take::Item(k) = self.queue.take(Duration::ZERO, |_| false, |_| false) else {
                break;
            };
            sum += self.px[k as usize];
            self.unissued -= self.px[k as usize];
            got.push_back(k);
        }
        let t = self.t;
        self.issued += 1;
        let s = &mut self.srcs[i];
        if s.held.is_empty() {
            s.busy_since = Some(t);
            if let Some(since) = s.idle_since.take() {
                s.idle_s += t - since;
            }
        }
        s.held.push_back((s.groups, got));
        s.groups += 1;
    }

    /// Idle sources start their next work.
    fn start_idle(&mut self) {
        let t = self.t;
        for s in &mut self.srcs {
            if s.ends.is_some() {
                continue;
            }
            let Some((_, items)) = s.held.front() else {
                continue;
            };
            s.ends = Some(match s.gpu {
                Some(g) => {
                    self.dispatches += 1;
                    let n: u64 = items.iter().map(|&k| self.px[k as usize]).sum();
                    let c: f64 = items.iter().map(|&k| self.cost[k as usize]).sum();
                    t + g.dispatch_s(n, c, self.platform.spp)
                }
                None => t + self.cost[items[0] as usize] * s.s_per_px,
            });
        }
    }

    /// The next event: the earliest end; every source ending then returns its results.
    /// `false` when nothing runs.
    fn next_event(&mut self) -> bool {
        let Some(next) = self
            .srcs
            .iter()
            .filter_map(|s| s.ends)
            .min_by(f64::total_cmp)
        else {
            return false;
        };
        self.t = next;
        let t = self.t;
        for s in self.srcs.iter_mut().filter(|s| s.ends == Some(next)) {
            s.ends = None;
            let (group, mut items) = s.held.pop_front().expect("a running source holds work");
            let finished: Vec<u32> = if s.gpu.is_some() {
                items.drain(..).collect()
            } else {
                vec![items.pop_front().expect("a hand-out holds an item")]
            };
            for k in finished {
                s.done_px += self.px[k as usize];
                s.items += 1;
                self.rendered.push(k);
            }
            s.last_result = t;
            if items.is_empty() {
                s.done_hand_outs += 1;
            } else {
                s.held.push_front((group, items));
            }
            if s.held.is_empty() {
                if let Some(since) = s.busy_since.take() {
                    s.busy_s += t - since;
                }
                s.idle_since = Some(t);
            }
        }
        true
    }

    fn outcome(self) -> Outcome {
        let t = self.t;
        let gpu_px = self
            .srcs
            .iter()
            .filter(|s| s.gpu.is_some())
            .map(|s| s.done_px)
            .sum();
        let thread_idle_end_s = self
            .srcs
            .iter()
            .filter(|s| s.gpu.is_none())
            .map(|s| t - s.last_result)
            .fold(0.0, f64::max);
        let stats = RunStats {
            wall_s: t,
            workers: self.srcs.iter().map(|s| s.lane(t)).collect(),
            master: Some(MasterStats {
                dispatch_s: 0.0,
                wait_s: 0.0,
                iterations: self.passes,
                rebalances: 0,
            }),
            items: self.px.len() as u64,
            issued: self.issued,
            ..RunStats::default()
        };
        Outcome {
            stats,
            wall_s: t,
            ideal_s: self.total_px as f64 / self.platform.summed_px_s(),
            gpu_px,
            thread_px: self.total_px - gpu_px,
            dispatches: self.dispatches,
            thread_idle_end_s,
            rendered: self.rendered,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default run of `--sources threads,gpu`: the master's chunk (16²) and B (2).
    const DEFAULT: Handing = Handing::Balanced { buffer: 2 };

    /// Within 1 %: `a` against `b`.
    fn near(a: f64, b: f64) -> bool {
        (a - b).abs() <= 0.01 * b.abs().max(1e-12)
    }

    #[test]
    fn a_gpu_lane_busy_idle_and_dispatch_add_up_to_lanes_times_wall_in_the_summary() {
        use crate::core::metrics::SourceKind;
        use crate::studies::experiment::results::RunRow;
        use crate::studies::experiment::summary::summarize;
        let p = Platform::h200_cornell();
        let fixed = |buffer, gpu_grain, gpu_buffer| Handing::Fixed {
            buffer,
            gpu_grain,
            gpu_buffer,
        };
        // The balancer, the master before it (the GPU starved: threads wait at the end) and
        // hand-picked grains.
        for (chunk, handing) in [
            (16, DEFAULT),
            (32, fixed(4, 0, 256)),
            (8, fixed(2, 1 << 18, 2)),
        ] {
            let o = simulate(&p, chunk, handing);
            let st = &o.stats;
            assert_eq!(st.workers.len(), 17, "16 threads and the GPU lane");
            let gpu = &st.workers[16];
            assert_eq!(gpu.source, Some(SourceKind::Gpu));
            assert_eq!(gpu.pixels, o.gpu_px);
            assert!(gpu.busy_s > 0.0 && gpu.items > 0, "{gpu:?}");
            let items: u64 = st.workers.iter().map(|w| w.items).sum();
            assert_eq!(items, st.items, "every item on one lane");
            // Each lane, the GPU's among them: busy + idle (summed span by span) = wall.
            for (k, w) in st.workers.iter().enumerate() {
                assert!(w.busy_s > 0.0 && w.idle_s >= 0.0, "lane {k}: {w:?}");
                assert!(
                    (w.busy_s + w.idle_s - o.wall_s).abs() <= 1e-9 * o.wall_s,
                    "lane {k}: busy {} + idle {} against wall {}",
                    w.busy_s,
                    w.idle_s,
                    o.wall_s
                );
            }
            // As a row of runs.csv and its summary: the columns a measured run fills, and the
            // overhead breakdown (busy, imbalance, other idle, dispatch) read from them.
            let mut row = RunRow::example();
            row.config = format!("sim {chunk} {handing:?}");
            row.scheduler = "master".into();
            row.workers = st.workers.len();
            row.set_stats(st);
            let lanes = row.workers as f64 * o.wall_s;
            assert!(
                near(row.work_s + row.idle_s + row.dispatch_s, lanes),
                "Σ busy {} + idle {} + dispatch {} against workers × wall {lanes}",
                row.work_s,
                row.idle_s,
                row.dispatch_s
            );
            let sums = summarize(std::slice::from_ref(&row));
            let l = sums[0].lanes;
            assert!(near(l.total(), lanes), "{l:?} against {lanes}");
            assert!(near(l.busy_s, row.work_s), "{l:?} against {row:?}");
            assert!(near(l.imbalance_s, row.imbalance_s), "{l:?}");
            assert!(near(l.other_idle_s, row.idle_s - row.imbalance_s), "{l:?}");
            assert_eq!(l.dispatch_s, 0.0, "the simulated master costs no time");
            // The GPU lane's part of the busy time, as the summary's shares report it.
            let at = SourceKind::ALL
                .iter()
                .position(|k| *k == SourceKind::Gpu)
                .unwrap();
            let share = sums[0].shares[at].expect("the GPU's share");
            assert!(near(share.busy_s, gpu.busy_s), "{share:?}");
            assert!(near(share.pixel_share, o.gpu_px as f64 / (1024.0 * 1024.0)));
        }
    }

    #[test]
    fn the_fit_reproduces_the_measured_gpu_curve() {
        let g = GpuModel::h200();
        let rate = |n: u64| n as f64 / g.dispatch_s(n, n as f64, 1);
        assert!((rate(262_144) / 38e6 - 1.0).abs() < 1e-9);
        assert!((rate(1024) / 2.5e6 - 1.0).abs() < 1e-9);
        assert!((g.peak_px_s(512) * 512.0 / 320e6 - 1.0).abs() < 1e-9);
        // Points not fitted: within 15 % of 20 M (16 384 px) and 31 M (65 536 px).
        assert!((rate(16_384) / 20e6 - 1.0).abs() < 0.15, "{}", rate(16_384));
        assert!((rate(65_536) / 31e6 - 1.0).abs() < 0.15, "{}", rate(65_536));
        assert!((90_000.0..93_000.0).contains(&g.fill_px), "{}", g.fill_px);
    }

    #[test]
    fn the_default_balancer_reaches_95_percent_of_the_summed_rate_on_the_h200_pair() {
        let p = Platform::h200_cornell();
        let mut o = simulate(&p, 16, DEFAULT);
        let mut seen = std::mem::take(&mut o.rendered);
        seen.sort_unstable();
        assert!(seen.iter().enumerate().all(|(i, &k)| k == i as u32));
        assert_eq!(seen.len(), 4096, "every item rendered exactly once");
        assert!(o.of_sum() >= 0.95, "{o:?}");
        // The threads do their part: at least half their share of the pixels (3.4 %).
        assert!(o.thread_px as f64 >= 0.017 * 1024.0 * 1024.0, "{o:?}");
    }

    #[test]
    fn the_balancer_holds_over_the_measured_spread_of_rates_grains_and_tile_costs() {
        // Threads 9.0–12.6 M paths/s, the GPU 300–341 M, ceiling tiles at a third of the
        // cost to the same, tiles of 8², 16², 32² with B = 2 or 4.
        for threads in [9e6, 12.6e6] {
            for gpu in [300e6, 341e6] {
                for top_cost in [1.0 / 3.0, 1.0] {
                    for (chunk, buffer) in [(8, 2), (16, 2), (16, 4), (32, 4)] {
                        let mut p = Platform::h200_cornell();
                        for r in &mut p.thread_paths_s {
                            *r *= threads / 11e6;
                        }
                        let g = p.gpu.as_mut().unwrap();
                        g.per_path_s *= 320e6 / gpu;
                        p.top_cost = top_cost;
                        let o = simulate(&p, chunk, Handing::Balanced { buffer });
                        assert!(
                            o.of_sum() >= 0.95,
                            "{threads} {gpu} {top_cost} {chunk} {buffer}: {o:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn the_old_single_grain_falls_far_short_and_hand_picked_grains_match_the_device() {
        let p = Platform::h200_cornell();
        // The master before the balancer, one grain for both (`--chunk 32 --buffer 4
        // --gpu-buffer 256`): measured 0.55–0.68 of the sum on the H200.
        let old = simulate(
            &p,
            32,
            Handing::Fixed {
                buffer: 4,
                gpu_grain: 0,
                gpu_buffer: 256,
            },
        );
        assert!(old.of_sum() < 0.75, "{old:?}");
        // Each source its own grain by hand (`--chunk 8 --buffer 2 --gpu-chunk 512
        // --gpu-buffer 2`): measured 0.949–0.976.
        let own = simulate(
            &p,
            8,
            Handing::Fixed {
                buffer: 2,
                gpu_grain: 512 * 512,
                gpu_buffer: 2,
            },
        );
        assert!((0.93..1.0).contains(&own.of_sum()), "{own:?}");
        // And the default balancer with the old one grain and B: still ≥ 0.95.
        let balanced = simulate(&p, 32, Handing::Balanced { buffer: 4 });
        assert!(balanced.of_sum() >= 0.95, "{balanced:?}");
    }
}
