//! Compute sources: the report's "computing power sources". A source takes a [`WorkItem`] and
//! hands back a [`DelayedResult`] at once; the result is polled, taken or waited on later.
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

impl Cell {
    fn new() -> Arc<Self> {
        Arc::new(Cell {
            ready: AtomicBool::new(false),
            inner: Mutex::new(CellInner {
                value: None,
                waiter: None,
            }),
        })
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
        self.cell.ready.load(Ordering::Acquire)
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
        cell.ready.store(true, Ordering::Release);
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

/// How a source wakes a blocked master: it sends (source, item) after completing a result.
/// A hint only: the master always polls the results themselves.
#[derive(Clone, Debug)]
pub struct Notifier(pub crossbeam::channel::Sender<(u32, u32)>);

impl Notifier {
    pub fn ring(&self, source: u32, item: u32) {
        let _ = self.0.send((source, item));
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

pub trait ComputeSource: Send {
    fn id(&self) -> u32;
    fn label(&self) -> String;
    /// Hand an item over; returns at once. A lost source returns an already failed result.
    fn submit(&mut self, item: WorkItem) -> DelayedResult;
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
}
