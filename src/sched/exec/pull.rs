//! A worker rule played over compute sources by the calling thread: the sources cannot take
//! their own items (they are ranks, a GPU, a researcher's source behind the interface), so
//! this thread hands each idle source what the rule gives it and collects the results.
//!
//! - [`WorkerRule::Own`]: source s gets its items at once.
//! - [`WorkerRule::Pool`] and [`WorkerRule::Dispense`]: a source with nothing outstanding
//!   takes what the pool's [`Dispense`] grants, reporting its previous chunk (items and
//!   seconds from hand-out to result).
//! - [`WorkerRule::Steal`]: refused: stealing needs workers that share memory.
//!
//! Nothing is re-queued: a lost source fails the run (the master is the fault-tolerant one).

use crate::core::metrics::{MasterStats, Probe, RunStats};
use crate::core::render::WorkItem;
use crate::sched::results::{finish_sources, seal_stats};
use crate::sched::rule::{Dispense, ItemTimes, Report, WorkerRule};
use crate::sched::{wire, Collector, Results, SchedError, SpecError};
use crate::source::{ComputeSource, DelayedResult, Doorbell, Wait};
use std::time::{Duration, Instant};

/// What one source holds: its outstanding results and when its chunk went out.
struct Held {
    out: Vec<DelayedResult>,
    chunk: usize,
    since: Instant,
    times: ItemTimes,
    report: Option<Report>,
}

impl Held {
    /// Once its chunk is all back: what it reports with its next request.
    fn close_chunk(&mut self) {
        if self.chunk == 0 || !self.out.is_empty() {
            return;
        }
        let secs = self.since.elapsed().as_secs_f64();
        self.times.add_group(self.chunk as u64, secs);
        self.report = Some(Report {
            items: self.chunk,
            secs,
            grab_secs: 0.0,
            times: self.times,
        });
        self.chunk = 0;
    }
}

/// The run as this thread sees it: the sources, what each holds, the results so far.
struct Pull<'a> {
    items: &'a [WorkItem],
    sources: Vec<Box<dyn ComputeSource>>,
    held: Vec<Held>,
    collector: Collector,
    stats: RunStats,
    /// Items handed out so far (a pool's hand-outs need not be in item order).
    handed: usize,
}

impl Pull<'_> {
    /// Hand items `range` to source `s` (one `submit` each, as MPI ranks take them).
    fn submit(&mut self, s: usize, range: std::ops::Range<usize>) {
        self.handed += range.len();
        for i in range {
            self.stats.bytes += wire::item_bytes(&self.items[i]);
            self.stats.issued += 1;
            let r = self.sources[s].submit(self.items[i].clone());
            self.held[s].out.push(r);
        }
    }

    /// Take every ready result; `true` when one failed (its source is gone).
    fn collect(&mut self) -> bool {
        let mut failed = false;
        for h in self.held.iter_mut() {
            let mut j = 0;
            while j < h.out.len() {
                if !h.out[j].is_ready() {
                    j += 1;
                    continue;
                }
                match h.out.swap_remove(j).try_take() {
                    Ok(Ok(r)) => self.collector.accept(r),
                    Ok(Err(_)) => failed = true,
                    Err(d) => h.out.push(d),
                }
            }
        }
        failed
    }

    /// Give every source with nothing outstanding what the pool grants it, reporting its last.
    fn top_up(&mut self, pool: &mut dyn Dispense) {
        for s in 0..self.sources.len() {
            self.held[s].close_chunk();
            if !self.held[s].out.is_empty() || self.handed >= self.items.len() {
                continue;
            }
            let report = self.held[s].report.take();
            let Some(range) = pool.grant(s, report.as_ref()) else {
                continue;
            };
            (self.held[s].chunk, self.held[s].since) = (range.len(), Instant::now());
            self.submit(s, range);
        }
    }

    /// How the run ends, if it ends now.
    fn verdict(
        &mut self,
        failed: bool,
        t0: Instant,
        deadline: Option<Duration>,
    ) -> Option<Result<(), SchedError>> {
        let (n, done) = (self.items.len(), self.collector.tally.done);
        if failed {
            let lost = self.sources.iter().filter(|s| s.is_lost()).count();
            self.stats.lost_sources = lost.max(1) as u64;
            return Some(Err(SchedError::LostItems {
                lost: (n - done) as u64,
                total: n as u64,
            }));
        }
        if done == n {
            return Some(Ok(()));
        }
        deadline.filter(|dl| t0.elapsed() >= *dl).map(|dl| {
            Err(SchedError::Deadline {
                deadline: dl,
                done: done as u64,
                total: n as u64,
            })
        })
    }
}

/// Run `items` on `sources` under `rule`; a lost source or a passed `deadline` fails the run.
pub(in crate::sched) fn run_pull(
    rule: WorkerRule,
    items: &[WorkItem],
    mut sources: Vec<Box<dyn ComputeSource>>,
    deadline: Option<Duration>,
    probe: Probe,
) -> Result<(Results, RunStats), SchedError> {
    let t0 = Instant::now();
    let (n, k) = (items.len(), sources.len());
    let bell = Doorbell::default();
    for s in sources.iter_mut() {
        s.set_notifier(bell.notifier());
    }
    let held = (0..k)
        .map(|_| Held {
            out: Vec::new(),
            chunk: 0,
            since: t0,
            times: ItemTimes::default(),
            report: None,
        })
        .collect();
    let mut p = Pull {
        items,
        sources,
        held,
        collector: Collector::new(n),
        stats: RunStats {
            items: n as u64,
            ..Default::default()
        },
        handed: 0,
    };
    let mut pool = match rule {
        WorkerRule::Own(own) => {
            for s in 0..k {
                for i in own.items(s, n, k) {
                    p.submit(s, i..i + 1);
                }
            }
            None
        }
        pool @ (WorkerRule::Pool(_) | WorkerRule::Dispense(_)) => pool.into_dispense(n).ok(),
        WorkerRule::Steal(_) => {
            return Err(SpecError {
                field: "scheduler".into(),
                msg: "work stealing needs workers that share memory; over these sources use \
                      self_scheduling, guided or a factoring rule"
                    .into(),
            }
            .into())
        }
    };
    let mut m = MasterStats::default();
    let outcome = loop {
        m.iterations += 1;
        let failed = p.collect();
        if let Some(outcome) = p.verdict(failed, t0, deadline) {
            break outcome;
        }
        if let Some(d) = pool.as_mut() {
            p.top_up(d.as_mut());
        }
        let tw = Instant::now();
        bell.wait(Duration::from_millis(2), Wait::Block, || {
            p.held
                .iter()
                .flat_map(|h| &h.out)
                .any(DelayedResult::is_ready)
        });
        m.wait_s += tw.elapsed().as_secs_f64();
    };
    let Pull {
        sources,
        held,
        collector,
        mut stats,
        ..
    } = p;
    drop(held);
    let wall = t0.elapsed().as_secs_f64();
    let mut spans = Vec::new();
    finish_sources(sources, wall, &mut stats, &mut spans);
    outcome?;
    seal_stats(&mut stats, spans, &probe, wall, &collector, m);
    Ok((collector.results, stats))
}
