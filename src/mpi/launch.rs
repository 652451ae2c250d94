//! Rank 0's side of an MPI launch: waiting for every worker's READY ([`gather_ready`]), and the
//! worker ranks as a source set ([`MpiRanks`]) that `sched::render_scene_with` builds in the
//! run's set and plays the rule over while this thread, MPI's, serves their messages.

use super::comm::{tag, Comm, MpiError};
use super::hub::{stop_ranks, Hub, HubEnd, HubReport, Peer};
use super::wire::Ready;
use crate::core::metrics::Probe;
use crate::source::{ComputeSource, ServedSources};
use std::cell::RefCell;
use std::time::{Duration, Instant};

/// How long a worker may take to build its scene and tracer.
pub const READY_WAIT: Duration = Duration::from_secs(600);
/// How long rank 0 waits for the workers' goodbyes after STOP.
pub const STOP_WAIT: Duration = Duration::from_secs(10);

/// Why the workers are not ready.
#[derive(Debug, thiserror::Error)]
pub enum ReadyError {
    /// Talking to the workers failed.
    #[error(transparent)]
    Mpi(#[from] MpiError),
    /// Ranks could not build the scene, or did not answer in time (one line per rank); the
    /// workers have been stopped.
    #[error("the scene could not be built on every rank:\n  {}", .0.join("\n  "))]
    NotBuilt(Vec<String>),
}

/// Wait for every worker's READY; a rank that could not build the scene stops the run with
/// its own message (and every worker is stopped).
///
/// # Errors
/// A failed MPI call, a rank's build error, a rank silent for [`READY_WAIT`].
pub fn gather_ready(comm: &Comm) -> Result<Vec<Peer>, ReadyError> {
    let mut peers: Vec<Option<Peer>> = vec![None; comm.size as usize];
    let mut errors = Vec::new();
    let end = Instant::now() + READY_WAIT;
    let mut missing = comm.size as usize - 1;
    while missing > 0 {
        if Instant::now() > end {
            errors.push(format!(
                "{missing} rank(s) did not report ready within {} s",
                READY_WAIT.as_secs()
            ));
            break;
        }
        let Some(p) = comm.iprobe(None)? else {
            std::thread::sleep(Duration::from_micros(200));
            continue;
        };
        let body = comm.recv(p)?;
        if p.tag != tag::READY || peers[p.source as usize].is_some() {
            continue;
        }
        missing -= 1;
        match Ready::decode(&body) {
            Ok(r) if r.error.is_empty() => {
                peers[p.source as usize] = Some(Peer {
                    rank: p.source,
                    pid: r.pid,
                    host: r.host,
                })
            }
            Ok(r) => errors.push(format!(
                "rank {} ({}, pid {}): {}",
                p.source, r.host, r.pid, r.error
            )),
            Err(e) => errors.push(format!("rank {}: {e}", p.source)),
        }
        if peers[p.source as usize].is_none() {
            // Keep the slot marked as answered.
            peers[p.source as usize] = Some(Peer {
                rank: -1,
                pid: 0,
                host: String::new(),
            });
        }
    }
    if !errors.is_empty() {
        let all: Vec<i32> = (1..comm.size).collect();
        stop_ranks(comm, &all, true, STOP_WAIT);
        return Err(ReadyError::NotBuilt(errors));
    }
    Ok(peers.into_iter().flatten().filter(|p| p.rank > 0).collect())
}

/// The ready worker ranks of a launch as the `mpi` of a run's source set: the factory asks for
/// their sources, the run's calling thread serves them ([`Hub`]).
pub struct MpiRanks<'c> {
    comm: &'c Comm,
    peers: &'c [Peer],
    silence: Duration,
    end: HubEnd,
    hub: RefCell<Option<Hub<'c>>>,
    report: RefCell<Option<HubReport>>,
    labels: RefCell<Vec<String>>,
}

impl<'c> MpiRanks<'c> {
    /// `peers` of `comm` (after [`gather_ready`]); a rank with work outstanding that says
    /// nothing for `silence` is lost; after the run the workers stop or stay as `end` says.
    pub fn new(comm: &'c Comm, peers: &'c [Peer], silence: Duration, end: HubEnd) -> Self {
        Self {
            comm,
            peers,
            silence,
            end,
            hub: RefCell::new(None),
            report: RefCell::new(None),
            labels: RefCell::new(Vec::new()),
        }
    }

    /// The labels of the sources built for the run, in id order.
    pub fn labels(&self) -> Vec<String> {
        self.labels.borrow().clone()
    }

    /// What the hub saw over the run (ranks lost, messages). A run that never got as far as
    /// serving its ranks still ends them as [`HubEnd`] says.
    pub fn finish(self) -> HubReport {
        if self.report.borrow().is_none() {
            if self.hub.borrow().is_some() {
                self.serve();
            } else if let HubEnd::Stop(wait) = self.end {
                let ranks: Vec<i32> = self.peers.iter().map(|p| p.rank).collect();
                stop_ranks(self.comm, &ranks, true, wait);
            }
        }
        self.report.into_inner().unwrap_or_default()
    }
}

impl ServedSources for MpiRanks<'_> {
    fn len(&self) -> usize {
        self.peers.len()
    }

    fn sources(&self, first: u32, probe: Probe) -> Vec<Box<dyn ComputeSource>> {
        let (hub, sources) = Hub::new(self.comm, self.peers, first, probe, self.silence);
        *self.hub.borrow_mut() = Some(hub);
        *self.labels.borrow_mut() = sources.iter().map(|s| s.label()).collect();
        sources
    }

    fn serve(&self) {
        let Some(hub) = self.hub.borrow_mut().take() else {
            return;
        };
        let report = match self.end {
            HubEnd::Stop(wait) => hub.serve(wait),
            HubEnd::KeepWorkers => hub.serve_run(),
        };
        *self.report.borrow_mut() = Some(report);
    }
}
