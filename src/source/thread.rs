//! [`SourceThread`]: the lifecycle a source that serves from one OS thread of its own shares
//! with every other such source (local threads, the GPU's submitting thread): the inbox, the
//! lost and cancel flags, the master's notifier, and stopping (cancel, close the inbox, join)
//! on `finish` or drop.

use super::{Notifier, SourceReport};
use crossbeam::channel::{unbounded, Receiver, Sender};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};
use std::thread::JoinHandle;

/// What a source's thread and its handle share.
pub struct Flags {
    lost: AtomicBool,
    cancel: AtomicBool,
    /// Items taken to the end, in inbox order ([`super::ComputeSource::finished`]).
    finished: AtomicU64,
    notifier: OnceLock<Notifier>,
}

impl Flags {
    /// Ring the master's doorbell, once one is set.
    pub fn ring(&self) {
        if let Some(n) = self.notifier.get() {
            n.ring();
        }
    }

    /// `n` more items taken to the end; call after their results are completed, so that a master
    /// that sees the count also sees the result.
    pub fn items_finished(&self, n: u64) {
        self.finished.fetch_add(n, Ordering::SeqCst);
    }

    /// The source is gone: none of its outstanding results will arrive.
    pub fn set_lost(&self) {
        self.lost.store(true, Ordering::SeqCst);
    }

    /// Has the handle asked the thread to skip what is still queued?
    pub fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }
}

/// One pending result per item of `items` (drained), pushed to `out` in order, each with its
/// completer: the message a source that serves hand-outs from its own thread sends it.
pub fn pending_batch(
    items: &mut Vec<crate::core::render::WorkItem>,
    source: u32,
    out: &mut Vec<super::DelayedResult>,
) -> Vec<(crate::core::render::WorkItem, super::Completer)> {
    items
        .drain(..)
        .map(|item| {
            let (result, done) = super::DelayedResult::pending(item.id, source);
            out.push(result);
            (item, done)
        })
        .collect()
}

/// The handle of a source's thread, which takes messages `M` from its inbox and returns the
/// source's report when the inbox closes.
pub struct SourceThread<M> {
    inbox: Option<Sender<M>>,
    flags: Arc<Flags>,
    handle: Option<JoinHandle<SourceReport>>,
}

impl<M: Send + 'static> SourceThread<M> {
    /// Spawn thread `name` running `serve` over the inbox.
    pub fn spawn(
        name: String,
        serve: impl FnOnce(&Flags, &Receiver<M>) -> SourceReport + Send + 'static,
    ) -> Self {
        let (tx, rx) = unbounded::<M>();
        let flags = Arc::new(Flags {
            lost: AtomicBool::new(false),
            cancel: AtomicBool::new(false),
            finished: AtomicU64::new(0),
            notifier: OnceLock::new(),
        });
        let fl = flags.clone();
        let handle = std::thread::Builder::new()
            .name(name)
            .spawn(move || serve(&fl, &rx))
            .expect("spawning a source thread");
        Self {
            inbox: Some(tx),
            flags,
            handle: Some(handle),
        }
    }

    /// Hand the thread a message. A failed send drops the message's completers, which fails
    /// their results: the thread is gone.
    pub fn send(&self, m: M) {
        if let Some(tx) = &self.inbox {
            let _ = tx.send(m);
        }
    }
}

impl<M> SourceThread<M> {
    /// [`super::ComputeSource::is_lost`].
    pub fn is_lost(&self) -> bool {
        self.flags.lost.load(Ordering::SeqCst)
    }

    /// [`super::ComputeSource::finished`], for a thread that calls [`Flags::items_finished`].
    pub fn finished(&self) -> u64 {
        self.flags.finished.load(Ordering::SeqCst)
    }

    /// [`super::ComputeSource::set_notifier`].
    pub fn set_notifier(&self, notifier: Notifier) {
        let _ = self.flags.notifier.set(notifier);
    }

    /// Cancel what is queued, close the inbox and join: the thread's report (an empty one if
    /// it panicked).
    pub fn finish(&mut self) -> SourceReport {
        self.stop().unwrap_or(SourceReport {
            lost: true,
            ..Default::default()
        })
    }

    fn stop(&mut self) -> Option<SourceReport> {
        self.flags.cancel.store(true, Ordering::SeqCst);
        self.inbox = None;
        let mut report = self.handle.take().and_then(|h| h.join().ok())?;
        // Joined: the flag is final.
        report.lost = self.is_lost();
        Some(report)
    }
}

impl<M> Drop for SourceThread<M> {
    fn drop(&mut self) {
        let _ = self.stop();
    }
}
