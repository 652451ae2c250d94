//! Schedulers: who renders which work item, and when. Every scheduler returns the same
//! [`RunStats`] and an image bit-identical to the serial render.

pub mod spec;
pub mod stats;

pub use spec::{Chunk, Order, Requeue, SchedulerKind, SchedulerSpec, SpecError, Wait};
pub use stats::{MasterStats, RunStats, Span, WorkerStats, MASTER_LANE};
