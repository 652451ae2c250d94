//! Rank 0's MPI side: the [`Hub`] is the one thread that talks MPI for every
//! [`MpiRankSource`]; `super::launch::MpiRanks` serves it while a run plays.
//!
//! A rank counts as lost when an MPI call to it fails, when it runs on this host and its
//! process is gone (checked every [`LIVENESS_EVERY`]), or when it has had work outstanding and
//! said nothing for `silence` (the only signal for a remote rank that died without MPI
//! noticing).

use super::comm::{backoff, tag, Comm, Pending, SendReq};
use super::source::{Cmd, MpiRankSource, Shared};
use super::wire::decode_results;
use crate::core::metrics::{Probe, Span};
use crate::sched::wire::encode_item;
use crate::source::{Completer, ComputeSource, SourceFailure};
use crossbeam::channel::{Receiver, TryRecvError};
use std::collections::{HashMap, VecDeque};
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How often the hub checks that local ranks' processes still exist.
pub const LIVENESS_EVERY: Duration = Duration::from_millis(20);
/// Test hook: do not check local ranks by pid, so a killed rank is found the way a remote
/// one is (a failed MPI call or silence).
pub const ENV_NO_PID_CHECK: &str = "RAYSCHED_MPI_NO_PID_CHECK";

struct RankState {
    rank: i32,
    id: u32,
    shared: Arc<Shared>,
    outstanding: HashMap<u32, VecDeque<Completer>>,
    pending: usize,
    last_heard: Instant,
    /// The worker's pid when it runs on this host (checked for liveness).
    local_pid: Option<u32>,
    lost: Option<String>,
}

/// What the hub saw over a run.
#[derive(Clone, Debug, Default)]
pub struct HubReport {
    /// (rank, why) of every rank lost.
    pub lost: Vec<(i32, String)>,
    /// MPI messages sent (item hand-outs) and received.
    pub messages: u64,
}

/// The MPI side of rank 0: owns the per-rank state, serves the sources' channel.
pub struct Hub<'c> {
    comm: &'c Comm,
    rx: Receiver<Cmd>,
    ranks: Vec<RankState>,
    probe: Probe,
    silence: Duration,
    report: HubReport,
    /// Item sends in flight: (rank, request, when sent).
    sends: Vec<(i32, SendReq, Instant)>,
}

/// The rhythm of a hub loop: when liveness was last checked, and for how many passes
/// nothing moved.
struct Pace {
    last_check: Instant,
    idle: u32,
}

impl Default for Pace {
    fn default() -> Self {
        Self {
            last_check: Instant::now(),
            idle: 0,
        }
    }
}

/// A worker rank as rank 0 knows it after READY.
#[derive(Clone, Debug)]
pub struct Peer {
    /// Its rank in `MPI_COMM_WORLD`.
    pub rank: i32,
    /// Its process id on `host`.
    pub pid: u32,
    /// The host it runs on (a pid is checked only when it is this host).
    pub host: String,
}

impl<'c> Hub<'c> {
    /// One source per peer, with ids `first_id..`.
    pub fn new(
        comm: &'c Comm,
        peers: &[Peer],
        first_id: u32,
        probe: Probe,
        silence: Duration,
    ) -> (Self, Vec<Box<dyn ComputeSource>>) {
        let (tx, rx) = crossbeam::channel::unbounded();
        let me = crate::util::host::hostname();
        let pid_check = std::env::var_os(ENV_NO_PID_CHECK).is_none();
        let mut ranks = Vec::new();
        let mut sources: Vec<Box<dyn ComputeSource>> = Vec::new();
        for (k, p) in peers.iter().enumerate() {
            let shared = Arc::new(Shared::new());
            let id = first_id + k as u32;
            sources.push(Box::new(MpiRankSource::new(
                id,
                p.rank,
                tx.clone(),
                shared.clone(),
            )));
            ranks.push(RankState {
                rank: p.rank,
                id,
                shared,
                outstanding: HashMap::new(),
                pending: 0,
                last_heard: Instant::now(),
                local_pid: (pid_check && p.host == me && !me.is_empty()).then_some(p.pid),
                lost: None,
            });
        }
        let hub = Self {
            comm,
            rx,
            ranks,
            probe,
            silence,
            report: HubReport::default(),
            sends: Vec::new(),
        };
        (hub, sources)
    }

    fn state(&mut self, rank: i32) -> Option<&mut RankState> {
        self.ranks.iter_mut().find(|r| r.rank == rank)
    }

    /// Declare `rank` lost: fail its outstanding results so the master re-queues them.
    fn lose(&mut self, rank: i32, why: String) {
        let Some(st) = self.state(rank) else { return };
        if st.lost.is_some() {
            return;
        }
        st.shared.lost.store(true, Ordering::SeqCst);
        let id = st.id;
        for (_, q) in st.outstanding.drain() {
            for done in q {
                done.complete(Err(SourceFailure::Lost {
                    source_id: id,
                    reason: why.clone(),
                }));
            }
        }
        if let Some(n) = st.shared.notifier.get() {
            n.ring();
        }
        st.pending = 0;
        st.lost = Some(why.clone());
        eprintln!("rank 0: MPI rank {rank} lost: {why}");
        self.report.lost.push((rank, why));
    }

    fn submit(&mut self, cmd: Cmd) {
        let Cmd { rank, items } = cmd;
        let lost = self.state(rank).is_none_or(|st| st.lost.is_some());
        if lost {
            return; // dropping the completers fails the results as lost
        }
        // The message owns its bytes until MPI is done with them (`isend`).
        let mut msg = Vec::new();
        for (item, _) in &items {
            encode_item(item, &mut msg);
        }
        match self.comm.isend(rank, tag::ITEM, msg) {
            Ok(req) => self.sends.push((rank, req, Instant::now())),
            Err(e) => {
                drop(items);
                self.lose(rank, format!("sending an item failed: {e}"));
                return;
            }
        }
        self.report.messages += 1;
        let st = self.state(rank).expect("rank checked above");
        if st.pending == 0 {
            st.last_heard = Instant::now();
        }
        st.pending += items.len();
        for (item, done) in items {
            st.outstanding.entry(item.id).or_default().push_back(done);
        }
    }

    fn on_message(&mut self, p: Pending, body: Vec<u8>) {
        self.report.messages += 1;
        let epoch = self.probe.epoch;
        let timeline = self.probe.timeline;
        let Some(st) = self.state(p.source) else {
            return;
        };
        st.last_heard = Instant::now();
        if p.tag != tag::RESULT || st.lost.is_some() {
            return;
        }
        // A message carries the results the worker had ready, each with its busy time.
        let results = match decode_results(&body) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("rank 0: from rank {}: {e}", p.source);
                return;
            }
        };
        for (result, busy_ns) in results {
            let item = result.item;
            let Some(done) = st.outstanding.get_mut(&item).and_then(VecDeque::pop_front) else {
                continue;
            };
            st.pending -= 1;
            {
                let mut rep = st.shared.report.lock().unwrap_or_else(|e| e.into_inner());
                rep.stats.items += 1;
                rep.stats.pixels += result.pixels.len() as u64;
                rep.stats.rays += result.rays;
                rep.stats.busy_s += busy_ns as f64 * 1e-9;
                if timeline {
                    // Rank 0's clock: the span ends when the result arrived.
                    let end = (Instant::now() - epoch).as_nanos() as u64;
                    rep.spans.push(Span {
                        worker: st.id,
                        item,
                        start_ns: end.saturating_sub(busy_ns),
                        end_ns: end,
                    });
                }
            }
            done.complete(Ok(result));
        }
        if let Some(n) = st.shared.notifier.get() {
            n.ring();
        }
    }

    /// Receive every message waiting now; false when there was none.
    fn poll(&mut self) -> bool {
        let mut any = false;
        loop {
            match self.comm.iprobe(None) {
                Ok(Some(p)) => match self.comm.recv(p) {
                    Ok(body) => {
                        any = true;
                        self.on_message(p, body)
                    }
                    Err(e) => self.lose(p.source, format!("receiving failed: {e}")),
                },
                Ok(None) => return any,
                Err(_) => {
                    // Some rank is broken: probe them one by one to find it.
                    for r in self.live_ranks() {
                        match self.comm.iprobe(Some(r)) {
                            Ok(Some(p)) => match self.comm.recv(p) {
                                Ok(body) => self.on_message(p, body),
                                Err(e) => self.lose(r, format!("receiving failed: {e}")),
                            },
                            Ok(None) => {}
                            Err(e) => self.lose(r, format!("probing failed: {e}")),
                        }
                    }
                    return any;
                }
            }
        }
    }

    fn check_liveness(&mut self) {
        let now = Instant::now();
        let mut dead = Vec::new();
        // Sends that completed are done with; one stuck for the silence limit means the
        // receiver is gone (a live worker drains its messages within a heartbeat).
        let mut sends = std::mem::take(&mut self.sends);
        sends.retain_mut(|(rank, req, at)| match self.comm.test(req) {
            Ok(true) => false,
            Ok(false) if now - *at > self.silence => {
                dead.push((
                    *rank,
                    format!(
                        "an item sent to it was not taken for {:.1} s",
                        self.silence.as_secs_f64()
                    ),
                ));
                true
            }
            Ok(false) => true,
            Err(e) => {
                dead.push((*rank, format!("sending an item failed: {e}")));
                false
            }
        });
        let lost: Vec<i32> = dead.iter().map(|d| d.0).collect();
        sends.retain(|(r, _, _)| !lost.contains(r));
        self.sends = sends;
        for st in self.ranks.iter().filter(|r| r.lost.is_none()) {
            if let Some(pid) = st.local_pid {
                if !process_alive(pid) {
                    dead.push((st.rank, format!("its process {pid} is gone (killed?)")));
                    continue;
                }
            }
            if st.pending > 0 && now - st.last_heard > self.silence {
                dead.push((
                    st.rank,
                    format!(
                        "sent nothing, not even a heartbeat, for {:.1} s with work outstanding",
                        self.silence.as_secs_f64()
                    ),
                ));
            }
        }
        for (r, why) in dead {
            self.lose(r, why);
        }
    }

    /// Serve the sources until every one of them is dropped (the master is done), then stop
    /// the live workers and wait (at most `stop_wait`) for their goodbyes.
    pub fn serve(mut self, stop_wait: Duration) -> HubReport {
        self.serve_sources();
        self.stop(stop_wait);
        self.report
    }

    /// Serve one run and leave the workers running for the next: after the master is done,
    /// wait until every live rank has answered every item it was sent (re-issued copies
    /// included), so no result of this run can be taken for one of the next (item ids repeat).
    pub fn serve_run(mut self) -> HubReport {
        self.serve_sources();
        let mut pace = Pace::default();
        while self.ranks.iter().any(|r| r.lost.is_none() && r.pending > 0) {
            let busy = self.poll();
            self.pace(&mut pace, busy);
        }
        self.report
    }

    fn serve_sources(&mut self) {
        let mut pace = Pace::default();
        let mut open = true;
        while open {
            let mut busy = false;
            loop {
                match self.rx.try_recv() {
                    Ok(cmd) => {
                        busy = true;
                        self.submit(cmd)
                    }
                    Err(TryRecvError::Empty) => break,
                    Err(TryRecvError::Disconnected) => {
                        open = false;
                        break;
                    }
                }
            }
            busy |= self.poll();
            self.pace(&mut pace, busy);
        }
    }

    /// The end of one pass of a hub loop (`busy`: it moved a message): check liveness when
    /// due, then back off for as long as the hub has been idle.
    fn pace(&mut self, pace: &mut Pace, busy: bool) {
        if pace.last_check.elapsed() >= LIVENESS_EVERY {
            self.check_liveness();
            pace.last_check = Instant::now();
        }
        pace.idle = if busy { 0 } else { pace.idle.saturating_add(1) };
        backoff(pace.idle);
    }

    fn stop(&mut self, stop_wait: Duration) {
        let finalize = self.report.lost.is_empty() as u8;
        stop_ranks(self.comm, &self.live_ranks(), finalize == 1, stop_wait);
    }

    /// Ranks not (yet) declared lost.
    fn live_ranks(&self) -> Vec<i32> {
        self.ranks
            .iter()
            .filter(|r| r.lost.is_none())
            .map(|r| r.rank)
            .collect()
    }

    /// Has any rank been declared lost so far?
    pub fn any_lost(&self) -> bool {
        !self.report.lost.is_empty()
    }
}

/// How the hub ends a run.
#[derive(Clone, Copy, Debug)]
pub enum HubEnd {
    /// Stop the workers, waiting at most this long for their goodbyes (`render`).
    Stop(Duration),
    /// Leave the workers running for the next run (`run`'s experiments).
    KeepWorkers,
}

/// Send STOP to `ranks` and drain their messages until each has said BYE (or `wait` passed).
pub fn stop_ranks(comm: &Comm, ranks: &[i32], finalize: bool, wait: Duration) {
    let mut waiting: Vec<i32> = Vec::new();
    for &r in ranks {
        if comm.send(r, tag::STOP, &[finalize as u8]).is_ok() {
            waiting.push(r);
        }
    }
    let end = Instant::now() + wait;
    let mut idle = 0;
    while !waiting.is_empty() && Instant::now() < end {
        match comm.iprobe(None) {
            Ok(Some(p)) => {
                idle = 0;
                if comm.recv(p).is_ok() && p.tag == tag::BYE {
                    waiting.retain(|&r| r != p.source);
                }
            }
            Ok(None) => {
                idle += 1;
                backoff(idle)
            }
            Err(_) => break,
        }
    }
}

/// Is `pid` a running (not zombie) process on this host?
pub fn process_alive(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        // Field 3, after the parenthesised command name, is the state.
        Ok(s) => s
            .rsplit_once(')')
            .and_then(|(_, rest)| rest.split_whitespace().next())
            .is_some_and(|state| state != "Z" && state != "X"),
        Err(_) => false,
    }
}
