//! The event-driven play of one configuration on one cell: the pool protocol over a link,
//! one dispenser, workers rendering their queued chunks.

use super::config::{Config, Fleet, HandOrder, Link};
use super::corpus::{Cell, CostMap};
use crate::sched::decompose::scatter;
use crate::sched::dls::{self, ChunkRule, ItemTimes, Report};
use crate::studies::simulate::hetero::{GpuModel, Platform};
use std::cmp::Ordering;
use std::collections::{BinaryHeap, VecDeque};

#[derive(Clone, Copy, Debug, PartialEq)]
struct Ev {
    t: f64,
    seq: u64,
    kind: EvKind,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum EvKind {
    /// A request reaches the dispenser.
    Ask {
        w: usize,
        sent: f64,
        report: Option<Report>,
    },
    /// An answer reaches worker w: items `start..start + len` of the order.
    Answer {
        w: usize,
        start: usize,
        len: usize,
        asked_s: f64,
    },
    /// Worker w finishes its running chunk.
    Done { w: usize },
}

impl Eq for Ev {}
impl Ord for Ev {
    fn cmp(&self, o: &Self) -> Ordering {
        // A min-heap on (t, seq).
        o.t.total_cmp(&self.t).then(o.seq.cmp(&self.seq))
    }
}
impl PartialOrd for Ev {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

struct Worker {
    /// Seconds per unit cost (threads), or the GPU.
    unit_s: f64,
    gpu: Option<GpuModel>,
    /// Slowdown: (from this time on, factor), checked before each item.
    slows: Option<(f64, f64)>,
    queue: VecDeque<(usize, usize, f64)>,
    running: bool,
    times: ItemTimes,
    pending: Option<Report>,
}

/// The hand-out order of the map's pixels.
fn hand_order(map: &CostMap, order: HandOrder) -> Vec<u32> {
    let n = map.cost.len();
    match order {
        HandOrder::Scanline => (0..n as u32).collect(),
        HandOrder::Scatter => {
            let mut o: Vec<u32> = (0..n as u32).collect();
            o.sort_by_key(|&i| scatter(map.side, i % map.side, i / map.side));
            o
        }
    }
}

/// The cell's workers, with the fleet's slow worker or mid-run slowdown.
fn fleet_workers(cell: &Cell, spp: u32) -> Vec<Worker> {
    let mut workers: Vec<Worker> = match cell.fleet {
        Fleet::ThreadsGpu => {
            let h = Platform::h200_cornell();
            h.thread_paths_s
                .iter()
                .map(|r| (f64::from(spp) / r, None))
                .chain(std::iter::once((0.0, h.gpu)))
                .map(|(unit_s, gpu)| Worker::new(unit_s, gpu))
                .collect()
        }
        _ => (0..cell.p)
            .map(|_| Worker::new(cell.unit_s, None))
            .collect(),
    };
    let p = workers.len();
    let total: f64 = cell.map.cost.iter().sum::<f64>() * cell.unit_s;
    match cell.fleet {
        Fleet::OneSlow => workers[0].unit_s *= 3.0,
        Fleet::SlowsHalfway => workers[0].slows = Some((total / p as f64 / 2.0, 3.0)),
        _ => {}
    }
    workers
}

/// The pending events, earliest first, ties in the order pushed.
#[derive(Default)]
struct Events {
    heap: BinaryHeap<Ev>,
    seq: u64,
}

impl Events {
    fn push(&mut self, t: f64, kind: EvKind) {
        self.seq += 1;
        self.heap.push(Ev {
            t,
            seq: self.seq,
            kind,
        });
    }
}

/// The one dispenser: requests served in arrival order, `service_s` each, the rule called as
/// the real dispenser calls it under its lock.
struct Desk {
    rule: Box<dyn ChunkRule>,
    /// The next item of the order to hand out.
    next: usize,
    n: usize,
    /// When the dispenser is free again.
    free_at: f64,
}

impl Desk {
    /// Serve worker `w`'s request arriving at `t`: the answer's arrival time, its first item
    /// and its length (0 once everything is handed out).
    fn serve(
        &mut self,
        t: f64,
        w: usize,
        report: Option<Report>,
        link: &Link,
    ) -> (f64, usize, usize) {
        let start = t.max(self.free_at);
        self.free_at = start + link.service_s;
        if let Some(r) = report {
            self.rule.report(w, &r);
        }
        let n = self.n;
        let len = if self.next < n {
            self.rule.next(w, n - self.next).clamp(1, n - self.next)
        } else {
            0
        };
        let first = self.next;
        self.next += len;
        (self.free_at + link.latency_s, first, len)
    }
}

/// Play `config` on `cell`: the wall time, seconds.
pub fn play(cell: &Cell, config: Config) -> f64 {
    let map = cell.map;
    let n = map.cost.len();
    let order = hand_order(map, config.order);
    let spp = 512u32;
    let mut workers = fleet_workers(cell, spp);
    let p = workers.len();
    let mut desk = Desk {
        rule: config.rule.build(n, p),
        next: 0,
        n,
        free_at: 0.0,
    };
    let mut events = Events::default();
    for w in 0..p {
        for _ in 0..config.buffer.max(1) {
            let report = None;
            events.push(
                cell.link.latency_s,
                EvKind::Ask {
                    w,
                    sent: 0.0,
                    report,
                },
            );
        }
    }
    let (mut done, mut wall) = (0usize, 0.0f64);
    while let Some(ev) = events.heap.pop() {
        let t = ev.t;
        match ev.kind {
            EvKind::Ask { w, sent, report } => {
                let (at, start, len) = desk.serve(t, w, report, &cell.link);
                let asked_s = at - sent;
                events.push(
                    at,
                    EvKind::Answer {
                        w,
                        start,
                        len,
                        asked_s,
                    },
                );
            }
            EvKind::Answer {
                w,
                start,
                len,
                asked_s,
            } => {
                if len == 0 {
                    continue;
                }
                workers[w].queue.push_back((start, len, asked_s));
                if !workers[w].running {
                    let end = workers[w].start(t, &order, &map.cost, spp);
                    events.push(end, EvKind::Done { w });
                }
            }
            EvKind::Done { w } => {
                let (_, len, _) = workers[w].queue.front().copied().expect("running");
                done += len;
                wall = wall.max(t);
                let report = workers[w].finish();
                // Ask for the next, carrying this chunk's report.
                let at = t + cell.link.latency_s;
                events.push(at, EvKind::Ask { w, sent: t, report });
                if !workers[w].queue.is_empty() {
                    let end = workers[w].start(t, &order, &map.cost, spp);
                    events.push(end, EvKind::Done { w });
                }
            }
        }
        if done == n {
            break;
        }
    }
    wall
}

impl Worker {
    fn new(unit_s: f64, gpu: Option<GpuModel>) -> Self {
        Self {
            unit_s,
            gpu,
            slows: None,
            queue: VecDeque::new(),
            running: false,
            times: ItemTimes::default(),
            pending: None,
        }
    }

    /// Start the queue's first chunk at `t`: when it ends. Its report is ready for the next
    /// request (the times it measured are known at its end, which is when it asks).
    fn start(&mut self, t: f64, order: &[u32], cost: &[f64], spp: u32) -> f64 {
        let (start, len, asked_s) = self.queue[0];
        self.running = true;
        let items = &order[start..start + len];
        let secs = if let Some(g) = self.gpu {
            let c: f64 = items.iter().map(|&i| cost[i as usize]).sum();
            let s = g.dispatch_s(len as u64, c, spp);
            // A dispatch is timed whole: one group.
            self.times.add_group(len as u64, s);
            s
        } else {
            let mut now = t;
            for group in items.chunks(dls::timed_group(len)) {
                let t0 = now;
                for &i in group {
                    let f = match self.slows {
                        Some((from, f)) if now >= from => f,
                        _ => 1.0,
                    };
                    now += cost[i as usize] * self.unit_s * f;
                }
                self.times.add_group(group.len() as u64, now - t0);
            }
            now - t
        };
        self.pending = Some(Report {
            items: len,
            secs,
            grab_secs: asked_s,
            times: self.times,
        });
        t + secs
    }

    /// The running chunk is done: its report.
    fn finish(&mut self) -> Option<Report> {
        self.queue.pop_front();
        self.running = false;
        self.pending.take()
    }
}
