//! Schedulers: who renders which work item, and when. Every scheduler returns the same
//! [`RunStats`] and an image bit-identical to the serial render.

// PLACEHOLDER until the schedulers branch merges: delete placeholder.rs, `mod placeholder;`
// and the `pub use placeholder::…` line below.
mod placeholder;
pub mod spec;
pub mod stats;

pub use placeholder::{run_scheduler, SchedError};

pub use spec::{Chunk, Order, Requeue, SchedulerKind, SchedulerSpec, SpecError, Wait};
pub use stats::{MasterStats, RunStats, Span, WorkerStats, MASTER_LANE};
