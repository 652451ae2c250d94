//! What a run measured, and how it measures: the [`RunStats`] every scheduler returns, and the
//! per-item clock ([`Probe`], `BusyClock`) that compute sources and shared workers read.
//!
//! Below both `sched` and `source`, so either can fill these in without importing the other.

mod clock;
mod stats;

pub(crate) use clock::BusyClock;
pub use clock::Probe;
pub use stats::{MasterStats, RunStats, SourceKind, Span, WorkerStats, MASTER_LANE};
