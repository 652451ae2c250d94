//! The founding design's master (README): a thread that renders nothing keeps at most B items
//! outstanding per compute source, taken from a FIFO queue. A handed-out item goes to the back of
//! the queue; if the master meets it again while it is unfinished, the re-queue policy decides
//! whether it is handed out again (`seed`: yes; `timeout:<ms>`: once outstanding that long;
//! `never`: the item left the queue when first handed out). The first result wins; later ones are
//! counted as duplicates and dropped. Sources that are lost have their items re-queued at once
//! (unless the policy is `never`); a deadline bounds every run, so nothing hangs.

use super::{
    wire, Collector, MasterParams, MasterStats, Results, RunOptions, RunStats, SchedError,
};
use crate::render::WorkItem;
use crate::sched::{Requeue, Span, MASTER_LANE};
use crate::source::{ComputeSource, DelayedResult, Doorbell, Probe};
use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// How long the master waits before it re-polls everything even without a notification
/// (sources that cannot ring, results failed by a dropped completer).
const TICK: Duration = Duration::from_millis(2);

struct Slot {
    item: u32,
    result: DelayedResult,
    at: Instant,
}

/// A slot outstanding longer than this no longer counts against the buffer, so a dropped
/// result cannot block its source for good. `seed`/`never`: 4× the slowest result seen so far
/// (at least 10 ms); `timeout:<ms>`: the timeout.
fn stale_after(requeue: Requeue, slowest: Duration) -> Duration {
    match requeue {
        Requeue::Timeout(d) => d,
        _ => (slowest * 4).max(Duration::from_millis(10)),
    }
}

/// Submit the items collected for one source as one message and keep their slots. Batching,
/// with reused result cells and rings only to a sleeping master, took the master from 160–370
/// to 93–95 ns per one-pixel item at B = 64; sending an idle source's first item alone (the
/// caller's job) keeps B = 2 from waiting for the whole scan (430 → 270–280 ns).
fn hand_out(
    src: &mut Box<dyn ComputeSource>,
    batch: &mut Vec<WorkItem>,
    results: &mut Vec<DelayedResult>,
    slots: &mut Vec<Slot>,
    now: Instant,
) {
    if batch.is_empty() {
        return;
    }
    src.submit_batch(batch, results);
    slots.extend(results.drain(..).map(|result| Slot {
        item: result.item(),
        result,
        at: now,
    }));
}

/// Run `items` on `sources` under the master with `params` (buffer, re-queue policy, wait strategy).
pub fn run_master(
    params: &MasterParams,
    items: &[WorkItem],
    mut sources: Vec<Box<dyn ComputeSource>>,
    opts: &RunOptions,
    probe: Probe,
) -> Result<(Results, RunStats), SchedError> {
    let t0 = Instant::now();
    let n = items.len();
    let bell = Doorbell::default();
    for s in sources.iter_mut() {
        s.set_notifier(bell.notifier());
    }
    let b = params.buffer;
    let timed = probe.stats;
    let mut m = MasterStats::default();
    let mut stats = RunStats {
        items: n as u64,
        ..Default::default()
    };
    let mut c = Collector::new(n);
    let mut queue: VecDeque<u32> = (0..n as u32).collect();
    let mut out: Vec<Vec<Slot>> = sources.iter().map(|_| Vec::with_capacity(b)).collect();
    let mut alive = vec![true; sources.len()];
    // Last hand-out time (timeout policy) or None = may be handed out again at once.
    let mut issued_at: Vec<Option<Instant>> = vec![None; n];
    let mut handed = vec![false; n];
    let mut known_lost = 0u64;
    let mut slowest = Duration::ZERO;
    let mut master_spans = Vec::new();
    let mut batch = Vec::new();
    let mut handed_out = Vec::new();
    let result = loop {
        m.iterations += 1;
        let now = Instant::now();
        let issued_before = stats.issued;
        let mut first_issued = u32::MAX;
        // 1. Collect whatever is ready; a failure means the source is gone.
        for (s, slots) in out.iter_mut().enumerate() {
            let mut k = 0;
            while k < slots.len() {
                if !slots[k].result.is_ready() {
                    // Only a re-issued item can be finished by another source.
                    if stats.reissued > 0 && c.is_done(slots[k].item) {
                        slots.swap_remove(k); // done elsewhere: its slot is free again
                    } else {
                        k += 1;
                    }
                    continue;
                }
                let slot = slots.swap_remove(k);
                match slot.result.try_take() {
                    Ok(Ok(r)) => {
                        slowest = slowest.max(now.saturating_duration_since(slot.at));
                        c.accept(r)
                    }
                    Ok(Err(_)) => {
                        alive[s] = false;
                        if !c.is_done(slot.item) {
                            match params.requeue {
                                Requeue::Never => known_lost += 1,
                                _ => issued_at[slot.item as usize] = None,
                            }
                        }
                    }
                    Err(d) => slots.push(Slot { result: d, ..slot }),
                }
            }
        }
        for (s, src) in sources.iter().enumerate() {
            if alive[s] && src.is_lost() {
                alive[s] = false;
            }
        }
        if c.tally.done == n {
            break Ok(());
        }
        let live = alive.iter().filter(|a| **a).count();
        if live == 0 {
            break Err(SchedError::AllSourcesLost {
                sources: sources.len() as u64,
                remaining: (n - c.tally.done) as u64,
                total: n as u64,
            });
        }
        if params.requeue == Requeue::Never && c.tally.done as u64 + known_lost == n as u64 {
            break Err(SchedError::LostItems {
                lost: known_lost,
                total: n as u64,
            });
        }
        if let Some(dl) = opts.deadline {
            if t0.elapsed() >= dl {
                let (done, total) = (c.tally.done as u64, n as u64);
                break Err(match params.requeue {
                    Requeue::Never => SchedError::LostItems {
                        lost: total - done,
                        total,
                    },
                    _ => SchedError::Deadline {
                        deadline: dl,
                        done,
                        total,
                    },
                });
            }
        }
        // 2. Top every live source up to B outstanding items.
        let stale = stale_after(params.requeue, slowest);
        for (s, src) in sources.iter_mut().enumerate() {
            if !alive[s] {
                continue;
            }
            let mut scanned = 0;
            let len = queue.len();
            let mut fresh = out[s].iter().filter(|sl| now - sl.at < stale).count();
            while fresh < b && scanned < len {
                let Some(i) = queue.pop_front() else { break };
                scanned += 1;
                if c.is_done(i) {
                    continue; // finished: leaves the queue for good
                }
                if handed[i as usize] {
                    let again = match (params.requeue, issued_at[i as usize]) {
                        (Requeue::Revisit, _) | (_, None) => true,
                        (Requeue::Timeout(d), Some(at)) => now - at >= d,
                        (Requeue::Never, _) => false,
                    };
                    // Not again to a source that still holds a fresh copy.
                    if !again || out[s].iter().any(|sl| sl.item == i && now - sl.at < stale) {
                        queue.push_back(i);
                        continue;
                    }
                    stats.reissued += 1;
                }
                let item = items[i as usize].clone();
                stats.bytes += wire::item_bytes(&item);
                batch.push(item);
                fresh += 1;
                if fresh == 1 {
                    // The source is idle: its first item goes at once, not after the scan.
                    hand_out(src, &mut batch, &mut handed_out, &mut out[s], now);
                }
                if stats.issued == issued_before {
                    first_issued = i;
                }
                stats.issued += 1;
                handed[i as usize] = true;
                issued_at[i as usize] = Some(now);
                if params.requeue != Requeue::Never {
                    queue.push_back(i);
                }
            }
            hand_out(src, &mut batch, &mut handed_out, &mut out[s], now);
        }
        // 3. Wait for a result (or the tick), the chosen way.
        let t_wait = timed.then(Instant::now);
        if let Some(b) = t_wait {
            m.dispatch_s += (b - now).as_secs_f64();
            if probe.timeline && stats.issued > issued_before {
                // The master's own lane: each loop pass that handed something out, labelled with
                // the first item of the pass.
                master_spans.push(Span {
                    worker: MASTER_LANE,
                    item: first_issued,
                    start_ns: (now - probe.epoch).as_nanos() as u64,
                    end_ns: (b - probe.epoch).as_nanos() as u64,
                });
            }
        }
        bell.wait(TICK, params.wait, || {
            out.iter().flatten().any(|sl| sl.result.is_ready())
        });
        if let Some(a) = t_wait {
            m.wait_s += a.elapsed().as_secs_f64();
        }
    };
    // Results still in flight are duplicates or lost; cancel them and stop every source.
    drop(out);
    let wall_run = t0.elapsed().as_secs_f64();
    let mut spans = master_spans;
    for src in sources {
        let mut rep = src.finish();
        rep.stats.idle_s = (wall_run - rep.stats.busy_s).max(0.0);
        stats.workers.push(rep.stats);
        spans.extend(rep.spans);
    }
    stats.lost_sources = alive.iter().filter(|a| !**a).count() as u64;
    result?;
    if probe.timeline {
        spans.sort_by_key(|s| (s.start_ns, s.worker));
        stats.timeline = Some(spans);
    }
    stats.wall_s = t0.elapsed().as_secs_f64();
    c.tally.record(&mut stats);
    stats.master = Some(m);
    Ok((c.results, stats))
}
