//! Every scheduler × granularity × buffer × workers gives the serial image bit for bit;
//! faults are survived (or reported, never hung on); bad parameters are clear errors.

use raysched::render::{render_serial, Image, TileResult, WorkItem};
use raysched::scene::{load_scene_str, Scene};
use raysched::sched::{
    decompose, run, Chunk, MasterParams, Order, Passes, Policy, Requeue, Returns, RunOptions,
    RunPlan, SchedError, SchedulerKind, SchedulerSpec, SelfSchedulingParams, Slow, Sources, Wait,
    Weights,
};
use raysched::source::{FaultPlan, Job};
use raysched::tracer::{AnyTracer, TracerKind};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

/// The master's parameters of a master spec.
fn master(spec: &mut SchedulerSpec) -> &mut MasterParams {
    match &mut spec.policy {
        Policy::Master(m) => m,
        p => panic!("{p:?} is not the master"),
    }
}

/// Set `grab` where the kind has one (self_scheduling, guided, work_stealing).
fn set_grab(spec: &mut SchedulerSpec, grab: usize) {
    if spec.check_name("grab").is_ok() {
        spec.set("grab", &grab.to_string()).unwrap();
    }
}

/// A cheap scene with shadow rays and bounces: a diffuse sphere on a floor under an
/// environment; odd sizes catch edge bugs.
fn scene(w: u32, h: u32) -> Arc<Scene> {
    let text = format!(
        r#"
[camera]
origin = [0, 0.5, 4]
target = [0, 0, 0]
up = [0, 1, 0]
fov_deg = 40
width = {w}
height = {h}
[render]
spp = 1
max_depth = 3
[materials.white]
type = "diffuse"
reflectance = [0.8, 0.7, 0.6]
[[shapes]]
type = "sphere"
material = "white"
radius = 1
[[shapes]]
type = "rectangle"
material = "white"
transform = [{{ translate = [0, -1, 0] }}, {{ rotate = {{ axis = [1, 0, 0], deg = -90 }} }}, {{ scale = 4 }}]
[[lights]]
type = "environment"
radiance = [1, 1, 1]
"#
    );
    Arc::new(
        load_scene_str(
            &text,
            "test",
            std::path::Path::new("."),
            "test",
            &Default::default(),
        )
        .unwrap(),
    )
}

struct Fixture {
    scene: Arc<Scene>,
    tracer: Arc<AnyTracer>,
    serial: Image,
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let scene = scene(17, 13);
        let tracer = Arc::new(AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap());
        let (serial, _) = render_serial(&scene, &*tracer);
        Fixture {
            scene,
            tracer,
            serial,
        }
    })
}

const CHUNKS: [Chunk; 6] = [
    Chunk::Tile { w: 1, h: 1 },
    Chunk::Tile { w: 4, h: 4 },
    Chunk::Tile { w: 16, h: 16 },
    Chunk::Tile { w: 64, h: 64 },
    Chunk::Rows(1),
    Chunk::Frame,
];

fn check_run(spec: &SchedulerSpec) {
    let f = fixture();
    let (image, stats) = crate::support::render(spec, &f.scene, &f.tracer)
        .unwrap_or_else(|e| panic!("{}: {e}", spec.label()));
    let label = spec.label();
    assert_eq!(
        image.hash(),
        f.serial.hash(),
        "{label}: image differs from the serial render"
    );
    let (chunk, order) = spec.layout(17, 13);
    let n = decompose(17, 13, chunk, order).len() as u64;
    assert_eq!(stats.items, n, "{label}");
    assert_eq!(
        stats.workers.len(),
        spec.workers,
        "{label}: one WorkerStats per worker"
    );
    let rendered: u64 = stats.workers.iter().map(|w| w.items).sum();
    let pixels: u64 = stats.workers.iter().map(|w| w.pixels).sum();
    assert!(
        stats.wall_s > 0.0 && stats.bytes > 0 && stats.rays > 0,
        "{label}"
    );
    if spec.kind() == SchedulerKind::Master {
        assert!(stats.master.as_ref().unwrap().iterations > 0);
        assert_eq!(
            stats.issued - stats.reissued,
            n,
            "{label}: each item handed out once before re-issues"
        );
        assert!(rendered >= n && pixels >= 17 * 13, "{label}");
    } else {
        assert!(stats.master.is_none());
        assert_eq!(
            (stats.issued, stats.duplicates, rendered, pixels),
            (n, 0, n, 17 * 13),
            "{label}"
        );
    }
    for w in &stats.workers {
        assert!(w.busy_s >= 0.0 && w.idle_s >= 0.0);
    }
}

#[test]
fn every_scheduler_granularity_and_worker_count_matches_serial() {
    let mut runs = 0;
    let mut seen = Vec::new();
    for kind in SchedulerKind::ALL
        .into_iter()
        .filter(|k| *k != SchedulerKind::Master)
    {
        for (ci, chunk) in CHUNKS.into_iter().enumerate() {
            for workers in [1, 2, 3, 5] {
                let mut spec = SchedulerSpec::new(kind, chunk, workers);
                spec.order = Order::ALL[(ci + workers) % Order::ALL.len()];
                set_grab(&mut spec, 1 + ci % 3);
                spec.timeline = workers == 3;
                check_run(&spec);
                seen.push((chunk, spec.order));
                runs += 1;
            }
        }
    }
    assert_eq!(runs, (SchedulerKind::ALL.len() - 1) * 6 * 4);
    for order in Order::ALL {
        assert!(seen.iter().any(|&(_, o)| o == order), "{order:?} never ran");
    }
    // Over one-pixel items, where its blocks differ from `scatter`'s cells (17×13: partial
    // blocks on two edges).
    assert!(seen.contains(&(Chunk::Tile { w: 1, h: 1 }, Order::ScatterBlocks)));
}

/// A heterogeneous run (one worker 3× slower) changes who renders what, never the image.
#[test]
fn every_scheduler_matches_serial_with_a_slowed_worker() {
    for kind in SchedulerKind::ALL {
        for workers in [2, 3] {
            let mut spec = SchedulerSpec::new(kind, Chunk::Tile { w: 4, h: 4 }, workers);
            spec.slow = Slow::parse("1:3").unwrap();
            assert!(spec.label().contains("slow=1:3"), "{}", spec.label());
            check_run(&spec);
        }
    }
    for weights in Weights::ALL {
        let mut spec = SchedulerSpec::new(
            SchedulerKind::WeightedFactoring,
            Chunk::Tile { w: 1, h: 1 },
            2,
        );
        spec.set("weights", weights.id()).unwrap();
        spec.slow = Slow::parse("1:2").unwrap();
        check_run(&spec);
    }
}

/// pbrt and Mitsuba cut the image themselves: 17×13 on 2 threads gives pbrt tiles of
/// ⌊√(221/16)⌋ = 3 in row order and Mitsuba 16² blocks (1 block at 32, 2 ≥ 2 threads at 16)
/// from the centre.
#[test]
fn production_renderer_policies_choose_their_own_tiles() {
    let pbrt = SchedulerSpec::new(SchedulerKind::Pbrt, Chunk::Frame, 2);
    assert_eq!(
        pbrt.layout(17, 13),
        (Chunk::Tile { w: 3, h: 3 }, Order::Scanline)
    );
    assert_eq!(pbrt.label(), "pbrt chunk=auto");
    let mitsuba = SchedulerSpec::new(SchedulerKind::Mitsuba, Chunk::Frame, 2);
    assert_eq!(
        mitsuba.layout(17, 13),
        (Chunk::Tile { w: 16, h: 16 }, Order::Spiral)
    );
    let f = fixture();
    let (_, stats) = crate::support::render(&pbrt, &f.scene, &f.tracer).unwrap();
    assert_eq!(stats.items, 6 * 5);
    let (_, stats) = crate::support::render(&mitsuba, &f.scene, &f.tracer).unwrap();
    assert_eq!(stats.items, 2);
}

#[test]
fn master_every_granularity_buffer_and_worker_count_matches_serial() {
    for (ci, chunk) in CHUNKS.into_iter().enumerate() {
        for buffer in [1, 2, 8, 64] {
            for workers in [1, 2, 3, 5] {
                let mut spec = SchedulerSpec::new(SchedulerKind::Master, chunk, workers);
                master(&mut spec).buffer = buffer;
                spec.order = Order::ALL[(ci + buffer) % 3];
                master(&mut spec).requeue = [
                    Requeue::Revisit,
                    Requeue::Never,
                    Requeue::Timeout(Duration::from_millis(5)),
                ][(buffer + workers) % 3];
                master(&mut spec).wait = Wait::ALL[(ci + workers) % 3];
                master(&mut spec).returns = Returns::ALL[(ci + buffer + workers) % 2];
                for passes in Passes::ALL {
                    master(&mut spec).passes = passes;
                    check_run(&spec);
                }
            }
        }
    }
}

#[test]
fn timeline_has_one_span_per_rendered_item() {
    let f = fixture();
    let by_workers = SchedulerSpec {
        policy: Policy::Master(MasterParams {
            passes: Passes::Workers,
            ..MasterParams::DEFAULT
        }),
        ..SchedulerSpec::new(SchedulerKind::Master, Chunk::Tile { w: 4, h: 4 }, 2)
    };
    let specs = SchedulerKind::ALL
        .into_iter()
        .map(|k| SchedulerSpec::new(k, Chunk::Tile { w: 4, h: 4 }, 2))
        .chain([by_workers]);
    for mut spec in specs {
        let kind = spec.kind();
        spec.timeline = true;
        let (_, stats) = crate::support::render(&spec, &f.scene, &f.tracer).unwrap();
        let spans = stats.timeline.expect("timeline requested");
        let (master, work): (Vec<&raysched::metrics::Span>, Vec<_>) = spans
            .iter()
            .partition(|s| s.worker == raysched::metrics::MASTER_LANE);
        let rendered: u64 = stats.workers.iter().map(|w| w.items).sum();
        assert_eq!(work.len() as u64, rendered, "{kind:?}");
        assert!(work
            .iter()
            .all(|s| s.end_ns >= s.start_ns && (s.worker as usize) < 2));
        // The master has its own lane: at least one hand-out pass, none for the others.
        if kind == SchedulerKind::Master {
            assert!(!master.is_empty(), "master lane missing");
            assert!(master.iter().all(|s| s.end_ns >= s.start_ns));
        } else {
            assert!(master.is_empty(), "{kind:?} has no master");
        }
    }
}

#[test]
fn edge_cases_tiny_image_more_workers_than_items_chunk_larger_than_image() {
    let scene = scene(1, 1);
    let tracer = Arc::new(AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap());
    let (serial, _) = render_serial(&scene, &*tracer);
    for kind in SchedulerKind::ALL {
        for chunk in [
            Chunk::Tile { w: 1, h: 1 },
            Chunk::Tile { w: 64, h: 64 },
            Chunk::Rows(7),
            Chunk::Frame,
        ] {
            let mut spec = SchedulerSpec::new(kind, chunk, 5);
            set_grab(&mut spec, 9);
            if kind == SchedulerKind::Master {
                master(&mut spec).requeue = Requeue::Revisit;
            }
            let (image, stats) = crate::support::render(&spec, &scene, &tracer).unwrap();
            assert_eq!(image.hash(), serial.hash(), "{}", spec.label());
            assert_eq!(stats.items, 1);
            assert_eq!(stats.workers.len(), 5);
        }
    }
}

/// Guided and the factoring family hand out scattered pixels but run each hand-out in scanline
/// order; self-scheduling runs them as handed out. One worker, 64² one-pixel items in `scatter`
/// order: the first hand-out of factoring (half the items), AF and AWF (an eighth, their
/// probe) and guided (a half) is run top row first, left to right.
#[test]
fn shares_of_scattered_pixels_run_in_scanline_order() {
    use std::sync::Mutex;
    let items = decompose(64, 64, Chunk::Tile { w: 1, h: 1 }, Order::Scatter);
    let run_order = |kind: SchedulerKind| -> Vec<(u32, u32)> {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let s2 = seen.clone();
        let job: Job = Arc::new(move |it: &WorkItem| {
            let p = it.pixels(64).next().unwrap();
            s2.lock().unwrap().push((p / 64, p % 64));
            TileResult {
                item: it.id,
                pixels: smallvec::smallvec![[0.0; 3]],
                rays: 1,
                nonfinite: 0,
            }
        });
        let mut spec = SchedulerSpec::new(kind, Chunk::Tile { w: 1, h: 1 }, 1);
        spec.order = Order::Scatter;
        RunPlan::of(&spec, &RunOptions::default())
            .and_then(|plan| run(&plan, &items, Sources::threads(&job, &spec)))
            .unwrap();
        let v = seen.lock().unwrap().clone();
        v
    };
    let n = items.len();
    for (kind, first) in [
        (SchedulerKind::Factoring, n / 2),
        (SchedulerKind::Guided, n / 2),
        (SchedulerKind::AdaptiveFactoring, n / 8),
        (SchedulerKind::Awf, n / 8),
    ] {
        assert!(kind.runs_hand_outs_in_scanline());
        let ran = run_order(kind);
        assert_eq!(ran.len(), n, "{kind:?}");
        assert!(
            ran[..first].windows(2).all(|w| w[0] < w[1]),
            "{kind:?}: its first {first} pixels not in scanline order"
        );
    }
    let ss = SchedulerKind::SelfScheduling;
    assert!(!ss.runs_hand_outs_in_scanline());
    let ran = run_order(ss);
    assert!(ran[..64].windows(2).any(|w| w[0] > w[1]), "as handed out");
}

/// Every pixel is rendered by someone, and each item's first result is the one kept.
#[test]
fn every_item_rendered_and_kept_once_even_with_duplicates() {
    let items = decompose(17, 13, Chunk::Tile { w: 1, h: 1 }, Order::Hilbert);
    let renders: Arc<Vec<AtomicU32>> =
        Arc::new((0..items.len()).map(|_| AtomicU32::new(0)).collect());
    let r2 = renders.clone();
    let job: Job = Arc::new(move |it: &WorkItem| {
        r2[it.id as usize].fetch_add(1, Ordering::Relaxed);
        TileResult {
            item: it.id,
            pixels: smallvec::smallvec![[it.id as f32; 3]],
            rays: 1,
            nonfinite: 0,
        }
    });
    let mut spec = SchedulerSpec::new(SchedulerKind::Master, Chunk::Tile { w: 1, h: 1 }, 3);
    master(&mut spec).requeue = Requeue::Revisit;
    master(&mut spec).buffer = 8;
    let (results, stats) = RunPlan::of(&spec, &RunOptions::default())
        .and_then(|plan| run(&plan, &items, Sources::threads(&job, &spec)))
        .unwrap();
    for (i, r) in results.iter().enumerate() {
        assert_eq!(r.as_ref().unwrap().item, i as u32);
        assert!(renders[i].load(Ordering::Relaxed) >= 1);
    }
    let total: u64 = renders
        .iter()
        .map(|r| r.load(Ordering::Relaxed) as u64)
        .sum();
    assert!(stats.duplicates <= total - items.len() as u64);
    assert_eq!(
        stats.rays,
        items.len() as u64,
        "rays count first results only"
    );
}

fn faults() -> FaultPlan {
    FaultPlan {
        drop_fraction: 0.1,
        delay_fraction: 0.2,
        max_delay: Duration::from_millis(3),
        panic: Some((1, 1)),
        seed: 7,
    }
}

#[test]
fn master_with_requeue_survives_drops_delays_and_a_panicking_worker() {
    let f = fixture();
    for requeue in [
        Requeue::Revisit,
        Requeue::Timeout(Duration::from_millis(20)),
    ] {
        for (chunk, buffer) in [
            (Chunk::Tile { w: 1, h: 1 }, 1),
            (Chunk::Tile { w: 4, h: 4 }, 2),
            (Chunk::Rows(1), 8),
        ] {
            let mut spec = SchedulerSpec::new(SchedulerKind::Master, chunk, 3);
            master(&mut spec).requeue = requeue;
            master(&mut spec).buffer = buffer;
            let opts = RunOptions {
                deadline: Some(Duration::from_secs(20)),
                faults: Some(faults()),
                ..Default::default()
            };
            let (image, stats) =
                crate::support::render_with(&spec, &f.scene, &f.tracer, &opts).unwrap();
            assert_eq!(image.hash(), f.serial.hash(), "{}", spec.label());
            assert_eq!(stats.lost_sources, 1, "{}", spec.label());
            assert!(
                stats.reissued > 0,
                "{}: lost work must be re-issued",
                spec.label()
            );
        }
    }
}

#[test]
fn master_never_requeue_reports_lost_items_within_the_deadline() {
    let f = fixture();
    let mut spec = SchedulerSpec::new(SchedulerKind::Master, Chunk::Tile { w: 1, h: 1 }, 3);
    master(&mut spec).requeue = Requeue::Never;
    let opts = RunOptions {
        deadline: Some(Duration::from_millis(1500)),
        faults: Some(faults()),
        ..Default::default()
    };
    let t = Instant::now();
    let err = crate::support::render_with(&spec, &f.scene, &f.tracer, &opts).unwrap_err();
    assert!(
        t.elapsed() < Duration::from_secs(5),
        "took {:?}",
        t.elapsed()
    );
    match err {
        SchedError::LostItems { lost, total } => {
            assert!(lost > 0 && lost < total, "{lost} of {total}");
            assert!(err
                .to_string()
                .contains(&format!("{lost} of {total} items were lost")));
        }
        e => panic!("expected LostItems, got {e}"),
    }
    // Only a panic, no drops: the lost items are known at once, no deadline needed.
    let plan = FaultPlan {
        panic: Some((0, 0)),
        ..Default::default()
    };
    let opts = RunOptions {
        deadline: Some(Duration::from_secs(30)),
        faults: Some(plan),
        ..Default::default()
    };
    let t = Instant::now();
    let err = crate::support::render_with(&spec, &f.scene, &f.tracer, &opts).unwrap_err();
    assert!(
        matches!(err, SchedError::LostItems { lost, .. } if lost >= 1),
        "{err}"
    );
    assert!(t.elapsed() < Duration::from_secs(10));
}

/// The fault injector wraps sources that a master thread drives: with the passes run by the
/// workers a fault plan is a spec error naming `passes`, not a run without the faults.
#[test]
fn a_fault_plan_needs_the_masters_own_thread() {
    let f = fixture();
    let mut spec = SchedulerSpec::new(SchedulerKind::Master, Chunk::Tile { w: 4, h: 4 }, 2);
    master(&mut spec).passes = Passes::Workers;
    let opts = RunOptions {
        faults: Some(faults()),
        ..Default::default()
    };
    match crate::support::render_with(&spec, &f.scene, &f.tracer, &opts) {
        Err(SchedError::Spec(e)) => {
            assert_eq!(e.field, "passes");
            assert!(e.msg.contains("fault injector"), "{}", e.msg);
        }
        other => panic!("expected a spec error, got {:?}", other.map(|_| ())),
    }
}

#[test]
fn all_sources_lost_is_an_error_not_a_hang() {
    let job: Job = Arc::new(|_: &WorkItem| panic!("every worker dies"));
    let items = decompose(17, 13, Chunk::Tile { w: 4, h: 4 }, Order::Scanline);
    let mut spec = SchedulerSpec::new(SchedulerKind::Master, Chunk::Tile { w: 4, h: 4 }, 2);
    master(&mut spec).requeue = Requeue::Revisit;
    for passes in Passes::ALL {
        master(&mut spec).passes = passes;
        let err = RunPlan::of(&spec, &RunOptions::default())
            .and_then(|plan| run(&plan, &items, Sources::threads(&job, &spec)))
            .unwrap_err();
        assert!(
            matches!(err, SchedError::AllSourcesLost { sources: 2, .. }),
            "{passes:?}: {err}"
        );
    }
    // Without a master a worker panic is an error too, never a crash of the caller.
    for kind in SchedulerKind::ALL
        .into_iter()
        .filter(|k| *k != SchedulerKind::Master)
    {
        let spec = SchedulerSpec::new(kind, Chunk::Tile { w: 4, h: 4 }, 2);
        let err = RunPlan::of(&spec, &RunOptions::default())
            .and_then(|plan| run(&plan, &items, Sources::threads(&job, &spec)))
            .unwrap_err();
        assert!(
            matches!(err, SchedError::WorkerPanic(ref m) if m.contains("every worker dies")),
            "{kind:?}: {err}"
        );
    }
}

#[test]
fn bad_parameters_are_clear_errors() {
    let f = fixture();
    let base = SchedulerSpec::new(SchedulerKind::Master, Chunk::Frame, 2);
    for (spec, field) in [
        (
            SchedulerSpec {
                workers: 0,
                ..base.clone()
            },
            "workers",
        ),
        (
            SchedulerSpec {
                policy: Policy::Master(MasterParams {
                    buffer: 0,
                    ..MasterParams::DEFAULT
                }),
                ..base.clone()
            },
            "buffer",
        ),
        (
            SchedulerSpec {
                policy: Policy::SelfScheduling(SelfSchedulingParams { grab: 0 }),
                ..base.clone()
            },
            "grab",
        ),
        (
            SchedulerSpec {
                chunk: Chunk::Tile { w: 0, h: 4 },
                ..base.clone()
            },
            "chunk",
        ),
    ] {
        match crate::support::render(&spec, &f.scene, &f.tracer) {
            Err(SchedError::Spec(e)) => assert_eq!(e.field, field),
            other => panic!(
                "{field}: expected a spec error, got {:?}",
                other.map(|_| ())
            ),
        }
    }
    assert!(Chunk::parse("0").is_err());
    assert!(SchedulerKind::from_id("fifo")
        .unwrap_err()
        .to_string()
        .contains("unknown scheduler 'fifo'"));
    assert!(Order::from_id("peano")
        .unwrap_err()
        .to_string()
        .contains("unknown order 'peano'"));
}

mod cli {
    use crate::support::assert_ok;
    use std::process::{Command, Output};

    fn scene_file(dir: &std::path::Path) -> std::path::PathBuf {
        let p = dir.join("s.toml");
        std::fs::write(
            &p,
            "[camera]\norigin=[0,0,4]\ntarget=[0,0,0]\nup=[0,1,0]\nfov_deg=40\nwidth=9\nheight=7\n[render]\nspp=1\n\
             [materials.w]\ntype=\"diffuse\"\nreflectance=[0.5,0.5,0.5]\n[[shapes]]\ntype=\"sphere\"\nmaterial=\"w\"\nradius=1\n\
             [[lights]]\ntype=\"environment\"\nradiance=[1,1,1]\n",
        )
        .unwrap();
        p
    }

    #[test]
    fn the_chunk_left_out_is_the_kinds_own_default() {
        let dir = tempfile::tempdir().unwrap();
        let scene = scene_file(dir.path());
        let out = dir.path().join("o.pfm");
        // 9×7 pixels: 2×2 tiles make 5 · 4 = 20 items, 16×16 one, single pixels 63.
        for (args, chunk, items) in [
            (&["--scheduler", "awf"][..], "chunk=2", 20),
            (&["--scheduler", "guided"][..], "chunk=2", 20),
            (&["--scheduler", "self_scheduling"][..], "chunk=16", 1),
            (&["--scheduler", "awf", "--chunk", "1"][..], "chunk=1", 63),
        ] {
            let o = Command::new(env!("CARGO_BIN_EXE_raysched"))
                .args(["render", scene.to_str().unwrap(), "-o"])
                .arg(&out)
                .args(args)
                .output()
                .unwrap();
            assert_ok(&o);
            let text = String::from_utf8_lossy(&o.stdout);
            assert!(text.contains(chunk), "{args:?}: {text}");
            assert!(
                text.contains(&format!("items {items} ")),
                "{args:?}: {text}"
            );
        }
    }

    #[test]
    fn render_with_a_scheduler_and_bad_flags_exit_2_naming_the_flag() {
        let dir = tempfile::tempdir().unwrap();
        let scene = scene_file(dir.path());
        let out = dir.path().join("o.pfm");
        let run = |extra: &[&str]| -> Output {
            Command::new(env!("CARGO_BIN_EXE_raysched"))
                .args([
                    "render",
                    scene.to_str().unwrap(),
                    "-o",
                    out.to_str().unwrap(),
                ])
                .args(extra)
                .output()
                .unwrap()
        };
        let o = run(&[
            "--threads",
            "2",
            "--scheduler",
            "master",
            "--chunk",
            "1",
            "--buffer",
            "2",
            "--order",
            "morton",
            "--requeue",
            "seed",
            "--wait",
            "spin",
        ]);
        assert_ok(&o);
        assert!(out.exists());
        for (flag, value) in [
            ("--chunk", "0"),
            ("--buffer", "0"),
            ("--threads", "0"),
            ("--scheduler", "fastest"),
            ("--order", "zigzag"),
            ("--requeue", "maybe"),
            ("--wait", "nap"),
            ("--grab", "0"),
        ] {
            // The master's flags go with the master, `--grab` with a kind that grabs.
            let kind = match flag {
                "--buffer" | "--requeue" | "--wait" => "master",
                _ => "self_scheduling",
            };
            let args: &[&str] = if flag == "--scheduler" {
                &[flag, value]
            } else {
                &["--scheduler", kind, flag, value]
            };
            let o = run(args);
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{flag} {value}: {err}");
            assert!(err.contains(flag), "{flag}: {err}");
            assert_eq!(err.trim_end().lines().count(), 1, "{flag}: one line: {err}");
        }
        // A parameter the chosen kind does not have is refused, naming the flag.
        let o = run(&["--scheduler", "static", "--buffer", "4"]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(
            err.contains("--buffer") && err.contains("only master"),
            "{err}"
        );
    }
}

/// The identity test with the Embree tracer: every scheduler, at per-ray and per-block
/// granularity, gives the image of the 1-thread serial Embree render.
#[cfg(feature = "embree")]
#[test]
fn every_scheduler_matches_serial_with_embree() {
    every_scheduler_matches_serial_with(TracerKind::Embree);
}

/// The same identity with Embree 4.
#[cfg(feature = "embree4")]
#[test]
fn every_scheduler_matches_serial_with_embree4() {
    every_scheduler_matches_serial_with(TracerKind::Embree4);
}

#[cfg(any(feature = "embree", feature = "embree4"))]
fn every_scheduler_matches_serial_with(tracer: TracerKind) {
    use raysched::tracer::Tracer;
    let scene = scene(17, 13);
    let tracer = Arc::new(AnyTracer::build(tracer, &scene, 1).unwrap());
    let (serial, _) = render_serial(&scene, &*tracer);
    for kind in SchedulerKind::ALL {
        for chunk in [
            Chunk::Tile { w: 1, h: 1 },
            Chunk::Tile { w: 4, h: 4 },
            Chunk::Rows(2),
        ] {
            for workers in [1, 3] {
                let spec = SchedulerSpec::new(kind, chunk, workers);
                let (image, _) = crate::support::render(&spec, &scene, &tracer)
                    .unwrap_or_else(|e| panic!("{}: {e}", spec.label()));
                assert_eq!(
                    image.hash(),
                    serial.hash(),
                    "{} {}",
                    tracer.id(),
                    spec.label()
                );
            }
        }
    }
}

/// A job that sleeps `d` per item and returns black pixels: a known, render-free item time.
fn sleeping_job(d: Duration) -> Job {
    Arc::new(move |it: &WorkItem| {
        std::thread::sleep(d);
        TileResult {
            item: it.id,
            pixels: smallvec::smallvec![[0.0; 3]; it.pixel_count()],
            rays: 1,
            nonfinite: 0,
        }
    })
}

#[test]
fn the_balancer_probes_a_dispatch_source_at_its_fill_first_and_loses_nothing() {
    use raysched::metrics::Probe;
    use raysched::sched::rule::Dispatch;
    use raysched::sched::Hetero;
    use raysched::source::{slowed_job, ComputeSource, LocalThreadSource};
    // Source 1 says it runs each hand-out as one dispatch filled at 64 items of 16 px; it
    // renders 8× as fast as source 0. 2000 items of ≥ 25 µs on source 1.
    let job = sleeping_job(Duration::from_micros(25));
    let probe = Probe::new(true, false);
    let log: Arc<std::sync::Mutex<Vec<usize>>> = Arc::default();
    let sources: Vec<Box<dyn ComputeSource>> = vec![
        Box::new(LocalThreadSource::spawn(
            0,
            slowed_job(job.clone(), 8.0),
            probe,
        )),
        Box::new(Recording {
            inner: LocalThreadSource::spawn(1, job, probe),
            sizes: log.clone(),
            whole: true,
            dispatch: Some(Dispatch {
                overhead: Duration::from_micros(10),
                fill_px: 64 * 16,
            }),
        }),
    ];
    let items: Vec<WorkItem> = (0..2000).map(|i| WorkItem::rect(i, 0, 0, 4, 4)).collect();
    let hetero = Hetero {
        balance: true,
        ..Default::default()
    };
    let (results, stats) =
        master_over(MasterParams::default(), hetero, &items, sources, probe).unwrap();
    assert!((0..2000).all(|i| results.get(i).is_some()));
    assert_eq!(stats.workers[0].items + stats.workers[1].items, 2000);
    // Its first hand-out is the probe of its fill; none is smaller but the queue's last.
    let sizes = log.lock().unwrap().clone();
    assert_eq!(sizes[0], 64, "{sizes:?}");
    let (_, before_last) = sizes.split_last().unwrap();
    assert!(before_last.iter().all(|&n| n >= 64), "{sizes:?}");
    assert!(stats.workers[1].items > stats.workers[0].items);
    assert_eq!(
        stats.workers[0].source,
        Some(raysched::metrics::SourceKind::Threads)
    );
}

/// A local thread source that records the size of every hand-out it is given; `whole`: it
/// says its hand-outs go whole, as a GPU does.
struct Recording {
    inner: raysched::source::LocalThreadSource,
    sizes: Arc<std::sync::Mutex<Vec<usize>>>,
    whole: bool,
    /// What it says of its dispatches (a GPU-like source for the balancer).
    dispatch: Option<raysched::sched::rule::Dispatch>,
}

impl raysched::source::ComputeSource for Recording {
    fn id(&self) -> u32 {
        self.inner.id()
    }
    fn label(&self) -> String {
        self.inner.label()
    }
    fn submit(&mut self, item: WorkItem) -> raysched::source::DelayedResult {
        self.sizes.lock().unwrap().push(1);
        self.inner.submit(item)
    }
    fn submit_batch(
        &mut self,
        items: &mut Vec<WorkItem>,
        out: &mut Vec<raysched::source::DelayedResult>,
    ) {
        self.sizes.lock().unwrap().push(items.len());
        self.inner.submit_batch(items, out)
    }
    fn runs_hand_outs_whole(&self) -> bool {
        self.whole
    }
    fn dispatch(&self) -> Option<raysched::sched::rule::Dispatch> {
        self.dispatch
    }
    fn is_lost(&self) -> bool {
        self.inner.is_lost()
    }
    fn set_notifier(&mut self, n: raysched::source::Notifier) {
        self.inner.set_notifier(n)
    }
    fn finish(self: Box<Self>) -> raysched::source::SourceReport {
        Box::new(self.inner).finish()
    }
}

#[test]
fn a_source_with_its_own_grain_gets_whole_groups_of_items_and_the_others_single_items() {
    use raysched::metrics::Probe;
    use raysched::sched::Hetero;
    use raysched::source::{ComputeSource, LocalThreadSource};
    let job = sleeping_job(Duration::from_micros(50));
    let probe = Probe::new(true, false);
    let logs: Vec<Arc<std::sync::Mutex<Vec<usize>>>> = (0..2).map(|_| Arc::default()).collect();
    let sources: Vec<Box<dyn ComputeSource>> = logs
        .iter()
        .enumerate()
        .map(|(i, log)| {
            Box::new(Recording {
                inner: LocalThreadSource::spawn(i as u32, job.clone(), probe),
                sizes: log.clone(),
                whole: false,
                dispatch: None,
            }) as Box<dyn ComputeSource>
        })
        .collect();
    // 1001 items of 16 pixels; source 1 takes 64 px (4 items) per hand-out, 2 outstanding.
    let items: Vec<WorkItem> = (0..1001).map(|i| WorkItem::rect(i, 0, 0, 4, 4)).collect();
    let hetero = Hetero {
        buffers: vec![2, 2],
        grains: vec![0, 64],
        balance: false,
    };
    let (results, stats) =
        master_over(MasterParams::default(), hetero, &items, sources, probe).unwrap();
    assert!((0..1001).all(|i| results.get(i).is_some()));
    let grouped = logs[1].lock().unwrap().clone();
    let (last, whole) = grouped.split_last().expect("source 1 got work");
    assert!(whole.iter().all(|&n| n == 4), "{grouped:?}");
    assert!(*last >= 1 && *last <= 4, "{grouped:?}");
    assert_eq!(grouped.iter().sum::<usize>() as u64, stats.workers[1].items);
    // The other source keeps the master's B = 2 of single items: hand-outs of 1 or 2.
    let single = logs[0].lock().unwrap().clone();
    assert!(single.iter().all(|&n| n <= 2), "{single:?}");
    assert_eq!(stats.workers[0].items + stats.workers[1].items, 1001);
}

#[test]
fn an_idle_source_gets_its_first_item_ahead_of_the_rest_unless_its_hand_outs_go_whole() {
    use raysched::metrics::Probe;
    use raysched::source::{ComputeSource, LocalThreadSource};
    let job = sleeping_job(Duration::from_micros(50));
    let probe = Probe::new(true, false);
    let items: Vec<WorkItem> = (0..64).map(|i| WorkItem::rect(i, 0, 0, 1, 1)).collect();
    let first_hand_outs = |whole: bool| {
        let log: Arc<std::sync::Mutex<Vec<usize>>> = Arc::default();
        let source = Box::new(Recording {
            inner: LocalThreadSource::spawn(0, job.clone(), probe),
            sizes: log.clone(),
            whole,
            dispatch: None,
        }) as Box<dyn ComputeSource>;
        let params = MasterParams {
            buffer: 16,
            ..Default::default()
        };
        let (results, _) =
            master_over(params, Default::default(), &items, vec![source], probe).unwrap();
        assert!((0..64).all(|i| results.get(i).is_some()));
        let sizes = log.lock().unwrap().clone();
        sizes[..2].to_vec()
    };
    // B = 16: a thread gets its first item alone so it starts while the master scans on.
    assert_eq!(first_hand_outs(false), [1, 15]);
    // A source whose hand-out costs the same at any size gets the 16 in one.
    assert_eq!(first_hand_outs(true)[0], 16);
}

/// The master with `params` over `sources` (each with its own buffer and grain, `hetero`),
/// through the one run path.
fn master_over(
    params: MasterParams,
    hetero: raysched::sched::Hetero,
    items: &[WorkItem],
    sources: Vec<Box<dyn raysched::source::ComputeSource>>,
    probe: raysched::metrics::Probe,
) -> Result<(raysched::sched::Results, raysched::metrics::RunStats), raysched::sched::SchedError> {
    use raysched::sched::{run, Policy, RunPlan, Slow, Sources};
    let plan = RunPlan {
        scheduler: &Policy::Master(params),
        slow: Slow::NONE,
        opts: &RunOptions::default(),
        probe,
    };
    run(&plan, items, Sources::Boxed(sources, hetero))
}
