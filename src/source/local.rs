//! `LocalThreadSource`: one OS thread with its own inbox. The job closes over the scene and
//! tracer by `Arc`, so every thread reads the one copy; `Tracer: Sync` and the immutable
//! `Scene` make that sharing read-only by type, not by convention.

use super::thread::{Flags, SourceThread};
use super::{
    Completer, ComputeSource, DelayedResult, HandOutCompleter, Job, Notifier, Outcome,
    SourceFailure, SourceReport,
};
use crate::core::metrics::{BusyClock, Probe};
use crate::core::render::WorkItem;
use crossbeam::channel::Receiver;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// A compute source that runs its job on one OS thread of its own, items in arrival order.
pub struct LocalThreadSource {
    id: u32,
    thread: SourceThread<Batch>,
}

/// One inbox message: the items of one hand-out, each with the completer of its result, or
/// (`HandOut`) with one completer for them all. A single item travels without a `Vec`: at
/// buffer 2 most hand-outs are one item, and a `Vec` allocated by the master and freed by the
/// worker cost both sides glibc's arena lock.
enum Batch {
    One((WorkItem, Completer)),
    Many(Vec<(WorkItem, Completer)>),
    HandOut(Vec<WorkItem>, HandOutCompleter),
}

impl LocalThreadSource {
    /// Start the thread of source `id`, which runs `job` on every item it is handed.
    pub fn spawn(id: u32, job: Job, probe: Probe) -> Self {
        let thread = SourceThread::spawn(format!("source-{id}"), move |fl, rx| {
            serve(id, &job, probe, fl, rx)
        });
        Self { id, thread }
    }
}

/// What the source's thread keeps over its run.
struct Serving<'a> {
    id: u32,
    job: &'a Job,
    probe: Probe,
    fl: &'a Flags,
    clock: BusyClock,
    report: SourceReport,
    /// Set once the job panicked: every later item fails with it.
    failure: Option<SourceFailure>,
}

impl Serving<'_> {
    /// Render `item` unless the source is lost or cancelled.
    fn outcome(&mut self, item: &WorkItem) -> Outcome {
        if let Some(f) = &self.failure {
            return Err(f.clone());
        }
        if self.fl.cancelled() {
            return Err(SourceFailure::Cancelled { item: item.id });
        }
        match catch_unwind(AssertUnwindSafe(|| (self.job)(item))) {
            Ok(r) => {
                let (probe, id) = (self.probe, self.id);
                self.clock
                    .item_done(&probe, id, item.id, &mut self.report.spans);
                self.report.stats.count(item, r.rays);
                Ok(r)
            }
            Err(panic) => {
                self.fl.set_lost();
                let f = SourceFailure::Lost {
                    source_id: self.id,
                    reason: format!("worker panicked: {}", panic_message(&panic)),
                };
                self.failure = Some(f.clone());
                Err(f)
            }
        }
    }

    /// Run one message's items in order. Behind a panic (`failure` set) this fails each of
    /// them with it, so it also drains the inbox of a lost source.
    fn run(&mut self, batch: Batch) {
        match batch {
            Batch::One((item, done)) => self.run_one(&item, done),
            Batch::Many(v) => v
                .into_iter()
                .for_each(|(item, done)| self.run_one(&item, done)),
            Batch::HandOut(items, mut done) => {
                for (k, item) in items.iter().enumerate() {
                    let o = self.outcome(item);
                    done.set(k, o);
                }
                done.publish();
                self.fl.items_finished(items.len() as u64);
                self.fl.ring();
            }
        }
    }

    /// One item with a result cell of its own.
    fn run_one(&mut self, item: &WorkItem, done: Completer) {
        let o = self.outcome(item);
        done.complete(o);
        self.fl.items_finished(1);
        self.fl.ring();
    }
}

/// The source's thread: run every message's items in order until the inbox closes or the
/// job panics (then this item and everything still queued fail as lost).
fn serve(id: u32, job: &Job, probe: Probe, fl: &Flags, rx: &Receiver<Batch>) -> SourceReport {
    let mut report = SourceReport::default();
    report.stats.source = Some(crate::core::metrics::SourceKind::Threads);
    let mut s = Serving {
        id,
        job,
        probe,
        fl,
        clock: BusyClock::start(&probe),
        report,
        failure: None,
    };
    while let Ok(batch) = rx.recv() {
        // Waiting for a message never counts as busy.
        s.clock.restart(&probe);
        s.run(batch);
        if s.failure.is_some() {
            // The source is lost: everything queued behind the panicking item fails too.
            while let Ok(batch) = rx.try_recv() {
                s.run(batch);
            }
            fl.ring();
            break;
        }
    }
    s.report.stats.busy_s = s.clock.busy().as_secs_f64();
    s.report
}

/// The message of a panic payload (`&str` or `String`), or a placeholder.
pub fn panic_message(p: &Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "non-string panic payload".into())
}

/// The label of local thread source `id`.
pub fn thread_label(id: u32) -> String {
    format!("local-thread-{id}")
}

impl ComputeSource for LocalThreadSource {
    fn id(&self) -> u32 {
        self.id
    }
    fn label(&self) -> String {
        thread_label(self.id)
    }
    fn submit(&mut self, item: WorkItem) -> DelayedResult {
        let (d, c) = DelayedResult::pending(item.id, self.id);
        self.thread.send(Batch::One((item, c)));
        d
    }
    fn submit_batch(&mut self, items: &mut Vec<WorkItem>, out: &mut Vec<DelayedResult>) {
        if items.len() == 1 {
            out.extend(items.pop().map(|it| self.submit(it)));
            return;
        }
        let batch = super::thread::pending_batch(items, self.id, out);
        self.thread.send(Batch::Many(batch));
    }
    fn submit_hand_out(&mut self, items: &mut Vec<WorkItem>, out: &mut Vec<DelayedResult>) {
        if items.is_empty() {
            return;
        }
        let done = HandOutCompleter::pending(items.iter().map(|it| it.id), self.id, out);
        self.thread
            .send(Batch::HandOut(std::mem::take(items), done));
    }
    fn returns_per_hand_out(&self) -> bool {
        true
    }
    fn is_lost(&self) -> bool {
        self.thread.is_lost()
    }
    fn finished(&self) -> Option<u64> {
        Some(self.thread.finished())
    }
    fn set_notifier(&mut self, notifier: Notifier) {
        self.thread.set_notifier(notifier);
    }
    fn finish(mut self: Box<Self>) -> SourceReport {
        self.thread.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::empty_result as result;
    use std::sync::Arc;
    use std::time::Duration;

    #[test]
    fn batch_results_come_back_in_order_and_a_panic_fails_the_rest_as_lost() {
        let job: Job = Arc::new(|it: &WorkItem| {
            assert!(it.id != 5, "item 5 panics");
            result(it.id)
        });
        let mut src = LocalThreadSource::spawn(0, job, Probe::new(true, false));
        let mut out = Vec::new();
        let mut items: Vec<_> = (0..8).map(|i| WorkItem::rect(i, 0, 0, 1, 1)).collect();
        src.submit_batch(&mut items, &mut out);
        assert!(items.is_empty());
        let later = src.submit(WorkItem::rect(8, 0, 0, 1, 1));
        let got: Vec<_> = out
            .into_iter()
            .map(|d| (d.item(), d.wait_timeout(Duration::from_secs(10)).ok()))
            .collect();
        for (i, (item, o)) in got.iter().enumerate() {
            assert_eq!(*item, i as u32);
            match o {
                Some(Ok(r)) => assert!(i < 5 && r.item == i as u32),
                Some(Err(SourceFailure::Lost { .. })) => assert!(i >= 5),
                other => panic!("item {i}: {other:?}"),
            }
        }
        let later = later.wait_timeout(Duration::from_secs(10));
        assert!(matches!(later, Ok(Err(SourceFailure::Lost { .. }))));
        assert!(src.is_lost());
        assert_eq!(Box::new(src).finish().stats.items, 5);
    }

    #[test]
    fn a_hand_out_comes_back_whole_and_in_order_and_a_panic_fails_the_rest() {
        let job: Job = Arc::new(|it: &WorkItem| {
            assert!(it.id != 13, "item 13 panics");
            result(it.id)
        });
        let mut src = LocalThreadSource::spawn(1, job, Probe::new(true, false));
        assert!(src.returns_per_hand_out());
        let mut out = Vec::new();
        let mut items: Vec<_> = (0..6).map(|i| WorkItem::rect(i, 0, 0, 1, 1)).collect();
        src.submit_hand_out(&mut items, &mut out);
        assert!(items.is_empty());
        let first: Vec<_> = std::mem::take(&mut out)
            .into_iter()
            .map(|d| (d.item(), d.wait_timeout(Duration::from_secs(10))))
            .collect();
        for (i, (item, o)) in first.into_iter().enumerate() {
            assert_eq!(item, i as u32);
            assert_eq!(o.unwrap().unwrap().item, i as u32);
        }
        // Six items finished: counted right after the hand-out's results are out.
        let counted = |src: &LocalThreadSource, n: u64| {
            let t0 = std::time::Instant::now();
            while src.finished() != Some(n) && t0.elapsed() < Duration::from_secs(10) {
                std::thread::yield_now();
            }
            src.finished()
        };
        assert_eq!(counted(&src, 6), Some(6));
        // A panic at the hand-out's second item: the first arrives, the rest fail, and so
        // does a hand-out queued behind it.
        let mut items: Vec<_> = (12..16).map(|i| WorkItem::rect(i, 0, 0, 1, 1)).collect();
        src.submit_hand_out(&mut items, &mut out);
        let mut items: Vec<_> = (16..18).map(|i| WorkItem::rect(i, 0, 0, 1, 1)).collect();
        src.submit_hand_out(&mut items, &mut out);
        let got: Vec<_> = out
            .into_iter()
            .map(|d| d.wait_timeout(Duration::from_secs(10)).ok())
            .collect();
        assert!(matches!(&got[0], Some(Ok(r)) if r.item == 12));
        assert!(got[1..]
            .iter()
            .all(|o| matches!(o, Some(Err(SourceFailure::Lost { source_id: 1, .. })))));
        assert!(src.is_lost());
        assert_eq!(counted(&src, 12), Some(12));
        assert_eq!(Box::new(src).finish().stats.items, 7);
    }
}
