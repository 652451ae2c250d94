//! The master without a thread of its own (`passes = workers`). Its ledger is the master
//! thread's — a FIFO queue, at most B items outstanding per source, a handed-out item
//! re-queued at the back under the re-queue policy, the first result winning, a lost source's
//! items handed out again — kept behind one lock, and its pass is run by each local worker for
//! itself whenever it reports: results in, its own buffer topped up to B. No item and no result
//! crosses threads as a message, so no wake-up stands between a worker and its next item; a
//! master thread cannot hand out faster than one cross-thread round trip per B items per
//! source (`dispatch_ratio`'s floor table).
//!
//! Local threads only: an MPI rank or a GPU needs a thread that talks to it, and the fault
//! injector wraps sources that a master thread drives. A worker whose job panics is a lost
//! source: its unfinished items are re-queued (under `never`, lost).

use super::master::Progress;
use super::shared::{finish, Local};
use crate::core::metrics::{MasterStats, Probe, RunStats, Span, MASTER_LANE};
use crate::core::render::WorkItem;
use crate::sched::rule::MasterQueue;
use crate::sched::rule::MasterRule;
use crate::sched::{wire, Results, Returns, SchedError};
use crate::source::local::panic_message;
use crate::source::{Job, Wait};
use std::collections::VecDeque;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex, MutexGuard, PoisonError, TryLockError};
use std::time::{Duration, Instant};

/// How long an idle worker waits before it runs a pass again (nothing may be handed out to it
/// yet: items outstanding elsewhere under `timeout:<ms>`).
const TICK: Duration = Duration::from_millis(2);

/// What a worker does after its pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Step {
    /// Render what it holds.
    Render,
    /// Nothing it may take now: wait, then pass again.
    Idle,
    /// The run is over, or nothing is left that could come to it.
    Stop,
}

/// The ledger behind the lock: the items' side of the master (results stay with the workers
/// that made them, as in the shared schedulers: see `Results`).
struct Ledger {
    n: usize,
    buffer: usize,
    deadline: Option<Duration>,
    t0: quanta::Instant,
    /// The master's queue; only the timeout policy reads a clock for it.
    queue: MasterQueue,
    alive: Vec<bool>,
    /// First results reported so far.
    done: usize,
    /// How the run ended, once it has.
    end: Option<Result<(), SchedError>>,
    /// A pass's items, reused.
    scratch: Vec<u32>,
}

impl Ledger {
    fn new(n: usize, workers: usize, params: &MasterRule, deadline: Option<Duration>) -> Self {
        let t0 = quanta::Instant::now();
        Self {
            n,
            buffer: params.buffer,
            deadline,
            t0,
            queue: MasterQueue::new(n, params.requeue),
            alive: vec![true; workers],
            done: 0,
            end: None,
            scratch: Vec::new(),
        }
    }

    /// A worker's pass: count the `reported` first results it made since its last pass,
    /// decide whether the run is over, then top `held` (its items not yet run) up to B from
    /// the queue. `done[i]`: item i has a result (set by whoever rendered it first).
    fn pass(&mut self, reported: usize, held: &mut VecDeque<u32>, done: &[AtomicBool]) -> Step {
        self.done += reported;
        if self.end.is_none() {
            self.end = self.verdict();
        }
        if self.end.is_some() {
            return Step::Stop;
        }
        let now = if self.queue.timed() {
            quanta::Instant::now() - self.t0
        } else {
            Duration::ZERO
        };
        let mut got = std::mem::take(&mut self.scratch);
        self.queue.top_up(
            now,
            self.buffer.saturating_sub(held.len()),
            |i| done[i as usize].load(Ordering::Acquire),
            |i| held.contains(&i),
            &mut got,
        );
        held.extend(got.drain(..));
        self.scratch = got;
        match (held.is_empty(), self.queue.is_empty()) {
            (false, _) => Step::Render,
            // Under `never` an item leaves the queue when handed out, under the other policies
            // once it is found done: an empty queue has nothing more for this worker.
            (true, true) => Step::Stop,
            (true, false) => Step::Idle,
        }
    }

    /// Worker `w` is lost with `unfinished` (its items not run, and the one that failed): hand
    /// them out again at once, or (`never`) count them lost for good.
    fn lose(&mut self, w: usize, unfinished: impl Iterator<Item = u32>, done: &[AtomicBool]) {
        self.alive[w] = false;
        for i in unfinished {
            if done[i as usize].load(Ordering::Acquire) {
                continue;
            }
            self.queue.lost(i);
        }
        if self.end.is_none() {
            self.end = self.verdict();
        }
    }

    /// How the run ends, if it ends now (the master thread's verdict).
    fn verdict(&self) -> Option<Result<(), SchedError>> {
        Progress {
            total: self.n as u64,
            done: self.done as u64,
            known_lost: self.queue.known_lost,
            sources: self.alive.len() as u64,
            alive: self.alive.iter().filter(|&&a| a).count() as u64,
            requeue: self.queue.requeue(),
            deadline_passed: self.deadline.filter(|dl| self.t0.elapsed() >= *dl),
        }
        .verdict()
    }
}

/// The lock, and the bell idle workers wait on.
struct Shared<'a> {
    ledger: Mutex<Ledger>,
    bell: Condvar,
    /// Per item: it has a result.
    done: Vec<AtomicBool>,
    items: &'a [WorkItem],
    params: MasterRule,
    probe: Probe,
}

impl Shared<'_> {
    fn lock(&self) -> MutexGuard<'_, Ledger> {
        self.ledger.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// With stats on and no timeline, one pass in this many is timed and the master's dispatch
/// time is their sum scaled up. Timing every pass (two clock reads around it) made a run of
/// one-pixel zero-work items 1.43× as long at B = 2 per hand-out and 1.47–1.55× item by
/// item (`dispatch_ratio`, stats on/off pairs, 2-core Xeon VM).
const TIME_EVERY: u64 = 16;

/// What one worker accumulates (as a shared scheduler's worker does, plus its passes as the
/// master's); merged once at the end.
struct Worker {
    local: Local,
    master: MasterStats,
    /// Seconds of the timed passes, and how many were timed.
    timed_s: f64,
    timed: u64,
}

impl Worker {
    fn new(id: u32, probe: &Probe, expect: usize) -> Self {
        Self {
            local: Local::new(id, probe, expect),
            master: MasterStats::default(),
            timed_s: 0.0,
            timed: 0,
        }
    }

    /// Run passes and items until the run ends for this worker, or its job panics (it is then
    /// lost, and the ledger knows).
    fn run(&mut self, sh: &Shared<'_>, job: &Job) {
        let per_item = sh.params.returns == Returns::Item;
        let mut held: VecDeque<u32> = VecDeque::with_capacity(sh.params.buffer);
        let mut reported = 0;
        loop {
            // `item`: a pass after every item, but one that finds the lock taken is left to
            // the next item while the worker still holds some (as a master thread busy with
            // another source leaves a result in its cell); `hand_out`: a pass once all it
            // holds is run, waiting for the lock.
            let wait = !per_item || held.is_empty();
            let step = match self.pass(sh, reported, &mut held, wait) {
                Some(step) => {
                    reported = 0;
                    step
                }
                None => Step::Render,
            };
            match step {
                Step::Stop => break,
                Step::Idle => {
                    self.idle(sh);
                    continue;
                }
                Step::Render => {}
            }
            let run = if per_item { 1 } else { held.len() };
            for _ in 0..run {
                let Some(i) = held.pop_front() else { break };
                match self.render(sh, job, i) {
                    Some(first) => reported += usize::from(first),
                    None => {
                        let mut l = sh.lock();
                        // The results made since the last pass count before the loss.
                        l.done += reported;
                        l.lose(
                            self.local.id as usize,
                            std::iter::once(i).chain(held.drain(..)),
                            &sh.done,
                        );
                        drop(l);
                        sh.bell.notify_all();
                        return;
                    }
                }
            }
        }
    }

    /// Render item `i` unless it is done already: whether its result is the first (a later
    /// one is a duplicate, counted and dropped), or `None` when the job panicked.
    fn render(&mut self, sh: &Shared<'_>, job: &Job, i: u32) -> Option<bool> {
        let item = &sh.items[i as usize];
        self.local.item_bytes += wire::item_bytes(item);
        if sh.done[i as usize].load(Ordering::Acquire) {
            return Some(false); // a copy handed out again was done elsewhere
        }
        let r = catch_unwind(AssertUnwindSafe(|| job(item))).ok()?;
        let probe = &sh.probe;
        if probe.timeline {
            self.local
                .clock
                .item_done(probe, self.local.id, i, &mut self.local.spans);
        }
        self.local.stats.count(item, r.rays);
        if sh.done[i as usize].swap(true, Ordering::AcqRel) {
            self.local.tally.bytes += wire::result_bytes(&r);
            self.local.tally.duplicates += 1;
            return Some(false);
        }
        self.local.tally.add(&r);
        self.local.ids.push(i);
        self.local.results.push(r);
        Some(true)
    }

    /// One pass under the lock, waiting for it if `wait`, else `None` when it is taken.
    /// Timed as [`TIME_EVERY`] says; with a timeline every pass is timed, and one that handed
    /// something out goes into the master's lane.
    fn pass(
        &mut self,
        sh: &Shared<'_>,
        reported: usize,
        held: &mut VecDeque<u32>,
        wait: bool,
    ) -> Option<Step> {
        let probe = &sh.probe;
        let before = held.len();
        let timed =
            probe.timeline || (probe.stats && self.master.iterations.is_multiple_of(TIME_EVERY));
        let a = timed.then(quanta::Instant::now);
        let mut ledger = if wait {
            sh.lock()
        } else {
            match sh.ledger.try_lock() {
                Ok(l) => l,
                Err(TryLockError::Poisoned(p)) => p.into_inner(),
                Err(TryLockError::WouldBlock) => return None,
            }
        };
        let step = ledger.pass(reported, held, &sh.done);
        drop(ledger);
        if step == Step::Stop {
            sh.bell.notify_all();
        }
        self.master.iterations += 1;
        if let Some(a) = a {
            let b = quanta::Instant::now();
            self.timed_s += (b - a).as_secs_f64();
            self.timed += 1;
            if probe.timeline {
                self.local.clock.mark(probe); // the next item's span starts after the pass
                if held.len() > before {
                    let e = probe.tsc_epoch;
                    self.local.spans.push(Span {
                        worker: MASTER_LANE,
                        item: held[before],
                        start_ns: (a - e).as_nanos() as u64,
                        end_ns: (b - e).as_nanos() as u64,
                    });
                }
            }
        }
        Some(step)
    }

    /// The master's dispatch time of this worker's passes: the timed ones scaled to all.
    fn dispatch_s(&self) -> f64 {
        if self.timed == 0 {
            return 0.0;
        }
        self.timed_s * self.master.iterations as f64 / self.timed as f64
    }

    /// Nothing to take now: wait as the master's `wait` says, at most a tick.
    fn idle(&mut self, sh: &Shared<'_>) {
        let probe = &sh.probe;
        if probe.stats {
            self.local.clock.mark(probe); // busy until now
        }
        let t = probe.stats.then(Instant::now);
        match sh.params.wait {
            Wait::Block => {
                let l = sh.lock();
                if l.end.is_none() {
                    let _ = sh.bell.wait_timeout(l, TICK);
                }
            }
            // Nothing signals new work but the tick (or the run's end, which the next pass sees).
            Wait::Spin | Wait::Yield => sh.params.wait.poll(TICK, || false),
        }
        if let Some(t) = t {
            self.master.wait_s += t.elapsed().as_secs_f64();
            self.local.clock.restart(probe);
        }
    }
}

/// Run `items` under the master with `params`, its passes run by `jobs.len()` local workers
/// (worker i runs `jobs[i]`).
pub(in crate::sched) fn run_locked_master(
    params: &MasterRule,
    items: &[WorkItem],
    jobs: &[Job],
    deadline: Option<Duration>,
    probe: Probe,
) -> Result<(Results, RunStats), SchedError> {
    let t0 = Instant::now();
    let n = items.len();
    // A fair share plus a quarter, as the shared schedulers reserve.
    let expect = n / jobs.len().max(1) + n / (4 * jobs.len().max(1));
    let sh = Shared {
        ledger: Mutex::new(Ledger::new(n, jobs.len(), params, deadline)),
        bell: Condvar::new(),
        done: (0..n).map(|_| AtomicBool::new(false)).collect(),
        items,
        params: *params,
        probe,
    };
    let workers: Vec<Worker> = std::thread::scope(|s| {
        let handles: Vec<_> = jobs
            .iter()
            .enumerate()
            .map(|(id, job)| {
                let sh = &sh;
                s.spawn(move || {
                    let mut w = Worker::new(id as u32, &sh.probe, expect);
                    w.run(sh, job);
                    w.local.clock.mark(&sh.probe); // its last item or pass ended now
                    w
                })
            })
            .collect();
        // A worker's job runs under `catch_unwind`: a join fails only on a bug of its own.
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .map_err(|p| SchedError::WorkerPanic(panic_message(&p)))
            })
            .collect::<Result<_, _>>()
    })?;
    let ledger = sh
        .ledger
        .into_inner()
        .unwrap_or_else(PoisonError::into_inner);
    match ledger.end {
        Some(Err(e)) => return Err(e),
        Some(Ok(())) => {}
        // Every worker stopped on an empty queue: every item was reported.
        None if ledger.done == n => {}
        None => {
            return Err(SchedError::LostItems {
                lost: (n - ledger.done) as u64,
                total: n as u64,
            })
        }
    }
    let mut master = MasterStats::default();
    let locals = workers
        .into_iter()
        .map(|w| {
            master.dispatch_s += w.dispatch_s();
            master.wait_s += w.master.wait_s;
            master.iterations += w.master.iterations;
            w.local
        })
        .collect();
    // Duplicates were dropped as they were made (the `done` flags) and are in the tallies.
    let (results, mut stats) = finish(locals, n, t0, probe);
    stats.issued = ledger.queue.issued;
    stats.reissued = ledger.queue.reissued;
    stats.lost_sources = ledger.alive.iter().filter(|a| !**a).count() as u64;
    stats.master = Some(master);
    Ok((results, stats))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::render::TileResult;
    use crate::sched::{MasterParams, Passes, Requeue};
    use std::sync::atomic::AtomicU32;
    use std::sync::Arc;

    fn items(n: u32) -> Vec<WorkItem> {
        (0..n).map(|i| WorkItem::rect(i, i, 0, 1, 1)).collect()
    }

    fn result(it: &WorkItem) -> TileResult {
        TileResult {
            item: it.id,
            pixels: Default::default(),
            rays: 1,
            nonfinite: 0,
        }
    }

    fn params(buffer: usize, requeue: Requeue, returns: Returns) -> MasterRule {
        MasterParams {
            buffer,
            requeue,
            returns,
            passes: Passes::Workers,
            ..MasterParams::DEFAULT
        }
        .into()
    }

    /// Wait (at most 5 s) until `ok`.
    fn wait_until(ok: impl Fn() -> bool) {
        let t0 = Instant::now();
        while !ok() && t0.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    /// Worker 0's job: it says it has started, then waits until `count` reaches `until`.
    /// Worker 1's: it waits until worker 0 has started (so worker 0 has taken its first
    /// hand-out), then counts its items in `count`.
    fn stuck_and_counting(until: u32) -> [Job; 2] {
        let count = Arc::new(AtomicU32::new(0));
        let started = Arc::new(AtomicBool::new(false));
        let (c, s) = (count.clone(), started.clone());
        let stuck: Job = Arc::new(move |it: &WorkItem| {
            s.store(true, Ordering::SeqCst);
            wait_until(|| c.load(Ordering::SeqCst) >= until);
            result(it)
        });
        let counting: Job = Arc::new(move |it: &WorkItem| {
            wait_until(|| started.load(Ordering::SeqCst));
            count.fetch_add(1, Ordering::SeqCst);
            result(it)
        });
        [stuck, counting]
    }

    /// Worker 0 is stuck on its first hand-out until worker 1 has run every other item: it
    /// holds B items and is given no more, whichever way results come back.
    #[test]
    fn a_stuck_worker_holds_its_b_items_and_no_more() {
        const N: u32 = 40;
        for returns in Returns::ALL {
            for b in [1, 2, 5] {
                let jobs = stuck_and_counting(N - b);
                let p = params(b as usize, Requeue::Never, returns);
                let (res, stats) =
                    run_locked_master(&p, &items(N), &jobs, None, Probe::new(true, false)).unwrap();
                let per: Vec<u64> = stats.workers.iter().map(|w| w.items).collect();
                assert_eq!(
                    per,
                    vec![u64::from(b), u64::from(N - b)],
                    "{returns:?} B={b}"
                );
                assert!((0..N).all(|i| res.has(i)));
                assert_eq!((stats.issued, stats.reissued, stats.duplicates), (40, 0, 0));
            }
        }
    }

    /// Under `seed` a handed-out item goes to the back of the queue: the idle worker meets
    /// worker 0's stuck item there and runs it, and worker 0's late copy is a duplicate.
    #[test]
    fn seed_hands_a_stuck_item_to_the_idle_worker() {
        const N: u32 = 30;
        for returns in Returns::ALL {
            // Worker 0 waits until worker 1 has run all N items, its stuck one included.
            let jobs = stuck_and_counting(N);
            let p = params(1, Requeue::Revisit, returns);
            let (res, stats) =
                run_locked_master(&p, &items(N), &jobs, None, Probe::new(true, false)).unwrap();
            assert!((0..N).all(|i| res.has(i)));
            let per: Vec<u64> = stats.workers.iter().map(|w| w.items).collect();
            assert_eq!(per, vec![1, u64::from(N)], "{returns:?}");
            assert_eq!((stats.reissued, stats.duplicates), (1, 1), "{returns:?}");
            assert_eq!(stats.rays, u64::from(N), "a duplicate's rays do not count");
        }
    }

    /// A worker whose job panics is a lost source: under `seed` and `timeout` its items are
    /// run by the other; under `never` they are lost, counted at once (no deadline needed).
    #[test]
    fn a_panicking_worker_is_a_lost_source() {
        const N: u32 = 50;
        // Worker 1 waits for worker 0's death, so a late-starting worker 0 (a loaded machine)
        // still takes its items and dies rather than finding the queue empty.
        let jobs = || -> [Job; 2] {
            let died = Arc::new(std::sync::atomic::AtomicBool::new(false));
            let d = died.clone();
            let dies: Job = Arc::new(move |_: &WorkItem| {
                d.store(true, std::sync::atomic::Ordering::SeqCst);
                panic!("worker 0 dies")
            });
            let fine: Job = Arc::new(move |it: &WorkItem| {
                let t0 = Instant::now();
                while !died.load(std::sync::atomic::Ordering::SeqCst)
                    && t0.elapsed() < Duration::from_secs(5)
                {
                    std::thread::sleep(Duration::from_micros(50));
                }
                result(it)
            });
            [dies, fine]
        };
        for requeue in [Requeue::Revisit, Requeue::Timeout(Duration::from_secs(60))] {
            for returns in Returns::ALL {
                let p = params(3, requeue, returns);
                let (res, stats) =
                    run_locked_master(&p, &items(N), &jobs(), None, Probe::new(true, false))
                        .unwrap();
                assert!((0..N).all(|i| res.has(i)), "{requeue:?} {returns:?}");
                assert_eq!(stats.lost_sources, 1);
                // Worker 0 took 3 items at most and finished none: each is handed out again.
                assert!((1..=3).contains(&stats.reissued), "{}", stats.reissued);
            }
        }
        let p = params(3, Requeue::Never, Returns::Item);
        let t0 = Instant::now();
        let err =
            run_locked_master(&p, &items(N), &jobs(), None, Probe::new(true, false)).unwrap_err();
        assert!(
            matches!(err, SchedError::LostItems { lost: 3, total: 50 }),
            "{err}"
        );
        assert!(t0.elapsed() < Duration::from_secs(5));
    }

    /// A deadline ends a run that would take far longer, as the master thread's does.
    #[test]
    fn the_deadline_ends_the_run() {
        let slow: Job = Arc::new(|it: &WorkItem| {
            std::thread::sleep(Duration::from_millis(2));
            result(it)
        });
        let jobs = [slow.clone(), slow];
        let p = params(2, Requeue::Revisit, Returns::Item);
        let t0 = Instant::now();
        let err = run_locked_master(
            &p,
            &items(10_000),
            &jobs,
            Some(Duration::from_millis(50)),
            Probe::new(false, false),
        )
        .unwrap_err();
        assert!(
            matches!(err, SchedError::Deadline { done, total: 10_000, .. } if done < 10_000),
            "{err}"
        );
        assert!(t0.elapsed() < Duration::from_secs(5), "{:?}", t0.elapsed());
    }

    /// The master's statistics: one pass per item at least (item returns), every pass counted
    /// and, with stats on, a dispatch time; without stats none.
    #[test]
    fn passes_are_counted_and_timed_only_with_stats() {
        let job: Job = Arc::new(result);
        let jobs = [job.clone(), job];
        let p = params(4, Requeue::Never, Returns::HandOut);
        for stats_on in [true, false] {
            let (_, stats) =
                run_locked_master(&p, &items(4000), &jobs, None, Probe::new(stats_on, false))
                    .unwrap();
            let m = stats.master.unwrap();
            // A pass per hand-out of at most 4 items, one more per worker at the end.
            assert!(m.iterations >= 1000, "{}", m.iterations);
            assert_eq!(m.dispatch_s > 0.0, stats_on);
        }
    }
}
