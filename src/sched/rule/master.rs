//! The founding design's master, as a rule: one FIFO queue of every item. A handed-out item
//! goes to the back of the queue (unless the re-queue policy is `never`); when the master
//! meets it again unfinished, the policy decides whether it goes out again (`seed`: yes;
//! `timeout:<ms>`: once outstanding that long; `never`: it left the queue), and never to a
//! holder that still has it. An item whose copy was lost goes out again at once (or, under
//! `never`, counts as lost for good). How many items a source may hold (B) is the executor's
//! count of its fresh slots; what is fresh differs between a thread's slots and a simulated
//! worker's, the queue's rule does not.
//!
//! The thread master (`sched::exec::master`), the workers-run master (`sched::exec::locked_master`) and
//! the simulated master (`simgrid::protocols`) all take their items from this queue. Times
//! are durations since the run's start, whatever clock the executor reads.

use crate::sched::param::{Passes, Requeue, Returns, Wait};
use std::collections::VecDeque;
use std::time::Duration;

/// The master protocol's settings: what any kind that hands out through a [`MasterQueue`]
/// tells its executors (the `master` kind's parameters convert into it; a second master-like
/// kind would build one of its own). Plain data: no kind's parameter machinery.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MasterRule {
    /// Items outstanding per compute source (B).
    pub buffer: usize,
    /// When a handed-out, unfinished item is handed out again.
    pub requeue: Requeue,
    /// How the hand-out thread waits for results.
    pub wait: Wait,
    /// How local threads hand results back: item by item or per hand-out.
    pub returns: Returns,
    /// Who runs the passes: a thread of its own, or each local worker under one lock.
    pub passes: Passes,
}

/// What the queue's front gave.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Take {
    /// This item goes out now (booked as handed out).
    Item(u32),
    /// The front item may not go out now (done, or not yet again); scan on.
    Skip,
    /// Nothing is queued.
    Empty,
}

/// The master's FIFO of items with its re-queue policy.
#[derive(Clone, Debug)]
pub struct MasterQueue {
    requeue: Requeue,
    queue: VecDeque<u32>,
    handed: Vec<bool>,
    /// Last hand-out time, or `None`: may go out again at once.
    issued_at: Vec<Option<Duration>>,
    /// Hand-outs so far, first ones and repeats.
    pub issued: u64,
    /// Hand-outs of an item already handed out.
    pub reissued: u64,
    /// Items whose only copy was lost under `never`.
    pub known_lost: u64,
}

impl MasterQueue {
    /// Items `0..n` queued in order.
    pub fn new(n: usize, requeue: Requeue) -> Self {
        Self {
            requeue,
            queue: (0..n as u32).collect(),
            handed: vec![false; n],
            issued_at: vec![None; n],
            issued: 0,
            reissued: 0,
            known_lost: 0,
        }
    }

    /// Items queued (done ones among them until met).
    pub fn len(&self) -> usize {
        self.queue.len()
    }

    /// Is nothing queued?
    pub fn is_empty(&self) -> bool {
        self.queue.is_empty()
    }

    /// Does the run read a clock for its re-queue decisions (`timeout`)? Elsewhere `now` may
    /// be any value.
    pub fn timed(&self) -> bool {
        matches!(self.requeue, Requeue::Timeout(_))
    }

    /// Take the queue's front for a holder that `holds` says which items it holds fresh, at
    /// `now`. A done item (`done`) leaves the queue for good; one that may not go out yet
    /// goes to the back.
    #[inline]
    pub fn take(
        &mut self,
        now: Duration,
        done: impl Fn(u32) -> bool,
        holds: impl Fn(u32) -> bool,
    ) -> Take {
        let Some(i) = self.queue.pop_front() else {
            return Take::Empty;
        };
        if done(i) {
            return Take::Skip;
        }
        if self.handed[i as usize] {
            let again = match (self.requeue, self.issued_at[i as usize]) {
                (Requeue::Revisit, _) | (_, None) => true,
                (Requeue::Timeout(d), Some(at)) => now.saturating_sub(at) >= d,
                (Requeue::Never, _) => false,
            };
            if !again || holds(i) {
                self.queue.push_back(i);
                return Take::Skip;
            }
            self.reissued += 1;
        }
        self.issued += 1;
        self.handed[i as usize] = true;
        self.issued_at[i as usize] = Some(now);
        if self.requeue != Requeue::Never {
            self.queue.push_back(i);
        }
        Take::Item(i)
    }

    /// Top a holder up: take at most `room` items from the queue's front into `out`, scanning
    /// each queued entry at most once ([`Self::take`] decides each). `holds` says what the
    /// holder held before this pass (an item taken now goes to the back, beyond this scan).
    /// Every executor's plain pass (the workers-run master, the simulated and the modelled
    /// master) is this; the thread master's grouped passes call [`Self::take`] themselves.
    pub fn top_up(
        &mut self,
        now: Duration,
        room: usize,
        done: impl Fn(u32) -> bool,
        holds: impl Fn(u32) -> bool,
        out: &mut Vec<u32>,
    ) {
        let len = self.len();
        let mut scanned = 0;
        let mut taken = 0;
        while taken < room && scanned < len {
            scanned += 1;
            match self.take(now, &done, &holds) {
                Take::Item(i) => {
                    out.push(i);
                    taken += 1;
                }
                Take::Skip => {}
                Take::Empty => break,
            }
        }
    }

    /// Item `i`'s copy was lost with its holder (and `i` is not done): it goes out again at
    /// once, or under `never` counts as lost for good.
    pub fn lost(&mut self, i: u32) {
        match self.requeue {
            Requeue::Never => self.known_lost += 1,
            Requeue::Revisit | Requeue::Timeout(_) => self.issued_at[i as usize] = None,
        }
    }

    /// The re-queue policy.
    pub fn requeue(&self) -> Requeue {
        self.requeue
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drain(q: &mut MasterQueue, now: Duration, done: &[bool], held: &[u32]) -> Vec<u32> {
        let mut out = Vec::new();
        for _ in 0..q.len() {
            match q.take(now, |i| done[i as usize], |i| held.contains(&i)) {
                Take::Item(i) => out.push(i),
                Take::Skip => {}
                Take::Empty => break,
            }
        }
        out
    }

    #[test]
    fn seed_hands_unfinished_items_out_again_at_the_back_but_not_to_their_holder() {
        let mut q = MasterQueue::new(3, Requeue::Revisit);
        let z = Duration::ZERO;
        assert_eq!(drain(&mut q, z, &[false; 3], &[]), [0, 1, 2]);
        // Item 1 is done, item 0 is held by this holder: only 2 goes out again.
        assert_eq!(drain(&mut q, z, &[false, true, false], &[0]), [2]);
        assert_eq!((q.issued, q.reissued), (4, 1));
        assert_eq!(q.len(), 2, "the done item left the queue");
    }

    #[test]
    fn never_hands_out_once_and_counts_lost_copies() {
        let mut q = MasterQueue::new(2, Requeue::Never);
        let z = Duration::ZERO;
        assert_eq!(drain(&mut q, z, &[false; 2], &[]), [0, 1]);
        assert!(q.is_empty());
        q.lost(1);
        assert_eq!(q.known_lost, 1);
    }

    #[test]
    fn timeout_waits_until_the_copy_is_that_old_and_a_lost_copy_goes_at_once() {
        let d = Duration::from_millis(50);
        let mut q = MasterQueue::new(2, Requeue::Timeout(d));
        assert_eq!(drain(&mut q, Duration::ZERO, &[false; 2], &[]), [0, 1]);
        assert!(drain(&mut q, Duration::from_millis(49), &[false; 2], &[]).is_empty());
        q.lost(1);
        assert_eq!(
            drain(&mut q, Duration::from_millis(49), &[false; 2], &[]),
            [1]
        );
        assert_eq!(
            drain(&mut q, Duration::from_millis(98), &[false; 2], &[]),
            [0]
        );
        assert_eq!(q.reissued, 2);
    }
}
