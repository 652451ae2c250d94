//! What a cell varies (fleet, link) and what a configuration chooses (rule, B, order), with
//! the reference grid of fixed configurations.

use crate::sched::dls::ChunkRule;
use crate::sched::kinds::adaptive_factoring::AdaptiveFactoring;
use crate::sched::kinds::auto::Auto;
use crate::sched::kinds::awf::Awf;
use crate::sched::kinds::factoring::Factoring;
use crate::sched::rule::Grab;

/// Who renders: thread speeds and maybe a GPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fleet {
    /// P equal threads.
    Equal,
    /// Worker 0 three times slower.
    OneSlow,
    /// Worker 0 slows to a third of its speed half-way through the ideal run.
    SlowsHalfway,
    /// 16 threads and one GPU at the H200 pair's rates ([`Platform::h200_cornell`]), 512 spp.
    ThreadsGpu,
}

impl Fleet {
    /// Its name in the table.
    pub fn name(self) -> &'static str {
        match self {
            Self::Equal => "equal",
            Self::OneSlow => "one_3x_slower",
            Self::SlowsHalfway => "slows_to_third",
            Self::ThreadsGpu => "16threads_h200",
        }
    }
}

/// The cost of one hand-out: dispenser service time and one-way latency.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Link {
    /// Its name in the table.
    pub name: &'static str,
    /// Seconds the dispenser spends on one request (serialised).
    pub service_s: f64,
    /// One-way latency, seconds.
    pub latency_s: f64,
}

/// The master's zero-work hand-out cost on this machine (results/published/simulation/
/// inputs.toml, `master_h_s.B2`; M-026 measured 276–302 ns per item at B = 2 on 2 workers).
const MASTER_S: f64 = 148e-9;

/// The links of the corpus: the shared counter (14.8 ns per grab, results/published/
/// simulation/inputs.toml `counter_s`, M-026), the master thread, and the master over MPI on
/// the shipped 5 µs and 500 µs clusters (platforms/, experiments/simulation*.toml).
pub const LINKS: [Link; 4] = [
    Link {
        name: "counter",
        service_s: 14.8e-9,
        latency_s: 0.0,
    },
    Link {
        name: "master",
        service_s: MASTER_S,
        latency_s: 0.0,
    },
    Link {
        name: "mpi_5us",
        service_s: MASTER_S,
        latency_s: 5e-6,
    },
    Link {
        name: "mpi_500us",
        service_s: MASTER_S,
        latency_s: 500e-6,
    },
];

/// The order items are handed out in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum HandOrder {
    /// Scanline.
    Scanline,
    /// Stratified (`Order::Scatter`).
    Scatter,
}

/// A rule of the reference grid, or `auto`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RuleId {
    /// `auto`.
    Auto,
    /// Contiguous bands, one per worker.
    Static,
    /// k items per hand-out (self-scheduling; the master at chunk k).
    Fixed(usize),
    /// Guided, k = 2, at least this many.
    Guided(usize),
    /// FAC2, at least this many.
    Fac2(usize),
    /// Adaptive factoring, at least this many.
    Af(usize),
    /// AWF-C, at least this many.
    Awf(usize),
}

impl RuleId {
    pub(super) fn build(self, n: usize, p: usize) -> Box<dyn ChunkRule> {
        match self {
            Self::Auto => Box::new(Auto::new(p)),
            Self::Static => Box::new(Grab::fixed(n.div_ceil(p).max(1))),
            Self::Fixed(k) => Box::new(Grab::fixed(k)),
            Self::Guided(k) => Box::new(Grab::guided(k, 2, p)),
            Self::Fac2(k) => Box::new(Factoring::fac2(p, k)),
            Self::Af(k) => Box::new(AdaptiveFactoring::new(p, k)),
            Self::Awf(k) => Box::new(Awf::new(p, k)),
        }
    }
}

/// A configuration: rule, B and order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Config {
    /// The rule.
    pub rule: RuleId,
    /// Hand-outs a worker holds at most.
    pub buffer: usize,
    /// The hand-out order.
    pub order: HandOrder,
}

impl std::fmt::Display for Config {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (name, k) = match self.rule {
            RuleId::Auto => ("auto", None),
            RuleId::Static => ("static", None),
            RuleId::Fixed(k) => ("self_scheduling", Some(k)),
            RuleId::Guided(k) => ("guided", Some(k)),
            RuleId::Fac2(k) => ("factoring", Some(k)),
            RuleId::Af(k) => ("adaptive_factoring", Some(k)),
            RuleId::Awf(k) => ("awf", Some(k)),
        };
        write!(f, "{name}")?;
        if let Some(k) = k {
            write!(f, " k={k}")?;
        }
        let o = match self.order {
            HandOrder::Scanline => "scanline",
            HandOrder::Scatter => "scatter",
        };
        write!(f, " B={} {o}", self.buffer)
    }
}

/// `auto` as the executors play it: stratified order (its default, as every rule that sizes
/// its own hand-outs), B = 1 where a hand-out has no latency (threads take their next chunk
/// when done), B = 2 over a network (the source protocol keeps one request in flight).
pub fn auto_config(link: &Link) -> Config {
    Config {
        rule: RuleId::Auto,
        buffer: if link.latency_s > 0.0 { 2 } else { 1 },
        order: HandOrder::Scatter,
    }
}

/// The reference grid: every rule × k ∈ 1, 2, 4, … ≤ n × B ∈ {1, 2} × order, and static.
pub fn fixed_grid(n: usize) -> Vec<Config> {
    let mut out = Vec::new();
    for order in [HandOrder::Scanline, HandOrder::Scatter] {
        out.push(Config {
            rule: RuleId::Static,
            buffer: 1,
            order,
        });
        for buffer in [1, 2] {
            let mut k = 1;
            while k <= n {
                for rule in [
                    RuleId::Fixed(k),
                    RuleId::Guided(k),
                    RuleId::Fac2(k),
                    RuleId::Af(k),
                    RuleId::Awf(k),
                ] {
                    out.push(Config {
                        rule,
                        buffer,
                        order,
                    });
                }
                k *= 2;
            }
        }
    }
    out
}
