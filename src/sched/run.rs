//! The one run path: a [`Scheduler`]'s rule played over a run's sources. Every executor is
//! chosen here from the rule and the kind of sources, never from the scheduler's name:
//!
//! | rule ↓ / sources →          | [`Sources::Threads`]            | [`Sources::Boxed`]          |
//! |-----------------------------|---------------------------------|-----------------------------|
//! | master, passes `thread`     | the master over thread sources  | the master                  |
//! | master, passes `workers`    | the workers-run master          | refused (needs threads)     |
//! | worker rules                | the workers take their own      | this thread hands out       |

use super::exec::master::{self, Hetero};
use super::exec::{locked_master, pull, shared};
use super::rule::{HandOut, Scheduler};
use super::{
    factory, worker_jobs, Passes, Results, RunOptions, Runner, SchedError, SchedulerSpec, Slow,
    SpecError,
};
use crate::core::metrics::{Probe, RunStats};
use crate::core::render::WorkItem;
use crate::source::{ComputeSource, Job};

/// What a run hands its items to.
pub enum Sources {
    /// Local threads, thread i running `jobs[i]`: the worker rules run on them directly (the
    /// lock-free fast paths), the master wraps each in a [`crate::source::LocalThreadSource`]
    /// (or a fault injector, [`RunOptions::faults`]).
    Threads(Vec<Job>),
    /// Anything behind the source interface, in any mix and order (thread sources, a GPU,
    /// MPI ranks, a researcher's own, decorated ones), with each one's own buffer and grain
    /// under the master ([`Hetero`]; default: the master's B, item by item).
    Boxed(Vec<Box<dyn ComputeSource>>, Hetero),
}

impl Sources {
    /// `spec.workers` local threads, each running `job`, the slowed ones slowed as `spec.slow`
    /// says.
    pub fn threads(job: &Job, spec: &SchedulerSpec) -> Self {
        Self::Threads(worker_jobs(job, spec.workers, spec.slow))
    }

    fn len(&self) -> usize {
        match self {
            Self::Threads(j) => j.len(),
            Self::Boxed(s, _) => s.len(),
        }
    }
}

/// How to run: the scheduler, the known slowdown of its workers (weighted factoring's known
/// weights read it), the run's options and what to time.
pub struct RunPlan<'a> {
    /// The scheduler whose rule is played.
    pub scheduler: &'a dyn Scheduler,
    /// Workers slowed by a known factor ([`Slow::NONE`] by default).
    pub slow: Slow,
    /// Deadline, faults.
    pub opts: &'a RunOptions,
    /// What to time per item.
    pub probe: Probe,
}

impl<'a> RunPlan<'a> {
    /// The plan of a built-in scheduler's `spec`, checked first ([`SchedulerSpec::validate`]):
    /// its policy and slowdown, timing as `opts.stats` and `spec.timeline` say.
    pub fn of(spec: &'a SchedulerSpec, opts: &'a RunOptions) -> Result<Self, SchedError> {
        spec.validate()?;
        Ok(Self {
            scheduler: &spec.policy,
            slow: spec.slow,
            opts,
            probe: Probe::new(opts.stats, spec.timeline),
        })
    }
}

/// Run `items` on `sources` under `plan`; results come back indexed by item id. Items must
/// be numbered 0, 1, … in the order given.
///
/// # Errors
/// A rule the sources cannot play ([`SchedError::Spec`]), no sources, lost items, a passed
/// deadline, a panicking worker.
pub fn run(
    plan: &RunPlan<'_>,
    items: &[WorkItem],
    sources: Sources,
) -> Result<(Results, RunStats), SchedError> {
    debug_assert!(items.iter().enumerate().all(|(i, it)| it.id == i as u32));
    let (opts, probe) = (plan.opts, plan.probe);
    if sources.len() == 0 {
        return Err(SchedError::AllSourcesLost {
            sources: 0,
            remaining: items.len() as u64,
            total: items.len() as u64,
        });
    }
    match (
        plan.scheduler
            .hand_out(items.len(), sources.len(), plan.slow),
        sources,
    ) {
        (HandOut::ByMaster(m), Sources::Threads(jobs)) if m.passes == Passes::Workers => {
            if let Some(r) = opts
                .faults
                .as_ref()
                .and(Runner::Faults.refuses_value("passes", m.passes.id()))
            {
                return Err(refused(r.param, r.as_value()));
            }
            locked_master::run_locked_master(&m, items, &jobs, opts.deadline, probe)
        }
        (HandOut::ByMaster(m), Sources::Boxed(..)) if m.passes == Passes::Workers => Err(refused(
            "passes",
            "workers: the passes run by the workers need local threads alone (use thread)".into(),
        )),
        (HandOut::ByMaster(m), Sources::Threads(jobs)) => {
            let sources = factory::thread_sources(&jobs, 0, opts.faults.as_ref(), probe);
            master::run_master_hetero(&m, &Hetero::default(), items, sources, opts, probe)
        }
        (HandOut::ByMaster(m), Sources::Boxed(sources, hetero)) => {
            master::run_master_hetero(&m, &hetero, items, sources, opts, probe)
        }
        (HandOut::ByWorkers(rule), Sources::Threads(jobs)) => {
            shared::run_shared(rule, items, &jobs, probe)
        }
        (HandOut::ByWorkers(rule), Sources::Boxed(sources, _)) => {
            pull::run_pull(rule, items, sources, opts.deadline, probe)
        }
    }
}

fn refused(field: &str, msg: String) -> SchedError {
    SpecError {
        field: field.into(),
        msg,
    }
    .into()
}
