//! `LocalThreadSource`: one OS thread with its own inbox. The job closes over the scene and
//! tracer by `Arc`, so every thread reads the one copy; `Tracer: Sync` and the immutable
//! `Scene` make that sharing read-only by type, not by convention.

use super::{
    Completer, ComputeSource, DelayedResult, Job, Notifier, Probe, SourceFailure, SourceReport,
};
use crate::render::WorkItem;
use crate::sched::Span;
use crossbeam::channel::{unbounded, Sender};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::thread::JoinHandle;
use std::time::Instant;

struct Shared {
    lost: AtomicBool,
    cancel: AtomicBool,
    notifier: OnceLock<Notifier>,
}

pub struct LocalThreadSource {
    id: u32,
    inbox: Option<Sender<(WorkItem, Completer)>>,
    shared: Arc<Shared>,
    handle: Option<JoinHandle<SourceReport>>,
}

impl LocalThreadSource {
    pub fn spawn(id: u32, job: Job, probe: Probe) -> Self {
        let (tx, rx) = unbounded::<(WorkItem, Completer)>();
        let shared = Arc::new(Shared {
            lost: AtomicBool::new(false),
            cancel: AtomicBool::new(false),
            notifier: OnceLock::new(),
        });
        let sh = shared.clone();
        let handle = std::thread::Builder::new()
            .name(format!("source-{id}"))
            .spawn(move || {
                let mut report = SourceReport::default();
                let ring = |item: u32| {
                    if let Some(n) = sh.notifier.get() {
                        n.ring(id, item);
                    }
                };
                while let Ok((item, done)) = rx.recv() {
                    if sh.cancel.load(Ordering::Relaxed) {
                        done.complete(Err(SourceFailure::Cancelled { item: item.id }));
                        continue;
                    }
                    let t0 = probe.stats.then(Instant::now);
                    match catch_unwind(AssertUnwindSafe(|| job(&item))) {
                        Ok(r) => {
                            if let Some(t0) = t0 {
                                let t1 = Instant::now();
                                report.stats.busy_s += (t1 - t0).as_secs_f64();
                                if probe.timeline {
                                    report.spans.push(Span {
                                        worker: id,
                                        item: item.id,
                                        start_ns: (t0 - probe.epoch).as_nanos() as u64,
                                        end_ns: (t1 - probe.epoch).as_nanos() as u64,
                                    });
                                }
                            }
                            report.stats.items += 1;
                            report.stats.pixels += item.pixel_count() as u64;
                            report.stats.rays += r.rays;
                            done.complete(Ok(r));
                            ring(item.id);
                        }
                        Err(panic) => {
                            // The source is lost: fail this item and everything queued behind it.
                            sh.lost.store(true, Ordering::SeqCst);
                            let reason = panic_message(&panic);
                            let lost = || SourceFailure::Lost {
                                source_id: id,
                                reason: format!("worker panicked: {reason}"),
                            };
                            done.complete(Err(lost()));
                            ring(item.id);
                            while let Ok((it, c)) = rx.try_recv() {
                                c.complete(Err(lost()));
                                ring(it.id);
                            }
                            break;
                        }
                    }
                }
                report
            })
            .expect("spawning a source thread");
        Self {
            id,
            inbox: Some(tx),
            shared,
            handle: Some(handle),
        }
    }
}

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
        if let Some(tx) = &self.inbox {
            // A failed send drops the completer, which fails the result: the thread is gone.
            let _ = tx.send((item, c));
        }
        d
    }
    fn is_lost(&self) -> bool {
        self.shared.lost.load(Ordering::SeqCst)
    }
    fn set_notifier(&mut self, notifier: Notifier) {
        let _ = self.shared.notifier.set(notifier);
    }
    fn finish(mut self: Box<Self>) -> SourceReport {
        self.shared.cancel.store(true, Ordering::SeqCst);
        self.inbox = None;
        self.handle
            .take()
            .and_then(|h| h.join().ok())
            .unwrap_or_default()
    }
}

impl Drop for LocalThreadSource {
    fn drop(&mut self) {
        self.shared.cancel.store(true, Ordering::SeqCst);
        self.inbox = None;
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}
