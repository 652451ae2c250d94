//! How a source wakes a master that waits for results: the master's [`Doorbell`] and the
//! sources' [`Notifier`]s, with the master's [`Wait`] strategy.

use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How the master waits for results (its ids are parsed in `sched::spec`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Wait {
    /// Busy-poll: lowest latency, but steals a core from the workers.
    Spin,
    /// Poll, yielding the core between polls.
    Yield,
    /// Sleep on the result channel until something arrives.
    Block,
}

/// How a source wakes a waiting master: [`Notifier::ring`] after completing a result. It sends
/// only while the master is armed (about to block), so a busy master pays nothing per item —
/// one channel message per item was ~20 % of the master's dispatch cost at one-pixel items.
/// A hint only: the master always polls the results themselves.
#[derive(Clone, Debug)]
pub struct Notifier {
    tx: crossbeam::channel::Sender<()>,
    armed: Arc<AtomicBool>,
}

impl Notifier {
    /// Call after the result is visible (its cell filled): the SeqCst pair with
    /// [`Doorbell::wait`] makes sure one side sees the other, so no wake-up is lost.
    pub fn ring(&self) {
        if self.armed.load(Ordering::SeqCst) && self.armed.swap(false, Ordering::SeqCst) {
            let _ = self.tx.send(());
        }
    }
}

/// The master's side of its sources' [`Notifier`]s.
#[derive(Debug)]
pub struct Doorbell {
    tx: crossbeam::channel::Sender<()>,
    rx: crossbeam::channel::Receiver<()>,
    armed: Arc<AtomicBool>,
}

impl Default for Doorbell {
    fn default() -> Self {
        let (tx, rx) = crossbeam::channel::unbounded();
        Self {
            tx,
            rx,
            armed: Arc::new(AtomicBool::new(false)),
        }
    }
}

impl Wait {
    /// Poll `ready` until it holds or `timeout` has passed, spinning or yielding the core
    /// between polls (`Block` spins: a blocking wait sleeps on what it waits for instead).
    pub(crate) fn poll(self, timeout: Duration, mut ready: impl FnMut() -> bool) {
        let end = Instant::now() + timeout;
        while !ready() && Instant::now() < end {
            if self == Wait::Yield {
                std::thread::yield_now();
            } else {
                std::hint::spin_loop();
            }
        }
    }
}

impl Doorbell {
    /// A notifier for one source; any number may ring this doorbell.
    pub fn notifier(&self) -> Notifier {
        Notifier {
            tx: self.tx.clone(),
            armed: self.armed.clone(),
        }
    }

    /// Wait until a source rings or `timeout` passes, unless `ready()` already holds after
    /// arming (a result that landed before arming rang nobody). `wait` picks how.
    pub fn wait(&self, timeout: Duration, wait: Wait, ready: impl Fn() -> bool) {
        // Armed stays armed until a ring disarms it: the master never writes `false` itself,
        // and stores `true` only when a ring took it. Each store moves the flag's line away
        // from the workers, who read it at every result; two stores per wait cost B = 2
        // ~13 % of its dispatch time. A stale armed flag costs at most one extra message.
        if !self.armed.load(Ordering::SeqCst) {
            self.armed.store(true, Ordering::SeqCst);
        }
        if !ready() {
            match wait {
                Wait::Block => {
                    let _ = self.rx.recv_timeout(timeout);
                }
                Wait::Spin | Wait::Yield => wait.poll(timeout, || self.rx.try_recv().is_ok()),
            }
        }
        while self.rx.try_recv().is_ok() {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::{empty_result as result, Completer, DelayedResult};

    /// The master arms the bell, re-checks, and sleeps; a worker fills a cell and rings. If a
    /// wake-up could be lost, some wait would run to its (long) timeout.
    #[test]
    fn the_doorbell_loses_no_wake_up() {
        let bell = Doorbell::default();
        let ring = bell.notifier();
        let (tx, rx) = crossbeam::channel::unbounded::<Completer>();
        let worker = std::thread::spawn(move || {
            for c in rx {
                c.complete(Ok(result(0)));
                ring.ring();
            }
        });
        let timeout = Duration::from_secs(5);
        for i in 0..2000 {
            let (d, c) = DelayedResult::pending(i, 0);
            tx.send(c).unwrap();
            let t = Instant::now();
            while !d.is_ready() {
                bell.wait(timeout, Wait::Block, || d.is_ready());
            }
            assert!(t.elapsed() < timeout, "round {i}: the ring was lost");
        }
        drop(tx);
        worker.join().unwrap();
    }
}
