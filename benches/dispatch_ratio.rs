//! Dispatch cost per item as a ratio to the bare shared counter measured in the same run,
//! interleaved: absolute nanoseconds move 2–3× between machines (and between this VM's fast
//! and slow states), a ratio to `fetch_add` on one padded counter by two threads much less.
//!
//! Every scheduler at one-pixel zero-work items (2¹⁸ items, 2 workers, as `dispatch`), the
//! dynamic-loop-scheduling family included, the master at B = 2, 4, 16, 64 with stats on and
//! off. Each of `ROUNDS` rounds times the counter, then the scheduler; the table gives the
//! medians in ns per item, the ratio of the medians and the ratio's range over the rounds.
//!
//! `cargo bench --bench dispatch_ratio` (~1 min). The goals it checks: the factoring family no
//! dearer per item than `guided`; the master at B ≥ 4 within 10× the counter; the master's
//! stats-on cost within 10 % of stats-off.

use crossbeam::utils::CachePadded;
use raysched::render::{TileResult, WorkItem};
use raysched::sched::{
    decompose, run_items, Chunk, MasterParams, Order, Policy, Requeue, RunOptions, SchedulerKind,
    SchedulerSpec, Wait,
};
use raysched::source::Job;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

const ITEMS: usize = 1 << 18;
const ROUNDS: usize = 9;

fn counter_ns() -> f64 {
    let next = CachePadded::new(AtomicUsize::new(0));
    let t0 = Instant::now();
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| {
                let mut acc = 0usize;
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= ITEMS {
                        break;
                    }
                    acc ^= i;
                }
                std::hint::black_box(acc)
            });
        }
    });
    t0.elapsed().as_secs_f64() * 1e9 / ITEMS as f64
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    // `cargo bench` passes `--bench`; a filter argument selects rows by name.
    let filter: Option<String> = std::env::args().skip(1).find(|a| !a.starts_with('-'));
    let job: Job = Arc::new(|it: &WorkItem| TileResult {
        item: it.id,
        pixels: Vec::new(),
        rays: 0,
        nonfinite: 0,
    });
    let px = Chunk::Tile { w: 1, h: 1 };
    let items = decompose(512, 512, px, Order::Scanline);
    let mut rows: Vec<(String, SchedulerSpec, bool)> = SchedulerKind::ALL
        .into_iter()
        .filter(|k| *k != SchedulerKind::Master)
        .map(|k| (k.id().to_string(), SchedulerSpec::new(k, px, 2), true))
        .collect();
    for buffer in [2, 4, 16, 64] {
        for stats in [true, false] {
            let s = SchedulerSpec {
                policy: Policy::Master(MasterParams {
                    wait: Wait::Block,
                    buffer,
                    requeue: Requeue::Never,
                }),
                ..SchedulerSpec::new(SchedulerKind::Master, px, 2)
            };
            let name = format!(
                "master_block_b{buffer}_{}",
                if stats { "stats_on" } else { "stats_off" }
            );
            rows.push((name, s, stats));
        }
    }
    println!(
        "{:<34} {:>9} {:>9} {:>7} {:>15}",
        "scheduler (2 workers, 2^18 items)", "ns/item", "counter", "ratio", "ratio range"
    );
    for (name, spec, stats) in rows {
        if filter.as_deref().is_some_and(|f| !name.contains(f)) {
            continue;
        }
        let opts = RunOptions {
            stats,
            ..Default::default()
        };
        // One untimed run of each first (thread and allocator warm-up).
        counter_ns();
        run_items(&spec, &items, job.clone(), &opts).unwrap();
        let (mut c, mut s, mut r) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..ROUNDS {
            let cn = counter_ns();
            let t0 = Instant::now();
            run_items(&spec, &items, job.clone(), &opts).unwrap();
            let sn = t0.elapsed().as_secs_f64() * 1e9 / ITEMS as f64;
            c.push(cn);
            s.push(sn);
            r.push(sn / cn);
        }
        let (lo, hi) = r
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(*x), b.max(*x)));
        let (cm, sm) = (median(&mut c), median(&mut s));
        println!(
            "{name:<34} {sm:>9.1} {cm:>9.1} {:>6.1}× {:>7.1}–{:.1}×",
            sm / cm,
            lo,
            hi
        );
    }
}
