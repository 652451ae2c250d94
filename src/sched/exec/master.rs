//! The report's master: a thread that renders nothing keeps at most B items outstanding per
//! compute source, taken from a FIFO queue. A handed-out item goes to the back of the queue;
//! if the master meets it again while it is unfinished, the re-queue policy decides whether it
//! is handed out again (`seed`: yes; `timeout:<ms>`: once outstanding that long; `never`: the
//! item left the queue when first handed out). The first result wins; later ones are counted
//! as duplicates and dropped. Sources that are lost have their items re-queued at once (unless
//! the policy is `never`); a deadline bounds every run, so nothing hangs.

use crate::core::metrics::{MasterStats, Probe, RunStats, Span, MASTER_LANE};
use crate::core::render::WorkItem;
use crate::sched::results::{finish_sources, seal_stats};
use crate::sched::rule::{Balance, Facts, Grant, MasterQueue, MasterRule, Shape, Take};
use crate::sched::{wire, Collector, Requeue, Results, Returns, RunOptions, SchedError};
use crate::source::{ComputeSource, DelayedResult, Doorbell};
use std::time::{Duration, Instant};

/// How long the master waits before it re-polls everything even without a notification
/// (sources that cannot ring, results failed by a dropped completer).
const TICK: Duration = Duration::from_millis(2);

struct Slot {
    item: u32,
    result: DelayedResult,
    at: Instant,
    /// Its place among the items submitted to its source.
    seq: u64,
    /// The hand-out it went in (its place among the source's hand-outs).
    group: u64,
}

/// For a source that cannot count its finished items: a slot outstanding longer than this no
/// longer counts against the buffer, so a dropped result cannot block its source for good.
/// `seed`/`never`: 4× the slowest result seen so far (at least 10 ms); `timeout:<ms>`: the
/// timeout.
fn stale_after(requeue: Requeue, slowest: Duration) -> Duration {
    match requeue {
        Requeue::Timeout(d) => d,
        _ => (slowest * 4).max(Duration::from_millis(10)),
    }
}

/// When a slot still holds its source: the source's count of finished items where it keeps
/// one (a finished item whose result has not arrived was lost), else the slot's age.
#[derive(Clone, Copy)]
struct Staleness {
    now: Instant,
    after: Duration,
    finished: Option<u64>,
}

impl Staleness {
    /// Does `sl` still count against its source's buffer? Judged by age alone, a slot whose
    /// item outlasted `after` went stale while it was being rendered, and the master queued
    /// more items behind it: on a scene whose costliest tile took ~15 ms against a 10 ms
    /// floor, that worker ran 8–9 tiles against 5 and finished 1.4 ms after the other
    /// (skewed_x100 at 16², B = 2; at B = 4 the other sat idle 8.3 ms).
    fn fresh(&self, sl: &Slot) -> bool {
        match self.finished {
            Some(f) => sl.seq >= f || sl.result.is_ready(),
            None => self.now - sl.at < self.after,
        }
    }
}

/// One compute source as the master sees it.
struct Lane {
    src: Box<dyn ComputeSource>,
    /// Its items outstanding, each with its result.
    slots: Vec<Slot>,
    /// False once it failed a result or said it is lost.
    alive: bool,
    /// Items outstanding at most for this source (its B), where no balancer runs.
    buffer: usize,
    /// Pixels per hand-out (its items go out in groups this large); 0: item by item.
    grain: u64,
    /// Items submitted to it so far (the next slot's `seq`).
    submitted: u64,
    /// Its results come back per hand-out ([`Returns::HandOut`], where the source can).
    per_hand_out: bool,
    /// Its hand-outs go whole ([`ComputeSource::runs_hand_outs_whole`]).
    whole: bool,
    /// What the balancer is told of it ([`Facts`]), kept as results come back.
    meter: Meter,
}

/// What the master measures of one source for the balancer: the executor reads the clock,
/// the rule ([`Balance`]) is passed the numbers.
#[derive(Default)]
struct Meter {
    /// Hand-outs submitted (the next one's group).
    hand_outs: u64,
    /// Pixels of its accepted results.
    done_px: u64,
    /// Hand-outs whose every result came back (counted where [`Self::groups`] is set).
    done_hand_outs: u64,
    /// Count finished hand-outs (a dispatch source under the balancer).
    groups: bool,
    /// Busy time closed so far, and since when it has held work, if it does.
    busy: Duration,
    busy_since: Option<Instant>,
    /// The guard refused it since its last hand-out (so a refusal is counted once).
    refused: bool,
}

impl Lane {
    /// Most items per hand-out: ⌈B/2⌉ where results come back per hand-out (two hand-outs
    /// outstanding, so the source renders one while the other's results travel), else all B.
    /// Returned per hand-out, one-pixel zero-work items took the master 0.76–0.79× its
    /// per-item time at B = 64, 0.85–0.92× at B = 16 and 1.03–1.12× at B = 4 (`dispatch_ratio
    /// -- floor`, same rounds, 2-core EPYC VM).
    fn piece(&self) -> usize {
        if self.per_hand_out {
            self.buffer.div_ceil(2)
        } else {
            usize::MAX
        }
    }

    /// Submit the items collected for this source as one message and keep their slots.
    /// Batching, with reused result cells and rings only to a sleeping master, took the
    /// master from 160–370 to 93–95 ns per one-pixel item at B = 64; sending an idle source's
    /// first item alone (the caller's job) keeps B = 2 from waiting for the whole scan
    /// (430 → 270–280 ns).
    fn hand_out(
        &mut self,
        batch: &mut Vec<WorkItem>,
        results: &mut Vec<DelayedResult>,
        now: Instant,
    ) {
        if batch.is_empty() {
            return;
        }
        if self.per_hand_out && batch.len() > 1 {
            self.src.submit_hand_out(batch, results);
        } else {
            self.src.submit_batch(batch, results);
        }
        let first = self.submitted;
        self.submitted += results.len() as u64;
        let group = self.meter.hand_outs;
        self.meter.hand_outs += 1;
        if self.slots.is_empty() {
            self.meter.busy_since = Some(now);
        }
        self.slots
            .extend(results.drain(..).zip(first..).map(|(result, seq)| Slot {
                item: result.item(),
                result,
                at: now,
                seq,
                group,
            }));
    }

    /// What the balancer is told of this source at `now`; `px` gives an item's pixels.
    fn facts(&self, now: Instant, px: impl Fn(u32) -> u64) -> Facts {
        let m = &self.meter;
        let mut groups: Vec<u64> = self.slots.iter().map(|sl| sl.group).collect();
        groups.sort_unstable();
        groups.dedup();
        Facts {
            alive: self.alive,
            done_px: m.done_px,
            done_hand_outs: m.done_hand_outs,
            busy: m.busy + m.busy_since.map_or(Duration::ZERO, |s| now - s),
            held_px: self.slots.iter().map(|sl| px(sl.item)).sum(),
            held: groups.len(),
        }
    }
}

/// The items' side of the master: the FIFO queue, what was handed out when, what is done.
struct Ledger<'a> {
    items: &'a [WorkItem],
    /// The run's start: the queue's times are durations since.
    t0: Instant,
    queue: MasterQueue,
    collector: Collector,
    /// The longest a result took so far (the staleness scale).
    slowest: Duration,
    item_bytes: u64,
    /// Pixels of the items not handed out (or to go out again), for the balancer.
    unissued_px: u64,
    /// Scratch of one hand-out: the items going to one source, then their results.
    batch: Vec<WorkItem>,
    handed_out: Vec<DelayedResult>,
}

impl<'a> Ledger<'a> {
    fn new(items: &'a [WorkItem], params: &MasterRule, t0: Instant) -> Self {
        let n = items.len();
        Self {
            items,
            t0,
            queue: MasterQueue::new(n, params.requeue),
            collector: Collector::new(n),
            slowest: Duration::ZERO,
            item_bytes: 0,
            unissued_px: items.iter().map(|i| i.pixel_count() as u64).sum(),
            batch: Vec::new(),
            handed_out: Vec::new(),
        }
    }

    fn done(&self) -> usize {
        self.collector.tally.done
    }

    /// Take whatever `lane` has ready; a failure means the source is gone.
    fn collect(&mut self, lane: &mut Lane, now: Instant) {
        let mut k = 0;
        while k < lane.slots.len() {
            if !lane.slots[k].result.is_ready() {
                // Only a re-issued item can be finished by another source.
                if self.queue.reissued > 0 && self.collector.is_done(lane.slots[k].item) {
                    lane.slots.swap_remove(k); // done elsewhere: its slot is free again
                } else {
                    k += 1;
                }
                continue;
            }
            let slot = lane.slots.swap_remove(k);
            match slot.result.try_take() {
                Ok(Ok(r)) => {
                    self.slowest = self.slowest.max(now.saturating_duration_since(slot.at));
                    let m = &mut lane.meter;
                    m.done_px += self.items[slot.item as usize].pixel_count() as u64;
                    if m.groups && !lane.slots.iter().any(|sl| sl.group == slot.group) {
                        m.done_hand_outs += 1;
                    }
                    self.collector.accept(r)
                }
                Ok(Err(_)) => {
                    lane.alive = false;
                    self.requeue_lost(slot.item);
                }
                Err(d) => lane.slots.push(Slot { result: d, ..slot }),
            }
        }
        if lane.slots.is_empty() {
            if let Some(since) = lane.meter.busy_since.take() {
                lane.meter.busy += now.saturating_duration_since(since);
            }
        }
    }

    /// `item`'s copy was lost with its source: hand it out again at once, or (`never`) count
    /// it as lost for good.
    fn requeue_lost(&mut self, item: u32) {
        if !self.collector.is_done(item) {
            self.queue.lost(item);
            if self.queue.requeue() != Requeue::Never {
                self.unissued_px += self.items[item as usize].pixel_count() as u64;
            }
        }
    }

    /// Top `lane` up to B fresh outstanding items from the queue (B hand-outs of its grain
    /// for a lane with one, [`Self::top_up_grouped`]); `first` gets the first item handed out
    /// in this pass.
    fn top_up(&mut self, lane: &mut Lane, now: Instant, after: Duration, first: &mut Option<u32>) {
        let stale = Staleness {
            now,
            after,
            finished: lane.src.finished(),
        };
        if lane.grain > 0 {
            return self.top_up_grouped(lane, stale, first);
        }
        let mut scanned = 0;
        let len = self.queue.len();
        let piece = lane.piece();
        let mut fresh = lane.slots.iter().filter(|sl| stale.fresh(sl)).count();
        while fresh < lane.buffer && scanned < len {
            scanned += 1;
            let Some(i) = self.pop_ready(&lane.slots, stale) else {
                continue;
            };
            self.issue(i, first);
            fresh += 1;
            if (fresh == 1 && !lane.whole) || self.batch.len() >= piece {
                // The source is idle: its first item goes at once, not after the scan; and a
                // full piece goes as its own hand-out. Not for a source whose hand-out costs
                // about the same at any size: with a dispatch of max(20 ms, 0.156 ms per tile),
                // sending the first tile alone took a GPU-like source's 1024 tiles from
                // 0.165-0.21 s to 0.245-0.25 s (`examples/hetero_tail`, GPU alone, B = 256).
                lane.hand_out(&mut self.batch, &mut self.handed_out, now);
            }
        }
        lane.hand_out(&mut self.batch, &mut self.handed_out, now);
    }

    /// [`Self::top_up`] for a lane with its own grain: consecutive items go out together
    /// once their pixels reach the grain (one message, one GPU dispatch), up to B such
    /// hand-outs' pixels outstanding; only the queue's last items go out as a smaller one.
    fn top_up_grouped(&mut self, lane: &mut Lane, stale: Staleness, first: &mut Option<u32>) {
        let now = stale.now;
        let items = self.items;
        let px = |i: u32| items[i as usize].pixel_count() as u64;
        let cap = lane.buffer as u64 * lane.grain;
        let mut fresh: u64 = lane
            .slots
            .iter()
            .filter(|sl| stale.fresh(sl))
            .map(|sl| px(sl.item))
            .sum();
        let mut grouped = 0u64;
        let mut scanned = 0;
        let len = self.queue.len();
        // A group once started is completed, so every hand-out but the last is whole.
        while (fresh < cap || grouped > 0) && scanned < len {
            scanned += 1;
            let Some(i) = self.pop_ready(&lane.slots, stale) else {
                continue;
            };
            self.issue(i, first);
            fresh += px(i);
            grouped += px(i);
            if grouped >= lane.grain {
                lane.hand_out(&mut self.batch, &mut self.handed_out, now);
                grouped = 0;
            }
        }
        lane.hand_out(&mut self.batch, &mut self.handed_out, now);
    }

    /// One hand-out of about `px` pixels to `lane` (consecutive items until their pixels
    /// reach it, at least one), as the balancer granted; the pixels handed out.
    fn hand_out_px(
        &mut self,
        lane: &mut Lane,
        px: u64,
        stale: Staleness,
        first: &mut Option<u32>,
    ) -> u64 {
        let mut grouped = 0u64;
        let mut scanned = 0;
        let len = self.queue.len();
        while grouped < px.max(1) && scanned < len {
            scanned += 1;
            let Some(i) = self.pop_ready(&lane.slots, stale) else {
                continue;
            };
            self.issue(i, first);
            grouped += self.items[i as usize].pixel_count() as u64;
        }
        lane.hand_out(&mut self.batch, &mut self.handed_out, stale.now);
        grouped
    }

    /// The queue's next item if it may be handed out now to the source holding `slots`
    /// ([`MasterQueue::take`], which books it); `None` when it is done or may not go out
    /// again yet.
    fn pop_ready(&mut self, slots: &[Slot], stale: Staleness) -> Option<u32> {
        let (queue, collector) = (&mut self.queue, &self.collector);
        let now = stale.now.saturating_duration_since(self.t0);
        match queue.take(
            now,
            |i| collector.is_done(i),
            |i| slots.iter().any(|sl| sl.item == i && stale.fresh(sl)),
        ) {
            Take::Item(i) => Some(i),
            Take::Skip | Take::Empty => None,
        }
    }

    /// Put item `i` into the batch being handed out.
    fn issue(&mut self, i: u32, first: &mut Option<u32>) {
        let item = self.items[i as usize].clone();
        self.unissued_px = self.unissued_px.saturating_sub(item.pixel_count() as u64);
        self.item_bytes += wire::item_bytes(&item);
        self.batch.push(item);
        first.get_or_insert(i);
    }
}

/// The master's state over one run.
struct Master<'a> {
    params: MasterRule,
    deadline: Option<Duration>,
    probe: Probe,
    t0: Instant,
    bell: Doorbell,
    lanes: Vec<Lane>,
    ledger: Ledger<'a>,
    stats: MasterStats,
    /// The master's own timeline lane.
    spans: Vec<Span>,
    /// Picks each source's hand-outs from its measured throughput (heterogeneous runs).
    balance: Option<Balance>,
}

/// How the master hands out to sources of different speeds: each source's own buffer and
/// grain, or the balancer that picks them itself.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Hetero {
    /// Per source (by position), its buffer; 0 or a missing entry takes the master's B. For
    /// a source with a grain, B counts hand-outs of that grain.
    pub buffers: Vec<usize>,
    /// Per source (by position), pixels per hand-out: consecutive items go out together
    /// until their pixels reach it (a GPU wants large dispatches, threads small items);
    /// 0 or a missing entry: item by item.
    pub grains: Vec<u64>,
    /// Play the grain-picking balancer ([`Balance`]): a probe of a dispatch source's fill
    /// first, each source's grain and buffer from its measured rate where `grains` and
    /// `buffers` give none, and the tail guard (several sources only).
    pub balance: bool,
}

/// Where a master's run stands, for its verdict (the master thread's and `locked_master`'s).
pub(in crate::sched) struct Progress {
    pub total: u64,
    pub done: u64,
    /// Items whose only copy was lost under `never`.
    pub known_lost: u64,
    pub sources: u64,
    /// Sources not lost.
    pub alive: u64,
    pub requeue: Requeue,
    /// The run's deadline, once it has passed.
    pub deadline_passed: Option<Duration>,
}

impl Progress {
    /// How the run ends, if it ends now: every item done, every source lost, every item done
    /// or lost for good (`never`), or the deadline passed.
    pub(in crate::sched) fn verdict(&self) -> Option<Result<(), SchedError>> {
        let (n, done) = (self.total, self.done);
        if done == n {
            return Some(Ok(()));
        }
        if self.alive == 0 {
            return Some(Err(SchedError::AllSourcesLost {
                sources: self.sources,
                remaining: n - done,
                total: n,
            }));
        }
        let never = self.requeue == Requeue::Never;
        if never && done + self.known_lost == n {
            return Some(Err(SchedError::LostItems {
                lost: self.known_lost,
                total: n,
            }));
        }
        let deadline = self.deadline_passed?;
        Some(Err(if never {
            SchedError::LostItems {
                lost: n - done,
                total: n,
            }
        } else {
            SchedError::Deadline {
                deadline,
                done,
                total: n,
            }
        }))
    }
}

/// The master over `sources` with `params` (buffer, re-queue policy, wait), per-source
/// buffers and grains and, optionally, the time-equalising balancer: the executor
/// [`crate::sched::run`] plays a master rule on.
pub(crate) fn run_master_hetero(
    params: &MasterRule,
    hetero: &Hetero,
    items: &[WorkItem],
    sources: Vec<Box<dyn ComputeSource>>,
    opts: &RunOptions,
    probe: Probe,
) -> Result<(Results, RunStats), SchedError> {
    let mut master = Master::new(params, items, sources, opts.deadline, probe);
    for (lane, &b) in master.lanes.iter_mut().zip(&hetero.buffers) {
        if b > 0 {
            lane.buffer = b;
        }
    }
    let pixels: usize = items.iter().map(|i| i.pixel_count()).sum();
    let pixels_per_item = pixels as f64 / items.len().max(1) as f64;
    for (lane, &g) in master.lanes.iter_mut().zip(&hetero.grains) {
        // A grain no larger than the items changes nothing: item by item.
        lane.grain = if (g as f64) > pixels_per_item { g } else { 0 };
    }
    if hetero.balance && master.lanes.len() > 1 {
        let shapes = master
            .lanes
            .iter()
            .map(|l| l.src.dispatch().map_or(Shape::Items, Shape::Dispatch))
            .collect::<Vec<_>>();
        for (lane, shape) in master.lanes.iter_mut().zip(&shapes) {
            lane.meter.groups = matches!(shape, Shape::Dispatch(_));
        }
        let item_px = (pixels_per_item.round() as u64).max(1);
        let mut b = Balance::new(shapes, item_px, params.buffer);
        for (i, lane) in master.lanes.iter().enumerate() {
            let buffer = hetero.buffers.get(i).copied().filter(|&b| b > 0);
            b = b.fix(i, (lane.grain > 0).then_some(lane.grain), buffer);
        }
        master.balance = Some(b);
    }
    let outcome = loop {
        master.stats.iterations += 1;
        let now = Instant::now();
        // 1. Collect whatever is ready; stop when done, or when nothing can finish the run.
        master.collect(now);
        if let Some(outcome) = master.verdict() {
            break outcome;
        }
        // 2. Top every live source up to B outstanding items.
        let first = master.hand_out(now);
        // 3. Wait for a result (or the tick), the chosen way.
        master.wait(now, first);
    };
    master.finish(outcome)
}

impl<'a> Master<'a> {
    fn new(
        params: &MasterRule,
        items: &'a [WorkItem],
        mut sources: Vec<Box<dyn ComputeSource>>,
        deadline: Option<Duration>,
        probe: Probe,
    ) -> Self {
        let t0 = Instant::now();
        let bell = Doorbell::default();
        for s in sources.iter_mut() {
            s.set_notifier(bell.notifier());
        }
        let lanes = sources
            .into_iter()
            .map(|src| Lane {
                slots: Vec::with_capacity(params.buffer),
                alive: true,
                buffer: params.buffer,
                grain: 0,
                submitted: 0,
                per_hand_out: params.returns == Returns::HandOut && src.returns_per_hand_out(),
                whole: src.runs_hand_outs_whole(),
                meter: Meter::default(),
                src,
            })
            .collect();
        Self {
            params: *params,
            deadline,
            probe,
            t0,
            bell,
            lanes,
            ledger: Ledger::new(items, params, t0),
            stats: MasterStats::default(),
            spans: Vec::new(),
            balance: None,
        }
    }

    fn collect(&mut self, now: Instant) {
        for lane in &mut self.lanes {
            self.ledger.collect(lane, now);
        }
        for lane in &mut self.lanes {
            if lane.alive && lane.src.is_lost() {
                lane.alive = false;
            }
        }
    }

    /// How the run ends, if it ends now ([`Progress::verdict`]).
    fn verdict(&self) -> Option<Result<(), SchedError>> {
        Progress {
            total: self.ledger.items.len() as u64,
            done: self.ledger.done() as u64,
            known_lost: self.ledger.queue.known_lost,
            sources: self.lanes.len() as u64,
            alive: self.lanes.iter().filter(|l| l.alive).count() as u64,
            requeue: self.params.requeue,
            deadline_passed: self.deadline.filter(|dl| self.t0.elapsed() >= *dl),
        }
        .verdict()
    }

    /// Top every live source up; the first item handed out in this pass, if any.
    fn hand_out(&mut self, now: Instant) -> Option<u32> {
        let stale = stale_after(self.params.requeue, self.ledger.slowest);
        let mut first = None;
        if let Some(b) = self.balance.take() {
            self.hand_out_balanced(&b, now, stale, &mut first);
            self.balance = Some(b);
            return first;
        }
        for lane in self.lanes.iter_mut().filter(|l| l.alive) {
            self.ledger.top_up(lane, now, stale, &mut first);
        }
        first
    }

    /// Give every live source what the balancer grants it, hand-out by hand-out, telling
    /// the rule each time what every source holds and what is queued. A grant the tail
    /// guard cut, and a source's first refusal since its last hand-out, count as
    /// rebalances.
    fn hand_out_balanced(
        &mut self,
        b: &Balance,
        now: Instant,
        after: Duration,
        first: &mut Option<u32>,
    ) {
        let items = self.ledger.items;
        let px = |i: u32| items[i as usize].pixel_count() as u64;
        let mut facts: Vec<Facts> = self.lanes.iter().map(|l| l.facts(now, px)).collect();
        for i in 0..self.lanes.len() {
            let lane = &mut self.lanes[i];
            let stale = Staleness {
                now,
                after,
                finished: lane.src.finished(),
            };
            while lane.alive {
                let grant = b.grant(i, &facts, self.ledger.unissued_px);
                match grant {
                    Grant::Cut(_) => self.stats.rebalances += 1,
                    Grant::Refused if !lane.meter.refused => {
                        lane.meter.refused = true;
                        self.stats.rebalances += 1;
                    }
                    Grant::Full(_) | Grant::Refused | Grant::Wait => {}
                }
                let Some(n) = grant.pixels() else { break };
                if self.ledger.hand_out_px(lane, n, stale, first) == 0 {
                    break;
                }
                lane.meter.refused = false;
                facts[i] = lane.facts(now, px);
            }
        }
    }

    /// Wait for a ring or the tick; with stats on, the pass since `now` counts as dispatch
    /// time and (timeline) a pass that handed out `first` goes into the master's lane.
    fn wait(&mut self, now: Instant, first: Option<u32>) {
        let t_wait = self.probe.stats.then(Instant::now);
        if let Some(b) = t_wait {
            self.stats.dispatch_s += (b - now).as_secs_f64();
            if let Some(item) = first.filter(|_| self.probe.timeline) {
                let epoch = self.probe.epoch;
                self.spans.push(Span {
                    worker: MASTER_LANE,
                    item,
                    start_ns: (now - epoch).as_nanos() as u64,
                    end_ns: (b - epoch).as_nanos() as u64,
                });
            }
        }
        let lanes = &self.lanes;
        self.bell.wait(TICK, self.params.wait, || {
            lanes
                .iter()
                .flat_map(|l| &l.slots)
                .any(|sl| sl.result.is_ready())
        });
        if let Some(a) = t_wait {
            self.stats.wait_s += a.elapsed().as_secs_f64();
        }
    }

    /// Stop every source and put the run's statistics together.
    fn finish(self, outcome: Result<(), SchedError>) -> Result<(Results, RunStats), SchedError> {
        // Results still in flight are duplicates or lost: drop them, then stop every source.
        let (sources, alive): (Vec<_>, Vec<_>) =
            self.lanes.into_iter().map(|l| (l.src, l.alive)).unzip();
        let ledger = self.ledger;
        let mut stats = RunStats {
            items: ledger.items.len() as u64,
            issued: ledger.queue.issued,
            reissued: ledger.queue.reissued,
            bytes: ledger.item_bytes,
            ..Default::default()
        };
        let mut spans = self.spans;
        let master_stats = self.stats;
        let lost_at_end = finish_sources(
            sources,
            self.t0.elapsed().as_secs_f64(),
            &mut stats,
            &mut spans,
        );
        stats.lost_sources = alive
            .iter()
            .zip(&lost_at_end)
            .filter(|(alive, lost)| !**alive || **lost)
            .count() as u64;
        outcome?;
        let wall_s = self.t0.elapsed().as_secs_f64();
        seal_stats(
            &mut stats,
            spans,
            &self.probe,
            wall_s,
            &ledger.collector,
            master_stats,
        );
        Ok((ledger.collector.results, stats))
    }
}

#[cfg(test)]
mod staleness_tests {
    use super::*;
    use crate::core::render::TileResult;
    use crate::sched::MasterParams;
    use crate::source::{Job, LocalThreadSource};
    use std::sync::atomic::{AtomicU32, Ordering};
    use std::sync::Arc;

    /// Item 0 is rendered until every item but the one queued behind it (item 1) is done by
    /// the other source (or 2 s pass). A slot judged stale by its age alone (10 ms) lets the
    /// master queue more items behind item 0, which then cannot finish before 2 s and its
    /// source renders more than its B = 2.
    #[test]
    fn a_long_item_keeps_its_slot_and_nothing_more_queues_behind_it() {
        const N: u32 = 40;
        let elsewhere = Arc::new(AtomicU32::new(0));
        let count = elsewhere.clone();
        let job: Job = Arc::new(move |it: &WorkItem| {
            if it.id == 0 {
                let t0 = Instant::now();
                while count.load(Ordering::SeqCst) < N - 2 && t0.elapsed() < Duration::from_secs(2)
                {
                    std::thread::sleep(Duration::from_millis(1));
                }
            } else {
                std::thread::sleep(Duration::from_millis(1));
                if it.id > 1 {
                    count.fetch_add(1, Ordering::SeqCst);
                }
            }
            TileResult {
                item: it.id,
                pixels: Default::default(),
                rays: 0,
                nonfinite: 0,
            }
        });
        let probe = Probe::new(true, false);
        let sources: Vec<Box<dyn ComputeSource>> = (0..2)
            .map(|id| Box::new(LocalThreadSource::spawn(id, job.clone(), probe)) as _)
            .collect();
        let items: Vec<WorkItem> = (0..N).map(|i| WorkItem::rect(i, i, 0, 1, 1)).collect();
        let params = MasterParams {
            buffer: 2,
            requeue: Requeue::Never,
            ..MasterParams::DEFAULT
        };
        let (_, stats) = run_master_hetero(
            &params.into(),
            &Hetero::default(),
            &items,
            sources,
            &RunOptions::default(),
            probe,
        )
        .unwrap();
        let per_source: Vec<u64> = stats.workers.iter().map(|w| w.items).collect();
        assert_eq!(per_source, vec![2, u64::from(N) - 2]);
    }
}
