//! The per-item clock: [`Probe`] (what a run records) and [`BusyClock`] (a worker's busy time).

use super::Span;
use std::time::{Duration, Instant};

/// Instrumentation settings shared by every source of a run.
#[derive(Clone, Copy, Debug)]
pub struct Probe {
    /// Time every item (busy time); off, no clock is read per item.
    pub stats: bool,
    /// Record a (worker, item, start, end) span per item; implies `stats`.
    pub timeline: bool,
    /// Time zero of the run's timeline.
    pub epoch: Instant,
    /// The same time zero on the TSC clock used per item (`quanta`: ~18 ns a read on the
    /// 2-core KVM dev box vs ~47 ns for `std::time::Instant::now`).
    pub tsc_epoch: quanta::Instant,
}

impl Probe {
    /// Settings with time zero now; `timeline` turns `stats` on too.
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
    /// A clock whose first busy span starts now.
    pub(crate) fn start(probe: &Probe) -> Self {
        let mut c = Self {
            closed: Duration::ZERO,
            since: probe.tsc_epoch,
            last: probe.tsc_epoch,
        };
        c.restart(probe);
        c
    }

    /// The worker waited: close the current run of items; the next busy span starts now.
    pub(crate) fn restart(&mut self, probe: &Probe) {
        if probe.stats {
            self.closed += self.last - self.since;
            self.since = quanta::Instant::now();
            self.last = self.since;
        }
    }

    /// The worker's latest item ended now (no timeline entry).
    #[inline]
    pub(crate) fn mark(&mut self, probe: &Probe) {
        if probe.stats {
            self.last = quanta::Instant::now();
        }
    }

    /// Item `item` of `worker` ended now: its span ends here, and goes into the timeline if
    /// one is recorded.
    #[inline]
    pub(crate) fn item_done(
        &mut self,
        probe: &Probe,
        worker: u32,
        item: u32,
        spans: &mut Vec<Span>,
    ) {
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
    pub(crate) fn absorb(&mut self, other: &BusyClock) {
        self.closed += other.busy();
    }

    /// Total busy time so far.
    pub(crate) fn busy(&self) -> Duration {
        self.closed + (self.last - self.since)
    }
}
