//! How adaptive factoring and AWF hand out 2² items in `scatter` order on two workers: hand-outs
//! per render, and how many items sit in hand-outs that a worker runs as handed out rather than
//! in scanline order (fewer than 4 items, or under 1/256 of all; `sched::scanline`), where each
//! item lands far from the one before it.
//!
//! Hand-outs are read back from the timeline: a worker's item ids sorted, each maximal run of
//! consecutive ids one hand-out (ids follow the hand-out order). Two hand-outs in a row to the
//! same worker read as one, so the counts are a lower bound.
//!
//! ```sh
//! cargo run --release --example hand_outs -- [renders per scene and rule, default 10]
//! ```

use raysched::scene::{load_scene, SceneOverrides};
use raysched::sched::{
    decompose, render_job, run, Chunk, Order, RunOptions, RunPlan, SchedulerKind, SchedulerSpec,
    Sources,
};
use raysched::tracer::BvhTracer;
use std::path::Path;
use std::sync::Arc;

/// The lengths of the runs of consecutive values in `ids` (sorted in place).
fn runs(ids: &mut [u32]) -> Vec<usize> {
    ids.sort_unstable();
    let mut out = Vec::new();
    let mut len = 0;
    for k in 0..ids.len() {
        if k > 0 && ids[k] != ids[k - 1] + 1 {
            out.push(len);
            len = 0;
        }
        len += 1;
    }
    if len > 0 {
        out.push(len);
    }
    out
}

fn main() {
    let renders: u32 = std::env::args()
        .nth(1)
        .map_or(10, |a| a.parse().expect("renders: a positive integer"));
    let scenes = [
        ("skewed_low", 16),
        ("skewed_mid", 16),
        ("skewed_high", 16),
        ("skewed_x100", 16),
        ("skewed_x1000", 8),
        ("cornell_box", 16),
    ];
    println!("scene         rule                hand-outs  items in small  in sparse  of");
    for (name, spp) in scenes {
        let o = SceneOverrides {
            width: Some(128),
            height: Some(128),
            spp: Some(spp),
            ..Default::default()
        };
        let path = format!("scenes/{name}.toml");
        let scene = Arc::new(load_scene(Path::new(&path), &o).unwrap_or_else(|e| panic!("{e}")));
        let tracer = Arc::new(BvhTracer::new(&scene.geometry));
        for kind in [SchedulerKind::AdaptiveFactoring, SchedulerKind::Awf] {
            let mut spec = SchedulerSpec::new(kind, Chunk::Tile { w: 2, h: 2 }, 2);
            spec.order = Order::Scatter;
            spec.timeline = true;
            let items = decompose(128, 128, spec.chunk, spec.order);
            let (mut hand_outs, mut small, mut sparse) = (0, 0, 0);
            for _ in 0..renders {
                let job = render_job(&scene, &tracer);
                let (_, stats) = RunPlan::of(&spec, &RunOptions::default())
                    .and_then(|plan| run(&plan, &items, Sources::threads(&job, &spec)))
                    .unwrap_or_else(|e| panic!("{e}"));
                let spans = stats.timeline.unwrap_or_default();
                for w in 0..spec.workers as u32 {
                    let mut ids: Vec<u32> = spans
                        .iter()
                        .filter(|s| s.worker == w)
                        .map(|s| s.item)
                        .collect();
                    for r in runs(&mut ids) {
                        hand_outs += 1;
                        small += if r < 4 { r } else { 0 };
                        sparse += if r * 256 < items.len() { r } else { 0 };
                    }
                }
            }
            let per = |x: usize| x as f64 / f64::from(renders.max(1));
            println!(
                "{name:13} {:19} {:9.1}  {:14.1}  {:9.1}  {}",
                kind.id(),
                per(hand_outs),
                per(small),
                per(sparse),
                items.len()
            );
        }
    }
}
