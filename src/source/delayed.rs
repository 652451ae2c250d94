//! The result cell between a source and the master: [`DelayedResult`] (the master's end,
//! polled with one atomic load) and [`Completer`] (the source's end, which fails the result as
//! lost if dropped unfinished); for a hand-out whose results come back together, one cell and
//! one [`HandOutCompleter`] for all its items.

use super::{Outcome, SourceFailure};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::Thread;
use std::time::{Duration, Instant};

/// `repr(C)`, `ready` first: the flag the master polls shares its cache line with the Arc's
/// counts, which the master's take touches next, so a result costs it one line moved from
/// the worker instead of two.
#[derive(Debug)]
#[repr(C)]
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

    /// Keep `cell` for reuse if nobody else holds it any more, returning the value it held;
    /// a cell still shared comes back. Moved in, so keeping it costs no reference-count
    /// update.
    fn recycle(mut cell: Arc<Self>) -> Result<Option<Outcome>, Arc<Self>> {
        let Some(c) = Arc::get_mut(&mut cell) else {
            return Err(cell);
        };
        *c.ready.get_mut() = false;
        c.inner.clear_poison();
        let inner = c.inner.get_mut().unwrap_or_else(|e| e.into_inner());
        let value = inner.value.take();
        inner.waiter = None;
        SPARE.with(|s| {
            let mut s = s.borrow_mut();
            if s.len() < SPARE_CELLS {
                s.push(cell);
            }
        });
        Ok(value)
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
    link: Link,
}

/// Where a [`DelayedResult`]'s outcome arrives.
#[derive(Debug)]
enum Link {
    /// A cell of its own.
    Own(Arc<Cell>),
    /// The cell of a hand-out returned as a whole, and this item's place in it.
    Shared(Arc<HandOutCell>, usize),
    /// Its own cell went back to the spares (in `try_take` or `drop`).
    Gone,
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
    /// An empty result of `item` from `source`, and the completer that fills it.
    pub fn pending(item: u32, source: u32) -> (Self, Completer) {
        let cell = Cell::new();
        (
            Self {
                item,
                source,
                link: Link::Own(cell.clone()),
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
            link: Link::Own(Cell::new()),
        }
    }

    /// A result that is already there.
    pub fn ready(item: u32, source: u32, outcome: Outcome) -> Self {
        let (d, c) = Self::pending(item, source);
        c.complete(outcome);
        d
    }

    /// The id of the item this is the result of.
    pub fn item(&self) -> u32 {
        self.item
    }
    /// The id of the source the item was handed to.
    pub fn source(&self) -> u32 {
        self.source
    }

    /// Has the outcome arrived? One atomic load; never blocks.
    pub fn is_ready(&self) -> bool {
        match &self.link {
            Link::Own(c) => c.ready.load(Ordering::SeqCst),
            Link::Shared(h, _) => h.ready.load(Ordering::SeqCst),
            Link::Gone => false,
        }
    }

    /// The outcome if it is ready, else the handle back. A completer drops its handle right
    /// after filling the cell, so the master usually holds the only one by now: then the
    /// value is taken and the cell recycled without the lock (one atomic read-modify-write per
    /// result instead of five: lock, unlock, the uniqueness check, a clone and a drop; M-132).
    pub fn try_take(mut self) -> Result<Outcome, Self> {
        if !self.is_ready() {
            return Err(self);
        }
        let cell = match std::mem::replace(&mut self.link, Link::Gone) {
            Link::Own(cell) => cell,
            Link::Shared(h, k) => {
                let v = h.lock().values.get_mut(k).and_then(Option::take);
                self.link = Link::Shared(h, k);
                return v.ok_or(self);
            }
            Link::Gone => return Err(self),
        };
        match Cell::recycle(cell) {
            Ok(value) => value.ok_or(self),
            Err(cell) => {
                let v = cell
                    .inner
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .value
                    .take();
                self.link = Link::Own(cell);
                v.ok_or(self)
            }
        }
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
        let cell = match &self.link {
            Link::Own(cell) => cell,
            Link::Shared(h, k) => {
                return match h.wait(*k, end) {
                    Some(v) => Ok(v),
                    None => Err(self),
                }
            }
            Link::Gone => {
                // Its value was taken: nothing more will arrive.
                std::thread::sleep(timeout);
                return Err(self);
            }
        };
        loop {
            {
                let mut g = cell.inner.lock().unwrap_or_else(|e| e.into_inner());
                if let Some(v) = g.value.take() {
                    return Ok(v);
                }
                g.waiter = Some(std::thread::current());
            }
            let now = Instant::now();
            if now >= end {
                cell.inner.lock().unwrap_or_else(|e| e.into_inner()).waiter = None;
                return Err(self);
            }
            // An unpark that came before this park makes it return at once: no lost wake-up.
            std::thread::park_timeout(end - now);
        }
    }
}

impl Drop for DelayedResult {
    fn drop(&mut self) {
        if let Link::Own(cell) = std::mem::replace(&mut self.link, Link::Gone) {
            // A shared cell comes back and is dropped: its completer fills it for nobody.
            let _ = Cell::recycle(cell);
        }
    }
}

impl Completer {
    /// The id of the item whose result this completes.
    pub fn item(&self) -> u32 {
        self.item
    }
    /// Deliver `outcome` and wake a waiter, if any.
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

/// The one cell of a hand-out whose results come back together ([`super::Returns::HandOut`]):
/// the worker fills its own list and publishes it once, so the lot costs one lock, one flag
/// and one ring instead of one of each per item.
#[derive(Debug)]
struct HandOutCell {
    ready: AtomicBool,
    inner: Mutex<HandOutInner>,
}

#[derive(Debug, Default)]
struct HandOutInner {
    /// One per item, in hand-out order, once published; each is taken once.
    values: Vec<Option<Outcome>>,
    waiters: Vec<Thread>,
}

impl HandOutCell {
    fn lock(&self) -> std::sync::MutexGuard<'_, HandOutInner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Wait until published (or `end`), then take result `k`.
    fn wait(&self, k: usize, end: Instant) -> Option<Outcome> {
        loop {
            {
                let mut g = self.lock();
                if self.ready.load(Ordering::SeqCst) {
                    return g.values.get_mut(k).and_then(Option::take);
                }
                let me = std::thread::current();
                if !g.waiters.iter().any(|t| t.id() == me.id()) {
                    g.waiters.push(me);
                }
            }
            let now = Instant::now();
            if now >= end {
                return None;
            }
            // An unpark that came before this park makes it return at once: no lost wake-up.
            std::thread::park_timeout(end - now);
        }
    }
}

/// The producing side of a hand-out returned as a whole: results are set one by one on the
/// worker's side and published together. Dropped unpublished (a worker that unwound), it
/// publishes what it has and fails the rest as lost.
pub struct HandOutCompleter {
    source: u32,
    cell: Option<Arc<HandOutCell>>,
    values: Vec<Option<Outcome>>,
}

impl HandOutCompleter {
    /// The results of `items` (a hand-out to `source`), pushed to `out` in order, and the one
    /// completer that fills them all.
    pub fn pending(
        items: impl ExactSizeIterator<Item = u32>,
        source: u32,
        out: &mut Vec<DelayedResult>,
    ) -> Self {
        let n = items.len();
        let cell = Arc::new(HandOutCell {
            ready: AtomicBool::new(false),
            inner: Mutex::new(HandOutInner::default()),
        });
        out.extend(items.enumerate().map(|(k, item)| DelayedResult {
            item,
            source,
            link: Link::Shared(cell.clone(), k),
        }));
        Self {
            source,
            cell: Some(cell),
            values: (0..n).map(|_| None).collect(),
        }
    }

    /// The outcome of the hand-out's `k`-th item (kept until [`Self::publish`]).
    pub fn set(&mut self, k: usize, outcome: Outcome) {
        if let Some(v) = self.values.get_mut(k) {
            *v = Some(outcome);
        }
    }

    /// Deliver every outcome (those never set fail as lost) and wake waiters.
    pub fn publish(mut self) {
        self.deliver();
    }

    fn deliver(&mut self) {
        let Some(cell) = self.cell.take() else {
            return;
        };
        let lost = SourceFailure::Lost {
            source_id: self.source,
            reason: "result dropped unfinished".to_string(),
        };
        let mut values = std::mem::take(&mut self.values);
        for v in values.iter_mut().filter(|v| v.is_none()) {
            *v = Some(Err(lost.clone()));
        }
        let waiters = {
            let mut g = cell.lock();
            g.values = values;
            // SeqCst: pairs with the master's arming in `Doorbell::wait` (see `Notifier::ring`).
            cell.ready.store(true, Ordering::SeqCst);
            std::mem::take(&mut g.waiters)
        };
        for t in waiters {
            t.unpark();
        }
    }
}

impl Drop for HandOutCompleter {
    fn drop(&mut self) {
        self.deliver();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::empty_result as result;

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
    fn a_hand_out_is_published_whole_in_order_and_a_dropped_one_fails_what_it_lacks() {
        let mut out = Vec::new();
        let mut done = HandOutCompleter::pending([5, 6, 7].into_iter(), 2, &mut out);
        assert_eq!(out.iter().map(|d| d.item()).collect::<Vec<_>>(), [5, 6, 7]);
        done.set(0, Ok(result(5)));
        done.set(1, Ok(result(6)));
        // Set but not published: nothing is ready yet.
        assert!(out.iter().all(|d| !d.is_ready()));
        let d7 = out.pop().unwrap();
        let t = std::thread::spawn(move || d7.wait_timeout(Duration::from_secs(10)));
        std::thread::sleep(Duration::from_millis(20));
        done.set(2, Ok(result(7)));
        done.publish();
        assert_eq!(t.join().unwrap().unwrap().unwrap().item, 7);
        let got: Vec<u32> = out
            .into_iter()
            .map(|d| d.try_take().unwrap().unwrap().item)
            .collect();
        assert_eq!(got, [5, 6]);
        // Dropped with one result set: that one arrives, the other fails as lost.
        let mut out = Vec::new();
        let mut done = HandOutCompleter::pending([1, 2].into_iter(), 4, &mut out);
        done.set(1, Ok(result(2)));
        drop(done);
        let (a, b) = (out.remove(0), out.remove(0));
        assert!(matches!(
            a.try_take(),
            Ok(Err(SourceFailure::Lost { source_id: 4, .. }))
        ));
        assert_eq!(b.try_take().unwrap().unwrap().item, 2);
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
}
