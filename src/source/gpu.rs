//! `GpuSource` (feature `gpu`): a compute source whose hand-outs run on a GPU. Each
//! `submit_batch` becomes one dispatch (every pixel of every item of the hand-out, one kernel
//! invocation per pixel); its [`DelayedResult`]s complete when the dispatch's readback buffer
//! is mapped. A thread of its own submits and waits, so the master never blocks on the
//! device: while the oldest dispatch runs, later hand-outs are already encoded and queued.
//!
//! Unlike the CPU sources, a result is not bit-identical to `render_item`'s: the kernel draws
//! the same random numbers but rounds differently (`gpu` module docs), so a run with a GPU
//! source is compared with the serial image statistically, not bit for bit.

use super::thread::{Flags, SourceThread};
use super::{Completer, ComputeSource, DelayedResult, Notifier, SourceFailure, SourceReport};
use crate::core::gpu::{Dispatch, Entry, GpuInfo, GpuRenderer, PixelOut};
use crate::core::metrics::{Probe, Span};
use crate::core::render::WorkItem;
use crossbeam::channel::{Receiver, TryRecvError};
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Duration;

/// One inbox message: the items of one hand-out, each with the completer of its result.
type Batch = Vec<(WorkItem, Completer)>;

/// A GPU as one compute source: one dispatch per hand-out.
pub struct GpuSource {
    id: u32,
    thread: SourceThread<Batch>,
    info: GpuInfo,
}

impl GpuSource {
    /// Start the thread of source `id` over `renderer` (the scene already on the device).
    pub fn spawn(id: u32, renderer: Arc<GpuRenderer>, probe: Probe) -> Self {
        let info = renderer.info().clone();
        let thread = SourceThread::spawn(format!("gpu-source-{id}"), move |fl, rx| {
            serve(id, &renderer, probe, fl, rx)
        });
        Self { id, thread, info }
    }

    /// The adapter this source renders on.
    pub fn info(&self) -> &GpuInfo {
        &self.info
    }
}

/// One dispatch in flight: its items (with their completers) and when it was submitted.
struct InFlight {
    dispatch: Dispatch,
    items: Vec<(WorkItem, Completer)>,
    submitted: quanta::Instant,
}

/// The GPU's busy time: the union of the intervals during which a dispatch was in flight.
struct GpuClock {
    busy: Duration,
    since: Option<quanta::Instant>,
    /// End of the latest completed dispatch: a later dispatch's span starts no earlier.
    last_end: Option<quanta::Instant>,
}

impl GpuClock {
    fn started(&mut self, now: quanta::Instant) {
        self.since.get_or_insert(now);
    }
    fn idle(&mut self, now: quanta::Instant) {
        if let Some(s) = self.since.take() {
            self.busy += now - s;
        }
    }
}

fn serve(id: u32, r: &GpuRenderer, probe: Probe, fl: &Flags, rx: &Receiver<Batch>) -> SourceReport {
    let mut report = SourceReport::default();
    report.stats.source = Some(crate::core::metrics::SourceKind::Gpu);
    let mut lane = Lane {
        id,
        r,
        fl,
        failure: None,
        clock: GpuClock {
            busy: Duration::ZERO,
            since: None,
            last_end: None,
        },
        inflight: VecDeque::new(),
    };
    let mut open = true;
    loop {
        // Take every hand-out waiting; block only when nothing is in flight.
        let mut next = next_batch(rx, &mut open, lane.inflight.is_empty());
        while let Some(batch) = next.take() {
            lane.submit(batch);
            fl.ring();
            if open {
                next = rx.try_recv().ok();
            }
        }
        let Some(job) = lane.inflight.pop_front() else {
            if open {
                continue;
            }
            break;
        };
        lane.finish(job, probe, &mut report);
        fl.ring();
    }
    lane.clock.idle(quanta::Instant::now());
    if probe.stats {
        report.stats.busy_s = lane.clock.busy.as_secs_f64();
    }
    report
}

/// The next hand-out from `rx`: waits for one when `block` (nothing in flight), else takes
/// one only if it is there. Clears `open` when the channel is closed.
fn next_batch(rx: &Receiver<Batch>, open: &mut bool, block: bool) -> Option<Batch> {
    if !*open {
        None
    } else if block {
        rx.recv().map_err(|_| *open = false).ok()
    } else {
        match rx.try_recv() {
            Ok(b) => Some(b),
            Err(TryRecvError::Empty) => None,
            Err(TryRecvError::Disconnected) => {
                *open = false;
                None
            }
        }
    }
}

/// The GPU lane's state while it serves: its dispatches in flight, its clock and its failure
/// (after which every hand-out fails with it).
struct Lane<'a> {
    id: u32,
    r: &'a GpuRenderer,
    fl: &'a Flags,
    failure: Option<SourceFailure>,
    clock: GpuClock,
    inflight: VecDeque<InFlight>,
}

impl Lane<'_> {
    /// Submit `batch` in dispatch groups; or fail it with the lane's failure, or as cancelled.
    fn submit(&mut self, batch: Batch) {
        if let Some(f) = &self.failure {
            batch
                .into_iter()
                .for_each(|(_, c)| c.complete(Err(f.clone())));
        } else if self.fl.cancelled() {
            for (item, c) in batch {
                c.complete(Err(SourceFailure::Cancelled { item: item.id }));
            }
        } else {
            let r = self.r;
            for group in dispatch_groups(batch, r.max_tasks as usize) {
                let items: Vec<WorkItem> = group.iter().map(|(i, _)| i.clone()).collect();
                match r.submit(&r.tasks_of(&items), Entry::Render) {
                    Ok(dispatch) => {
                        let now = quanta::Instant::now();
                        self.clock.started(now);
                        self.inflight.push_back(InFlight {
                            dispatch,
                            items: group,
                            submitted: now,
                        });
                    }
                    Err(e) => {
                        let f = lose(self.fl, self.id, e.to_string());
                        group
                            .into_iter()
                            .for_each(|(_, c)| c.complete(Err(f.clone())));
                        self.failure = Some(f);
                    }
                }
            }
        }
    }

    /// Wait for `job` (the oldest dispatch) and deliver its items; if it failed, fail them and
    /// every other dispatch in flight.
    fn finish(&mut self, job: InFlight, probe: Probe, report: &mut SourceReport) {
        let InFlight {
            dispatch,
            items,
            submitted,
        } = job;
        match self.r.wait(dispatch) {
            Ok(px) => {
                let job = (items, submitted);
                let now = deliver(self.id, self.r, probe, job, &px, &mut self.clock, report);
                if self.inflight.is_empty() {
                    self.clock.idle(now);
                }
            }
            Err(e) => {
                let f = lose(self.fl, self.id, e.to_string());
                items
                    .into_iter()
                    .for_each(|(_, c)| c.complete(Err(f.clone())));
                for j in self.inflight.drain(..) {
                    j.items
                        .into_iter()
                        .for_each(|(_, c)| c.complete(Err(f.clone())));
                }
                self.failure = Some(f);
                self.clock.idle(quanta::Instant::now());
            }
        }
    }
}

/// Complete a finished dispatch's items (submitted at `submitted`) with their results (`px`,
/// its per-task output), counting and timing them; when it was read back.
fn deliver(
    id: u32,
    r: &GpuRenderer,
    probe: Probe,
    (done_items, submitted): (Vec<(WorkItem, Completer)>, quanta::Instant),
    px: &[PixelOut],
    clock: &mut GpuClock,
    report: &mut SourceReport,
) -> quanta::Instant {
    let now = quanta::Instant::now();
    let items: Vec<WorkItem> = done_items.iter().map(|(i, _)| i.clone()).collect();
    let results = r.results(&items, px);
    let start = clock.last_end.map_or(submitted, |e| e.max(submitted));
    for ((item, done), res) in done_items.into_iter().zip(results) {
        if probe.timeline {
            report.spans.push(Span {
                worker: id,
                item: item.id,
                start_ns: (start - probe.tsc_epoch).as_nanos() as u64,
                end_ns: (now - probe.tsc_epoch).as_nanos() as u64,
            });
        }
        report.stats.count(&item, res.rays);
        done.complete(Ok(res));
    }
    clock.last_end = Some(now);
    now
}

fn lose(fl: &Flags, id: u32, reason: String) -> SourceFailure {
    fl.set_lost();
    SourceFailure::Lost {
        source_id: id,
        reason,
    }
}

/// Split a hand-out into dispatches of at most `max_tasks` pixels at item boundaries (one
/// dispatch unless the hand-out exceeds the device's output-buffer limit; an item larger than
/// the limit goes alone and fails there with the limit in its message).
fn dispatch_groups(batch: Batch, max_tasks: usize) -> Vec<Batch> {
    let mut groups = vec![Vec::new()];
    let mut pixels = 0;
    for (item, c) in batch {
        let n = item.pixel_count();
        if pixels + n > max_tasks && pixels > 0 {
            groups.push(Vec::new());
            pixels = 0;
        }
        pixels += n;
        groups.last_mut().expect("one group").push((item, c));
    }
    groups.retain(|g| !g.is_empty());
    groups
}

impl ComputeSource for GpuSource {
    fn id(&self) -> u32 {
        self.id
    }
    fn label(&self) -> String {
        format!("gpu-{}", self.id)
    }
    fn submit(&mut self, item: WorkItem) -> DelayedResult {
        super::submit_one(self, item)
    }
    fn submit_batch(&mut self, items: &mut Vec<WorkItem>, out: &mut Vec<DelayedResult>) {
        self.thread
            .send(super::thread::pending_batch(items, self.id, out));
    }
    /// Each GPU thread renders its pixel's samples in turn, so a dispatch takes at least one
    /// pixel's samples however few pixels it holds: a tile sent alone ahead of the rest costs
    /// nearly a whole dispatch (reasoned from the kernel and re-enacted in
    /// `examples/hetero_tail`, not timed on a GPU).
    fn runs_hand_outs_whole(&self) -> bool {
        true
    }
    fn dispatch(&self) -> Option<super::Dispatch> {
        Some(super::GPU_DISPATCH)
    }
    fn is_lost(&self) -> bool {
        self.thread.is_lost()
    }
    fn set_notifier(&mut self, notifier: Notifier) {
        self.thread.set_notifier(notifier);
    }
    fn finish(mut self: Box<Self>) -> SourceReport {
        self.thread.finish()
    }
}
