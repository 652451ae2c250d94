//! Compute sources: the founding design's "computing power sources" (README). A source takes a
//! [`WorkItem`] and hands back a [`DelayedResult`] at once; the result is polled, taken or
//! waited on later.
//!
//! The trait is object safe so the master works over `Vec<Box<dyn ComputeSource>>`: local
//! threads ([`LocalThreadSource`]), fault-injecting wrappers ([`faulty`]) and, later, MPI ranks.
//! A source that dies (a worker panic, a killed rank) says so through [`ComputeSource::is_lost`]
//! and by failing its outstanding results; a result that is simply never delivered stays
//! pending, and only the master's re-queue policy or deadline can deal with it.

pub mod faulty;
pub mod local;

pub use faulty::{FaultPlan, FaultySource};
pub use local::LocalThreadSource;

use crate::render::{TileResult, WorkItem};
use crate::sched::{Span, WorkerStats};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::Thread;
use std::time::{Duration, Instant};

/// The per-item work every source runs: `render_item` in real runs, nothing in dispatch benches.
pub type Job = Arc<dyn Fn(&WorkItem) -> TileResult + Send + Sync>;

#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SourceFailure {
    #[error("compute source {source_id} lost: {reason}")]
    Lost { source_id: u32, reason: String },
    #[error("item {item} cancelled: the run was over")]
    Cancelled { item: u32 },
}

pub type Outcome = Result<TileResult, SourceFailure>;

#[derive(Debug)]
struct Cell {
    ready: AtomicBool,
    inner: Mutex<CellInner>,
}

/// Spare result cells of this thread (the master's): a cell whose result was taken and whose
/// completer is gone is reused, so handing out an item allocates nothing. A fresh allocation
/// and its free cost the master ~35 ns per one-pixel item (glibc, 2-core VM).
const SPARE_CELLS: usize = 4096;

thread_local! {
    static SPARE: std::cell::RefCell<Vec<Arc<Cell>>> = const { std::cell::RefCell::new(Vec::new()) };
}

impl Cell {
    fn new() -> Arc<Self> {
        SPARE.with(|s| s.borrow_mut().pop()).unwrap_or_else(|| {
            Arc::new(Cell {
                ready: AtomicBool::new(false),
                inner: Mutex::new(CellInner {
                    value: None,
                    waiter: None,
                }),
            })
        })
    }

    /// Keep `cell` for reuse if nobody else holds it any more.
    fn recycle(cell: &mut Arc<Self>) {
        let Some(c) = Arc::get_mut(cell) else { return };
        *c.ready.get_mut() = false;
        c.inner.clear_poison();
        let inner = c.inner.get_mut().unwrap_or_else(|e| e.into_inner());
        inner.value = None;
        inner.waiter = None;
        SPARE.with(|s| {
            let mut s = s.borrow_mut();
            if s.len() < SPARE_CELLS {
                s.push(cell.clone());
            }
        });
    }
}

#[derive(Debug)]
struct CellInner {
    value: Option<Outcome>,
    waiter: Option<Thread>,
}

/// A result that will arrive later (or never). Polling is one atomic load.
#[derive(Debug)]
pub struct DelayedResult {
    item: u32,
    source: u32,
    cell: Arc<Cell>,
}

/// The producing side of a [`DelayedResult`]. Dropped without [`Completer::complete`] (a worker
/// that unwound, a message dropped with its channel), it fails the result as lost, so nobody
/// waits forever on a source that is gone.
pub struct Completer {
    item: u32,
    source: u32,
    cell: Option<Arc<Cell>>,
}

impl DelayedResult {
    pub fn pending(item: u32, source: u32) -> (Self, Completer) {
        let cell = Cell::new();
        (
            Self {
                item,
                source,
                cell: cell.clone(),
            },
            Completer {
                item,
                source,
                cell: Some(cell),
            },
        )
    }

    /// A result that never arrives (a dropped message).
    pub fn never(item: u32, source: u32) -> Self {
        // No completer exists, so nothing can ever fill (or fail) it.
        Self {
            item,
            source,
            cell: Cell::new(),
        }
    }

    /// A result that is already there.
    pub fn ready(item: u32, source: u32, outcome: Outcome) -> Self {
        let (d, c) = Self::pending(item, source);
        c.complete(outcome);
        d
    }

    pub fn item(&self) -> u32 {
        self.item
    }
    pub fn source(&self) -> u32 {
        self.source
    }

    pub fn is_ready(&self) -> bool {
        self.cell.ready.load(Ordering::SeqCst)
    }

    /// The outcome if it is ready, else the handle back.
    pub fn try_take(self) -> Result<Outcome, Self> {
        if !self.is_ready() {
            return Err(self);
        }
        let v = self
            .cell
            .inner
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .value
            .take();
        v.ok_or(self)
    }

    /// Wait until the outcome arrives (forever for a [`DelayedResult::never`]).
    pub fn wait(mut self) -> Outcome {
        loop {
            match self.wait_timeout(Duration::from_secs(3600)) {
                Ok(o) => return o,
                Err(d) => self = d,
            }
        }
    }

    /// Wait at most `timeout`; on time-out the handle comes back.
    pub fn wait_timeout(self, timeout: Duration) -> Result<Outcome, Self> {
        let end = Instant::now() + timeout;
        loop {
            {
                let mut g = self.cell.inner.lock().unwrap_or_else(|e| e.into_inner());
                if let Some(v) = g.value.take() {
                    return Ok(v);
                }
                g.waiter = Some(std::thread::current());
            }
            let now = Instant::now();
            if now >= end {
                self.cell
                    .inner
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .waiter = None;
                return Err(self);
            }
            // An unpark that came before this park makes it return at once: no lost wake-up.
            std::thread::park_timeout(end - now);
        }
    }
}

impl Drop for DelayedResult {
    fn drop(&mut self) {
        Cell::recycle(&mut self.cell);
    }
}

impl Completer {
    pub fn item(&self) -> u32 {
        self.item
    }
    pub fn complete(mut self, outcome: Outcome) {
        if let Some(cell) = self.cell.take() {
            fill(&cell, outcome);
        }
    }
}

fn fill(cell: &Cell, outcome: Outcome) {
    let waiter = {
        let mut g = cell.inner.lock().unwrap_or_else(|e| e.into_inner());
        g.value = Some(outcome);
        // SeqCst: pairs with the master's arming in `Doorbell::wait` (see `Notifier::ring`).
        cell.ready.store(true, Ordering::SeqCst);
        g.waiter.take()
    };
    if let Some(t) = waiter {
        t.unpark();
    }
}

impl Drop for Completer {
    fn drop(&mut self) {
        if let Some(cell) = self.cell.take() {
            let reason = "result dropped unfinished".to_string();
            fill(
                &cell,
                Err(SourceFailure::Lost {
                    source_id: self.source,
                    reason,
                }),
            );
        }
    }
}

/// How a source wakes a waiting master: [`Notifier::ring`] after completing a result. It sends
/// only while the master is armed (about to block), so a busy master pays nothing per item —
/// one channel message per item was ~20 % of the master's dispatch cost at one-pixel items.
/// A hint only: the master always polls the results themselves.
#[derive(Clone, Debug)]
pub struct Notifier {
    tx: crossbeam::channel::Sender<()>,
    armed: Arc<AtomicBool>,
}

impl Notifier {
    /// Call after the result is visible (its cell filled): the SeqCst pair with
    /// [`Doorbell::wait`] makes sure one side sees the other, so no wake-up is lost.
    pub fn ring(&self) {
        if self.armed.load(Ordering::SeqCst) && self.armed.swap(false, Ordering::SeqCst) {
            let _ = self.tx.send(());
        }
    }
}

/// The master's side of its sources' [`Notifier`]s.
#[derive(Debug)]
pub struct Doorbell {
    tx: crossbeam::channel::Sender<()>,
    rx: crossbeam::channel::Receiver<()>,
    armed: Arc<AtomicBool>,
}

impl Default for Doorbell {
    fn default() -> Self {
        let (tx, rx) = crossbeam::channel::unbounded();
        Self {
            tx,
            rx,
            armed: Arc::new(AtomicBool::new(false)),
        }
    }
}

impl Doorbell {
    pub fn notifier(&self) -> Notifier {
        Notifier {
            tx: self.tx.clone(),
            armed: self.armed.clone(),
        }
    }

    /// Wait until a source rings or `timeout` passes, unless `ready()` already holds after
    /// arming (a result that landed before arming rang nobody). `wait` picks how.
    pub fn wait(&self, timeout: Duration, wait: crate::sched::Wait, ready: impl Fn() -> bool) {
        use crate::sched::Wait;
        // Armed stays armed until a ring disarms it: the master never writes `false` itself,
        // and stores `true` only when a ring took it. Each store moves the flag's line away
        // from the workers, who read it at every result; two stores per wait cost B = 2
        // ~13 % of its dispatch time. A stale armed flag costs at most one extra message.
        if !self.armed.load(Ordering::SeqCst) {
            self.armed.store(true, Ordering::SeqCst);
        }
        if !ready() {
            match wait {
                Wait::Block => {
                    let _ = self.rx.recv_timeout(timeout);
                }
                Wait::Spin | Wait::Yield => {
                    let end = Instant::now() + timeout;
                    while self.rx.try_recv().is_err() && Instant::now() < end {
                        if wait == Wait::Spin {
                            std::hint::spin_loop();
                        } else {
                            std::thread::yield_now();
                        }
                    }
                }
            }
        }
        while self.rx.try_recv().is_ok() {}
    }
}

/// What a source did over a run (idle time is filled in by the scheduler from the wall time).
#[derive(Clone, Debug, Default)]
pub struct SourceReport {
    pub stats: WorkerStats,
    pub spans: Vec<Span>,
}

/// Instrumentation settings shared by every source of a run.
#[derive(Clone, Copy, Debug)]
pub struct Probe {
    /// Time every item (busy time); off, no clock is read per item.
    pub stats: bool,
    pub timeline: bool,
    /// Time zero of the run's timeline.
    pub epoch: Instant,
    /// The same time zero on the TSC clock used per item (`quanta`: ~18 ns a read on the
    /// 2-core KVM dev box vs ~47 ns for `std::time::Instant::now`).
    pub tsc_epoch: quanta::Instant,
}

impl Probe {
    pub fn new(stats: bool, timeline: bool) -> Self {
        Self {
            stats: stats || timeline,
            timeline,
            epoch: Instant::now(),
            tsc_epoch: quanta::Instant::now(),
        }
    }
}

/// A worker's busy time: an item's busy span runs from the end of the worker's previous item
/// (or from [`BusyClock::restart`], after a wait) to its own end. Busy time therefore includes
/// the per-item bookkeeping between two items (taking the next item), never a wait that
/// restarts the clock. Consecutive spans telescope, so the clock keeps only where the current
/// run of items started and where its last item ended: one clock read per item and no
/// arithmetic ([`BusyClock::item_done`]), or, for a worker that never waits and records no
/// timeline, a single read after its last item ([`BusyClock::mark`]).
pub(crate) struct BusyClock {
    /// Busy time of the runs of items closed by a wait.
    closed: Duration,
    /// Start of the current run of items (TSC clock).
    since: quanta::Instant,
    /// End of the current run's last item: the start of the next item's busy span.
    last: quanta::Instant,
}

impl BusyClock {
    pub fn start(probe: &Probe) -> Self {
        let mut c = Self {
            closed: Duration::ZERO,
            since: probe.tsc_epoch,
            last: probe.tsc_epoch,
        };
        c.restart(probe);
        c
    }

    /// The worker waited: close the current run of items; the next busy span starts now.
    pub fn restart(&mut self, probe: &Probe) {
        if probe.stats {
            self.closed += self.last - self.since;
            self.since = quanta::Instant::now();
            self.last = self.since;
        }
    }

    /// The worker's latest item ended now (no timeline entry).
    #[inline]
    pub fn mark(&mut self, probe: &Probe) {
        if probe.stats {
            self.last = quanta::Instant::now();
        }
    }

    /// Item `item` of `worker` ended now: its span ends here, and goes into the timeline if
    /// one is recorded.
    #[inline]
    pub fn item_done(&mut self, probe: &Probe, worker: u32, item: u32, spans: &mut Vec<Span>) {
        if !probe.stats {
            return;
        }
        let t1 = quanta::Instant::now();
        if probe.timeline {
            let e = probe.tsc_epoch;
            spans.push(Span {
                worker,
                item,
                start_ns: (self.last - e).as_nanos() as u64,
                end_ns: (t1 - e).as_nanos() as u64,
            });
        }
        self.last = t1;
    }

    /// Count `other`'s busy time as this clock's (a worker's clocks of several runs).
    pub fn absorb(&mut self, other: &BusyClock) {
        self.closed += other.busy();
    }

    /// Total busy time so far.
    pub fn busy(&self) -> Duration {
        self.closed + (self.last - self.since)
    }
}

/// `submit` of a source whose hand-out logic lives in `submit_batch`: a batch of one.
pub fn submit_one<S: ComputeSource + ?Sized>(src: &mut S, item: WorkItem) -> DelayedResult {
    let mut out = Vec::with_capacity(1);
    src.submit_batch(&mut vec![item], &mut out);
    out.pop().expect("one result per item")
}

pub trait ComputeSource: Send {
    fn id(&self) -> u32;
    fn label(&self) -> String;
    /// Hand an item over; returns at once. A lost source returns an already failed result.
    fn submit(&mut self, item: WorkItem) -> DelayedResult;
    /// Hand several items over at once (one message where the source can; a local thread
    /// then wakes once per hand-out, not per item); their results are pushed to `out` in order.
    /// `items` is left empty (its allocation is kept for the next hand-out).
    fn submit_batch(&mut self, items: &mut Vec<WorkItem>, out: &mut Vec<DelayedResult>) {
        out.extend(items.drain(..).map(|it| self.submit(it)));
    }
    /// The source is gone: none of its outstanding results will arrive.
    fn is_lost(&self) -> bool;
    /// Where to ring after each completed result (sources that cannot simply never ring; the
    /// master then wakes on its own tick).
    fn set_notifier(&mut self, _notifier: Notifier) {}
    /// Stop (skipping queued work) and report what the source did.
    fn finish(self: Box<Self>) -> SourceReport;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn result(item: u32) -> TileResult {
        TileResult {
            item,
            pixels: vec![],
            rays: 0,
            nonfinite: 0,
        }
    }

    #[test]
    fn delayed_result_poll_take_wait() {
        let (d, c) = DelayedResult::pending(4, 1);
        assert!(!d.is_ready());
        let d = d.try_take().unwrap_err();
        let d = d.wait_timeout(Duration::from_millis(5)).unwrap_err();
        let t = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(20));
            c.complete(Ok(result(4)));
        });
        assert_eq!(d.wait().unwrap().item, 4);
        t.join().unwrap();
        let d = DelayedResult::ready(7, 0, Ok(result(7)));
        assert!(d.is_ready());
        assert_eq!(d.try_take().unwrap().unwrap().item, 7);
    }

    #[test]
    fn dropped_completer_fails_the_result_and_never_stays_pending() {
        let (d, c) = DelayedResult::pending(2, 3);
        drop(c);
        assert!(matches!(
            d.wait_timeout(Duration::from_secs(1)),
            Ok(Err(SourceFailure::Lost { source_id: 3, .. }))
        ));
        let n = DelayedResult::never(1, 0);
        assert!(n.wait_timeout(Duration::from_millis(10)).is_err());
    }

    #[test]
    fn a_recycled_cell_starts_empty_and_a_held_one_is_never_reused() {
        // Taken with its completer gone: the cell goes back to this thread's spares.
        let d = DelayedResult::ready(1, 0, Ok(result(1)));
        assert_eq!(d.try_take().unwrap().unwrap().item, 1);
        let (d, c) = DelayedResult::pending(2, 0);
        assert!(!d.is_ready(), "a reused cell must not carry the old result");
        let d = d.try_take().unwrap_err();
        // Dropped while its completer lives: not recycled, so the completer fills its own cell.
        let (d2, c2) = DelayedResult::pending(3, 0);
        drop(d2);
        let fresh: Vec<_> = (0..8).map(|i| DelayedResult::pending(10 + i, 0)).collect();
        c2.complete(Ok(result(3)));
        assert!(fresh.iter().all(|(d, _)| !d.is_ready()));
        c.complete(Ok(result(2)));
        assert_eq!(d.try_take().unwrap().unwrap().item, 2);
    }

    #[test]
    fn batch_results_come_back_in_order_and_a_panic_fails_the_rest_as_lost() {
        let job: Job = Arc::new(|it: &WorkItem| {
            assert!(it.id != 5, "item 5 panics");
            result(it.id)
        });
        let mut src = LocalThreadSource::spawn(0, job, Probe::new(true, false));
        let mut out = Vec::new();
        let mut items: Vec<_> = (0..8).map(|i| WorkItem::rect(i, 0, 0, 1, 1)).collect();
        src.submit_batch(&mut items, &mut out);
        assert!(items.is_empty());
        let later = src.submit(WorkItem::rect(8, 0, 0, 1, 1));
        let got: Vec<_> = out
            .into_iter()
            .map(|d| (d.item(), d.wait_timeout(Duration::from_secs(10)).ok()))
            .collect();
        for (i, (item, o)) in got.iter().enumerate() {
            assert_eq!(*item, i as u32);
            match o {
                Some(Ok(r)) => assert!(i < 5 && r.item == i as u32),
                Some(Err(SourceFailure::Lost { .. })) => assert!(i >= 5),
                other => panic!("item {i}: {other:?}"),
            }
        }
        let later = later.wait_timeout(Duration::from_secs(10));
        assert!(matches!(later, Ok(Err(SourceFailure::Lost { .. }))));
        assert!(src.is_lost());
        assert_eq!(Box::new(src).finish().stats.items, 5);
    }

    /// The master arms the bell, re-checks, and sleeps; a worker fills a cell and rings. If a
    /// wake-up could be lost, some wait would run to its (long) timeout.
    #[test]
    fn the_doorbell_loses_no_wake_up() {
        let bell = Doorbell::default();
        let ring = bell.notifier();
        let (tx, rx) = crossbeam::channel::unbounded::<Completer>();
        let worker = std::thread::spawn(move || {
            for c in rx {
                c.complete(Ok(result(0)));
                ring.ring();
            }
        });
        let timeout = Duration::from_secs(5);
        for i in 0..2000 {
            let (d, c) = DelayedResult::pending(i, 0);
            tx.send(c).unwrap();
            let t = Instant::now();
            while !d.is_ready() {
                bell.wait(timeout, crate::sched::Wait::Block, || d.is_ready());
            }
            assert!(t.elapsed() < timeout, "round {i}: the ring was lost");
        }
        drop(tx);
        worker.join().unwrap();
    }
}
