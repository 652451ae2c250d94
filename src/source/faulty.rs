//! Fault injection for tests and experiments: drop a fraction of results (they never arrive),
//! delay some items, make one worker panic. Decisions come from a hash of (seed, source, item,
//! submission number), so a run's faults are reproducible and a re-issued item can succeed.

use super::{
    submit_one, ComputeSource, DelayedResult, Job, LocalThreadSource, Notifier, SourceReport,
};
use crate::core::metrics::Probe;
use crate::core::render::WorkItem;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

#[derive(Clone, Debug, PartialEq)]
/// Which faults to inject, and the seed that makes them reproducible.
pub struct FaultPlan {
    /// Fraction of results silently dropped (the message is lost; the source stays alive).
    pub drop_fraction: f64,
    /// Fraction of items delayed by up to `max_delay` before they are rendered.
    pub delay_fraction: f64,
    /// Longest delay of a delayed item.
    pub max_delay: Duration,
    /// (source id, n): that source's worker panics on its n-th item (0-based).
    pub panic: Option<(u32, u64)>,
    /// Seed of the fault decisions.
    pub seed: u64,
}

impl Default for FaultPlan {
    fn default() -> Self {
        Self {
            drop_fraction: 0.0,
            delay_fraction: 0.0,
            max_delay: Duration::ZERO,
            panic: None,
            seed: 1,
        }
    }
}

/// splitmix64 finaliser → uniform in [0, 1).
fn unit(seed: u64, a: u64, b: u64, c: u64) -> f64 {
    let z = crate::util::hash::mix64(
        seed ^ a.wrapping_mul(0x9e37_79b9_7f4a_7c15)
            ^ b.wrapping_mul(0xc2b2_ae3d_27d4_eb4f)
            ^ c.wrapping_mul(0x1656_67b1_9e37_79f9),
    );
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// The job as a faulty worker runs it: some items delayed, the planned one panics.
pub fn faulty_job(job: Job, plan: &FaultPlan, source: u32) -> Job {
    let plan = plan.clone();
    let calls = AtomicU64::new(0);
    Arc::new(move |item: &WorkItem| {
        let n = calls.fetch_add(1, Ordering::Relaxed);
        if plan.panic == Some((source, n)) {
            panic!(
                "injected fault: source {source} panics on its item #{n} (item {})",
                item.id
            );
        }
        let u = unit(plan.seed, source as u64, item.id as u64, n ^ 0xde1a);
        if u < plan.delay_fraction {
            std::thread::sleep(plan.max_delay.mul_f64(u / plan.delay_fraction));
        }
        job(item)
    })
}

/// Wraps any source and loses a fraction of its results on the way back.
pub struct FaultySource {
    inner: Box<dyn ComputeSource>,
    plan: FaultPlan,
    submitted: u64,
    /// Results dropped so far.
    pub dropped: u64,
}

impl FaultySource {
    /// Wrap `inner`, dropping a `plan.drop_fraction` of its results (delays and panics are
    /// [`faulty_job`]'s).
    pub fn new(inner: Box<dyn ComputeSource>, plan: FaultPlan) -> Self {
        Self {
            inner,
            plan,
            submitted: 0,
            dropped: 0,
        }
    }
}

impl ComputeSource for FaultySource {
    fn id(&self) -> u32 {
        self.inner.id()
    }
    fn label(&self) -> String {
        format!("faulty({})", self.inner.label())
    }
    fn submit(&mut self, item: WorkItem) -> DelayedResult {
        submit_one(self, item)
    }
    fn submit_batch(&mut self, items: &mut Vec<WorkItem>, out: &mut Vec<DelayedResult>) {
        let first = out.len();
        self.inner.submit_batch(items, out);
        let src = self.inner.id();
        for d in &mut out[first..] {
            let n = self.submitted;
            self.submitted += 1;
            if unit(self.plan.seed, src as u64, d.item() as u64, n) < self.plan.drop_fraction {
                self.dropped += 1;
                // The worker still renders it; the result just never comes back.
                *d = DelayedResult::never(d.item(), src);
            }
        }
    }
    fn is_lost(&self) -> bool {
        self.inner.is_lost()
    }
    fn finished(&self) -> Option<u64> {
        self.inner.finished()
    }
    fn set_notifier(&mut self, notifier: Notifier) {
        self.inner.set_notifier(notifier)
    }
    fn finish(self: Box<Self>) -> SourceReport {
        self.inner.finish()
    }
}

/// Local thread source `id` running `job` under `plan`.
pub fn faulty_source(job: &Job, id: u32, plan: &FaultPlan, probe: Probe) -> Box<dyn ComputeSource> {
    let local = LocalThreadSource::spawn(id, faulty_job(job.clone(), plan, id), probe);
    Box::new(FaultySource::new(Box::new(local), plan.clone()))
}
