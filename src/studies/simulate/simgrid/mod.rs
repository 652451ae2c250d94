//! SimGrid (feature `simgrid`, Debian's `libsimgrid-dev` 3.32): each scheduler's protocol
//! simulated on a platform XML file. [`ffi`] holds the bindings; [`protocols`] the actors.
//!
//! SimGrid's engine runs once per process and aborts the process on a malformed platform, so
//! `raysched simulate` runs each simulation in a child process
//! ([`crate::studies::simulate::child`]); the functions here are what that child calls.

pub mod ffi;
mod protocols;

use crate::sched::rule::Scheduler;
use crate::sched::{SchedulerKind, SchedulerSpec, Slow, SpecError};
use crate::studies::simulate::job::{placement_order, PlatformInfo, SimJob, SimOutcome};
use std::rc::Rc;

/// SimGrid options: quiet; boost contexts (the fastest context factory, M-126); no
/// cross-traffic (the TCP acks of each message, which matter only for bulk transfers).
///
/// Each actor's stack is a memory mapping plus one for its guard page; where that would pass
/// the process's limit (`vm.max_map_count`) the guard pages are left out, so a stack overflow
/// would no longer be caught.
fn options(actors: usize) -> Vec<String> {
    let mut o: Vec<String> = [
        "--log=root.thres:critical",
        "--cfg=contexts/factory:boost",
        "--cfg=network/crosstraffic:0",
    ]
    .map(String::from)
    .to_vec();
    if 2 * actors > crate::studies::simulate::job::mapping_budget() {
        o.push("--cfg=contexts/guard-size:0".into());
    }
    o
}

fn hosts_in_order() -> Vec<ffi::Host> {
    let mut hosts = ffi::Host::all();
    hosts.sort_by(|a, b| placement_order(&a.name(), &b.name()));
    hosts
}

/// Why a simulation did not run.
#[derive(Debug, thiserror::Error)]
pub enum SimgridError {
    /// SimGrid's library or one of its functions is missing.
    #[error("{0}")]
    Library(String),
    /// The job's scheduler or one of its parameters is invalid.
    #[error(transparent)]
    Spec(#[from] SpecError),
    /// The run needs more SimGrid actors than the process may map stacks for.
    #[error("{workers} workers need about {actors} SimGrid actors, more than this system's {budget} memory mappings per process (vm.max_map_count) allow")]
    Actors {
        /// Simulated workers.
        workers: usize,
        /// Actors they need.
        actors: usize,
        /// The memory mappings a process may hold.
        budget: usize,
    },
    /// The platform holds fewer workers than the job.
    #[error("{workers} workers do not fit on {platform} ({slots} worker slots)")]
    Fit {
        /// Simulated workers.
        workers: usize,
        /// The platform file.
        platform: String,
        /// Its worker slots.
        slots: usize,
    },
    /// A lost worker the job does not have.
    #[error("lost worker {worker} of {workers} workers")]
    Lost {
        /// The lost worker.
        worker: usize,
        /// Simulated workers.
        workers: usize,
    },
}

/// Load `platform` and list its hosts. Once per process.
///
/// # Errors
/// SimGrid cannot be opened.
pub fn inspect_platform(platform: &str) -> Result<PlatformInfo, SimgridError> {
    ffi::init(&options(0))?;
    ffi::load_platform(platform);
    Ok(PlatformInfo {
        hosts: hosts_in_order()
            .into_iter()
            .map(|h| (h.name(), h.speed(), h.cores()))
            .collect(),
    })
}

/// Simulate `job`. Once per process (SimGrid's engine cannot be re-created).
///
/// # Errors
/// As [`simulate_with`], and an unknown scheduler or parameter.
pub fn simulate(job: SimJob) -> Result<SimOutcome, SimgridError> {
    let kind = SchedulerKind::from_id(&job.scheduler)?;
    let mut spec = SchedulerSpec::new(kind, crate::sched::Chunk::Frame, job.workers);
    for (k, v) in &job.params {
        spec.set(k, v)?;
    }
    simulate_with(job, &spec.policy)
}

/// [`simulate`] of any [`Scheduler`], a researcher's own included (`job.scheduler` and
/// `job.params` are then only labels). The simulation has no known slowdown (host speeds
/// come from the platform), so `weighted_factoring` with `weights = known` sees equal weights.
///
/// # Errors
/// SimGrid cannot be opened, the run needs more actors than the system allows, the workers do
/// not fit on the platform, a lost worker the job lacks.
pub fn simulate_with(job: SimJob, scheduler: &dyn Scheduler) -> Result<SimOutcome, SimgridError> {
    let rule = scheduler.hand_out(job.cost_s.len(), job.workers, Slow::NONE);
    let started = std::time::Instant::now();
    let actors = crate::studies::simulate::job::actors_playing(&rule, job.workers, job.lost.len());
    let budget = crate::studies::simulate::job::mapping_budget();
    if actors > budget {
        return Err(SimgridError::Actors {
            workers: job.workers,
            actors,
            budget,
        });
    }
    ffi::init(&options(actors))?;
    ffi::load_platform(&job.platform.to_string_lossy());
    let hosts = hosts_in_order();
    let info = PlatformInfo {
        hosts: hosts
            .iter()
            .map(|h| (h.name(), h.speed(), h.cores()))
            .collect(),
    };
    if job.workers == 0 || job.workers > info.worker_slots() {
        return Err(SimgridError::Fit {
            workers: job.workers,
            platform: job.platform.display().to_string(),
            slots: info.worker_slots(),
        });
    }
    if let Some(l) = job.lost.iter().find(|l| l.worker >= job.workers) {
        return Err(SimgridError::Lost {
            worker: l.worker,
            workers: job.workers,
        });
    }
    let (master, placed) = info.placement(job.workers);
    let world = Rc::new(protocols::World::new(
        job,
        hosts[master],
        placed.iter().map(|&i| hosts[i]).collect(),
        rule.needs().hand_out_thread,
    ));
    protocols::spawn_protocol(Rc::clone(&world), rule);
    ffi::run();
    let mut out = world.finish();
    out.wall_s += world.job.start_s;
    out.host_s = started.elapsed().as_secs_f64();
    Ok(out)
}
