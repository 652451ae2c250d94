//! Schedulers: who renders which work item, and when. Every scheduler returns the same
//! [`RunStats`] and an image bit-identical to the serial render.
//!
//! The core ([`run_items`]) is generic over the per-item [`Job`], so the dispatch cost of each
//! scheduler can be measured with a job that renders nothing; [`run_scheduler`] instantiates
//! it with `render_item`.

pub mod decompose;
pub mod dls;
pub mod factory;
pub mod kinds;
mod locked_master;
pub mod master;
pub mod param;
mod pull;
pub mod refusal;
mod results;
pub mod rule;
mod run;
mod scanline;
mod shared;
pub mod sources;
pub mod spec;
pub mod wire;

pub use decompose::{decompose, decompose_frames};
pub use master::Hetero;
pub use param::{
    Chunk, Order, ParamInfo, ParamValue, Params, Passes, Requeue, Returns, Slow, SpecError, Wait,
    Weights,
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

use crate::metrics::{Probe, RunStats};
use crate::render::{render_item, Image, WorkItem};
use crate::scene::Scene;
use crate::source::{slowed_job, FaultPlan, Job};
use crate::tracer::Tracer;
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

/// Render `scene` under `spec`: the experiment runner's entry point.
pub fn run_scheduler<T: Tracer + 'static>(
    spec: &SchedulerSpec,
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
) -> Result<(Image, RunStats), SchedError> {
    run_scheduler_with(spec, scene, tracer, &RunOptions::default())
}

/// [`run_scheduler_frames`] with an animation's frames stacked into one film strip
/// ([`Image::stack`]); a static scene's image as it is.
pub fn run_scheduler_with<T: Tracer + 'static>(
    spec: &SchedulerSpec,
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    opts: &RunOptions,
) -> Result<(Image, RunStats), SchedError> {
    let (frames, stats) = run_scheduler_frames(spec, scene, tracer, opts)?;
    Ok((Image::stack(frames), stats))
}

/// Render every frame of `scene` under `spec`, one image per frame: the items of all frames
/// form one decomposition ([`decompose_frames`]), so whole frames are handed out like tiles.
pub fn run_scheduler_frames<T: Tracer + 'static>(
    spec: &SchedulerSpec,
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    opts: &RunOptions,
) -> Result<(Vec<Image>, RunStats), SchedError> {
    spec.validate()?;
    let (w, h) = (scene.width(), scene.height());
    let (chunk, order) = spec.layout(w, h);
    let items = decompose_frames(w, h, scene.frames(), chunk, order);
    let (results, mut stats) = run_items(spec, &items, render_job(scene, tracer), opts)?;
    let frames = assemble_frames(w, h, scene.frames(), &items, &results)?;
    (stats.features_used, stats.features_left_out) = scene.feature_report(tracer.accelerated());
    Ok((frames, stats))
}

/// Render every frame of `scene` under `spec` on the sources of `setup`, built by
/// [`factory::build_sources`] in the set's order (`spec.workers` local threads, slowed as
/// `spec.slow` says, when the set has threads; the GPU renderer `gpu` when it has a GPU),
/// each kind with its own buffer and grain under the master ([`factory::hetero_of`]). A
/// worker rule (self-scheduling, guided, the factoring family, static) is played over them by
/// this thread; stealing needs threads alone.
pub fn run_with_sources<T: Tracer + 'static>(
    spec: &SchedulerSpec,
    setup: &SourceSetup,
    scene: &Arc<Scene>,
    tracer: &Arc<T>,
    #[cfg(feature = "gpu")] gpu: Option<Arc<crate::gpu::GpuRenderer>>,
    opts: &RunOptions,
) -> Result<(Vec<Image>, RunStats), SchedError> {
    spec.validate()?;
    setup.validate()?;
    if setup.set.has(SourceKind::Gpu) {
        if let Some(r) = Runner::Gpu.refuses(&spec.policy) {
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
    let probe = Probe::new(opts.stats, spec.timeline);
    let job = render_job(scene, tracer);
    let ctx = factory::SourceContext {
        job: &job,
        threads: spec.workers,
        slow: spec.slow,
        faults: opts.faults.as_ref(),
        probe,
        #[cfg(feature = "gpu")]
        gpu,
    };
    let (kinds, sources): (Vec<SourceKind>, Vec<_>) = factory::build_sources(&setup.set, &ctx)?
        .into_iter()
        .unzip();
    let hetero = factory::hetero_of(setup, &kinds, (w, h));
    let plan = RunPlan {
        scheduler: &spec.policy,
        slow: spec.slow,
        opts,
        probe,
    };
    let (results, mut stats) = run(&plan, &items, Sources::Boxed(sources, hetero))?;
    let frames = assemble_frames(w, h, scene.frames(), &items, &results)?;
    (stats.features_used, stats.features_left_out) = scene.feature_report(tracer.accelerated());
    Ok((frames, stats))
}

/// Run `job` over `items` under `spec` on `spec.workers` local threads: [`run`] with
/// [`Sources::Threads`]. Results come back indexed by item id.
pub fn run_items(
    spec: &SchedulerSpec,
    items: &[WorkItem],
    job: Job,
    opts: &RunOptions,
) -> Result<(Results, RunStats), SchedError> {
    spec.validate()?;
    let plan = RunPlan {
        scheduler: &spec.policy,
        slow: spec.slow,
        opts,
        probe: Probe::new(opts.stats, spec.timeline),
    };
    run(
        &plan,
        items,
        Sources::Threads(worker_jobs(&job, spec.workers, spec.slow)),
    )
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
