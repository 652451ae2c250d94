//! The extension API from outside the crate: the two examples' scheduler and source, played by
//! every executor through the one run path, the cost model and the simulation.

#[path = "../../examples/custom_scheduler.rs"]
#[allow(dead_code, unreachable_pub)]
mod custom_scheduler;
#[path = "../../examples/custom_source.rs"]
#[allow(dead_code, unreachable_pub)]
mod custom_source;

#[path = "../../examples/custom_tracer.rs"]
#[allow(dead_code, unreachable_pub)]
mod custom_tracer;

#[path = "../../examples/two_level_pool.rs"]
#[allow(dead_code, unreachable_pub)]
mod two_level_pool;

use custom_scheduler::{cornell, predict, render, Fraction, On};
use raysched::sched::rule::{chunk_sequence, HandOut, Scheduler, WorkerRule};
use raysched::sched::{Policy, SchedulerKind, Slow};
use std::time::Duration;
use two_level_pool::{TwoLevel, TwoLevelPool};

const QUARTER: Fraction = Fraction {
    fraction: 0.25,
    min: 2,
};

#[test]
fn a_custom_rule_hands_out_its_fraction_of_what_is_left() {
    let HandOut::ByWorkers(WorkerRule::Pool(mut pool)) = QUARTER.hand_out(100, 2, Slow::NONE)
    else {
        panic!("the fraction rule is a pool rule")
    };
    // ⌈R/4⌉ at least 2: 100 → 25, 75 → 19, 56 → 14, 42 → 11, 31 → 8, 23 → 6, 17 → 5, …
    assert_eq!(
        chunk_sequence(pool.rule.as_mut(), 100, 2),
        [25, 19, 14, 11, 8, 6, 5, 3, 3, 2, 2, 2]
    );
}

#[test]
fn a_custom_rule_renders_the_serial_image_on_threads_and_on_sources() {
    let (scene, tracer) = cornell(32, 2);
    let serial = Policy::defaults(SchedulerKind::Static);
    let (reference, _) = render(&serial, On::Threads, 1, &scene, &tracer);
    for on in [On::Threads, On::Sources] {
        let (image, stats) = render(&QUARTER, on, 2, &scene, &tracer);
        assert_eq!(image.hash(), reference.hash(), "{on:?}");
        assert_eq!(stats.items, 64, "{on:?}: 8×8 tiles of 4²");
        assert_eq!(
            stats.workers.iter().map(|w| w.items).sum::<u64>(),
            64,
            "{on:?}: every item rendered once"
        );
    }
}

#[test]
fn the_cost_model_plays_a_custom_rule() {
    // 256 items of 0.1 ms on 2 workers: 12.8 ms of work each.
    let p = predict(&QUARTER, 2, 256, 1e-4);
    assert!((p.work_s - 12.8e-3).abs() < 1e-12, "{p:?}");
    // The last hand-outs are 2 items, so the workers end at most 2 items apart.
    assert!(p.imbalance_s <= 2e-4 + 1e-12, "{p:?}");
    // All of it in one hand-out: one worker runs all 256 items at 0.1 ms + h = 1 µs each.
    let whole = Fraction {
        fraction: 1.0,
        min: 1,
    };
    let q = predict(&whole, 2, 256, 1e-4);
    assert!((q.wall_s - 256.0 * 101e-6).abs() < 1e-9, "{q:?}");
}

#[test]
fn a_custom_source_joins_the_master_and_a_worker_rule() {
    let (scene, tracer) = cornell(32, 2);
    let serial = Policy::defaults(SchedulerKind::Static);
    let (reference, _) =
        custom_source::render_mixed(&serial, (1, 0, Duration::ZERO), &scene, &tracer);
    let delay = Duration::from_millis(1);
    for kind in [SchedulerKind::Master, SchedulerKind::SelfScheduling] {
        let policy = Policy::defaults(kind);
        let (image, stats) = custom_source::render_mixed(&policy, (1, 1, delay), &scene, &tracer);
        assert_eq!(image.hash(), reference.hash(), "{kind:?}");
        assert_eq!(stats.workers.len(), 2, "{kind:?}");
        assert!(
            stats.workers[1].items > 0,
            "{kind:?}: the network source rendered nothing"
        );
        assert_eq!(stats.workers.iter().map(|w| w.items).sum::<u64>(), 16);
    }
    // The fraction rule over the same two sources.
    let (image, _) = custom_source::render_mixed(&QUARTER, (1, 1, delay), &scene, &tracer);
    assert_eq!(image.hash(), reference.hash());
}

/// SimGrid runs once per process: each parent test runs its rule in a child of the test
/// binary, which prints `SIMULATED wall_s=… issued=…`.
#[cfg(feature = "simgrid")]
fn simulate_in_this_process(rule: &dyn Scheduler) {
    use raysched::simulate::job::{Network, SimJob};
    let platform = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("platforms/smp2.xml");
    let n = 256;
    let job = SimJob {
        platform,
        scheduler: rule.id(),
        params: Default::default(),
        workers: 2,
        cost_s: vec![1e-4; n],
        item_bytes: vec![25; n],
        result_bytes: vec![44; n],
        master_h_s: 0.0,
        counter_s: 0.0,
        start_s: 0.0,
        refill_s: 0.0,
        lost: Vec::new(),
        seed: 1,
        network: Network::Fine,
    };
    let out = raysched::simgrid::simulate_with(job, rule).unwrap();
    println!("SIMULATED wall_s={} issued={}", out.wall_s, out.issued);
}

/// Runs the ignored test `child` in a child process and reads its `SIMULATED` line:
/// (wall_s, issued, the line).
#[cfg(feature = "simgrid")]
fn simulated_in_a_child(child: &str) -> (f64, f64, String) {
    let out = std::process::Command::new(std::env::current_exe().unwrap())
        .args(["--exact", child, "--ignored", "--nocapture"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .find_map(|l| l.strip_prefix("SIMULATED "))
        .unwrap_or_else(|| panic!("no answer: {text} {}", String::from_utf8_lossy(&out.stderr)));
    let field = |k: &str| -> f64 {
        line.split_whitespace()
            .find_map(|f| f.strip_prefix(k)?.strip_prefix('='))
            .unwrap()
            .parse()
            .unwrap()
    };
    (field("wall_s"), field("issued"), line.to_string())
}

#[cfg(feature = "simgrid")]
#[test]
#[ignore = "run by the_simulation_plays_a_custom_rule in a process of its own"]
fn simulation_child() {
    simulate_in_this_process(&QUARTER);
}

#[cfg(feature = "simgrid")]
#[test]
fn the_simulation_plays_a_custom_rule() {
    let (wall, issued, line) = simulated_in_a_child("extension::simulation_child");
    assert_eq!(issued, 256.0, "{line}");
    // 12.8 ms of work per worker on smp2's cores, the last hand-outs 2 items (0.2 ms) apart,
    // and the messages' time on top.
    assert!((12.8e-3..14e-3).contains(&wall), "{line}");
}

#[test]
fn a_custom_tracer_renders_the_native_image_and_counts_its_queries() {
    use raysched::sched::{Chunk, SchedulerSpec};
    use raysched::tracer::BvhTracer;
    use std::sync::atomic::Ordering;
    use std::sync::Arc;
    let (scene, native) = cornell(16, 2);
    let counting = Arc::new(custom_tracer::Counting::new(BvhTracer::new(
        &scene.geometry,
    )));
    let spec = SchedulerSpec::new(SchedulerKind::SelfScheduling, Chunk::Tile { w: 4, h: 4 }, 2);
    let (a, _) = crate::support::render(&spec, &scene, &native).unwrap();
    let (b, stats) = crate::support::render(&spec, &scene, &counting).unwrap();
    assert_eq!(a.hash(), b.hash());
    // Every camera ray is a closest-hit query: at least one per pixel and sample.
    let intersects = counting.intersects.load(Ordering::Relaxed);
    assert!(intersects >= 16 * 16 * 2, "{intersects}");
    assert!(counting.occludeds.load(Ordering::Relaxed) > 0);
    assert!(stats.rays > 0);
}

const PAIRS: TwoLevel = TwoLevel { group: 2 };

#[test]
fn a_two_level_pool_shares_a_groups_chunk_among_its_workers() {
    use raysched::sched::rule::Dispense;
    // 100 items, 4 workers in 2 groups. Worker 0 takes group 0's chunk ⌈100/4⌉ = 25 and its
    // ⌈25/4⌉ = 7 of it; worker 2 group 1's ⌈75/4⌉ = 19 and ⌈19/4⌉ = 5; worker 1 the next
    // ⌈18/4⌉ = 5 of group 0's chunk, not of the pool.
    let mut pool = TwoLevelPool::new(100, 4, 2);
    assert_eq!(pool.grant(0, None), Some(0..7));
    assert_eq!(pool.grant(2, None), Some(25..30));
    assert_eq!(pool.grant(1, None), Some(7..12));
    // Every item exactly once, whoever asks.
    let mut seen = vec![0u8; 100];
    for r in [0..7, 25..30, 7..12] {
        r.for_each(|i| seen[i] += 1);
    }
    let mut w = 0;
    while let Some(r) = pool.grant(w, None) {
        r.for_each(|i| seen[i] += 1);
        w = (w + 3) % 4;
    }
    assert!(seen.iter().all(|&c| c == 1), "{seen:?}");
}

#[test]
fn a_two_level_pool_renders_the_serial_image_on_threads_and_on_sources() {
    let (scene, tracer) = cornell(32, 2);
    let serial = Policy::defaults(SchedulerKind::Static);
    let (reference, _) = render(&serial, On::Threads, 1, &scene, &tracer);
    for on in [On::Threads, On::Sources] {
        let (image, stats) = render(&PAIRS, on, 4, &scene, &tracer);
        assert_eq!(image.hash(), reference.hash(), "{on:?}");
        assert_eq!(
            stats.workers.iter().map(|w| w.items).sum::<u64>(),
            64,
            "{on:?}: every item rendered once"
        );
    }
}

#[test]
fn the_cost_model_plays_a_two_level_pool() {
    // 256 items of 0.1 ms on 4 workers: 6.4 ms of work each; a worker's last hand-out is one
    // item of its group's last chunk, so the workers end within a few items of each other.
    let p = predict(&PAIRS, 4, 256, 1e-4);
    assert!((p.work_s - 6.4e-3).abs() < 1e-12, "{p:?}");
    assert_eq!(p.items, 256);
    assert!(p.imbalance_s >= 0.0 && p.imbalance_s <= 4e-4, "{p:?}");
}

/// The two-level pool in the simulation, in a process of its own.
#[cfg(feature = "simgrid")]
#[test]
#[ignore = "run by the_simulation_plays_a_two_level_pool in a process of its own"]
fn simulation_child_two_level() {
    simulate_in_this_process(&PAIRS);
}

#[cfg(feature = "simgrid")]
#[test]
fn the_simulation_plays_a_two_level_pool() {
    let (wall, issued, line) = simulated_in_a_child("extension::simulation_child_two_level");
    assert_eq!(issued, 256.0, "{line}");
    // One group of both workers on smp2: 12.8 ms of work each, the last hand-outs one item.
    assert!((12.8e-3..14e-3).contains(&wall), "{line}");
}
