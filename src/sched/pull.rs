//! A worker rule played over compute sources by the calling thread: the sources cannot take
//! their own items (they are ranks, a GPU, a researcher's source behind the interface), so
//! this thread hands each idle source what the rule gives it and collects the results.
//!
//! - [`WorkerRule::Own`]: source s gets its items at once.
//! - [`WorkerRule::Pool`]: a source with nothing outstanding takes the next chunk the pool's
//!   rule sizes, reporting its previous chunk (items and seconds from hand-out to result).
//! - [`WorkerRule::Steal`]: refused: stealing needs workers that share memory.
//!
//! Nothing is re-queued: a lost source fails the run (the master is the fault-tolerant one).

use super::master::{finish_sources, seal_stats};
use super::rule::{ItemTimes, Report, WorkerRule};
use super::{wire, Collector, Results, SchedError, SpecError};
use crate::metrics::{MasterStats, Probe, RunStats};
use crate::render::WorkItem;
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

/// Run `items` on `sources` under `rule`; a lost source or a passed `deadline` fails the run.
pub(super) fn run_pull(
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
    let mut stats = RunStats {
        items: n as u64,
        ..Default::default()
    };
    let mut c = Collector::new(n);
    let mut held: Vec<Held> = (0..k)
        .map(|_| Held {
            out: Vec::new(),
            chunk: 0,
            since: t0,
            times: ItemTimes::default(),
            report: None,
        })
        .collect();
    let submit = |h: &mut Held, i: usize, src: &mut Box<dyn ComputeSource>, st: &mut RunStats| {
        st.bytes += wire::item_bytes(&items[i]);
        st.issued += 1;
        h.out.push(src.submit(items[i].clone()));
    };
    let mut next = 0usize;
    let mut pool = match rule {
        WorkerRule::Own(own) => {
            for (s, src) in sources.iter_mut().enumerate() {
                for i in own.items(s, n, k) {
                    submit(&mut held[s], i, src, &mut stats);
                }
            }
            next = n;
            None
        }
        WorkerRule::Pool(p) => Some(p.rule),
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
        let mut failed = None;
        for h in held.iter_mut() {
            let slots = &mut h.out;
            let mut j = 0;
            while j < slots.len() {
                if !slots[j].is_ready() {
                    j += 1;
                    continue;
                }
                match slots.swap_remove(j).try_take() {
                    Ok(Ok(r)) => c.accept(r),
                    Ok(Err(_)) => failed = Some(()),
                    Err(d) => slots.push(d),
                }
            }
        }
        if failed.is_some() {
            stats.lost_sources = sources.iter().filter(|s| s.is_lost()).count().max(1) as u64;
            break Err(SchedError::LostItems {
                lost: (n - c.tally.done) as u64,
                total: n as u64,
            });
        }
        if c.tally.done == n {
            break Ok(());
        }
        if let Some(dl) = deadline.filter(|dl| t0.elapsed() >= *dl) {
            break Err(SchedError::Deadline {
                deadline: dl,
                done: c.tally.done as u64,
                total: n as u64,
            });
        }
        if let Some(rule) = pool.as_mut() {
            for (s, src) in sources.iter_mut().enumerate() {
                let h = &mut held[s];
                if !h.out.is_empty() {
                    continue;
                }
                if h.chunk > 0 {
                    let secs = h.since.elapsed().as_secs_f64();
                    h.times.add_group(h.chunk as u64, secs);
                    h.report = Some(Report {
                        items: h.chunk,
                        secs,
                        grab_secs: 0.0,
                        times: h.times,
                    });
                    h.chunk = 0;
                }
                if next >= n {
                    continue;
                }
                if let Some(r) = h.report.take() {
                    rule.report(s, &r);
                }
                let grab = rule.next(s, n - next).clamp(1, n - next);
                for i in next..next + grab {
                    submit(h, i, src, &mut stats);
                }
                (h.chunk, h.since) = (grab, Instant::now());
                next += grab;
            }
        }
        let tw = Instant::now();
        bell.wait(Duration::from_millis(2), Wait::Block, || {
            held.iter()
                .flat_map(|h| &h.out)
                .any(DelayedResult::is_ready)
        });
        m.wait_s += tw.elapsed().as_secs_f64();
    };
    drop(held);
    let wall = t0.elapsed().as_secs_f64();
    let mut spans = Vec::new();
    finish_sources(sources, wall, &mut stats, &mut spans);
    outcome?;
    seal_stats(&mut stats, spans, &probe, wall, &c, m);
    Ok((c.results, stats))
}
