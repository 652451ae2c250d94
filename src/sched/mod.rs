//! Schedulers: who renders which work item, and when. Every scheduler returns the same
//! [`RunStats`] and an image bit-identical to the serial render.
//!
//! The one run path is [`run`]: a scheduler's rule played over [`Sources`], generic over the
//! per-item [`Job`], so the dispatch cost of each scheduler can be measured with a job that
//! renders nothing. [`render_scene`] runs it over a scene's items with `render_item` and
//! assembles the frames.

pub mod decompose;
pub mod dls;
pub mod exec;
pub mod factory;
pub mod kinds;
pub mod param;
pub mod refusal;
mod results;
pub mod rule;
mod run;
mod scanline;
pub mod sources;
pub mod spec;
pub mod wire;

pub use decompose::{decompose, decompose_frames};
pub use exec::master::{self, Hetero};
pub use param::{
    Chunk, Order, ParamInfo, ParamValue, Params, Passes, Requeue, Returns, Slow, SpecError,
    ValueError, Wait, Weights,
};
pub use refusal::{Refusal, Runner};
pub use results::Results;
pub(crate) use results::{Collector, Tally};
pub use run::{run, RunPlan, Sources};
pub use sources::{
    share_columns, source_params, HandOut, Share, SourceKind, SourceParam, SourceSet, SourceSetup,
};
pub use spec::{
    param_columns, AdaptiveFactoringParams, AwfParams, FactoringParams, FixedSizeParams,
    GuidedParams, MasterParams, MitsubaParams, PbrtParams, Policy, SchedulerKind, SchedulerSpec,
    SelfSchedulingParams, StaticCyclicParams, StaticParams, TrapezoidParams,
    WeightedFactoringParams, WorkStealingDequeParams, WorkStealingParams,
};

use crate::core::metrics::RunStats;
use crate::core::render::{render_item, Image, RenderCounters, WorkItem};
use crate::core::scene::Scene;
use crate::core::tracer::Tracer;
use crate::source::local::panic_message;
use crate::source::{slowed_job, FaultPlan, Job, ServedSources};
use std::sync::Arc;
use std::time::Duration;

#[derive(Debug, thiserror::Error)]
/// Why a scheduler run produced no image.
pub enum SchedError {
    #[error(transparent)]
    /// The scheduler spec is invalid.
    Spec(#[from] SpecError),
    #[error("{lost} of {total} items were lost and re-queue policy 'never' cannot redo them")]
    /// Items were lost (a lost source, a dropped result) and could not be redone.
    LostItems {
        /// Items without a result.
        lost: u64,
        /// Items in the run.
        total: u64,
    },
    #[error("deadline of {deadline:?} passed with {done} of {total} items done")]
    /// The run's deadline passed before every item was done.
    Deadline {
        /// The deadline that passed.
        deadline: Duration,
        /// Items done by then.
        done: u64,
        /// Items in the run.
        total: u64,
    },
    #[error(
        "all {sources} compute sources were lost with {remaining} of {total} items unfinished"
    )]
    /// Every compute source was lost before the run finished.
    AllSourcesLost {
        /// Sources the run started with.
        sources: u64,
        /// Items without a result.
        remaining: u64,
        /// Items in the run.
        total: u64,
    },
    #[error("worker thread panicked: {0}")]
    /// A worker thread panicked (the panic's message).
    WorkerPanic(String),
    #[error("building the thread pool: {0}")]
    /// The thread pool could not be built.
    Pool(String),
    #[error("item {item}: no result (scheduler bug)")]
    /// An item has no result after a run that reported success (a scheduler bug).
    Missing {
        /// The item without a result.
        item: u32,
    },
}

/// Run settings that are not part of the scheduler's identity.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Time each item (busy/idle, master dispatch/wait). Off, no clock is read per item.
    pub stats: bool,
    /// Give up after this long (master only): never a hang, even when results are dropped.
    pub deadline: Option<Duration>,
    /// Master only: wrap each local source in a fault injector.
    pub faults: Option<FaultPlan>,
}

impl Default for RunOptions {
    fn default() -> Self {
        Self {
            stats: true,
            deadline: None,
            faults: None,
        }
    }
}

/// The render job: `render_item` over one shared scene and tracer (no per-thread copies).
pub fn render_job<T: Tracer + 'static>(scene: &Arc<Scene>, tracer: &Arc<T>) -> Job {
    let (scene, tracer) = (scene.clone(), tracer.clone());
    Arc::new(move |item: &WorkItem| render_item(&scene, &*tracer, item))
}

/// Where a scene's render runs ([`render_scene`]): `spec.workers` local threads, or the
/// sources a [`SourceSetup`] names.
pub struct RenderOn<'a> {
    /// The kinds of source and each one's hand-out; threads alone by default.
    pub setup: &'a SourceSetup,
    /// The GPU renderer, when the setup has a GPU.
    #[cfg(feature = "gpu")]
    pub gpu: Option<Arc<crate::core::gpu::GpuRenderer>>,
}

impl RenderOn<'static> {
    /// `spec.workers` local threads, which take their own items under a worker rule (the
    /// lock-free fast paths) or are the master's sources.
    pub fn threads() -> Self {
        static THREADS: std::sync::OnceLock<SourceSetup> = std::sync::OnceLock::new();
        Self {
            setup: THREADS.get_or_init(SourceSetup::default),
            #[cfg(feature = "gpu")]
            gpu: None,
        }
    }
}

/// Render every frame of `scene` under `spec` on `on`, one image per frame: the items of all
/// frames form one decomposition ([`decompose_frames`], so whole frames are handed out like
/// tiles), [`run`] plays the scheduler's rule over them, and the results are assembled.
///
/// On threads alone the rule runs on [`Sources::Threads`]. Otherwise the sources are built by
/// [`factory::build_sources`] in the set's order (`spec.workers` local threads, slowed as
/// `spec.slow` says, when the set has threads; the GPU renderer when it has a GPU), each kind
/// with its own buffer and grain under the master ([`factory::hetero_of`]); a worker rule is
/// played over them by this thread, and stealing needs threads alone.
pub fn render_scene<T: Tracer + 'static>(
    spec: &SchedulerSpec,
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    on: &RenderOn<'_>,
    opts: &RunOptions,
) -> Result<(Vec<Image>, RunStats), SchedError> {
    render_scene_with(spec, scene, tracer, on, opts, None)
}

/// [`render_scene`] with sources that the calling thread must serve while the run plays
/// (`ranks`: an MPI launch's ranks, the set's `mpi`): the rule is then played on a thread of
/// its own. `spec.workers` counts every source; the local threads are those beyond the ranks.
pub fn render_scene_with<T: Tracer + 'static>(
    spec: &SchedulerSpec,
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    on: &RenderOn<'_>,
    opts: &RunOptions,
    ranks: Option<&dyn ServedSources>,
) -> Result<(Vec<Image>, RunStats), SchedError> {
    let plan = RunPlan::of(spec, opts)?;
    let setup = on.setup;
    setup.validate()?;
    for (kind, runner) in [
        (SourceKind::Gpu, Runner::Gpu),
        (SourceKind::Mpi, Runner::Mpi),
    ] {
        if let Some(r) = setup
            .set
            .has(kind)
            .then(|| runner.refuses(&spec.policy))
            .flatten()
        {
            return Err(SpecError {
                field: r.param.into(),
                msg: r.as_value(),
            }
            .into());
        }
    }
    let (w, h) = (scene.width(), scene.height());
    let (chunk, order) = spec.layout(w, h);
    let items = decompose_frames(w, h, scene.frames(), chunk, order);
    let job = render_job(scene, tracer);
    let sources = if setup.set == SourceSet::threads() {
        Sources::threads(&job, spec)
    } else {
        let ctx = factory::SourceContext {
            job: &job,
            threads: spec.workers - ranks.map_or(0, |r| r.len()).min(spec.workers),
            slow: spec.slow,
            faults: opts.faults.as_ref(),
            probe: plan.probe,
            #[cfg(feature = "gpu")]
            gpu: on.gpu.clone(),
            ranks,
        };
        let (kinds, sources): (Vec<SourceKind>, Vec<_>) = factory::build_sources(&setup.set, &ctx)?
            .into_iter()
            .unzip();
        Sources::Boxed(sources, factory::hetero_of(setup, &kinds, (w, h)))
    };
    let (results, mut stats) = match ranks {
        None => run(&plan, &items, sources)?,
        Some(ranks) => std::thread::scope(|s| {
            // The plan is rebuilt on the master's thread: a rule need not be `Sync`.
            let master = s.spawn(|| {
                let plan = RunPlan {
                    scheduler: &spec.policy,
                    slow: spec.slow,
                    opts,
                    probe: plan.probe,
                };
                run(&plan, &items, sources)
            });
            ranks.serve();
            master
                .join()
                .unwrap_or_else(|p| Err(SchedError::WorkerPanic(panic_message(&p))))
        })?,
    };
    let frames = assemble_frames(w, h, scene.frames(), &items, &results)?;
    (stats.features_used, stats.features_left_out) = scene.feature_report(tracer.accelerated());
    Ok((frames, stats))
}

/// The row-parallel configuration: `threads` workers (at least one) each taking the next
/// single row under self-scheduling, a registered kind like any other. [`render_parallel`] and
/// the convergence runs without a scheduler of their own (`converge::run_convergence`) use it.
pub fn rows_spec(threads: usize) -> SchedulerSpec {
    SchedulerSpec::new(
        SchedulerKind::SelfScheduling,
        Chunk::Rows(1),
        threads.max(1),
    )
}

/// Render `scene` on `threads` local threads under [`rows_spec`] through [`render_scene`]; an
/// animation comes back as a film strip ([`Image::stack`]). Bit-identical to
/// `render::render_serial`, as every run is.
///
/// # Errors
/// A worker thread that panicked.
pub fn render_parallel<T: Tracer + 'static>(
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    threads: usize,
) -> Result<(Image, RenderCounters), SchedError> {
    let spec = rows_spec(threads);
    let (frames, stats) = render_scene(
        &spec,
        scene,
        tracer,
        &RenderOn::threads(),
        &RunOptions::default(),
    )?;
    let counters = RenderCounters {
        rays: stats.rays,
        nonfinite: stats.nonfinite,
    };
    Ok((Image::stack(frames), counters))
}

/// Worker i's job: `job`, slowed by `slow`'s factor for the slowed workers.
pub fn worker_jobs(job: &Job, workers: usize, slow: Slow) -> Vec<Job> {
    (0..workers)
        .map(|i| slowed_job(job.clone(), slow.factor_of(i)))
        .collect()
}

/// Put each item's result into an image; a missing result is an error. Items of several
/// frames give the frames as one film strip ([`Image::stack`]).
pub fn assemble(
    width: u32,
    height: u32,
    items: &[WorkItem],
    results: &Results,
) -> Result<Image, SchedError> {
    let frames = items.iter().map(|it| it.frame + 1).max().unwrap_or(1);
    Ok(Image::stack(assemble_frames(
        width, height, frames, items, results,
    )?))
}

/// Put each item's result into the image of its frame (`frames` images).
pub fn assemble_frames(
    width: u32,
    height: u32,
    frames: u32,
    items: &[WorkItem],
    results: &Results,
) -> Result<Vec<Image>, SchedError> {
    let mut images: Vec<Image> = (0..frames.max(1))
        .map(|_| Image::new(width, height))
        .collect();
    for item in items {
        let r = results
            .get(item.id)
            .ok_or(SchedError::Missing { item: item.id })?;
        images[item.frame as usize].put(item, &r.pixels);
    }
    Ok(images)
}
