//! Scratch: a source's time per item under the master with spinning items of known cost.
use raysched::render::{TileResult, WorkItem};
use raysched::sched::{
    decompose, run_items, Chunk, Order, RunOptions, SchedulerKind, SchedulerSpec,
};
use std::sync::Arc;
use std::time::{Duration, Instant};

fn main() {
    let costs: Vec<f64> = std::env::args()
        .skip(1)
        .map(|a| a.parse::<f64>().unwrap() * 1e-6)
        .collect();
    for &c in &costs {
        for kind in [SchedulerKind::Master, SchedulerKind::SelfScheduling] {
            let spec = SchedulerSpec::new(kind, Chunk::Tile { w: 1, h: 1 }, 2);
            let d = Duration::from_secs_f64(c);
            let job: raysched::source::Job = Arc::new(move |it: &WorkItem| {
                let t0 = Instant::now();
                while t0.elapsed() < d {
                    std::hint::spin_loop();
                }
                TileResult {
                    item: it.id,
                    pixels: Vec::new(),
                    rays: 0,
                    nonfinite: 0,
                }
            });
            let n = ((0.04 / c) as u32).clamp(16, 4096);
            let mut per = Vec::new();
            for _ in 0..5 {
                let a = run_items(
                    &spec,
                    &decompose(n, 1, Chunk::Tile { w: 1, h: 1 }, Order::Scanline),
                    job.clone(),
                    &RunOptions::default(),
                )
                .unwrap()
                .1
                .wall_s;
                let b = run_items(
                    &spec,
                    &decompose(2 * n, 1, Chunk::Tile { w: 1, h: 1 }, Order::Scanline),
                    job.clone(),
                    &RunOptions::default(),
                )
                .unwrap()
                .1
                .wall_s;
                per.push(2.0 * (b - a) / n as f64 / c);
            }
            per.sort_by(f64::total_cmp);
            println!(
                "{:>6.0} us {:?} n={n}: per item / cost = {:.2} (min {:.2} max {:.2})",
                c * 1e6,
                kind,
                per[2],
                per[0],
                per[4]
            );
        }
    }
}
