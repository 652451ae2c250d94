//! Each rule shape's protocol as SimGrid actors, one small function per
//! [`HandOut`] shape (see [`spawn_protocol`]), driving the protocols of `sched::rule`.
//!
//! Costs: an item's measured seconds × [`REFERENCE_FLOPS`] are executed on its worker's host
//! (a slower host takes longer; on a shared node the master's executions share its cores);
//! the master executes its per-hand-out cost h for each item it hands out. Where an actor's
//! host has a core for every actor that computes on it (a cluster node with one worker, the
//! master's node of a cluster), the execution is a timer of flops ÷ speed instead (see
//! [`Cpu`]). The shared counter and a steal take `counter_s` of simulated time without using a
//! core (an atomic operation serialises, it does not compute). Messages carry their
//! wire-format sizes.
//!
//! State shared by the actors is a `Rc<RefCell<…>>`: SimGrid runs every actor on one thread,
//! and no borrow is held across a call that can switch actors (execute, sleep, put, get).

use super::ffi::{self, clock, execute, sleep_for, Host, Mailbox, Semaphore};
use crate::sched::dls::{ItemTimes, Report};
use crate::sched::rule::{band, Dispense, HandOut, MasterQueue, StealState, WorkerRule};
use crate::sched::Requeue;
use crate::studies::simulate::job::{Network, SimJob, SimOutcome, FAN_IN_GROUP, REFERENCE_FLOPS};
use std::cell::{Cell, RefCell};
use std::collections::{BinaryHeap, HashMap, VecDeque};
use std::rc::Rc;
use std::time::Duration;

/// Bytes of a message that carries nothing but its envelope (a steal request, an empty grab).
const EMPTY_MESSAGE: u64 = 1;

/// Tallies every protocol fills in.
pub(crate) struct Tally {
    pub(crate) out: SimOutcome,
    done: Vec<bool>,
    /// Simulated time each worker finished its last item (or its host went off).
    end: Vec<f64>,
    /// Last arrival of a result at the master's host.
    last_result: f64,
    lost: Vec<bool>,
}

type Shared<T> = Rc<RefCell<T>>;

/// How an actor spends computation: as an execution shared with the host's other executions,
/// or, on a core of its own, as a timer of the same length. SimGrid gives each of ≤ cores
/// executions a whole core, so both take the same simulated time; the timer spares the engine
/// a CPU-sharing variable per execution. (What made large runs slow was the shared mailbox,
/// see [`Inbox`].)
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Cpu {
    /// Shared: `sg_actor_execute`.
    Shared,
    /// A core of its own at this many flop/s: `sg_actor_sleep_for(flops / speed)`.
    Own(f64),
}

impl Cpu {
    /// Spend `flops` on the calling actor's host.
    fn compute(self, flops: f64) {
        match self {
            Cpu::Shared => execute(flops),
            Cpu::Own(speed) => sleep_for(flops / speed),
        }
    }
}

/// Everything one run's actors share.
pub(crate) struct World {
    pub(crate) job: SimJob,
    pub(crate) master_host: Host,
    pub(crate) worker_hosts: Vec<Host>,
    pub(crate) tally: Shared<Tally>,
    /// How each worker computes.
    worker_cpu: Vec<Cpu>,
    /// How the master computes its hand-outs.
    master_cpu: Cpu,
    /// The coarse network's links ([`Network::Coarse`]); `None` on SimGrid's network.
    wires: Option<Rc<Wires>>,
}

/// Each worker's [`Cpu`] and the master's: a host with at least as many cores as actors
/// computing on it (its workers, plus the master when `master_computes`) gives each a core.
fn cpus(master_host: Host, worker_hosts: &[Host], master_computes: bool) -> (Vec<Cpu>, Cpu) {
    let computing = |h: Host| {
        worker_hosts.iter().filter(|&&w| w == h).count()
            + usize::from(master_computes && h == master_host)
    };
    let cpu = |h: Host| {
        if computing(h) <= h.cores() {
            Cpu::Own(h.speed())
        } else {
            Cpu::Shared
        }
    };
    let mut memo: Vec<(Host, Cpu)> = Vec::new();
    let workers = worker_hosts
        .iter()
        .map(|&h| match memo.iter().find(|(m, _)| *m == h) {
            Some(&(_, c)) => c,
            None => {
                let c = cpu(h);
                memo.push((h, c));
                c
            }
        })
        .collect();
    (workers, cpu(master_host))
}

impl World {
    /// The world of `job`; `master_computes`: the rule has a hand-out thread, which executes
    /// its cost per hand-out on the master's host ([`crate::sched::rule::Needs`]).
    pub(crate) fn new(
        job: SimJob,
        master_host: Host,
        worker_hosts: Vec<Host>,
        master_computes: bool,
    ) -> Self {
        let (worker_cpu, master_cpu) = cpus(master_host, &worker_hosts, master_computes);
        let (n, w) = (job.cost_s.len(), job.workers);
        let tally = Tally {
            out: SimOutcome {
                busy_s: vec![0.0; w],
                worker_items: vec![0; w],
                ..Default::default()
            },
            done: vec![false; n],
            end: vec![0.0; w],
            last_result: 0.0,
            lost: vec![false; w],
        };
        let wires = (job.network == Network::Coarse).then(|| Rc::new(Wires::new()));
        Self {
            job,
            master_host,
            worker_hosts,
            tally: Rc::new(RefCell::new(tally)),
            worker_cpu,
            master_cpu,
            wires,
        }
    }

    /// The outcome once the simulation has ended.
    pub(crate) fn finish(&self) -> SimOutcome {
        let t = self.tally.borrow();
        let mut out = t.out.clone();
        out.done = t.done.iter().filter(|d| **d).count() as u64;
        let ends = t.end.iter().cloned().fold(0.0, f64::max);
        out.wall_s = out.wall_s.max(ends).max(t.last_result);
        out.lost_workers = t.lost.iter().filter(|l| **l).count() as u64;
        if out.error.is_none() && out.done < t.done.len() as u64 {
            out.error = Some(format!(
                "{} of {} items lost with {} worker(s); '{}' cannot redo them",
                t.done.len() as u64 - out.done,
                t.done.len(),
                out.lost_workers,
                self.job.scheduler
            ));
        }
        out
    }
}

/// Execute `items` on the calling worker `w` (one execution for all of them: fewer activities)
/// and count them done.
fn work(world: &World, w: usize, items: &[usize]) {
    let (tally, job) = (&world.tally, &world.job);
    let cost: f64 = items.iter().map(|&i| job.cost_s[i]).sum();
    let t0 = clock();
    world.worker_cpu[w].compute(cost * REFERENCE_FLOPS);
    let mut t = tally.borrow_mut();
    let now = clock();
    t.out.busy_s[w] += now - t0;
    t.out.worker_items[w] += items.len() as u64;
    t.end[w] = now;
    for &i in items {
        if std::mem::replace(&mut t.done[i], true) {
            t.out.duplicates += 1;
        }
    }
}

fn count_message(tally: &Shared<Tally>, bytes: u64) {
    let mut t = tally.borrow_mut();
    t.out.messages += 1;
    t.out.bytes += bytes;
}

/// Bytes of a message carrying `items`' entries of `sizes` (`job.item_bytes` or
/// `job.result_bytes`), at least an envelope.
fn bytes(sizes: &[u32], items: &[usize]) -> u64 {
    items
        .iter()
        .map(|&i| sizes[i] as u64)
        .sum::<u64>()
        .max(EMPTY_MESSAGE)
}

/// A message with the simulated time it reaches its receiver (ordered earliest first, then
/// in sending order).
struct Arrival<T> {
    at: f64,
    seq: u64,
    value: T,
}

impl<T> PartialEq for Arrival<T> {
    fn eq(&self, o: &Self) -> bool {
        self.seq == o.seq
    }
}
impl<T> Eq for Arrival<T> {}
impl<T> PartialOrd for Arrival<T> {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl<T> Ord for Arrival<T> {
    // Reversed: `BinaryHeap` is a max-heap and the earliest arrival must come first.
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        o.at.total_cmp(&self.at).then(o.seq.cmp(&self.seq))
    }
}

/// The coarse network ([`Network::Coarse`]): a message from host a to host b leaves when a's
/// outgoing link is free, occupies it for bytes / bandwidth, arrives a route latency later and
/// is delivered when b's incoming link has passed it (each link direction a FIFO server, as
/// `SPLITDUPLEX` gives each direction its own capacity). Latency and bandwidth are the
/// platform's, per route. Not modelled: a backbone shared by many pairs and the network
/// model's factors (M-128).
pub(crate) struct Wires {
    routes: RefCell<HashMap<(Host, Host), (f64, f64)>>,
    out_free: RefCell<HashMap<Host, f64>>,
    in_free: RefCell<HashMap<Host, f64>>,
}

impl Wires {
    fn new() -> Self {
        Self {
            routes: RefCell::new(HashMap::new()),
            out_free: RefCell::new(HashMap::new()),
            in_free: RefCell::new(HashMap::new()),
        }
    }

    /// When `bytes` sent now from `from` reach `to`.
    fn arrival(&self, from: Host, to: Host, bytes: u64) -> f64 {
        let (lat, bw) = *self
            .routes
            .borrow_mut()
            .entry((from, to))
            .or_insert_with(|| from.route_to(to));
        let tx = if bw > 0.0 { bytes as f64 / bw } else { 0.0 };
        let now = clock();
        let mut out = self.out_free.borrow_mut();
        let leave = out.get(&from).copied().unwrap_or(0.0).max(now);
        out.insert(from, leave + tx);
        let mut inn = self.in_free.borrow_mut();
        let at = (leave + lat + tx).max(inn.get(&to).copied().unwrap_or(0.0) + tx);
        inn.insert(to, at);
        at
    }
}

/// One receiver's messages. On SimGrid's network ([`Network::Fine`]) a receiver with one
/// sender at a time reads its own mailbox; one with many (the master, the counter, the sink)
/// is a fan-in: senders are split in groups of [`FAN_IN_GROUP`], each group sending to its own
/// mailbox `{name}{group}`, whose relay actor (on the receiver's host) moves each message, once
/// the network has delivered it, into one queue counted by a semaphore: the arrival order of
/// one shared mailbox without SimGrid's scan of its queue per message (M-127). On the coarse
/// network every message goes straight into the receiver's queue with its arrival time from
/// [`Wires`]; no flow, relay or mailbox.
struct Inbox<T> {
    name: String,
    host: Host,
    /// Fine network, many senders: relays feed `queue`.
    fan_in: bool,
    /// The coarse network's links; `None` on SimGrid's.
    wires: Option<Rc<Wires>>,
    queue: Shared<BinaryHeap<Arrival<T>>>,
    seq: Cell<u64>,
    ready: Semaphore,
}

impl<T: 'static> Inbox<T> {
    /// The inbox `name` on `host`; `senders` > 1 at a time makes it a fan-in.
    fn new(world: &World, name: &str, host: Host, fan_in: bool) -> Rc<Self> {
        let inbox = Rc::new(Self {
            name: name.to_string(),
            host,
            fan_in,
            wires: world.wires.clone(),
            queue: Rc::new(RefCell::new(BinaryHeap::new())),
            seq: Cell::new(0),
            ready: Semaphore::new(0),
        });
        if fan_in && inbox.wires.is_none() {
            for g in 0..world.job.workers.div_ceil(FAN_IN_GROUP) {
                let f = Rc::clone(&inbox);
                ffi::spawn("relay", host, true, move || {
                    let mb = Mailbox::<T>::by_name(&format!("{}{g}", f.name));
                    mb.set_receiver();
                    loop {
                        let v = mb.get();
                        f.push(v);
                    }
                });
            }
        }
        inbox
    }

    /// A worker's own inbox (one sender at a time).
    fn of_worker(world: &World, prefix: &str, k: usize) -> Rc<Self> {
        Self::new(world, &format!("{prefix}{k}"), world.worker_hosts[k], false)
    }

    fn own_mailbox(&self) -> Option<Mailbox<T>> {
        (self.wires.is_none() && !self.fan_in).then(|| Mailbox::by_name(&self.name))
    }

    /// Called by the receiving actor before its first `get`: on the fine network its mailbox
    /// takes messages as they are sent (eager).
    fn bind(&self) {
        if let Some(mb) = self.own_mailbox() {
            mb.set_receiver();
        }
    }

    /// Send `value` (`bytes` on the wire) from `from`, the `sender`-th of the inbox's senders,
    /// without waiting for its delivery.
    fn send(&self, from: Host, sender: usize, value: T, bytes: u64) {
        match &self.wires {
            Some(wires) => {
                let at = wires.arrival(from, self.host, bytes);
                self.enqueue(at, value);
            }
            None if self.fan_in => {
                Mailbox::by_name(&format!("{}{}", self.name, sender / FAN_IN_GROUP))
                    .put_detached(value, bytes)
            }
            None => Mailbox::by_name(&self.name).put_detached(value, bytes),
        }
    }

    /// Deliver `v` at once (from the receiver's own host, no network).
    fn push(&self, v: T) {
        self.enqueue(clock(), v);
    }

    fn enqueue(&self, at: f64, value: T) {
        let seq = self.seq.get();
        self.seq.set(seq + 1);
        self.queue.borrow_mut().push(Arrival { at, seq, value });
        self.ready.release();
    }

    /// Is a message waiting?
    fn has_message(&self) -> bool {
        match self.own_mailbox() {
            Some(mb) => mb.has_message(),
            None => self.queue.borrow().peek().is_some_and(|a| a.at <= clock()),
        }
    }

    /// The next message, waiting for one. Every enqueue releases a token; a token left over
    /// from a message taken without waiting costs one extra turn of the loop.
    fn get(&self) -> T {
        if let Some(mb) = self.own_mailbox() {
            return mb.get();
        }
        loop {
            let next = self.queue.borrow().peek().map(|a| a.at);
            match next {
                None => self.ready.acquire(),
                Some(at) => {
                    let wait = at - clock();
                    // A timeout means nothing earlier came: `at` is the earliest.
                    if wait <= 0.0 || !self.ready.acquire_timeout(wait) {
                        return self.queue.borrow_mut().pop().expect("peeked").value;
                    }
                }
            }
        }
    }
}

/// Start the actors that play `rule`, the scheduler's hand-out rule over `world.job`.
pub(crate) fn spawn_protocol(world: Rc<World>, rule: HandOut) {
    let n = world.job.cost_s.len();
    let master_inbox = matches!(rule, HandOut::ByMaster(_))
        .then(|| Inbox::<MasterMsg>::new(&world, "master", world.master_host, true));
    spawn_killers(&world, master_inbox.clone());
    match rule {
        HandOut::ByWorkers(WorkerRule::Own(own)) => {
            static_split(world, move |n, w, k| own.items(k, n, w).collect())
        }
        HandOut::ByMaster(p) => {
            if let Some(inbox) = master_inbox {
                master(world, inbox, p.buffer, p.requeue)
            }
        }
        HandOut::ByWorkers(WorkerRule::Steal(s)) => stealing(world, s.grab()),
        HandOut::ByWorkers(WorkerRule::Pool(pool)) => counter(world, Box::new(pool.dispenser(n))),
        HandOut::ByWorkers(WorkerRule::Dispense(d)) => counter(world, d),
    }
}

/// Turn the lost workers' hosts off at their times; the master hears of it at once (a local
/// source's failure is seen on its next result; over MPI after a silence, not modelled).
fn spawn_killers(world: &Rc<World>, master: Option<Rc<Inbox<MasterMsg>>>) {
    for lost in world.job.lost.clone() {
        let w = Rc::clone(world);
        let master = master.clone();
        ffi::spawn("killer", world.master_host, true, move || {
            sleep_for(lost.at_s);
            let host = w.worker_hosts[lost.worker];
            {
                let mut t = w.tally.borrow_mut();
                for (k, h) in w.worker_hosts.iter().enumerate() {
                    if *h == host && !t.lost[k] {
                        t.lost[k] = true;
                        t.end[k] = t.end[k].min(lost.at_s);
                    }
                }
            }
            host.turn_off();
            if let Some(m) = &master {
                m.push(MasterMsg::Lost);
            }
        });
    }
}

/// `static` / `static_cyclic`: each worker computes its fixed share; no messages.
fn static_split(world: Rc<World>, share: impl Fn(usize, usize, usize) -> Vec<usize>) {
    let (n, w) = (world.job.cost_s.len(), world.job.workers);
    for k in 0..w {
        let wd = Rc::clone(&world);
        let items = share(n, w, k);
        ffi::spawn("worker", world.worker_hosts[k], false, move || {
            wd.tally.borrow_mut().out.issued += items.len() as u64;
            work(&wd, k, &items);
        });
    }
}

/// A grab request: the worker, and the results of its previous grab riding with it (over MPI
/// the RESULT message is the request).
struct Request {
    worker: usize,
    /// Its previous chunk's items and simulated times, for the adaptive rules.
    report: Option<Report>,
}

/// A pool of any shape: a counter actor on the master's host answers each request with what
/// the pool's [`Dispense`] grants; an empty answer ends the worker.
fn counter(world: Rc<World>, mut pool: Box<dyn Dispense>) {
    let w = world.job.workers;
    let wd = Rc::clone(&world);
    let requests = Inbox::<Request>::new(&world, "counter", world.master_host, true);
    let grants: Vec<Rc<Inbox<Vec<usize>>>> =
        (0..w).map(|k| Inbox::of_worker(&world, "w", k)).collect();
    let inbox = Rc::clone(&requests);
    let to = grants.clone();
    ffi::spawn("counter", world.master_host, true, move || loop {
        let req = inbox.get();
        sleep_for(wd.job.counter_s);
        let items: Vec<usize> = pool
            .grant(req.worker, req.report.as_ref())
            .map_or_else(Vec::new, Iterator::collect);
        let c = items.len();
        let bytes = bytes(&wd.job.item_bytes, &items);
        wd.tally.borrow_mut().out.issued += c as u64;
        count_message(&wd.tally, bytes);
        to[req.worker].send(wd.master_host, 0, items, bytes);
    });
    for (k, inbox) in grants.into_iter().enumerate() {
        let wd = Rc::clone(&world);
        let counter = Rc::clone(&requests);
        ffi::spawn("worker", world.worker_hosts[k], false, move || {
            inbox.bind();
            let mut last: Vec<usize> = Vec::new();
            let mut report = None;
            loop {
                let bytes = bytes(&wd.job.result_bytes, &last);
                count_message(&wd.tally, bytes);
                let asked = clock();
                counter.send(wd.worker_hosts[k], k, Request { worker: k, report }, bytes);
                let items = inbox.get();
                if items.is_empty() {
                    let mut t = wd.tally.borrow_mut();
                    t.end[k] = clock();
                    return;
                }
                let started = clock();
                work(&wd, k, &items);
                report = Some(chunk_report(
                    &wd.job,
                    &items,
                    started - asked,
                    clock() - started,
                ));
                last = items;
            }
        });
    }
}

/// A worker's report on one chunk: its simulated duration, split over the items in
/// proportion to their measured costs (one execution runs the whole chunk).
fn chunk_report(job: &SimJob, items: &[usize], grab_secs: f64, secs: f64) -> Report {
    let cost: f64 = items.iter().map(|&i| job.cost_s[i]).sum();
    let scale = if cost > 0.0 { secs / cost } else { 0.0 };
    let mut times = ItemTimes::default();
    for &i in items {
        times.add(job.cost_s[i] * scale);
    }
    Report {
        items: items.len(),
        secs,
        grab_secs,
        times,
    }
}

/// Results of stolen or own work travel to the master's host, each message with its item
/// count; the run ends when the last item's result has arrived. (A daemon sink ended with the
/// last worker, before results in flight arrived: on the 500 µs cluster work stealing at 4096
/// workers came out at static's 0.1 ms, its results' 0.5 ms of latency left out.) With lost
/// workers some results never come, so there the sink is a daemon again and the run ends
/// with the last worker.
fn result_sink(world: &Rc<World>) -> Rc<Inbox<usize>> {
    let wd = Rc::clone(world);
    let sink = Inbox::<usize>::new(world, "sink", world.master_host, true);
    let inbox = Rc::clone(&sink);
    let n = world.job.cost_s.len();
    ffi::spawn(
        "sink",
        world.master_host,
        !world.job.lost.is_empty(),
        move || {
            let mut arrived = 0;
            while arrived < n {
                arrived += inbox.get();
                wd.tally.borrow_mut().last_result = clock();
            }
        },
    );
    sink
}

/// Work stealing: worker k starts with the contiguous band k of the items in its deque, takes
/// `grab` items at a time from its front, and when empty asks a random victim's steal server
/// (an actor on the victim's host) for the back half of the victim's deque. Rayon's recursive
/// splitting is modelled by these halves.
fn stealing(world: Rc<World>, grab: usize) {
    let (n, w) = (world.job.cost_s.len(), world.job.workers);
    let deques: Shared<Vec<VecDeque<usize>>> = Rc::new(RefCell::new(
        (0..w).map(|k| band(k, n, w).collect()).collect(),
    ));
    let unassigned = Rc::new(RefCell::new(n));
    world.tally.borrow_mut().out.issued = n as u64;
    let sink = result_sink(&world);
    // Shared, not copied into each actor: W actors × W inboxes is W² (at 8192 workers most of
    // the simulation's time went into copying and dropping those lists).
    let loot_boxes: Rc<[Rc<Inbox<Vec<usize>>>]> =
        (0..w).map(|k| Inbox::of_worker(&world, "w", k)).collect();
    let steal_boxes: Rc<[Rc<Inbox<usize>>]> = (0..w)
        .map(|k| Inbox::of_worker(&world, "steal", k))
        .collect();
    for (k, inbox) in steal_boxes.iter().cloned().enumerate() {
        let (wd, dq, left) = (
            Rc::clone(&world),
            Rc::clone(&deques),
            Rc::clone(&unassigned),
        );
        let loot_boxes = Rc::clone(&loot_boxes);
        ffi::spawn("steal-server", world.worker_hosts[k], true, move || {
            inbox.bind();
            loop {
                let thief = inbox.get();
                sleep_for(wd.job.counter_s);
                let loot: Vec<usize> = {
                    let mut d = dq.borrow_mut();
                    let keep = StealState::split(d[k].len());
                    d[k].split_off(keep).into()
                };
                *left.borrow_mut() -= loot.len();
                let bytes = bytes(&wd.job.item_bytes, &loot);
                count_message(&wd.tally, bytes);
                loot_boxes[thief].send(wd.worker_hosts[k], k, loot, bytes);
            }
        });
    }
    let thieves = StealState::per_worker(w, world.job.seed);
    for ((k, inbox), mut thief) in loot_boxes.iter().cloned().enumerate().zip(thieves) {
        let (wd, dq, left) = (
            Rc::clone(&world),
            Rc::clone(&deques),
            Rc::clone(&unassigned),
        );
        let steal_boxes = Rc::clone(&steal_boxes);
        let sink = Rc::clone(&sink);
        ffi::spawn("worker", world.worker_hosts[k], false, move || {
            inbox.bind();
            loop {
                let items: Vec<usize> = {
                    let mut d = dq.borrow_mut();
                    let take = grab.min(d[k].len());
                    d[k].drain(..take).collect()
                };
                if !items.is_empty() {
                    *left.borrow_mut() -= items.len();
                    work(&wd, k, &items);
                    let bytes = bytes(&wd.job.result_bytes, &items);
                    count_message(&wd.tally, bytes);
                    sink.send(wd.worker_hosts[k], k, items.len(), bytes);
                    continue;
                }
                if *left.borrow() == 0 {
                    return;
                }
                let Some(victim) = thief.victim() else {
                    return; // alone
                };
                count_message(&wd.tally, EMPTY_MESSAGE);
                steal_boxes[victim].send(wd.worker_hosts[k], k, k, EMPTY_MESSAGE);
                let loot = inbox.get();
                *left.borrow_mut() += loot.len();
                dq.borrow_mut()[k].extend(loot);
            }
        });
    }
}

/// What reaches the master: a result, or the news that a worker's host went off.
enum MasterMsg {
    Result { worker: usize, item: usize },
    Lost,
}

/// The master's ledger: the master's queue ([`MasterQueue`], the rule `sched::exec::master` plays
/// too) and what each simulated worker holds (≤ B fresh items).
struct Ledger {
    queue: MasterQueue,
    done: Vec<bool>,
    done_count: usize,
    held: Vec<Vec<usize>>,
    alive: Vec<bool>,
    buffer: usize,
}

impl Ledger {
    /// Top worker `k` up to B from the queue at the simulated time now: the items handed out
    /// and how many of them were handed out before.
    fn top_up(&mut self, k: usize) -> (Vec<usize>, u64) {
        let before = self.queue.reissued;
        let now = Duration::from_secs_f64(clock().max(0.0));
        let (done, held) = (&self.done, &self.held[k]);
        let mut got = Vec::new();
        self.queue.top_up(
            now,
            self.buffer.saturating_sub(held.len()),
            |i| done[i as usize],
            |i| held.contains(&(i as usize)),
            &mut got,
        );
        let batch: Vec<usize> = got.into_iter().map(|i| i as usize).collect();
        self.held[k].extend(&batch);
        (batch, self.queue.reissued - before)
    }
}

/// The master's workers: each runs the items its batches bring, in order, one result message
/// each, at most one item per the job's refill period.
fn master_workers(
    world: &Rc<World>,
    inbox: &Rc<Inbox<MasterMsg>>,
    batches: &[Rc<Inbox<Vec<usize>>>],
) {
    for (k, own) in batches.iter().cloned().enumerate() {
        let wd = Rc::clone(world);
        let master = Rc::clone(inbox);
        ffi::spawn("worker", world.worker_hosts[k], true, move || {
            let inbox = own;
            inbox.bind();
            let mut local: VecDeque<usize> = VecDeque::new();
            loop {
                while local.is_empty() || inbox.has_message() {
                    local.extend(inbox.get());
                }
                let Some(item) = local.pop_front() else {
                    continue;
                };
                let t0 = clock();
                work(&wd, k, &[item]);
                let bytes = wd.job.result_bytes[item] as u64;
                count_message(&wd.tally, bytes);
                master.send(
                    wd.worker_hosts[k],
                    k,
                    MasterMsg::Result { worker: k, item },
                    bytes,
                );
                // The source's period per item is at least the master's measured refill
                // period: it waits for its refill, idle.
                let rest = wd.job.refill_s - (clock() - t0);
                if rest > 0.0 {
                    sleep_for(rest);
                }
            }
        });
    }
}

/// The master: one actor executing h per hand-out, ≤ B items outstanding per worker, re-queue;
/// each worker finishes at most one item per the job's refill period.
fn master(world: Rc<World>, inbox: Rc<Inbox<MasterMsg>>, buffer: usize, requeue: Requeue) {
    let (n, w) = (world.job.cost_s.len(), world.job.workers);
    let batches: Vec<Rc<Inbox<Vec<usize>>>> =
        (0..w).map(|k| Inbox::of_worker(&world, "w", k)).collect();
    master_workers(&world, &inbox, &batches);
    let wd = world;
    ffi::spawn("master", wd.master_host, false, move || {
        let mut l = Ledger {
            queue: MasterQueue::new(n, requeue),
            done: vec![false; n],
            done_count: 0,
            held: vec![Vec::new(); w],
            alive: vec![true; w],
            buffer,
        };
        let hand_out = |l: &mut Ledger, k: usize| {
            let (batch, reissued) = l.top_up(k);
            if batch.is_empty() {
                return;
            }
            let t0 = clock();
            wd.master_cpu
                .compute(wd.job.master_h_s * batch.len() as f64 * REFERENCE_FLOPS);
            let bytes = bytes(&wd.job.item_bytes, &batch);
            {
                let mut t = wd.tally.borrow_mut();
                t.out.dispatch_s += clock() - t0;
                t.out.issued += batch.len() as u64;
                t.out.reissued += reissued;
            }
            count_message(&wd.tally, bytes);
            batches[k].send(wd.master_host, 0, batch, bytes);
        };
        for k in 0..w {
            hand_out(&mut l, k);
        }
        while l.done_count < n {
            match inbox.get() {
                MasterMsg::Result { worker, item } => {
                    wd.tally.borrow_mut().last_result = clock();
                    l.held[worker].retain(|&i| i != item);
                    if !std::mem::replace(&mut l.done[item], true) {
                        l.done_count += 1;
                    }
                    if l.alive[worker] {
                        hand_out(&mut l, worker);
                    }
                }
                MasterMsg::Lost => {
                    let lost: Vec<bool> = wd.tally.borrow().lost.clone();
                    for (k, &gone) in lost.iter().enumerate().take(w) {
                        if gone && l.alive[k] {
                            l.alive[k] = false;
                            for i in std::mem::take(&mut l.held[k]) {
                                if !l.done[i] {
                                    l.queue.lost(i as u32);
                                }
                            }
                        }
                    }
                    if l.queue.known_lost > 0 || !l.alive.iter().any(|a| *a) {
                        let mut t = wd.tally.borrow_mut();
                        t.out.error = Some(format!(
                            "{} items lost with their worker; re-queue policy '{}' cannot redo them",
                            n - l.done_count,
                            l.queue.requeue()
                        ));
                        t.out.wall_s = clock();
                        return;
                    }
                    // Workers left idle by the loss get the re-queued items now.
                    for k in 0..w {
                        if l.alive[k] && l.held[k].is_empty() {
                            hand_out(&mut l, k);
                        }
                    }
                }
            }
        }
        wd.tally.borrow_mut().out.wall_s = clock();
    });
}
