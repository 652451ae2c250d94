//! The master's balancer over sources of different speeds, as a rule: how many pixels a
//! source gets in its next hand-out, and whether it may have one now, from facts that the
//! executor measured and passes in ([`Facts`]: pixels done, busy time, hand-outs done and
//! held, what is queued). It reads no clock and does no I/O; the thread master
//! (`sched::exec::master`) and the deterministic simulation (`simulate::hetero`) play it alike.
//!
//! The policy (issue 52, item 4), per source:
//! - A source that runs each hand-out as one dispatch of fixed cost ([`Shape::Dispatch`], a
//!   GPU) first gets one *probe*: the pixels that fill the device, alone. Its result gives
//!   the device's rate before any larger hand-out, so a small first dispatch can no longer
//!   make the GPU look barely faster than a thread (what held the H200's pair to 0.33–0.61
//!   of the summed rate, `results/published/gpu/`).
//! - Its grain then: the smallest hand-out that reaches [`PEAK_SHARE`] of its peak under
//!   `t(n) = o + n / peak` for `n` at or past the fill, with `o` its measured per-dispatch
//!   overhead and `peak` from its results with `o` taken out: `max(fill, s/(1 − s)·o·peak)`.
//!   It holds [`DISPATCH_BUFFER`] hand-outs, so the device renders one while the other's
//!   results travel.
//! - A source that runs item by item ([`Shape::Items`], a CPU thread) takes one item per
//!   hand-out, one until its first result is back, then up to the master's B (one where an
//!   item takes [`LONG_ITEM`] or more).
//! - The tail guard: no hand-out beyond the source's share of what is left by measured rate,
//!   `rate · T − held` with `T = (queued + held by all) / Σ rate`, so every source finishes
//!   together; for any source but the fastest, a third of that ([`TAIL_SLACK`]). A hand-out that
//!   the share cannot hold is cut to it, down to the source's floor (one item, or the
//!   device's fill); below the floor it is refused, except to the fastest source, and to any
//!   source while nobody holds anything (so the run always moves).

pub use crate::source::{Dispatch, GPU_DISPATCH};
use std::time::Duration;

/// How a source runs what it is handed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// Item by item, each pixel at about the same cost whatever the hand-out (a CPU thread).
    Items,
    /// Each hand-out as one dispatch of a fixed cost (a GPU).
    Dispatch(Dispatch),
}

/// What the executor measured of one source, passed to [`Balance::grant`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Facts {
    /// Not lost.
    pub alive: bool,
    /// Pixels of its accepted results.
    pub done_px: u64,
    /// Its hand-outs whose results have all come back.
    pub done_hand_outs: u64,
    /// How long it has held work outstanding, all told.
    pub busy: Duration,
    /// Pixels it holds outstanding.
    pub held_px: u64,
    /// Hand-outs it holds outstanding.
    pub held: usize,
}

/// The share of its peak a dispatch source's grain reaches (issue 52: ~90 %).
pub const PEAK_SHARE: f64 = 0.9;

/// Hand-outs a dispatch source holds at most: one rendering, one whose results travel.
pub const DISPATCH_BUFFER: usize = 2;

/// How many times a hand-out a source other than the fastest must have in its share of
/// what is left to get it. Its rate is measured on its first items, which may be cheaper
/// than the rest (the Cornell box's ceiling tiles); a slow source that takes one item too
/// many holds the whole run, while one that stops early loses only part of its small share.
/// 2 let a slow thread's last tile end the simulated H200 run early; 3 did not (M-151).
pub const TAIL_SLACK: f64 = 3.0;

/// An item source whose item takes at least this long holds one at a time: more only hide
/// the master's round trip between two items (well under 1 % of 10 ms), and each one more
/// is taken on a rate measured on its first items, perhaps cheaper than the rest. At 32²
/// tiles and B = 4 in the H200 simulation, threads holding four tiles ended the run at
/// 0.61 of the summed rate; one at a time, 0.97 (M-151).
pub const LONG_ITEM: Duration = Duration::from_millis(10);

/// What the rule says to a source that could take a hand-out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Grant {
    /// Hand out about this many pixels (consecutive items until they reach it, at least one).
    Full(u64),
    /// The tail guard cut the hand-out to this many pixels.
    Cut(u64),
    /// Nothing now: its buffer is full, or it waits for its first result.
    Wait,
    /// Nothing now: even its smallest hand-out would outlast what is left for the others.
    Refused,
}

impl Grant {
    /// The pixels to hand out, if any.
    pub fn pixels(self) -> Option<u64> {
        match self {
            Self::Full(n) | Self::Cut(n) => Some(n),
            Self::Wait | Self::Refused => None,
        }
    }
}

/// The grain-picking balancer over one run's sources (by position).
#[derive(Clone, Debug, PartialEq)]
pub struct Balance {
    shapes: Vec<Shape>,
    /// Pixels of one item (the decomposition's mean).
    item_px: u64,
    /// Hand-outs an item source holds at most once its rate is known (the master's B).
    buffer: usize,
    /// Per source, a grain and a buffer given by the run ([`Self::fix`]) instead of picked.
    fixed: Vec<(Option<u64>, Option<usize>)>,
}

impl Balance {
    /// The rule over sources of `shapes`, items of `item_px` pixels on average, B = `buffer`
    /// for the item sources.
    pub fn new(shapes: Vec<Shape>, item_px: u64, buffer: usize) -> Self {
        Self {
            fixed: vec![(None, None); shapes.len()],
            shapes,
            item_px: item_px.max(1),
            buffer: buffer.max(1),
        }
    }

    /// Source `i` takes `grain` pixels per hand-out and holds `buffer` hand-outs where given
    /// (`--gpu-chunk`, `--gpu-buffer` beside `--balance`); the tail guard still applies.
    pub fn fix(mut self, i: usize, grain: Option<u64>, buffer: Option<usize>) -> Self {
        self.fixed[i] = (grain.map(|g| g.max(1)), buffer.map(|b| b.max(1)));
        self
    }

    /// The sources' shapes, by position.
    pub fn shapes(&self) -> &[Shape] {
        &self.shapes
    }

    /// Source `i`'s measured throughput in pixels per second of busy time, once it has one.
    pub fn rate(&self, f: &Facts) -> Option<f64> {
        let busy = f.busy.as_secs_f64();
        (f.done_px > 0 && busy > 0.0).then(|| f.done_px as f64 / busy)
    }

    /// Source `i`'s pixels per hand-out before the tail guard: one item for an item source;
    /// for a dispatch source the probe (its fill) until a result is back, then the smallest
    /// hand-out reaching [`PEAK_SHARE`] of its peak.
    pub fn grain(&self, i: usize, f: &Facts) -> u64 {
        if let Some(g) = self.fixed[i].0 {
            return g;
        }
        match self.shapes[i] {
            Shape::Items => self.item_px,
            Shape::Dispatch(d) => {
                let fill = d.fill_px.max(self.item_px);
                let o = d.overhead.as_secs_f64();
                // Device time: busy time less each finished dispatch's fixed cost.
                let device_s = f.busy.as_secs_f64() - f.done_hand_outs as f64 * o;
                if f.done_px == 0 || device_s <= 0.0 {
                    return fill;
                }
                let peak = f.done_px as f64 / device_s;
                let n = PEAK_SHARE / (1.0 - PEAK_SHARE) * o * peak;
                // Rounded up, less the float's own error (9·0.02·10⁶ is 180 000.000…03).
                fill.max((n * (1.0 - 1e-12)).ceil() as u64)
            }
        }
    }

    /// The smallest hand-out worth giving source `i`: one item, or the device's fill (a
    /// smaller dispatch takes about as long).
    fn floor(&self, i: usize) -> u64 {
        match self.shapes[i] {
            Shape::Items => self.item_px,
            Shape::Dispatch(d) => d.fill_px.max(self.item_px),
        }
    }

    /// Hand-outs source `i` may hold at most once its rate is known.
    pub fn buffer(&self, i: usize) -> usize {
        if let Some(b) = self.fixed[i].1 {
            return b;
        }
        match self.shapes[i] {
            Shape::Items => self.buffer,
            Shape::Dispatch(_) => DISPATCH_BUFFER,
        }
    }

    /// What source `i` gets now, with `facts` of every source (by position) and `queued_px`
    /// pixels not handed out yet.
    pub fn grant(&self, i: usize, facts: &[Facts], queued_px: u64) -> Grant {
        let f = &facts[i];
        if !f.alive || queued_px == 0 {
            return Grant::Wait;
        }
        let Some(rate) = self.rate(f) else {
            // Before its first result: one hand-out, the probe or a single item.
            return if f.held == 0 {
                Grant::Full(self.grain(i, f))
            } else {
                Grant::Wait
            };
        };
        let long = matches!(self.shapes[i], Shape::Items)
            && self.fixed[i].1.is_none()
            && self.item_px as f64 / rate >= LONG_ITEM.as_secs_f64();
        if f.held >= if long { 1 } else { self.buffer(i) } {
            return Grant::Wait;
        }
        let want = self.grain(i, f);
        let floor = self.floor(i).min(want);
        let live = || facts.iter().filter(|g| g.alive);
        let sum_rate: f64 = live().filter_map(|g| self.rate(g)).sum();
        let left_px = queued_px + live().map(|g| g.held_px).sum::<u64>();
        let fastest = live().filter_map(|g| self.rate(g)).all(|r| r <= rate);
        let slack = if fastest { 1.0 } else { TAIL_SLACK };
        let share = (rate * left_px as f64 / sum_rate - f.held_px as f64) / slack;
        if share >= want as f64 {
            return Grant::Full(want);
        }
        if share >= floor as f64 {
            return Grant::Cut(share as u64);
        }
        let nobody_holds = live().all(|g| g.held == 0);
        if fastest || nobody_holds {
            Grant::Cut(floor)
        } else {
            Grant::Refused
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GPU: Dispatch = Dispatch {
        overhead: Duration::from_micros(105),
        fill_px: 65_536,
    };

    fn facts(done_px: u64, busy_ms: u64, done_hand_outs: u64, held_px: u64, held: usize) -> Facts {
        Facts {
            alive: true,
            done_px,
            done_hand_outs,
            busy: Duration::from_millis(busy_ms),
            held_px,
            held,
        }
    }

    fn pair() -> Balance {
        Balance::new(vec![Shape::Items, Shape::Dispatch(GPU)], 256, 2)
    }

    #[test]
    fn a_dispatch_source_gets_one_probe_of_its_fill_before_anything_larger() {
        let b = pair();
        let idle = facts(0, 0, 0, 0, 0);
        let fs = [idle, idle];
        assert_eq!(b.grant(1, &fs, 1 << 20), Grant::Full(65_536));
        // The probe out, no result yet: nothing more, however much is queued.
        let probing = [idle, facts(0, 100, 0, 65_536, 1)];
        assert_eq!(b.grant(1, &probing, 1 << 20), Grant::Wait);
        // A thread before its first result holds one item.
        assert_eq!(b.grant(0, &fs, 1 << 20), Grant::Full(256));
        let one = [facts(0, 10, 0, 256, 1), idle];
        assert_eq!(b.grant(0, &one, 1 << 20), Grant::Wait);
    }

    #[test]
    fn the_gpu_grain_is_the_smallest_reaching_90_percent_of_its_peak() {
        let b = pair();
        // 65 536 px in 105 µs + 100 ms: peak 655 360 px/s; 9·o·peak = 620 px < fill.
        let f = facts(65_536, 0, 1, 0, 0);
        let f = Facts {
            busy: Duration::from_micros(100_105),
            ..f
        };
        assert_eq!(b.grain(1, &f), 65_536);
        // A device whose dispatch costs 20 ms against 1 G px/s: 9·0.02·1e9 = 180 M px.
        let slow_submit = Balance::new(
            vec![Shape::Dispatch(Dispatch {
                overhead: Duration::from_millis(20),
                fill_px: 1024,
            })],
            16,
            2,
        );
        let f = Facts {
            busy: Duration::from_millis(21),
            ..facts(1_000_000, 0, 1, 0, 0)
        };
        let g = slow_submit.grain(0, &f);
        assert!((179_000_000..=181_000_000).contains(&g), "{g}");
        // At that grain the model's rate is 90 % of the peak.
        let rate = g as f64 / (0.02 + g as f64 / 1e9);
        assert!((rate / 1e9 - 0.9).abs() < 1e-3, "{rate}");
    }

    #[test]
    fn the_tail_guard_cuts_a_hand_out_to_the_share_and_refuses_a_slow_source_at_the_end() {
        let b = pair();
        // Thread: 256 px per 100 ms = 2 560 px/s (an item of 100 ms: one held at a time);
        // GPU: 65 536 px per 100 ms = 655 360 px/s.
        let thread = facts(256, 100, 1, 0, 0);
        let gpu = facts(65_536, 100, 1, 65_536, 1);
        // Plenty queued: full hand-outs for both; the thread's one item at a time.
        assert_eq!(b.grant(0, &[thread, gpu], 1 << 20), Grant::Full(256));
        assert_eq!(b.grant(1, &[thread, gpu], 1 << 20), Grant::Full(65_536));
        let holding = facts(256, 100, 1, 256, 1);
        assert_eq!(b.grant(0, &[holding, gpu], 1 << 20), Grant::Wait);
        // 10 000 px queued, 65 536 held: 0.115 s left for all. The thread's share (294 px)
        // is under three items' worth (TAIL_SLACK): refused, the GPU finishes sooner.
        assert_eq!(b.grant(0, &[thread, gpu], 10_000), Grant::Refused);
        // The fastest source still gets its floor, and an idle thread one item while nobody
        // holds anything.
        assert_eq!(b.grant(1, &[thread, gpu], 10_000), Grant::Cut(65_536));
        let idle_g = Facts {
            held_px: 0,
            held: 0,
            ..gpu
        };
        assert_eq!(b.grant(0, &[thread, idle_g], 100), Grant::Cut(256));
        // A thread whose items take 1 ms holds the master's B and keeps taking while its
        // share holds three items.
        let quick = facts(25_600, 100, 100, 256, 1);
        assert_eq!(b.grant(0, &[quick, gpu], 10_000), Grant::Full(256));
        let full = facts(25_600, 100, 100, 512, 2);
        assert_eq!(b.grant(0, &[full, gpu], 1 << 20), Grant::Wait);
        // Between floor and grain the hand-out is cut to the share: a GPU whose grain is 4×
        // its fill (a large per-dispatch cost) gets less as the queue empties.
        let heavy = Balance::new(
            vec![
                Shape::Items,
                Shape::Dispatch(Dispatch {
                    overhead: Duration::from_millis(20),
                    fill_px: 1024,
                }),
            ],
            256,
            2,
        );
        let gpu = Facts {
            busy: Duration::from_millis(120),
            ..facts(100_000, 0, 1, 0, 0)
        };
        assert_eq!(heavy.grain(1, &gpu), 180_000);
        let thread = facts(256, 100, 1, 0, 0);
        match heavy.grant(1, &[thread, gpu], 50_000) {
            Grant::Cut(n) => assert!((1024..50_000).contains(&n), "{n}"),
            g => panic!("{g:?}"),
        }
        // A grain and buffer given by the run replace the picked ones.
        let given = pair().fix(1, Some(4096), Some(3));
        assert_eq!(given.grain(1, &gpu), 4096);
        assert_eq!(given.buffer(1), 3);
        assert_eq!(given.grain(0, &thread), 256);
        // A lost source gets nothing.
        let lost = Facts {
            alive: false,
            ..thread
        };
        assert_eq!(b.grant(0, &[lost, gpu], 1 << 20), Grant::Wait);
    }
}
