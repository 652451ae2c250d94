//! Sources behind a transport that one thread must serve while a run plays: MPI ranks, whose
//! communicator only the thread that initialised MPI may call (`MPI_THREAD_FUNNELED`). The
//! run's factory builds them in their place in the run's source set
//! (`sched::factory::build_sources`), and `sched::render_scene_with` plays the rule on a
//! thread of its own while the calling thread serves them.

use super::ComputeSource;
use crate::core::metrics::Probe;

/// Remote sources and the serving loop that carries their messages.
pub trait ServedSources {
    /// How many sources [`ServedSources::sources`] builds.
    fn len(&self) -> usize;
    /// Are there none?
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The sources, ids `first`, `first + 1`, …, timing as `probe` says. Called once per run,
    /// before [`ServedSources::serve`].
    fn sources(&self, first: u32, probe: Probe) -> Vec<Box<dyn ComputeSource>>;
    /// Carry the sources' messages, on the calling thread, until the run has dropped every
    /// source it was given.
    fn serve(&self);
}
