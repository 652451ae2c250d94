//! The judging corpus of `auto` (issue 61): a deterministic, event-driven simulation of pool
//! rules ([`ChunkRule`]) over per-pixel cost maps, workers of different speeds and hand-out
//! costs from a shared counter to a slow network link, and the verdict of `auto` against the
//! best fixed configuration in hindsight of every cell.
//!
//! The simulated executor is the pool protocol every executor plays: a worker holds at most B
//! hand-outs (asked for, queued or running); it asks for B at the start and for one more each
//! time it finishes a chunk, reporting that chunk with the request. Requests go over a link of
//! one-way latency L to one dispenser that serves them in arrival order, s seconds each (the
//! counter's contended grab, the master's hand-out), calling the rule as the real dispenser
//! does under its lock. A thread renders its chunk's items one after the other, item i of cost
//! cᵢ (seconds on a full-speed thread) taking cᵢ·f(t), f the worker's slowdown at that moment;
//! the GPU renders a chunk as one dispatch of [`GpuModel::dispatch_s`]. The rule is told each
//! chunk's time, its hand-out's time (request to answer) and the item times in groups
//! ([`dls::timed_group`]), exactly the [`Report`] the real executors fill in. Nothing reads a
//! clock: every run is a function of its inputs.
//!
//! What is not modelled: work stealing (shared memory only), tiles (a chunk is k consecutive
//! pixels in the order handed out), the master thread's wake-up latency beyond its measured
//! zero-work hand-out cost, and run-to-run noise of item costs.

mod config;
mod corpus;
mod plan;
mod play;
#[cfg(test)]
mod tests;
mod verdict;

pub use config::{auto_config, fixed_grid, Config, Fleet, HandOrder, Link, RuleId, LINKS};
pub use corpus::{cells, Cell, CostMap, MapError, SYNTHETIC};
pub use plan::{is_verdict, load, run, Plan, Written};
pub use play::play;
pub use verdict::{judge, median, summary, Verdict};
