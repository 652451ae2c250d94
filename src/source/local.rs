//! `LocalThreadSource`: one OS thread with its own inbox. The job closes over the scene and
//! tracer by `Arc`, so every thread reads the one copy; `Tracer: Sync` and the immutable
//! `Scene` make that sharing read-only by type, not by convention.

use super::thread::{Flags, SourceThread};
use super::{Completer, ComputeSource, DelayedResult, Job, Notifier, SourceFailure, SourceReport};
use crate::metrics::{BusyClock, Probe};
use crate::render::WorkItem;
use crossbeam::channel::Receiver;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// A compute source that runs its job on one OS thread of its own, items in arrival order.
pub struct LocalThreadSource {
    id: u32,
    thread: SourceThread<Batch>,
}

/// One inbox message: the items of one hand-out, each with the completer of its result. A
/// single item travels without a `Vec`: at buffer 2 most hand-outs are one item, and a `Vec`
/// allocated by the master and freed by the worker cost both sides glibc's arena lock.
enum Batch {
    One((WorkItem, Completer)),
    Many(Vec<(WorkItem, Completer)>),
}

impl IntoIterator for Batch {
    type Item = (WorkItem, Completer);
    type IntoIter =
        std::iter::Chain<std::option::IntoIter<Self::Item>, std::vec::IntoIter<Self::Item>>;
    fn into_iter(self) -> Self::IntoIter {
        let (one, many) = match self {
            Batch::One(x) => (Some(x), Vec::new()),
            Batch::Many(v) => (None, v),
        };
        one.into_iter().chain(many)
    }
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

/// The source's thread: run every message's items in order until the inbox closes or the
/// job panics (then this item and everything still queued fail as lost).
fn serve(id: u32, job: &Job, probe: Probe, fl: &Flags, rx: &Receiver<Batch>) -> SourceReport {
    let mut report = SourceReport::default();
    report.stats.source = crate::sched::SourceKind::Threads.id().into();
    let mut clock = BusyClock::start(&probe);
    let mut failure: Option<SourceFailure> = None;
    while let Ok(batch) = rx.recv() {
        // Waiting for a message never counts as busy.
        clock.restart(&probe);
        for (item, done) in batch {
            if let Some(f) = &failure {
                done.complete(Err(f.clone()));
                fl.item_finished();
                continue;
            }
            if fl.cancelled() {
                done.complete(Err(SourceFailure::Cancelled { item: item.id }));
                fl.item_finished();
                continue;
            }
            match catch_unwind(AssertUnwindSafe(|| job(&item))) {
                Ok(r) => {
                    clock.item_done(&probe, id, item.id, &mut report.spans);
                    report.stats.count(&item, r.rays);
                    done.complete(Ok(r));
                }
                Err(panic) => {
                    fl.set_lost();
                    let f = SourceFailure::Lost {
                        source_id: id,
                        reason: format!("worker panicked: {}", panic_message(&panic)),
                    };
                    done.complete(Err(f.clone()));
                    failure = Some(f);
                }
            }
            fl.item_finished();
            fl.ring();
        }
        if let Some(f) = &failure {
            // The source is lost: everything queued behind the panicking item fails too.
            while let Ok(batch) = rx.try_recv() {
                for (_, done) in batch {
                    done.complete(Err(f.clone()));
                    fl.item_finished();
                }
            }
            fl.ring();
            break;
        }
    }
    report.stats.busy_s = clock.busy().as_secs_f64();
    report
}

/// The message of a panic payload (`&str` or `String`), or a placeholder.
pub fn panic_message(p: &Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "non-string panic payload".into())
}

impl ComputeSource for LocalThreadSource {
    fn id(&self) -> u32 {
        self.id
    }
    fn label(&self) -> String {
        format!("local-thread-{}", self.id)
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
        let batch = items
            .drain(..)
            .map(|item| {
                let (d, c) = DelayedResult::pending(item.id, self.id);
                out.push(d);
                (item, c)
            })
            .collect();
        self.thread.send(Batch::Many(batch));
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
}
