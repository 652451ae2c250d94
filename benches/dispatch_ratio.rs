//! Dispatch cost per item as a ratio to the bare shared counter measured in the same run,
//! interleaved: absolute nanoseconds move 2–3× between machines (and between this VM's fast
//! and slow states), a ratio to `fetch_add` on one padded counter by two threads much less.
//!
//! Every scheduler at one-pixel zero-work items (2¹⁸ items, 2 workers, as `dispatch`), the
//! dynamic-loop-scheduling family included, the master at B = 2, 4, 16, 64 with stats on and
//! off. Each of `ROUNDS` rounds times the counter, then the scheduler; the table gives the
//! medians in ns per item, the ratio of the medians and the ratio's range over the rounds.
//!
//! Two more tables: the round trip of one message between two threads over the channels the
//! master and its local sources use (a master thread that refills B items per source per round
//! trip cannot hand out faster than one round trip per B·P items), and the master's stats-on
//! time over its stats-off time, paired round by round (on and off alternate, so machine drift
//! between rows does not enter the ratio).
//!
//! A fourth table, `bookkeeping`, gives the master's own time per item from its stats (the
//! passes of its loop, waiting excluded) with one worker and with two, as a ratio to the
//! counter: the part of its cost that no wake-up explains.
//!
//! A fifth, `floor`, times a minimal master over the same channels (no ledger, no re-queue, no
//! result cells; results back one message per item, or one per hand-out) in the same rounds as
//! the real one: what no master built on these channels can beat on this machine.
//!
//! `cargo bench --bench dispatch_ratio` (~35 s on the 2-core VM: 33 s on the EPYC). The goals it checks: the factoring family no
//! dearer per item than `guided`; the master at B ≥ 4 within 10× the counter; the master's
//! stats-on cost within 10 % of stats-off.

use crossbeam::utils::CachePadded;
use raysched::render::{TileResult, WorkItem};
use raysched::sched::{
    decompose, run, Chunk, MasterParams, Order, Passes, Policy, Requeue, Returns, RunOptions,
    RunPlan, SchedulerKind, SchedulerSpec, Sources, Wait,
};
use raysched::source::Job;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

const ITEMS: usize = 1 << 18;
const ROUNDS: usize = 9;
/// Pairs per buffer in the stats on/off table: enough for a distribution-free 95 % interval of
/// the median ratio (order statistics 10 and 22 of 31), since single pairs range 0.75–1.38×.
const PAIRS: usize = 31;
const BUFFERS: [usize; 4] = [2, 4, 16, 64];

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

/// The ranks (0-based, in sorted order) bounding a distribution-free interval of at least
/// 95 % for the median of `n` samples: the sign-test interval from the binomial(n, ½) tails.
fn median_ci_ranks(n: usize) -> (usize, usize) {
    // P(X ≤ j) for X ~ binomial(n, ½), summed until the tail would pass 2.5 %.
    let mut tail = 0.0f64;
    let mut term = 0.5f64.powi(n as i32); // P(X = 0)
    let mut k = 0;
    for j in 0..n / 2 {
        if tail + term > 0.025 {
            break;
        }
        tail += term;
        term *= (n - j) as f64 / (j + 1) as f64;
        k = j + 1;
    }
    (k.saturating_sub(1), (n - k).min(n - 1))
}

/// Smallest and largest of `v`.
fn range(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(*x), b.max(*x)))
}

/// Round trips of one message between two threads over crossbeam channels, ns each.
fn round_trip_ns() -> f64 {
    const TRIPS: usize = 20_000;
    let (to_echo, echo_in) = crossbeam::channel::unbounded::<u32>();
    let (to_main, main_in) = crossbeam::channel::unbounded::<u32>();
    std::thread::scope(|s| {
        s.spawn(move || {
            for m in echo_in {
                let _ = to_main.send(m);
            }
        });
        let t0 = Instant::now();
        for i in 0..TRIPS as u32 {
            to_echo.send(i).unwrap();
            main_in.recv().unwrap();
        }
        let ns = t0.elapsed().as_secs_f64() * 1e9 / TRIPS as f64;
        drop(to_echo);
        ns
    })
}

/// How a [`floor_ns`] worker hands its results back.
#[derive(Clone, Copy, PartialEq)]
enum Back {
    /// One message per item.
    PerItem,
    /// One message per hand-out, once all its items are rendered.
    PerHandOut,
}

/// A [`floor_ns`] worker's message: one result (no allocation) or a hand-out's.
enum Returned {
    One(TileResult),
    Many(Vec<TileResult>),
}

/// A minimal master over the channels the real one uses, as a floor under it: 2 workers, each
/// kept at `buffer` items outstanding in hand-outs of ⌈B/2⌉ (two in flight, so a worker has the
/// next one queued while the master refills), the results back over one shared channel, every
/// thread blocking when it has nothing to do. No ledger, no re-queue, no statistics, no
/// result cells: what handing out and collecting cost with nothing else. ns per item.
fn floor_ns(buffer: usize, returns: Back, items: &[WorkItem], job: &Job) -> f64 {
    use crossbeam::channel::unbounded;
    let t0 = Instant::now();
    let (to_master, results) = unbounded::<(usize, Returned)>();
    let half = buffer.div_ceil(2);
    let mut kept: Vec<Option<TileResult>> = vec![None; items.len()];
    std::thread::scope(|s| {
        let inboxes: Vec<_> = (0..2)
            .map(|w| {
                let (tx, rx) = unbounded::<Vec<WorkItem>>();
                let (to_master, job) = (to_master.clone(), job.clone());
                s.spawn(move || {
                    for hand_out in rx {
                        if returns == Back::PerHandOut {
                            let rs = hand_out.iter().map(|it| job(it)).collect();
                            let _ = to_master.send((w, Returned::Many(rs)));
                        } else {
                            for it in &hand_out {
                                let _ = to_master.send((w, Returned::One(job(it))));
                            }
                        }
                    }
                });
                tx
            })
            .collect();
        let (mut next, mut done) = (0, 0);
        let mut outstanding = [0usize; 2];
        while done < items.len() {
            for (w, inbox) in inboxes.iter().enumerate() {
                while outstanding[w] + half <= buffer.max(half) && next < items.len() {
                    let k = half.min(items.len() - next);
                    let _ = inbox.send(items[next..next + k].to_vec());
                    next += k;
                    outstanding[w] += k;
                }
            }
            let mut take = |(w, rs): (usize, Returned)| {
                let mut keep = |r: TileResult| {
                    let i = r.item as usize;
                    kept[i] = Some(r);
                    outstanding[w] -= 1;
                    done += 1;
                };
                match rs {
                    Returned::One(r) => keep(r),
                    Returned::Many(rs) => rs.into_iter().for_each(keep),
                }
            };
            take(results.recv().expect("the workers outlive the run"));
            while let Ok(m) = results.try_recv() {
                take(m);
            }
        }
    });
    std::hint::black_box(&kept);
    t0.elapsed().as_secs_f64() * 1e9 / items.len() as f64
}

/// One timed run of `spec`, ns per item.
fn run_ns(spec: &SchedulerSpec, items: &[WorkItem], job: &Job, opts: &RunOptions) -> f64 {
    let t0 = Instant::now();
    RunPlan::of(spec, opts)
        .and_then(|plan| run(&plan, items, Sources::threads(job, spec)))
        .unwrap();
    t0.elapsed().as_secs_f64() * 1e9 / items.len() as f64
}

fn main() {
    // `cargo bench` passes `--bench`; a filter argument selects rows by name.
    let filter: Option<String> = std::env::args().skip(1).find(|a| !a.starts_with('-'));
    let job: Job = Arc::new(|it: &WorkItem| TileResult {
        item: it.id,
        pixels: Default::default(),
        rays: 0,
        nonfinite: 0,
    });
    let px = Chunk::Tile { w: 1, h: 1 };
    let items = decompose(512, 512, px, Order::Scanline);
    let master_by = |buffer: usize, returns: Returns, passes: Passes| SchedulerSpec {
        policy: Policy::Master(MasterParams {
            wait: Wait::Block,
            buffer,
            requeue: Requeue::Never,
            returns,
            passes,
        }),
        ..SchedulerSpec::new(SchedulerKind::Master, px, 2)
    };
    let master_returning =
        |buffer: usize, returns: Returns| master_by(buffer, returns, Passes::Thread);
    let master = |buffer: usize| master_returning(buffer, Returns::Item);
    // The master without a thread of its own, results reported item by item or per hand-out.
    let by_workers = [("item", Returns::Item), ("hand_out", Returns::HandOut)];
    let mut rows: Vec<(String, SchedulerSpec, bool)> = SchedulerKind::ALL
        .into_iter()
        .filter(|k| *k != SchedulerKind::Master)
        .map(|k| (k.id().to_string(), SchedulerSpec::new(k, px, 2), true))
        .collect();
    for buffer in BUFFERS {
        for stats in [true, false] {
            let on_off = if stats { "stats_on" } else { "stats_off" };
            rows.push((
                format!("master_block_b{buffer}_{on_off}"),
                master(buffer),
                stats,
            ));
        }
    }
    for buffer in BUFFERS {
        for stats in [true, false] {
            let on_off = if stats { "stats_on" } else { "stats_off" };
            rows.push((
                format!("master_hand_out_b{buffer}_{on_off}"),
                master_returning(buffer, Returns::HandOut),
                stats,
            ));
        }
    }
    for (word, returns) in by_workers {
        for buffer in BUFFERS {
            for stats in [true, false] {
                let on_off = if stats { "stats_on" } else { "stats_off" };
                rows.push((
                    format!("master_workers_{word}_b{buffer}_{on_off}"),
                    master_by(buffer, returns, Passes::Workers),
                    stats,
                ));
            }
        }
    }
    let wanted = |name: &str| filter.as_deref().is_none_or(|f| name.contains(f));
    println!(
        "{:<34} {:>9} {:>9} {:>7} {:>15}",
        "scheduler (2 workers, 2^18 items)", "ns/item", "counter", "ratio", "ratio range"
    );
    for (name, spec, stats) in rows.iter().filter(|r| wanted(&r.0)) {
        let opts = RunOptions {
            stats: *stats,
            ..Default::default()
        };
        // One untimed run of each first (thread and allocator warm-up).
        counter_ns();
        RunPlan::of(spec, &opts)
            .and_then(|plan| run(&plan, &items, Sources::threads(&job, spec)))
            .unwrap();
        let (mut c, mut s, mut r) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..ROUNDS {
            let cn = counter_ns();
            let sn = run_ns(spec, &items, &job, &opts);
            c.push(cn);
            s.push(sn);
            r.push(sn / cn);
        }
        let (lo, hi) = range(&r);
        let (cm, sm) = (median(&mut c), median(&mut s));
        println!(
            "{name:<34} {sm:>9.1} {cm:>9.1} {:>6.1}× {:>7.1}–{:.1}×",
            sm / cm,
            lo,
            hi
        );
    }
    if wanted("round_trip") {
        let (mut c, mut t) = (Vec::new(), Vec::new());
        for _ in 0..ROUNDS {
            c.push(counter_ns());
            t.push(round_trip_ns());
        }
        let (cm, tm) = (median(&mut c), median(&mut t));
        let (lo, hi) = range(&t);
        println!(
            "\n{:<34} {tm:>9.1} {cm:>9.1} {:>6.1}× {lo:>7.0}–{hi:.0} ns",
            "round_trip (ns per trip)",
            tm / cm
        );
        for buffer in BUFFERS {
            // One round trip per B items per source, the P = 2 sources served in one pass.
            let floor = tm / (buffer as f64 * 2.0);
            println!(
                "  master floor at B = {buffer:<3} {floor:>16.1} ns/item {:>6.1}×",
                floor / cm
            );
        }
    }
    if wanted("bookkeeping") {
        // The master's own time per item (its stats: passes not waiting) with one worker, whose
        // core it does not share, and with two, which leave three threads on two cores: what
        // its ledger and result cells cost, apart from waiting for results.
        println!(
            "\n{:<34} {:>9} {:>9} {:>7} {:>9} {:>12}",
            "master's own time (stats on)", "dispatch", "counter", "ratio", "wait", "passes/item"
        );
        let opts = RunOptions {
            stats: true,
            ..Default::default()
        };
        let per = |x: f64| x / items.len() as f64;
        for buffer in BUFFERS {
            for workers in [1, 2] {
                let spec = SchedulerSpec {
                    workers,
                    ..master(buffer)
                };
                RunPlan::of(&spec, &opts)
                    .and_then(|plan| run(&plan, &items, Sources::threads(&job, &spec)))
                    .unwrap();
                let (mut c, mut d, mut w, mut p) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
                for _ in 0..ROUNDS {
                    c.push(counter_ns());
                    let (_, st) = RunPlan::of(&spec, &opts)
                        .and_then(|plan| run(&plan, &items, Sources::threads(&job, &spec)))
                        .unwrap();
                    let m = st.master.unwrap_or_default();
                    d.push(per(m.dispatch_s * 1e9));
                    w.push(per(m.wait_s * 1e9));
                    p.push(per(m.iterations as f64));
                }
                let (cm, dm) = (median(&mut c), median(&mut d));
                println!(
                    "{:<34} {dm:>9.1} {cm:>9.1} {:>6.1}× {:>9.1} {:>12.3}",
                    format!("bookkeeping_b{buffer}_w{workers}"),
                    dm / cm,
                    median(&mut w),
                    median(&mut p)
                );
            }
        }
    }
    if wanted("floor") {
        // The same rounds time the counter, the minimal master of `floor_ns` both ways and the
        // real master (stats off) both ways, so the ratio columns compare them without machine
        // drift.
        println!(
            "\n{:<34} {:>9} {:>9} {:>7} {:>9} {:>7} {:>9} {:>7} {:>9} {:>7} {:>18} {:>18} {:>18}",
            "master vs its floor (2 workers)",
            "counter",
            "per-item",
            "ratio",
            "per-h/o",
            "ratio",
            "master",
            "ratio",
            "m. h/o",
            "ratio",
            "master/per-item",
            "m. h/o / per-h/o",
            "m. h/o / master"
        );
        let opts = RunOptions {
            stats: false,
            ..Default::default()
        };
        for buffer in BUFFERS {
            let spec = master(buffer);
            let spec_h = master_returning(buffer, Returns::HandOut);
            floor_ns(buffer, Back::PerItem, &items, &job);
            let mut t: [Vec<f64>; 8] = Default::default();
            for _ in 0..ROUNDS {
                let c = counter_ns();
                let f = floor_ns(buffer, Back::PerItem, &items, &job);
                let h = floor_ns(buffer, Back::PerHandOut, &items, &job);
                let m = run_ns(&spec, &items, &job, &opts);
                let mh = run_ns(&spec_h, &items, &job, &opts);
                for (v, x) in t.iter_mut().zip([c, f, h, m, mh, m / f, mh / h, mh / m]) {
                    v.push(x);
                }
            }
            let (lo, hi) = range(&t[5]);
            let (hlo, hhi) = range(&t[6]);
            let (plo, phi) = range(&t[7]);
            let [c, f, h, m, mh, r, rh, p] = t.map(|mut v| median(&mut v));
            println!(
                "{:<34} {c:>9.1} {f:>9.1} {:>6.1}× {h:>9.1} {:>6.1}× {m:>9.1} {:>6.1}× {mh:>9.1} {:>6.1}× {r:>6.2} ({lo:.2}–{hi:.2}) {rh:>6.2} ({hlo:.2}–{hhi:.2}) {p:>6.2} ({plo:.2}–{phi:.2})",
                format!("floor_b{buffer}"),
                f / c,
                h / c,
                m / c,
                mh / c
            );
        }
    }
    if wanted("stats_pair") {
        // The sign-test tables (Conover, Practical Nonparametric Statistics): n = 9 → order
        // statistics 2 and 8, n = 31 → 10 and 22 (1-based).
        assert_eq!((median_ci_ranks(9), median_ci_ranks(31)), ((1, 7), (9, 21)));
        let (lo_rank, hi_rank) = median_ci_ranks(PAIRS);
        println!(
            "\n{:<34} {:>9} {:>15} {:>15}",
            format!("master stats on / off, {PAIRS} pairs"),
            "median",
            "95 % CI",
            "range"
        );
        let pairs = BUFFERS.iter().flat_map(|&b| {
            [
                (format!("stats_pair_b{b}"), master(b)),
                (
                    format!("stats_pair_workers_item_b{b}"),
                    master_by(b, Returns::Item, Passes::Workers),
                ),
                (
                    format!("stats_pair_workers_hand_out_b{b}"),
                    master_by(b, Returns::HandOut, Passes::Workers),
                ),
            ]
        });
        for (name, spec) in pairs {
            let mut r = Vec::new();
            for round in 0..PAIRS {
                let time = |stats| {
                    let opts = RunOptions {
                        stats,
                        ..Default::default()
                    };
                    run_ns(&spec, &items, &job, &opts)
                };
                // Alternate which goes first, so a trend in the machine favours neither.
                let (on, off) = if round % 2 == 0 {
                    let on = time(true);
                    (on, time(false))
                } else {
                    let off = time(false);
                    (time(true), off)
                };
                r.push(on / off);
            }
            let (lo, hi) = range(&r);
            let m = median(&mut r); // sorts r
            println!(
                "{:<34} {m:>8.3}× {:>7.3}–{:.3}× {lo:>7.3}–{hi:.3}×",
                name, r[lo_rank], r[hi_rank]
            );
        }
    }
}
