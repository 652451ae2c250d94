//! `static` and `self_scheduling` over compute sources (the thread versions in `sched` run a
//! job on their own threads; over ranks the items must travel through `submit`).
//!
//! - `static`: source s gets the contiguous band [s·n/k, (s+1)·n/k) at once; no master.
//! - `self_scheduling`: the counter lives at rank 0; a source with nothing outstanding takes
//!   the next `grab` items.
//!
//! Neither re-queues: a lost source fails the run (the master is the fault-tolerant one).

use crate::metrics::{MasterStats, Probe, RunStats};
use crate::render::WorkItem;
use crate::sched::master::{finish_sources, seal_stats};
use crate::sched::{wire, Collector, Policy, Results, SchedError, SchedulerKind, SchedulerSpec};
use crate::source::{ComputeSource, DelayedResult, Doorbell, Wait};
use std::time::{Duration, Instant};

/// Run `items` on `sources` under `static` or `self_scheduling` (the kind in `spec`); a lost
/// source or a passed `deadline` fails the run.
pub fn run_pull(
    spec: &SchedulerSpec,
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
    let mut out: Vec<Vec<DelayedResult>> = (0..k).map(|_| Vec::new()).collect();
    let submit = |out: &mut Vec<DelayedResult>,
                  i: usize,
                  src: &mut Box<dyn ComputeSource>,
                  stats: &mut RunStats| {
        stats.bytes += wire::item_bytes(&items[i]);
        stats.issued += 1;
        out.push(src.submit(items[i].clone()));
    };
    let mut next = 0usize;
    let grab = match spec.policy {
        Policy::SelfScheduling(p) => p.grab,
        _ => 1,
    };
    if spec.kind() == SchedulerKind::Static {
        for (s, src) in sources.iter_mut().enumerate() {
            for i in s * n / k..(s + 1) * n / k {
                submit(&mut out[s], i, src, &mut stats);
            }
        }
        next = n;
    }
    let mut m = MasterStats::default();
    let outcome = loop {
        m.iterations += 1;
        let mut failed = None;
        for slots in out.iter_mut() {
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
        for (s, src) in sources.iter_mut().enumerate() {
            if out[s].is_empty() && next < n {
                for i in next..(next + grab).min(n) {
                    submit(&mut out[s], i, src, &mut stats);
                }
                next = (next + grab).min(n);
            }
        }
        let tw = Instant::now();
        bell.wait(Duration::from_millis(2), Wait::Block, || {
            out.iter().flatten().any(DelayedResult::is_ready)
        });
        m.wait_s += tw.elapsed().as_secs_f64();
    };
    drop(out);
    let wall = t0.elapsed().as_secs_f64();
    let mut spans = Vec::new();
    finish_sources(sources, wall, &mut stats, &mut spans);
    outcome?;
    seal_stats(&mut stats, spans, &probe, wall, &c, m);
    Ok((c.results, stats))
}
