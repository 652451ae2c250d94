//! The one place a run's [`SourceSet`] becomes compute sources: local threads (slowed as the
//! run says, wrapped in a fault injector when asked), a GPU, in the set's order. A
//! researcher's own source needs no entry here: it is built by its caller and handed to
//! [`super::run`] in [`super::Sources::Boxed`] beside these (`examples/custom_source.rs`).

use super::exec::master::Hetero;
use super::{worker_jobs, SourceKind, SourceSet, SourceSetup, SpecError};
use crate::core::metrics::Probe;
use crate::source::faulty::faulty_source;
use crate::source::{ComputeSource, FaultPlan, Job, LocalThreadSource, ServedSources};
#[cfg(feature = "gpu")]
use std::sync::Arc;

/// What building a run's sources needs besides the set.
pub struct SourceContext<'a> {
    /// The render job every local thread runs.
    pub job: &'a Job,
    /// Local threads, when the set has `threads`.
    pub threads: usize,
    /// Which threads are slowed, and how much.
    pub slow: super::Slow,
    /// Wrap each local thread in a fault injector.
    pub faults: Option<&'a FaultPlan>,
    /// What to time per item.
    pub probe: Probe,
    /// The GPU renderer, when the set has `gpu` (the scene uploaded once, shared).
    #[cfg(feature = "gpu")]
    pub gpu: Option<Arc<crate::core::gpu::GpuRenderer>>,
    /// The MPI launch's ranks, when the set has `mpi` (`mpi::MpiRanks`).
    pub ranks: Option<&'a dyn ServedSources>,
}

/// A source with the kind it was built as.
pub type KindedSource = (SourceKind, Box<dyn ComputeSource>);

/// The sources of `set`, each with its kind, ids 0, 1, … in the set's order.
///
/// # Errors
/// A kind this build lacks, a GPU without its renderer, MPI ranks without the launch's
/// ranks ([`SourceContext::ranks`]).
pub fn build_sources(
    set: &SourceSet,
    ctx: &SourceContext<'_>,
) -> Result<Vec<KindedSource>, SpecError> {
    let mut out: Vec<KindedSource> = Vec::new();
    for &kind in set.kinds() {
        match kind {
            SourceKind::Threads => {
                let jobs = worker_jobs(ctx.job, ctx.threads, ctx.slow);
                let first = out.len() as u32;
                let threads = thread_sources(&jobs, first, ctx.faults, ctx.probe);
                out.extend(threads.into_iter().map(|s| (kind, s)));
            }
            SourceKind::Gpu => out.push((kind, gpu_source(out.len() as u32, ctx)?)),
            SourceKind::Mpi => {
                let ranks = ctx.ranks.ok_or_else(|| SpecError {
                    field: "sources".into(),
                    msg: "MPI ranks come from the MPI launch (mpirun -n N raysched render … \
                          --sources mpi), not from a source set"
                        .into(),
                })?;
                let ranks = ranks.sources(out.len() as u32, ctx.probe);
                out.extend(ranks.into_iter().map(|s| (kind, s)));
            }
        }
    }
    Ok(out)
}

/// One local thread source per job, ids `first`, `first + 1`, …, source i running `jobs[i]`
/// (inside a fault injector when `faults` says).
pub fn thread_sources(
    jobs: &[Job],
    first: u32,
    faults: Option<&FaultPlan>,
    probe: Probe,
) -> Vec<Box<dyn ComputeSource>> {
    (first..)
        .zip(jobs)
        .map(|(id, j)| thread_source(j, id, faults, probe))
        .collect()
}

/// A local thread running `job`, inside a fault injector when `faults` says.
pub fn thread_source(
    job: &Job,
    id: u32,
    faults: Option<&FaultPlan>,
    probe: Probe,
) -> Box<dyn ComputeSource> {
    match faults {
        Some(plan) => faulty_source(job, id, plan, probe),
        None => Box::new(LocalThreadSource::spawn(id, job.clone(), probe)),
    }
}

#[cfg(feature = "gpu")]
fn gpu_source(id: u32, ctx: &SourceContext<'_>) -> Result<Box<dyn ComputeSource>, SpecError> {
    let gpu = ctx.gpu.clone().ok_or_else(|| SpecError {
        field: "sources".into(),
        msg: "gpu among the sources but no GPU renderer given".into(),
    })?;
    Ok(Box::new(crate::source::GpuSource::spawn(
        id, gpu, ctx.probe,
    )))
}

#[cfg(not(feature = "gpu"))]
fn gpu_source(_id: u32, _ctx: &SourceContext<'_>) -> Result<Box<dyn ComputeSource>, SpecError> {
    Err(SpecError {
        field: "sources".into(),
        msg: "gpu: this raysched was built without feature `gpu` (cargo build --features gpu)"
            .into(),
    })
}

/// The master's per-source settings for sources of `kinds` (in that order) under `setup` on
/// a `width`×`height` image: each kind's own buffer and grain (0 where it has none: the
/// master's B, item by item), and whether the balancer runs ([`SourceSetup::balanced`]).
pub fn hetero_of(setup: &SourceSetup, kinds: &[SourceKind], (width, height): (u32, u32)) -> Hetero {
    let (buffers, grains) = kinds
        .iter()
        .map(|&k| {
            let own = setup.own(k);
            (
                own.buffer.unwrap_or(0),
                own.chunk.map_or(0, |c| c.pixels(width, height)),
            )
        })
        .unzip();
    Hetero {
        buffers,
        grains,
        balance: setup.balanced(),
    }
}
