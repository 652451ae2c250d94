//! What one simulated run needs (a [`SimJob`]) and what it reports (a [`SimOutcome`]). Both
//! travel as TOML between `raysched simulate` and the child process that runs SimGrid (the
//! engine cannot be re-created in one process, and a malformed platform aborts the process).

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Flop/s of the machine the costs were measured on: a host of speed `1Gf` in a platform file
/// runs an item in exactly its measured time; `2Gf` in half of it.
pub const REFERENCE_FLOPS: f64 = 1e9;

/// Senders per relay actor of a fan-in (`simgrid::protocols::FanIn`): a relay's mailbox
/// holds at most one message per sender of its group, so taking one scans ≤ 64 entries.
pub const FAN_IN_GROUP: usize = 64;

/// SimGrid actors a simulated run of `workers` workers of `kind` creates (an upper bound): a
/// worker each, a steal server each for work stealing, the fan-in relays, the master or
/// counter or sink, and `lost` killers. Each actor's stack is one memory mapping, two with
/// its guard page.
pub fn actors_needed(kind: crate::sched::SchedulerKind, workers: usize, lost: usize) -> usize {
    let rule = crate::sched::Policy::defaults(kind).rule(0, 1, crate::sched::Slow::NONE);
    actors_playing(&rule, workers, lost)
}

/// [`actors_needed`] for any rule: a stealing worker also runs a steal server.
pub fn actors_playing(rule: &crate::sched::rule::HandOut, workers: usize, lost: usize) -> usize {
    let per_worker = if rule.needs().shared_memory { 2 } else { 1 };
    per_worker * workers + workers.div_ceil(FAN_IN_GROUP) + 2 + lost
}

/// Memory mappings one process may hold (`vm.max_map_count`, Linux's default 65 530), with
/// room kept for the libraries and heap of the process itself.
pub fn mapping_budget() -> usize {
    let limit = std::fs::read_to_string("/proc/sys/vm/max_map_count")
        .ok()
        .and_then(|s| s.trim().parse::<usize>().ok())
        .unwrap_or(65_530);
    limit.saturating_sub(2_000)
}

/// How a simulated run's messages travel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Network {
    /// SimGrid's network model: every message a flow sharing the links of its route.
    #[default]
    Fine,
    /// Each message delivered after its route's latency plus bytes / bandwidth, each host's
    /// link direction a FIFO server (`simgrid::protocols::Wires`): no flows. SimGrid re-shares
    /// a link among every flow on it at each message, so ~W messages in flight at once cost
    /// ~W² (the 5 µs cluster's self-scheduling at chunk 4: 1.8 s to simulate at 1024 workers,
    /// 17 s at 4096).
    Coarse,
}

impl Network {
    /// The id in experiment files and `sim_runs.csv`.
    pub fn id(self) -> &'static str {
        match self {
            Network::Fine => "fine",
            Network::Coarse => "coarse",
        }
    }
}

/// A worker whose host is turned off at `at_s` seconds of simulated time.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LostWorker {
    /// The worker's index (0-based; its host is turned off, so every worker on it is lost).
    pub worker: usize,
    /// Simulated seconds after the start.
    pub at_s: f64,
}

/// One simulated run, every input measured (see [`crate::studies::simulate::inputs`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimJob {
    /// The SimGrid platform XML file.
    pub platform: PathBuf,
    /// Scheduler id ([`crate::sched::SchedulerKind`]).
    pub scheduler: String,
    /// The scheduler's parameters in their text form (the spec's `get`/`set`).
    pub params: BTreeMap<String, String>,
    /// Simulated workers.
    pub workers: usize,
    /// Seconds each item takes on a reference core, by item id.
    pub cost_s: Vec<f64>,
    /// Bytes of each item's ITEM message entry (`sched::wire::item_bytes`).
    pub item_bytes: Vec<u32>,
    /// Bytes of each item's RESULT message entry (`sched::wire::result_bytes` + busy time).
    pub result_bytes: Vec<u32>,
    /// The master's cost per hand-out, seconds (zero-work dispatch at this buffer).
    pub master_h_s: f64,
    /// The shared counter's cost per grab, seconds (zero-work self-scheduling, grab 1); also
    /// the cost of one steal.
    pub counter_s: f64,
    /// Seconds every run spends outside its items, added to the simulated wall: threads
    /// started and joined, measured for local threads (the intercept of the zero-work runs);
    /// 0 where that launch is not measured (a cluster's).
    #[serde(default)]
    pub start_s: f64,
    /// The master's refill period per source, seconds: a source under the master finishes
    /// at most one item per `refill_s` and waits out the rest (no core used). Measured for
    /// local threads (the sleeping master's wake-up and round trip per item) and for MPI
    /// launches on this node (the launch again with spinning items: rank 0's hub, the
    /// worker's MPI thread and their polling); 0 where it is not measured (a cluster's
    /// master, whose round trip is the simulated network's).
    #[serde(default)]
    pub refill_s: f64,
    /// Workers lost during the run.
    pub lost: Vec<LostWorker>,
    /// How its messages travel.
    #[serde(default)]
    pub network: Network,
    /// Seed of the work-stealing victim choice.
    pub seed: u64,
}

/// What a simulated run measured, in the terms of [`crate::core::metrics::RunStats`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SimOutcome {
    /// Simulated wall time, seconds.
    pub wall_s: f64,
    /// Simulated busy seconds per worker.
    pub busy_s: Vec<f64>,
    /// Items each worker rendered.
    pub worker_items: Vec<u64>,
    /// Simulated seconds the master spent handing out (0 without a master).
    pub dispatch_s: f64,
    /// Hand-outs, re-issues included (grabs count their items).
    pub issued: u64,
    /// Hand-outs of an item already handed out.
    pub reissued: u64,
    /// Results for an item already done.
    pub duplicates: u64,
    /// Simulated bytes of every message.
    pub bytes: u64,
    /// Messages sent.
    pub messages: u64,
    /// Items with a result.
    pub done: u64,
    /// Workers lost.
    pub lost_workers: u64,
    /// Why the run did not finish (items lost that the scheduler cannot redo), if it did not.
    pub error: Option<String>,
    /// Seconds of real time the simulation took.
    pub host_s: f64,
}

/// A platform's hosts as SimGrid read them.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PlatformInfo {
    /// (name, flop/s of one core, cores), in placement order ([`placement_order`]).
    pub hosts: Vec<(String, f64, usize)>,
}

impl PlatformInfo {
    /// Workers the platform can hold, one per core: every core of a one-host platform (the
    /// master shares the node), else every core of the hosts after the first (the master's).
    pub fn worker_slots(&self) -> usize {
        match self.hosts.len() {
            0 => 0,
            1 => self.hosts[0].2,
            _ => self.hosts[1..].iter().map(|h| h.2).sum(),
        }
    }
    /// Host index of each of `workers` workers (hosts filled core by core, in order), and the
    /// master's host index.
    pub fn placement(&self, workers: usize) -> (usize, Vec<usize>) {
        let first = usize::from(self.hosts.len() > 1);
        let mut out = Vec::with_capacity(workers);
        for (i, h) in self.hosts.iter().enumerate().skip(first) {
            for _ in 0..h.2 {
                if out.len() == workers {
                    return (0, out);
                }
                out.push(i);
            }
        }
        (0, out)
    }
}

/// Hosts sorted by name with their trailing number compared as a number (`node-2` before
/// `node-10`): the order workers are placed in.
pub fn placement_order(a: &str, b: &str) -> std::cmp::Ordering {
    let split = |s: &str| {
        let digits = s.len() - s.trim_end_matches(|c: char| c.is_ascii_digit()).len();
        let (head, tail) = s.split_at(s.len() - digits);
        (
            head.to_string(),
            tail.parse::<u64>().unwrap_or(0),
            s.to_string(),
        )
    };
    split(a).cmp(&split(b))
}
