//! Schedulers without a master: the workers take their own items from shared structures.
//! Every run spawns exactly `workers` threads (rayon: a pool of that size) and joins them.

use crate::core::metrics::{BusyClock, Probe, RunStats, Span, WorkerStats};
use crate::core::render::{TileResult, WorkItem};
use crate::sched::dls::{self, ItemTimes, Report, Timing};
use crate::sched::rule::{band, Dispense, Grab, Steal, StealState, WorkerRule};
use crate::sched::scanline::{as_handed_out, ScanlineScratch};
use crate::sched::{wire, Results, SchedError, Tally};
use crate::source::local::panic_message;
use crate::source::Job;
use crossbeam::deque::{Steal as Taken, Stealer, Worker};
use crossbeam::utils::CachePadded;
use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};
use std::time::Instant;

/// What one worker thread accumulates; merged once at the end (no shared counters).
pub(in crate::sched) struct Local {
    pub(in crate::sched) id: u32,
    pub(in crate::sched) clock: BusyClock,
    pub(in crate::sched) stats: WorkerStats,
    pub(in crate::sched) item_bytes: u64,
    pub(in crate::sched) spans: Vec<Span>,
    pub(in crate::sched) results: Vec<TileResult>,
    /// The item of each result, apart (see `Results::from_lists`).
    pub(in crate::sched) ids: Vec<u32>,
    pub(in crate::sched) tally: Tally,
    /// [`Local::chunk_order`]'s reused order and buffers.
    order: Vec<u32>,
    scratch: ScanlineScratch,
}

impl Local {
    /// A worker's run of items starts now; `expect` items reserves the result list (no
    /// re-allocation on the hot path for a fair share).
    pub(in crate::sched) fn new(id: u32, probe: &Probe, expect: usize) -> Self {
        Self {
            id,
            clock: BusyClock::start(probe),
            stats: WorkerStats::local_thread(),
            item_bytes: 0,
            spans: Vec::new(),
            results: Vec::with_capacity(expect),
            ids: Vec::with_capacity(expect),
            tally: Tally::default(),
            order: Vec::new(),
            scratch: ScanlineScratch::default(),
        }
    }

    /// These workers never wait between items: their busy time runs from their start to the
    /// end of their last item ([`Local::stop`]), so the clock is read per item only for the
    /// timeline (a read and a `Duration` sum per item cost one self-scheduling worker 2.5 of its
    /// 16.7 ns per zero-work item).
    #[inline]
    fn run(&mut self, job: &Job, item: &WorkItem, probe: &Probe) {
        let r = job(item);
        if probe.timeline {
            self.clock
                .item_done(probe, self.id, item.id, &mut self.spans);
        }
        self.stats.count(item, r.rays);
        self.item_bytes += wire::item_bytes(item);
        self.tally.add(&r);
        self.ids.push(item.id);
        self.results.push(r);
    }

    /// Run the items `range` of `items`, one hand-out, in [`Local::chunk_order`].
    #[inline]
    fn run_chunk(
        &mut self,
        job: &Job,
        (items, range): (&[WorkItem], Range<usize>),
        scanline: bool,
        probe: &Probe,
    ) {
        let order = self.chunk_order(items, range, scanline);
        for &i in &order {
            self.run(job, &items[i as usize], probe);
        }
        self.order = order;
    }

    /// The items of one hand-out in the order to run them: in scanline order where `scanline`
    /// ([`ScanlineScratch::order`]), else as handed out. In the worker's reused buffer: give
    /// it back to `self.order` when done.
    fn chunk_order(&mut self, items: &[WorkItem], range: Range<usize>, scanline: bool) -> Vec<u32> {
        let mut order = std::mem::take(&mut self.order);
        if scanline {
            self.scratch.order(items, range, &mut order);
        } else {
            as_handed_out(range, &mut order);
        }
        order
    }

    /// The worker has run its last item.
    pub(in crate::sched) fn stop(mut self, probe: &Probe) -> Self {
        self.clock.mark(probe);
        self
    }
}

/// Spawn one scoped thread per state and join them all (a panic becomes an error).
fn spawn_workers<S: Send>(
    states: Vec<S>,
    probe: &Probe,
    expect: usize,
    f: impl Fn(u32, S, &mut Local) + Sync,
) -> Result<Vec<Local>, SchedError> {
    std::thread::scope(|s| {
        let handles: Vec<_> = states
            .into_iter()
            .enumerate()
            .map(|(id, st)| {
                let f = &f;
                s.spawn(move || {
                    let mut l = Local::new(id as u32, probe, expect);
                    f(id as u32, st, &mut l);
                    l.stop(probe)
                })
            })
            .collect();
        let joined: Vec<_> = handles.into_iter().map(|h| h.join()).collect();
        joined
            .into_iter()
            .map(|r| r.map_err(|p| SchedError::WorkerPanic(panic_message(&p))))
            .collect()
    })
}

/// Play `rule` over `items` on `jobs.len()` worker threads; `jobs[i]` is worker i's job (the
/// same job for all but in a heterogeneous run). The rule decides who takes what; this
/// executor only chooses how to take it (an atomic counter where the rule allows one).
pub(in crate::sched) fn run_shared(
    rule: WorkerRule,
    items: &[WorkItem],
    jobs: &[Job],
    probe: Probe,
) -> Result<(Results, RunStats), SchedError> {
    let t0 = Instant::now();
    let (n, w) = (items.len(), jobs.len());
    let units = vec![(); w];
    let grab = match &rule {
        WorkerRule::Pool(p) => p.rule.as_grab().map_or(1, |g| g.grab),
        WorkerRule::Steal(s) => s.grab(),
        WorkerRule::Own(_) | WorkerRule::Dispense(_) => 1,
    };
    // A fair share plus a quarter: dynamic schedulers are rarely more uneven than that.
    let expect = n / w + n / (4 * w) + grab;
    let locals = match rule {
        WorkerRule::Own(own) => spawn_workers(units, &probe, expect, |id, (), l| {
            for i in own.items(id as usize, n, w) {
                l.run(&jobs[id as usize], &items[i], &probe);
            }
        })?,
        WorkerRule::Pool(pool) => match (pool.rule.as_grab(), pool.locked) {
            (Some(g), false) if g.constant().is_some() && !pool.scanline => {
                counter_locals(items, jobs, g.grab, expect, probe)?
            }
            (Some(g), false) => guided_locals(items, jobs, g, pool.scanline, expect, probe)?,
            (Some(g), true) if g.constant().is_some() && !pool.scanline => {
                mutex_locals(items, jobs, g.grab, expect, probe)?
            }
            _ => dispensed_locals(Box::new(pool.dispenser(n)), items, jobs, expect, probe)?,
        },
        WorkerRule::Dispense(d) => dispensed_locals(d, items, jobs, expect, probe)?,
        WorkerRule::Steal(Steal::Split { min }) => rayon_locals(items, jobs, w, min, probe)?,
        WorkerRule::Steal(Steal::Half) => deque_locals(items, jobs, expect, probe)?,
    };
    Ok(finish(locals, n, t0, probe))
}

/// A constant grab from one atomic counter: each take is one `fetch_add`.
fn counter_locals(
    items: &[WorkItem],
    jobs: &[Job],
    grab: usize,
    expect: usize,
    probe: Probe,
) -> Result<Vec<Local>, SchedError> {
    // Padded: nothing the workers read per item shares the counter's line; the cost is the
    // counter's own line moving between cores at every grab (`dispatch/shared_counter_only`).
    let next = CachePadded::new(AtomicUsize::new(0));
    grab_locals(items, jobs, grab, (expect, probe), || {
        next.fetch_add(grab, Ordering::Relaxed)
    })
}

/// Each worker takes `grab` consecutive items from where `take` says, until past the end.
fn grab_locals(
    items: &[WorkItem],
    jobs: &[Job],
    grab: usize,
    (expect, probe): (usize, Probe),
    take: impl Fn() -> usize + Sync,
) -> Result<Vec<Local>, SchedError> {
    let n = items.len();
    spawn_workers(vec![(); jobs.len()], &probe, expect, |id, (), l| loop {
        let s = take();
        if s >= n {
            break;
        }
        for it in &items[s..(s + grab).min(n)] {
            l.run(&jobs[id as usize], it, &probe);
        }
    })
}

/// A grab sized by what is left (guided), taken by compare-and-swap on one counter.
fn guided_locals(
    items: &[WorkItem],
    jobs: &[Job],
    g: Grab,
    scanline: bool,
    expect: usize,
    probe: Probe,
) -> Result<Vec<Local>, SchedError> {
    let n = items.len();
    let next = AtomicUsize::new(0);
    spawn_workers(vec![(); jobs.len()], &probe, expect, |id, (), l| {
        let job = &jobs[id as usize];
        let mut cur = next.load(Ordering::Relaxed);
        while cur < n {
            let c = g.size(n - cur).clamp(1, n - cur);
            match next.compare_exchange_weak(cur, cur + c, Ordering::Relaxed, Ordering::Relaxed) {
                Ok(_) => {
                    l.run_chunk(job, (items, cur..cur + c), scanline, &probe);
                    cur = next.load(Ordering::Relaxed);
                }
                Err(now) => cur = now,
            }
        }
    })
}

/// A constant grab taken under a mutex (pbrt-v4's loop: the next tile under its mutex).
fn mutex_locals(
    items: &[WorkItem],
    jobs: &[Job],
    grab: usize,
    expect: usize,
    probe: Probe,
) -> Result<Vec<Local>, SchedError> {
    let next = Mutex::new(0usize);
    grab_locals(items, jobs, grab, (expect, probe), || {
        let mut g = next.lock().unwrap_or_else(PoisonError::into_inner);
        let s = *g;
        *g += grab;
        s
    })
}

/// One crossbeam deque per worker, filled with its [`band`]; a thief takes half a victim's.
fn deque_locals(
    items: &[WorkItem],
    jobs: &[Job],
    expect: usize,
    probe: Probe,
) -> Result<Vec<Local>, SchedError> {
    let (n, w) = (items.len(), jobs.len());
    let deques: Vec<Worker<u32>> = (0..w).map(|_| Worker::new_fifo()).collect();
    for (id, d) in deques.iter().enumerate() {
        for i in band(id, n, w) {
            d.push(i as u32);
        }
    }
    let stealers: Vec<Stealer<u32>> = deques.iter().map(Worker::stealer).collect();
    let thieves = StealState::per_worker(w, STEAL_SEED);
    let states: Vec<_> = deques.into_iter().zip(thieves).collect();
    spawn_workers(states, &probe, expect, |id, (own, mut thief), l| {
        while let Some(i) = find_task(&own, &mut thief, &stealers) {
            l.run(&jobs[id as usize], &items[i as usize], &probe);
        }
    })
}

/// The seed of the threads' victim draws ([`StealState`]): which worker a thief asks first
/// changes who renders what, never an image.
const STEAL_SEED: u64 = 0x5eed;

/// A pool of any shape played under one lock ([`Dispense`]): each worker reports its previous
/// hand-out as it asks for the next.
fn dispensed_locals(
    dispenser: Box<dyn Dispense>,
    items: &[WorkItem],
    jobs: &[Job],
    expect: usize,
    probe: Probe,
) -> Result<Vec<Local>, SchedError> {
    let scanline = dispenser.scanline();
    let dispenser = Mutex::new(dispenser);
    spawn_workers(vec![(); jobs.len()], &probe, expect, |id, (), l| {
        run_dispensed(
            id as usize,
            &dispenser,
            (items, scanline),
            &jobs[id as usize],
            l,
            &probe,
        )
    })
}

/// One worker of a pool: ask the dispenser for a hand-out (reporting the previous one), run
/// it (in scanline order where `scanline`), timing what the rule asks for, until no item is
/// left for it.
fn run_dispensed(
    id: usize,
    dispenser: &Mutex<Box<dyn Dispense>>,
    (items, scanline): (&[WorkItem], bool),
    job: &Job,
    l: &mut Local,
    probe: &Probe,
) {
    let mut last: Option<Report> = None;
    let mut times = ItemTimes::default();
    // Timed from the first request on: the rule's own answer comes with the first chunk.
    let mut timing = Timing::Chunks;
    loop {
        let asked = (timing != Timing::None).then(Instant::now);
        let (s, c) = {
            let mut d = dispenser.lock().unwrap_or_else(PoisonError::into_inner);
            let Some(r) = d.grant(id, last.take().as_ref()) else {
                break;
            };
            timing = d.timing();
            (r.start, r.len())
        };
        let grab_secs = asked.map_or(0.0, |t| t.elapsed().as_secs_f64());
        match timing {
            Timing::None => l.run_chunk(job, (items, s..s + c), scanline, probe),
            Timing::Chunks => {
                let t0 = Instant::now();
                l.run_chunk(job, (items, s..s + c), scanline, probe);
                last = Some(Report {
                    items: c,
                    secs: t0.elapsed().as_secs_f64(),
                    grab_secs,
                    times,
                });
            }
            Timing::Items => {
                let order = l.chunk_order(items, s..s + c, scanline);
                let secs = run_timed_groups(order.len(), &mut times, Instant::now, |k| {
                    l.run(job, &items[order[k] as usize], probe)
                });
                l.order = order;
                last = Some(Report {
                    items: c,
                    secs,
                    grab_secs,
                    times,
                });
            }
        }
    }
}

/// Run items `0..n` (by `run`), timing them in groups of [`dls::timed_group`] consecutive
/// ones into `times`; their seconds. One clock read per group instead of per item: a read and
/// a variance update cost ~30–40 ns, 2 % of a 1.7 µs pixel of `skewed_low` at 16 spp.
fn run_timed_groups(
    n: usize,
    times: &mut ItemTimes,
    mut clock: impl FnMut() -> Instant,
    mut run: impl FnMut(usize),
) -> f64 {
    let t0 = clock();
    let mut t = t0;
    let g = dls::timed_group(n);
    for start in (0..n).step_by(g) {
        let end = (start + g).min(n);
        for k in start..end {
            run(k);
        }
        let now = clock();
        times.add_group((end - start) as u64, (now - t).as_secs_f64());
        t = now;
    }
    (t - t0).as_secs_f64()
}

/// The worker's next item: its own deque's front, else the back half of a victim's (crossbeam's
/// `steal_batch_and_pop` takes half, as [`StealState::split`] says), the victims in the order
/// the thief's [`StealState`] gives.
fn find_task(own: &Worker<u32>, thief: &mut StealState, stealers: &[Stealer<u32>]) -> Option<u32> {
    if let Some(i) = own.pop() {
        return Some(i);
    }
    // Items are never created during the run: once every deque is empty, we are done.
    loop {
        let mut retry = false;
        for v in thief.victims() {
            match stealers[v].steal_batch_and_pop(own) {
                Taken::Success(i) => return Some(i),
                Taken::Retry => retry = true,
                Taken::Empty => {}
            }
        }
        if !retry {
            return None;
        }
    }
}

fn rayon_locals(
    items: &[WorkItem],
    jobs: &[Job],
    w: usize,
    grab: usize,
    probe: Probe,
) -> Result<Vec<Local>, SchedError> {
    use rayon::prelude::*;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(w)
        .build()
        .map_err(|e| SchedError::Pool(e.to_string()))?;
    // One fold accumulator per rayon leaf task, always on one thread: merge them by thread.
    let folds = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        pool.install(|| {
            items
                .par_iter()
                .with_min_len(grab)
                .fold(
                    || Local::new(rayon::current_thread_index().unwrap_or(0) as u32, &probe, 0),
                    |mut l, it| {
                        l.run(&jobs[l.id as usize], it, &probe);
                        l
                    },
                )
                .map(|l| l.stop(&probe))
                .collect::<Vec<Local>>()
        })
    }))
    .map_err(|p| SchedError::WorkerPanic(panic_message(&p)))?;
    let mut locals: Vec<Local> = (0..w as u32).map(|i| Local::new(i, &probe, 0)).collect();
    for f in folds {
        let l = &mut locals[f.id as usize];
        l.clock.absorb(&f.clock);
        l.stats.items += f.stats.items;
        l.stats.pixels += f.stats.pixels;
        l.stats.rays += f.stats.rays;
        l.item_bytes += f.item_bytes;
        l.spans.extend(f.spans);
        l.results.extend(f.results);
        l.ids.extend(f.ids);
        l.tally.merge(&f.tally);
    }
    Ok(locals)
}

/// The run's results and statistics from its workers' accumulations (also the lock-held
/// master's, which then adds its own hand-out counts).
pub(in crate::sched) fn finish(
    locals: Vec<Local>,
    n: usize,
    t0: Instant,
    probe: Probe,
) -> (Results, RunStats) {
    let wall = t0.elapsed().as_secs_f64();
    let mut stats = RunStats {
        items: n as u64,
        ..Default::default()
    };
    let mut spans = Vec::new();
    let (mut lists, mut ids) = (Vec::with_capacity(locals.len()), Vec::new());
    let mut tally = Tally::default();
    for l in locals {
        let mut ws = l.stats;
        ws.busy_s = l.clock.busy().as_secs_f64();
        ws.idle_s = (wall - ws.busy_s).max(0.0);
        stats.issued += ws.items;
        stats.bytes += l.item_bytes;
        stats.workers.push(ws);
        spans.extend(l.spans);
        tally.merge(&l.tally);
        lists.push(l.results);
        ids.push(l.ids);
    }
    // The results stay in the workers' lists (no per-item move): see `Results`. A duplicate
    // is either dropped by its worker and counted in its tally (the lock-held master), or
    // found here (a second result of an item in the lists; its rays would count).
    let (results, duplicates) = Results::from_lists(n, lists, &ids);
    tally.duplicates += duplicates;
    if probe.timeline {
        spans.sort_by_key(|s| (s.start_ns, s.worker));
        stats.timeline = Some(spans);
    }
    stats.wall_s = wall;
    tally.record(&mut stats);
    (results, stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;
    use std::time::Duration;

    #[test]
    fn a_chunk_is_timed_in_groups_so_the_clock_is_read_at_most_33_times() {
        // A fake clock 1 µs further at every read; every item runs once, in order.
        let items: Vec<WorkItem> = (0..1024).map(|i| WorkItem::rect(i, i, 0, 1, 1)).collect();
        let (reads, base) = (Cell::new(0u32), Instant::now());
        let clock = || {
            reads.set(reads.get() + 1);
            base + Duration::from_micros(reads.get() as u64)
        };
        let mut ran = Vec::new();
        let mut times = ItemTimes::default();
        let secs = run_timed_groups(items.len(), &mut times, clock, |k| ran.push(items[k].id));
        assert_eq!(ran, (0..1024).collect::<Vec<u32>>());
        // 32 groups of 32 items: 33 reads (one per item would be 1 025).
        assert_eq!(reads.get(), 33);
        assert_eq!((times.n, times.groups), (1024, 32));
        assert!((secs - 32e-6).abs() < 1e-12, "{secs}");
        assert!((times.mean - 1e-6 / 32.0).abs() < 1e-15, "{times:?}");
        // A chunk of up to 32 items is timed item by item.
        reads.set(0);
        let mut small = ItemTimes::default();
        run_timed_groups(5, &mut small, clock, |_| {});
        assert_eq!((reads.get(), small.n, small.groups), (6, 5, 5));
    }
}
