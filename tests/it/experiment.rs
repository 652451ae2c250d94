//! The experiment runner through the real binary: config errors, resume after kills, plots.

use crate::support::assert_ok;
use raysched::experiment::results::read_runs;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_raysched");

fn scene_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/simple.toml")
}

/// A tiny experiment in `dir`: 2 scenes sizes × (serial + 6 scheduler configs) × reps.
fn write_tiny(dir: &Path, reps: u32) -> PathBuf {
    let text = format!(
        r#"name = "tiny"
repetitions = {reps}
ci_target = 0
min_sample_s = 0
warmup = 0
workers = [1, 2]
[[scenes]]
path = "{scene}"
width = 16
height = 16
spp = 1
[[scenes]]
path = "{scene}"
width = 24
height = 8
spp = 2
[[schedulers]]
kind = "master"
chunk = ["1", "4"]
buffer = [1, 2]
[[schedulers]]
kind = "static"
chunk = "rows:1"
"#,
        scene = scene_path().display()
    );
    let p = dir.join("tiny.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// A temporary folder holding the tiny experiment with `reps` repetitions, already run into
/// `res/` (asserted to succeed).
pub(crate) fn run_tiny(reps: u32) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let exp = write_tiny(dir.path(), reps);
    let out = run(
        &["run", exp.to_str().unwrap(), "--quiet", "--out", "res"],
        dir.path(),
    );
    assert_ok(&out);
    (dir, exp)
}

fn run(args: &[&str], cwd: &Path) -> std::process::Output {
    Command::new(BIN)
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap()
}

/// Each `(from, to, field)`: the experiment `good` with `from` replaced by `to` exits 2 with
/// an error naming the file and `field`.
fn assert_bad_configs(dir: &Path, good: &str, cases: &[(&str, &str, &str)]) {
    for (from, to, field) in cases {
        std::fs::write(dir.join("bad.toml"), good.replacen(from, to, 1)).unwrap();
        let out = run(&["run", "bad.toml", "--quiet", "--out", "res"], dir);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{to:?}: {err}");
        assert!(
            err.contains("bad.toml") && err.contains(field),
            "{to:?}: {err}"
        );
    }
}

#[test]
fn bad_configs_exit_2_naming_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let good = std::fs::read_to_string(write_tiny(dir.path(), 1)).unwrap();
    let cases = [
        (
            "kind = \"static\"\nchunk = \"rows:1\"",
            "kind = \"static\"\nchunk = \"rows:1\"\nbuffer = 4",
            "schedulers[1].buffer",
        ),
        ("repetitions = 1", "repetitions = 0", "repetitions"),
        (
            "warmup = 0",
            "warmup = 0\nisolation = \"fork\"",
            "isolation",
        ),
        ("workers = [1, 2]", "workers = [0, 2]", "workers"),
        (
            "chunk = [\"1\", \"4\"]",
            "chunk = [\"1\", \"0\"]",
            "schedulers[0].chunk",
        ),
        (
            "kind = \"master\"",
            "kind = \"fastest\"",
            "schedulers[0].kind",
        ),
        (
            "name = \"tiny\"",
            "name = \"tiny\"\ntracers = [\"embree\"]",
            "tracers[0]",
        ),
        ("width = 16", "width = 0", "scenes[0]"),
        // A TOML error: `file:line:column: key: message`.
        ("width = 16", "widht = 16", "bad.toml:9:1: scenes[0].widht"),
        (
            "kind = \"static\"\nchunk = \"rows:1\"",
            "kind = \"static\"\nchunk = \"rows:1\"\nslow = \"0:3\"",
            "schedulers[1].slow",
        ),
        (
            "kind = \"static\"\nchunk = \"rows:1\"",
            "kind = \"pbrt\"\nchunk = \"rows:1\"",
            "schedulers[1].chunk",
        ),
        // The sources axis and the per-source settings, from the one source definition.
        (
            "workers = [1, 2]",
            "workers = [1, 2]\nsources = [\"threads\", \"cuda\"]",
            "sources[1]: unknown compute source 'cuda'",
        ),
        (
            "workers = [1, 2]",
            "workers = [1, 2]\nsources = \"threads,threads\"",
            "sources: 'threads' given twice",
        ),
        (
            "workers = [1, 2]",
            "workers = [1, 2]\nsources = [\"mpi\"]",
            "sources[0]",
        ),
        (
            "workers = [1, 2]",
            "workers = [1, 2]\ngpu_adapter = \"llvmpipe\"",
            "gpu_adapter: applies only with gpu among the sources",
        ),
        (
            "buffer = [1, 2]",
            "buffer = [1, 2]\ngpu_chunk = \"64\"",
            "schedulers[0].gpu_chunk: applies to none of sources",
        ),
        (
            "buffer = [1, 2]",
            "buffer = [1, 2]\nbalance = [false, true]",
            "schedulers[0].balance",
        ),
        (
            "kind = \"static\"\nchunk = \"rows:1\"",
            "kind = \"static\"\nchunk = \"rows:1\"\ngpu_buffer = 2",
            "schedulers[1].gpu_buffer: 'static' has no gpu_buffer",
        ),
        // Without feature `gpu` (tests/it/gpu.rs runs such experiments with it).
        (
            "workers = [1, 2]",
            "workers = [1, 2]\nsources = [\"threads\", \"gpu\"]",
            "sources[1]: 'gpu' needs cargo feature `gpu`",
        ),
    ];
    for (i, (from, to, field)) in cases.into_iter().enumerate() {
        if to.contains("\"gpu\"") && cfg!(feature = "gpu") {
            continue; // valid with the feature
        }
        let res = format!("res{i}");
        assert!(good.contains(from), "{from}");
        let p = dir.path().join("bad.toml");
        std::fs::write(&p, good.replacen(from, to, 1)).unwrap();
        let out = run(
            &["run", p.to_str().unwrap(), "--quiet", "--out", &res],
            dir.path(),
        );
        let err = String::from_utf8_lossy(&out.stderr);
        if to.contains("embree") && cfg!(feature = "embree") {
            continue;
        }
        assert_eq!(out.status.code(), Some(2), "{to}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{to}: {err}");
        assert!(
            err.contains("bad.toml:") && err.contains(field),
            "{to}: {err}"
        );
        // Validation happens before anything is measured.
        assert!(
            !dir.path().join(&res).join("tiny/runs.csv").exists(),
            "{to}"
        );
    }
}

/// Kill the runner at random moments, resume, and check every (config, repetition) appears
/// exactly once and no partial line survives.
/// The process ids of `rows`, per repetition.
fn processes_by_repetition(rows: &[raysched::experiment::results::RunRow]) -> Vec<Vec<u32>> {
    let reps = rows.iter().map(|r| r.repetition + 1).max().unwrap_or(0);
    (0..reps)
        .map(|k| {
            let mut p: Vec<u32> = rows
                .iter()
                .filter(|r| r.repetition == k)
                .map(|r| r.process.expect("every new row names its process"))
                .collect();
            p.sort_unstable();
            p.dedup();
            p
        })
        .collect()
}

#[test]
fn each_round_is_measured_in_its_own_process_unless_isolation_is_none() {
    let (dir, exp) = run_tiny(3);
    let csv = dir.path().join("res/tiny/runs.csv");
    let (rows, _) = read_runs(&csv).unwrap();
    // 2 scenes × (serial + 8 master + 2 static) × 3 repetitions, one round per repetition.
    assert_eq!(rows.len(), 2 * 11 * 3);
    assert!(rows.iter().all(|r| r.identical), "every image as serial");
    let by_rep = processes_by_repetition(&rows);
    assert!(
        by_rep.iter().all(|p| p.len() == 1),
        "one process per round: {by_rep:?}"
    );
    let mut all: Vec<u32> = by_rep.concat();
    all.dedup();
    assert_eq!(all.len(), 3, "a new process for each round: {by_rep:?}");
    assert!(
        !all.contains(&std::process::id()),
        "not this test's process"
    );
    assert!(
        !dir.path().join("res/tiny/.predictions.json").exists(),
        "no scratch file left"
    );

    let one = [
        "run",
        exp.to_str().unwrap(),
        "--quiet",
        "--out",
        "res",
        "--fresh",
        "--isolation",
        "none",
    ];
    let out = run(&one, dir.path());
    assert_ok(&out);
    let (rows, _) = read_runs(&csv).unwrap();
    assert_eq!(rows.len(), 2 * 11 * 3);
    let mut all: Vec<u32> = processes_by_repetition(&rows).concat();
    all.sort_unstable();
    all.dedup();
    assert_eq!(all.len(), 1, "isolation none: one process for every round");

    // Renders repeated inside one sample still leave repetition 0's timeline (the first
    // render's) for every scheduler configuration.
    let text = std::fs::read_to_string(&exp).unwrap();
    std::fs::write(
        &exp,
        text.replace("min_sample_s = 0", "min_sample_s = 0.01"),
    )
    .unwrap();
    let out = run(&one[..6], dir.path());
    assert_ok(&out);
    let (rows, _) = read_runs(&csv).unwrap();
    assert!(
        rows.iter().any(|r| r.inner > 1),
        "some samples repeat their render"
    );
    for r in rows
        .iter()
        .filter(|r| r.scheduler != "serial" && r.repetition == 0)
    {
        let t = dir
            .path()
            .join(format!("res/tiny/timelines/{}.csv", r.config));
        assert!(t.exists(), "{} (inner {}): no timeline", r.label, r.inner);
    }

    let bad = run(
        &["run", exp.to_str().unwrap(), "--isolation", "fork"],
        dir.path(),
    );
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--isolation"));
}

#[test]
fn killed_runs_resume_without_lost_or_duplicated_rows() {
    let dir = tempfile::tempdir().unwrap();
    let reps = 40;
    let exp = write_tiny(dir.path(), reps);
    let args = ["run", exp.to_str().unwrap(), "--quiet", "--out", "res"];
    let csv = dir.path().join("res/tiny/runs.csv");
    // xorshift seeded from the clock: different kill points on every test run.
    let mut x = Instant::now().elapsed().as_nanos() as u64 | 1;
    x ^= std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as u64;
    let mut rnd = move |n: u64| {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x % n
    };
    let t0 = Instant::now();
    let mut kills = 0;
    let mut finished = false;
    while kills < 12 && t0.elapsed() < Duration::from_secs(30) {
        let mut child = Command::new(BIN)
            .args(args)
            .current_dir(dir.path())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(20 + rnd(250)));
        if child.try_wait().unwrap().is_some() {
            finished = true;
            break;
        }
        child.kill().unwrap();
        child.wait().unwrap();
        kills += 1;
        // Whatever the kill left, the rows read back are whole and unique so far.
        if csv.exists() {
            let (rows, _) = read_runs(&csv).unwrap();
            let mut seen = HashMap::new();
            for r in &rows {
                assert!(
                    seen.insert((r.config.clone(), r.repetition), ()).is_none(),
                    "duplicate after kill {kills}"
                );
            }
        }
    }
    let out = run(&args, dir.path());
    assert_ok(&out);
    let bytes = std::fs::read(&csv).unwrap();
    assert_eq!(bytes.last(), Some(&b'\n'), "no partial last line");
    let (rows, valid) = read_runs(&csv).unwrap();
    assert_eq!(
        valid as usize,
        bytes.len(),
        "every byte belongs to a whole row"
    );
    // 2 scenes × (serial + master 2 chunks × 2 buffers × 2 worker counts + static × 2).
    let configs = 2 * (1 + 8 + 2);
    let mut count: HashMap<(String, u32), usize> = HashMap::new();
    for r in &rows {
        *count.entry((r.config.clone(), r.repetition)).or_default() += 1;
        assert!(r.identical, "{} rep {}", r.label, r.repetition);
    }
    assert_eq!(
        count.len(),
        configs * reps as usize,
        "kills: {kills}, finished early: {finished}"
    );
    assert!(
        count.values().all(|&c| c == 1),
        "a (config, repetition) appears twice"
    );
    assert!(kills > 0 || finished, "the test never killed anything");

    // Re-running measures nothing new.
    let before = bytes.len();
    assert!(run(&args, dir.path()).status.success());
    assert_eq!(std::fs::read(&csv).unwrap().len(), before);

    // A changed experiment file that keeps every row valid resumes, measuring nothing; one
    // that invalidates them (spp) is refused (exit 2) unless --fresh.
    let text = std::fs::read_to_string(&exp).unwrap();
    std::fs::write(&exp, text.replace("warmup = 0", "warmup = 1")).unwrap();
    assert!(run(&args, dir.path()).status.success());
    assert_eq!(std::fs::read(&csv).unwrap().len(), before);
    std::fs::write(&exp, text.replace("spp = 2", "spp = 3")).unwrap();
    let out = run(&args, dir.path());
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--fresh"));
    std::fs::write(
        &exp,
        text.replace(&format!("repetitions = {reps}"), "repetitions = 1"),
    )
    .unwrap();
    let mut fresh = args.to_vec();
    fresh.push("--fresh");
    assert!(run(&fresh, dir.path()).status.success());
    assert_eq!(read_runs(&csv).unwrap().0.len(), configs);
}

#[test]
fn plot_regenerates_everything_from_the_csv() {
    let (dir, _) = run_tiny(2);
    let res = dir.path().join("res/tiny");
    for f in ["meta.toml", "summary.csv", "report.md"] {
        assert!(res.join(f).exists(), "{f}");
    }
    let imgs: Vec<_> = std::fs::read_dir(res.join("images"))
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(imgs.len(), 4, "EXR + PNG per serial baseline: {imgs:?}");
    std::fs::remove_dir_all(res.join("plots")).unwrap();
    std::fs::remove_file(res.join("report.md")).unwrap();
    let out = run(&["plot", res.to_str().unwrap()], dir.path());
    assert_ok(&out);
    let plots: Vec<String> = std::fs::read_dir(res.join("plots"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    for prefix in [
        "speedup_vs_workers_",
        "granularity_",
        "buffer_",
        "overhead_",
        "gantt_",
    ] {
        for ext in ["png", "svg"] {
            assert!(
                plots
                    .iter()
                    .any(|p| p.starts_with(prefix) && p.ends_with(ext)),
                "{prefix}*.{ext} in {plots:?}"
            );
        }
    }
    let png = plots
        .iter()
        .find(|p| p.starts_with("granularity_") && p.ends_with("png"))
        .unwrap();
    let img = image::open(res.join("plots").join(png)).unwrap();
    assert!(img.width() >= 800 && img.height() >= 500);
    // Print quality: every PNG rasterised from its SVG at twice the size.
    let out = run(
        &["plot", res.to_str().unwrap(), "--png-scale", "2"],
        dir.path(),
    );
    assert_ok(&out);
    let big = image::open(res.join("plots").join(png)).unwrap();
    assert_eq!(
        (big.width(), big.height()),
        (2 * img.width(), 2 * img.height())
    );
    for bad in ["0.5", "9", "nan"] {
        let out = run(
            &["plot", res.to_str().unwrap(), "--png-scale", bad],
            dir.path(),
        );
        assert_eq!(out.status.code(), Some(2), "--png-scale {bad}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("--png-scale"));
    }
    let report = std::fs::read_to_string(res.join("report.md")).unwrap();
    assert!(report.contains("per-ray master"), "{report}");
    assert!(
        report.contains("![") && report.contains("plots/granularity_"),
        "{report}"
    );
    // A results folder without runs.csv is bad input.
    assert_eq!(
        run(&["plot", dir.path().to_str().unwrap()], dir.path())
            .status
            .code(),
        Some(2)
    );
}

/// Timelines stay out of git: without them `plot` keeps the Gantt PNGs drawn before (and the
/// report still shows them), or skips the charts, and says so on stderr instead of failing.
#[test]
fn plot_without_timelines_keeps_or_skips_gantt_charts_with_a_note() {
    let (dir, _) = run_tiny(1);
    let res = dir.path().join("res/tiny");
    let gantts = |res: &Path| -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(res.join("plots"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|f| f.starts_with("gantt_") && f.ends_with(".png"))
            .collect();
        v.sort();
        v
    };
    let before = gantts(&res);
    assert!(!before.is_empty());
    std::fs::remove_dir_all(res.join("timelines")).unwrap();

    let out = run(&["plot", res.to_str().unwrap()], dir.path());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("no timeline") && err.contains("kept"), "{err}");
    assert_eq!(gantts(&res), before);
    let report = std::fs::read_to_string(res.join("report.md")).unwrap();
    assert!(report.contains(&format!("plots/{}", before[0])), "{report}");
    // Print quality from a folder without timelines: a kept chart is rasterised from the SVG
    // kept beside it (this failed on the staged SVG it never had).
    let gantt = res.join("plots").join(&before[0]);
    let small = image::open(&gantt).unwrap();
    let out = run(
        &["plot", res.to_str().unwrap(), "--png-scale", "2"],
        dir.path(),
    );
    assert_ok(&out);
    let big = image::open(&gantt).unwrap();
    assert_eq!(
        (big.width(), big.height()),
        (2 * small.width(), 2 * small.height())
    );

    std::fs::remove_dir_all(res.join("plots")).unwrap();
    let out = run(&["plot", res.to_str().unwrap()], dir.path());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("skipped"), "{err}");
    assert!(gantts(&res).is_empty());
    let report = std::fs::read_to_string(res.join("report.md")).unwrap();
    assert!(!report.contains("gantt_"), "{report}");
    assert!(res.join("plots").read_dir().unwrap().next().is_some());
}

/// `features_used` / `features_left_out` reach runs.csv and report.md: the one-sphere scene
/// builds no BVH and needs no refraction; the Cornell box has a BVH over its triangles.
#[test]
fn runs_record_what_each_scene_uses_and_leaves_out() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let text = format!(
        r#"name = "feats"
repetitions = 1
ci_target = 0
min_sample_s = 0
warmup = 0
workers = [1]
[[scenes]]
path = "{simple}"
width = 8
height = 8
spp = 1
[[scenes]]
path = "{cornell}"
width = 8
height = 8
spp = 1
[[schedulers]]
kind = "self_scheduling"
chunk = "4"
"#,
        simple = scenes.join("simple.toml").display(),
        cornell = scenes.join("cornell_box.toml").display()
    );
    std::fs::write(dir.path().join("feats.toml"), text).unwrap();
    let out = run(
        &["run", "feats.toml", "--quiet", "--out", "res"],
        dir.path(),
    );
    assert_ok(&out);
    let (rows, _) = read_runs(&dir.path().join("res/feats/runs.csv")).unwrap();
    assert_eq!(rows.len(), 4, "serial + one scheduler config per scene");
    for r in &rows {
        let used: Vec<&str> = r.features_used.split('+').collect();
        let left: Vec<&str> = r.features_left_out.split('+').collect();
        assert!(
            left.contains(&"refraction") && !used.contains(&"refraction"),
            "{r:?}"
        );
        match r.scene.as_str() {
            "simple" => {
                assert!(
                    used.contains(&"spheres") && used.contains(&"environment"),
                    "{r:?}"
                );
                assert!(
                    left.contains(&"bvh") && left.contains(&"triangles"),
                    "{r:?}"
                );
            }
            "cornell_box" => {
                assert!(
                    used.contains(&"bvh") && used.contains(&"area_lights"),
                    "{r:?}"
                );
                assert!(
                    left.contains(&"environment") && left.contains(&"spheres"),
                    "{r:?}"
                );
            }
            other => panic!("unexpected scene {other}"),
        }
    }
    let report = std::fs::read_to_string(dir.path().join("res/feats/report.md")).unwrap();
    assert!(report.contains("left out `"), "{report}");
}

/// `kind = "convergence"`: error against time for every (scene, tracer), CSV + plot + report;
/// its own fields are validated before anything renders.
#[test]
fn convergence_experiment_writes_rows_plot_and_slopes() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/furnace_a08.toml");
    let good = format!(
        "kind = \"convergence\"\nmax_spp = 8\nworkers = 1\ntracers = [\"bvh\", \"brute\"]\n\
         [[scenes]]\npath = \"{}\"\nwidth = 12\nheight = 12\n",
        scene.display()
    );
    std::fs::write(dir.path().join("conv.toml"), &good).unwrap();
    // `--dry-run` plans it (each tracer's reference and configuration) and writes nothing.
    let out = run(
        &["run", "conv.toml", "--dry-run", "--out", "res"],
        dir.path(),
    );
    assert_ok(&out);
    let plan = String::from_utf8_lossy(&out.stdout);
    assert!(
        plan.contains("1, 2, 4 … 8 spp (4 steps, 15 samples per pixel")
            && plan.contains("furnace_a08 · brute: reference analytic_environment")
            && plan.contains("rows_rayon ×1")
            && plan.contains("Nothing was measured"),
        "{plan}"
    );
    assert!(!dir.path().join("res").exists());
    let out = run(&["run", "conv.toml", "--quiet", "--out", "res"], dir.path());
    assert_ok(&out);
    let rows = raysched::converge::read_csv(&dir.path().join("res/conv/convergence.csv")).unwrap();
    // 1, 2, 4, 8 spp for each of the two tracers.
    assert_eq!(rows.len(), 8);
    for t in ["bvh", "brute"] {
        let spp: Vec<u32> = rows
            .iter()
            .filter(|r| r.tracer == t)
            .map(|r| r.spp)
            .collect();
        assert_eq!(spp, vec![1, 2, 4, 8], "{t}");
    }
    assert!(rows.iter().all(|r| r.rmse.is_finite() && r.rmse > 0.0));
    assert!(dir.path().join("res/conv/convergence.png").exists());
    let report = std::fs::read_to_string(dir.path().join("res/conv/report.md")).unwrap();
    assert!(
        report.contains("slope") && report.contains("furnace_a08"),
        "{report}"
    );
    // `raysched plot` redraws it from the CSV alone.
    std::fs::remove_file(dir.path().join("res/conv/convergence.png")).unwrap();
    let out = run(&["plot", "res/conv"], dir.path());
    assert_ok(&out);
    assert!(dir.path().join("res/conv/convergence.png").exists());

    assert_bad_configs(
        dir.path(),
        &good,
        &[
            ("max_spp = 8\n", "", "max_spp"),
            ("max_spp = 8", "max_spp = 0", "max_spp"),
            ("kind = \"convergence\"\n", "", "schedulers"),
        ],
    );
}

/// Schedulers are a dimension of a convergence experiment. One row set per
/// (tracer, scheduler); the images are bit-identical, so every error column of a step is the
/// same under every scheduler; the summary answers the time-budget question on stdout and in
/// report.md; an unknown scheduler is a config error naming the file and the field.
#[test]
fn convergence_per_scheduler_same_errors_and_budget_winner() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box.toml");
    let good = format!(
        "kind = \"convergence\"\nmax_spp = 4\nref_spp = 8\nworkers = 2\ntracers = [\"bvh\"]\n\
         [[scenes]]\npath = \"{}\"\nwidth = 10\nheight = 8\n\
         [[schedulers]]\nkind = \"master\"\nchunk = \"1\"\n\
         [[schedulers]]\nkind = \"work_stealing\"\nchunk = [\"3\", \"frame\"]\n\
         [[schedulers]]\nkind = \"static\"\nchunk = \"rows:1\"\n",
        scene.display()
    );
    std::fs::write(dir.path().join("conv.toml"), &good).unwrap();
    let out = run(&["run", "conv.toml", "--out", "res"], dir.path());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_ok(&out);
    let rows = raysched::converge::read_csv(&dir.path().join("res/conv/convergence.csv")).unwrap();
    let mut by_sched: std::collections::BTreeMap<String, Vec<_>> = Default::default();
    for r in &rows {
        by_sched.entry(r.scheduler.clone()).or_default().push(r);
    }
    let names: Vec<&str> = by_sched.keys().map(String::as_str).collect();
    assert_eq!(names.len(), 4, "{names:?}");
    assert!(
        names.iter().any(|n| n.starts_with("master chunk=1")),
        "{names:?}"
    );
    assert!(names.contains(&"work_stealing chunk=frame"), "{names:?}");
    let first = &by_sched[names[0]];
    for (name, g) in &by_sched {
        // 1, 2, 4 spp on 2 workers, errors identical bit for bit.
        assert_eq!(
            g.iter().map(|r| r.spp).collect::<Vec<_>>(),
            [1, 2, 4],
            "{name}"
        );
        for (a, b) in g.iter().zip(first) {
            assert_eq!(a.threads, 2);
            assert_eq!(
                (a.rmse, a.rel_mse, a.mae, a.max_err, a.rays),
                (b.rmse, b.rel_mse, b.mae, b.max_err, b.rays),
                "{name} vs {} at {} spp",
                names[0],
                a.spp
            );
        }
        assert!(g.windows(2).all(|w| w[1].wall_s > w[0].wall_s), "{name}");
    }
    let report = std::fs::read_to_string(dir.path().join("res/conv/report.md")).unwrap();
    let winner = raysched::converge::budget_winners(&rows);
    assert_eq!(winner.len(), 1);
    assert!(winner[0].contains("lowest RMSE is bvh/"), "{}", winner[0]);
    assert!(
        report.contains(&winner[0]) && stdout.contains(&winner[0]),
        "{report}\n{stdout}"
    );
    assert!(report.contains("load average"), "{report}");
    // Both plots are redrawn from the CSV alone.
    for p in ["convergence.png", "convergence.svg"] {
        std::fs::remove_file(dir.path().join("res/conv").join(p)).unwrap();
    }
    assert!(run(&["plot", "res/conv"], dir.path()).status.success());
    for p in ["convergence.png", "convergence.svg"] {
        assert!(dir.path().join("res/conv").join(p).exists(), "{p}");
    }

    assert_bad_configs(
        dir.path(),
        &good,
        &[
            (
                "kind = \"master\"",
                "kind = \"fastest\"",
                "schedulers[0].kind",
            ),
            (
                "chunk = \"rows:1\"",
                "chunk = \"rows:0\"",
                "schedulers[2].chunk",
            ),
            (
                "chunk = \"1\"\n",
                "chunk = \"1\"\nguided_k = 2\n",
                "schedulers[0].guided_k",
            ),
        ],
    );
}

/// The README's main command writes to the default results root, `results/runs/`: on a fresh
/// clone it measures (resumes nothing from the published snapshots under `results/published/`,
/// which it never touches), and a second run resumes, appending only a start record.
#[test]
fn the_readme_command_measures_and_a_second_run_resumes_without_touching_old_records() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md")).unwrap();
    let cmd = "cargo run --release -- run experiments/quick.toml\n";
    assert!(readme.contains(cmd), "the README's main command changed");
    let dir = tempfile::tempdir().unwrap();
    let exp = write_tiny(dir.path(), 2);
    // A published snapshot of the same experiment, as a clone has it.
    let out = run(
        &[
            "run",
            exp.to_str().unwrap(),
            "--quiet",
            "--out",
            "results/published",
        ],
        dir.path(),
    );
    assert_ok(&out);
    let published = dir.path().join("results/published/tiny");
    let snapshot: Vec<Vec<u8>> = ["runs.csv", "meta.toml", "report.md", "summary.csv"]
        .iter()
        .map(|f| std::fs::read(published.join(f)).unwrap())
        .collect();

    // The command as the README gives it: no --out.
    let out = run(&["run", exp.to_str().unwrap()], dir.path());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_ok(&out);
    let configs = 2 * (1 + 8 + 2);
    assert!(
        stdout.contains(&format!("tiny: {} runs measured", configs * 2))
            && stdout.contains(", 0 already done"),
        "{stdout}"
    );
    let mine = dir.path().join("results/runs/tiny");
    assert_eq!(
        read_runs(&mine.join("runs.csv")).unwrap().0.len(),
        configs * 2
    );
    for (f, before) in ["runs.csv", "meta.toml", "report.md", "summary.csv"]
        .iter()
        .zip(&snapshot)
    {
        assert_eq!(
            &std::fs::read(published.join(f)).unwrap(),
            before,
            "{f} changed"
        );
    }

    // A second run measures nothing and keeps every earlier record: runs.csv byte for byte,
    // meta.toml as a prefix (the new start is appended to its history).
    let csv = std::fs::read(mine.join("runs.csv")).unwrap();
    let meta = std::fs::read_to_string(mine.join("meta.toml")).unwrap();
    let out = run(&["run", exp.to_str().unwrap()], dir.path());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_ok(&out);
    assert!(
        stdout.contains(&format!(
            "tiny: 0 runs measured (0 untimed warm-ups and probes), {} already done",
            configs * 2
        )),
        "{stdout}"
    );
    assert_eq!(std::fs::read(mine.join("runs.csv")).unwrap(), csv);
    let meta2 = std::fs::read_to_string(mine.join("meta.toml")).unwrap();
    let parsed: raysched::experiment::meta::Meta = toml::from_str(&meta2).unwrap();
    assert_eq!(parsed.history.len(), 2);
    assert_eq!(parsed.history[1].rows_before, configs * 2);
    let first: raysched::experiment::meta::Meta = toml::from_str(&meta).unwrap();
    assert_eq!(first.history[..], parsed.history[..1]);
    assert_eq!(
        (first.started, first.git_commit, first.machine, first.scenes),
        (
            parsed.started.clone(),
            parsed.git_commit.clone(),
            parsed.machine.clone(),
            parsed.scenes.clone()
        )
    );

    // Rows from another build are refused in one line naming what differs, unless --fresh.
    let forged = meta2.replace(&parsed.history[0].commit, "0123abcd");
    std::fs::write(mine.join("meta.toml"), forged).unwrap();
    let out = run(&["run", exp.to_str().unwrap()], dir.path());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("commit 0123abcd →") && err.contains("--fresh"),
        "{err}"
    );
    assert_eq!(std::fs::read(mine.join("runs.csv")).unwrap(), csv);
    let out = run(
        &["run", exp.to_str().unwrap(), "--quiet", "--fresh"],
        dir.path(),
    );
    assert_ok(&out);
}

/// The class "growing a sweep forces `--fresh`": adding grid values (chunks, workers, a
/// scene) resumes and measures only the new configurations, every old row kept byte for byte
/// and the first start's provenance as it was. A change that invalidates old rows (spp, the
/// scene's content) is refused in one line that names `--out`, leaving `meta.toml` and
/// `runs.csv` byte-identical.
#[test]
fn growing_a_sweep_resumes_and_measures_only_new_configurations() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(scene_path(), dir.path().join("scene.toml")).unwrap();
    let exp = dir.path().join("grow.toml");
    let write = |chunks: &str, workers: &str, extra_scene: bool, spp: u32| {
        let mut text = format!(
            "name = \"grow\"\nrepetitions = 1\nci_target = 0\nmin_sample_s = 0\nwarmup = 0\n\
             workers = {workers}\n[[scenes]]\npath = \"scene.toml\"\nwidth = 16\nheight = 16\n\
             spp = {spp}\n[[schedulers]]\nkind = \"master\"\nchunk = {chunks}\n"
        );
        if extra_scene {
            text.push_str("[[scenes]]\npath = \"scene.toml\"\nwidth = 8\nheight = 8\nspp = 1\n");
        }
        std::fs::write(&exp, text).unwrap();
    };
    let res = dir.path().join("res/grow");
    let go = || run(&["run", "grow.toml", "--quiet", "--out", "res"], dir.path());
    let ids =
        |rows: &[raysched::experiment::results::RunRow]| -> std::collections::BTreeSet<String> {
            rows.iter().map(|r| r.config.clone()).collect()
        };
    write("[\"1\"]", "[2]", false, 1);
    assert_ok(&go());
    let csv1 = std::fs::read(res.join("runs.csv")).unwrap();
    let meta1: raysched::experiment::meta::Meta =
        toml::from_str(&std::fs::read_to_string(res.join("meta.toml")).unwrap()).unwrap();
    let (rows1, _) = read_runs(&res.join("runs.csv")).unwrap();
    assert_eq!(rows1.len(), 2, "serial + master chunk 1 on 2 workers");

    // More chunks, more workers and another scene: only the new configurations are measured.
    write("[\"1\", \"4\"]", "[2, 3]", true, 1);
    let out = go();
    assert_ok(&out);
    let csv2 = std::fs::read(res.join("runs.csv")).unwrap();
    assert_eq!(&csv2[..csv1.len()], &csv1[..], "old rows rewritten");
    let (rows2, _) = read_runs(&res.join("runs.csv")).unwrap();
    // Scene 16²: serial + 2 chunks × 2 worker counts; scene 8²: the same again.
    assert_eq!(rows2.len(), 10);
    let new_ids = ids(&rows2[2..]);
    assert!(
        new_ids.is_disjoint(&ids(&rows1)),
        "an old configuration measured again"
    );
    assert_eq!(new_ids.len(), 8);
    let meta2: raysched::experiment::meta::Meta =
        toml::from_str(&std::fs::read_to_string(res.join("meta.toml")).unwrap()).unwrap();
    assert_eq!(meta2.history.len(), 2);
    assert_eq!(
        meta2.history[0], meta1.history[0],
        "the first start's provenance"
    );
    assert_eq!(meta2.started, meta1.started);
    assert_eq!(meta2.scenes[0], meta1.scenes[0]);
    assert_eq!(meta2.scenes.len(), 2, "the added scene recorded");
    assert_ne!(meta2.experiment_hash, meta1.experiment_hash);
    assert_eq!(
        meta2.history[1].experiment_hash.as_deref(),
        Some(meta2.experiment_hash.as_str())
    );

    // Changes that invalidate old rows are refused, changing nothing.
    let refused = |what: &str| {
        let (csv, meta) = (
            std::fs::read(res.join("runs.csv")).unwrap(),
            std::fs::read(res.join("meta.toml")).unwrap(),
        );
        let out = go();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{what}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{what}: {err}");
        assert!(err.contains(what) && err.contains("--out"), "{what}: {err}");
        assert_eq!(std::fs::read(res.join("runs.csv")).unwrap(), csv, "{what}");
        assert_eq!(
            std::fs::read(res.join("meta.toml")).unwrap(),
            meta,
            "{what}"
        );
    };
    write("[\"1\", \"4\"]", "[2, 3]", true, 2);
    refused("spp");
    write("[\"1\", \"4\"]", "[2, 3]", true, 1);
    let scene = std::fs::read_to_string(dir.path().join("scene.toml")).unwrap();
    std::fs::write(
        dir.path().join("scene.toml"),
        scene.replace("[0.7, 0.7, 0.7]", "[0.6, 0.6, 0.6]"),
    )
    .unwrap();
    refused("changed (hash");
    // Dropping a grid value keeps its rows and measures nothing.
    std::fs::write(dir.path().join("scene.toml"), &scene).unwrap();
    write("[\"1\"]", "[2, 3]", true, 1);
    assert_ok(&go());
    assert_eq!(std::fs::read(res.join("runs.csv")).unwrap(), csv2);
}

/// The class "a scene file where an experiment is expected, and the reverse": each command
/// says in one line which kind of file it got and what to do with it, not `unknown field`.
/// An experiment's scene override out of range blames the experiment's field.
#[test]
fn a_scene_given_for_an_experiment_and_the_reverse_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let exp = write_tiny(dir.path(), 1);
    let scene = scene_path();
    let one_line_2 = |out: &std::process::Output, want: &[&str]| {
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(!err.contains("unknown field"), "{err}");
        for w in want {
            assert!(err.contains(w), "{w}: {err}");
        }
    };
    let out = run(
        &["run", scene.to_str().unwrap(), "--quiet", "--out", "res"],
        dir.path(),
    );
    one_line_2(
        &out,
        &[
            "simple.toml",
            "scene file, not an experiment",
            "raysched render",
        ],
    );
    assert!(!dir.path().join("res").exists(), "wrote a results folder");
    let out = run(
        &["render", exp.to_str().unwrap(), "-o", "x.exr", "--spp", "1"],
        dir.path(),
    );
    one_line_2(
        &out,
        &["tiny.toml", "experiment file, not a scene", "raysched run"],
    );
    assert!(!dir.path().join("x.exr").exists());

    // `width = 0` in the experiment: its field, scenes[0].width, in the experiment file.
    let text = std::fs::read_to_string(&exp).unwrap();
    for (from, to, key) in [
        ("width = 16", "width = 0", "scenes[0].width"),
        ("spp = 2", "spp = 0", "scenes[1].spp"),
    ] {
        std::fs::write(&exp, text.replacen(from, to, 1)).unwrap();
        let out = run(
            &["run", exp.to_str().unwrap(), "--quiet", "--out", "res"],
            dir.path(),
        );
        let err = String::from_utf8_lossy(&out.stderr);
        one_line_2(&out, &["tiny.toml", key]);
        assert!(
            !err.contains("simple.toml") && !err.contains("camera."),
            "{err}"
        );
    }
}

/// The class "`plot` on a runs.csv whose number column holds text": exit 2 naming the file,
/// the line and the column, and nothing written, wherever the bad row is (the last one too).
#[test]
fn plot_on_text_in_a_number_column_exits_2_naming_line_and_column() {
    let (dir, _) = run_tiny(1);
    let res = dir.path().join("res/tiny");
    let csv = std::fs::read_to_string(res.join("runs.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = header.iter().position(|c| *c == "wall_s").unwrap();
    let lines = csv.lines().count();
    for line in [2, lines] {
        std::fs::remove_dir_all(res.join("plots")).unwrap_or(());
        for f in ["summary.csv", "report.md", "summary.json", "runs.json"] {
            let _ = std::fs::remove_file(res.join(f));
        }
        let bad: Vec<String> = csv
            .lines()
            .enumerate()
            .map(|(i, l)| {
                if i + 1 != line {
                    return l.to_string();
                }
                let mut cells: Vec<&str> = l.split(',').collect();
                cells[col] = "fast";
                cells.join(",")
            })
            .collect();
        std::fs::write(res.join("runs.csv"), bad.join("\n") + "\n").unwrap();
        let listing = |d: &Path| -> Vec<String> {
            let mut v: Vec<String> = std::fs::read_dir(d)
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            v.sort();
            v
        };
        let before = listing(&res);
        let out = run(&["plot", res.to_str().unwrap()], dir.path());
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "line {line}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(
            err.contains("runs.csv")
                && err.contains(&format!("line {line}"))
                && err.contains(&format!("column {}", col + 1))
                && err.contains("wall_s")
                && err.contains("fast"),
            "line {line}: {err}"
        );
        assert_eq!(listing(&res), before, "line {line}: wrote something");
    }
}

/// Adaptive repetitions: a configuration stops early only with its median's interval within
/// the target (the summary shows the same interval), else at its run cap; short renders are
/// repeated inside one sample; every row records its timestamp, CPU time and load.
#[test]
fn adaptive_runs_stop_at_the_ci_target_or_the_cap() {
    let dir = tempfile::tempdir().unwrap();
    let exp = write_tiny(dir.path(), 2);
    let text = std::fs::read_to_string(&exp).unwrap().replace(
        "ci_target = 0\nmin_sample_s = 0\n",
        "ci_target = 0.02\nmax_repetitions = 7\nbudget_s = 1000\nmin_sample_s = 0.002\n",
    );
    std::fs::write(&exp, text).unwrap();
    let out = run(
        &["run", exp.to_str().unwrap(), "--quiet", "--out", "res"],
        dir.path(),
    );
    assert_ok(&out);
    let (rows, _) = read_runs(&dir.path().join("res/tiny/runs.csv")).unwrap();
    let sums = raysched::experiment::summary::summarize(&rows);
    assert_eq!(sums.len(), 2 * (1 + 8 + 2));
    for s in &sums {
        assert!((2..=7).contains(&s.n), "{} runs: {}", s.row.label, s.n);
        if s.n < 7 {
            assert!(
                s.n >= 5 && s.ci_half_rel <= 0.02,
                "{} stopped at {} with ±{}",
                s.row.label,
                s.n,
                s.ci_half_rel
            );
        }
        // Reps are 0..n, each once.
        let reps: Vec<u32> = s.walls.iter().map(|w| w.0).collect();
        assert_eq!(reps, (0..s.n as u32).collect::<Vec<_>>());
    }
    for r in &rows {
        assert!(r.inner >= 1 && r.timestamp.ends_with('Z'), "{r:?}");
        if cfg!(target_os = "linux") {
            assert!(r.user_s.is_some() && r.load_before.is_some() && r.load_after.is_some());
        }
    }
    // A 16×16 render takes well under 2 ms, so the samples are built of several renders.
    assert!(rows.iter().any(|r| r.inner > 1), "no inner repetition");
    // Exports beside the CSVs.
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("res/tiny/summary.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(json["schema"], "raysched.summary/1");
    assert_eq!(json["configurations"].as_array().unwrap().len(), sums.len());
    let runs: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("res/tiny/runs.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(runs["rows"].as_array().unwrap().len(), rows.len());
}

/// `compare`: a run against itself is "equivalent" everywhere (within the default ±5 %: the
/// tiny experiment sets no precision target); against a copy 20 % slower, "slower" everywhere
/// with p < 0.01, and `--fail-on-regression` exits 1. A copy 20 % slower whose machine-speed
/// probe is 20 % slower too is the machine drifting: "equivalent", unless `--raw`. With 3 runs
/// a side even the 20 % is "undecided", naming the 6 runs the test needs.
#[test]
fn compare_flags_a_known_slowdown_and_nothing_else() {
    use raysched::experiment::results::RunsFile;
    let (dir, _) = run_tiny(8);
    // Known wall times: A = 1 ms × (1 + k/1000), B = C = A × 1.2, same other columns; the probe
    // takes 10 ms in A and B, 12 ms in C.
    let (rows, _) = read_runs(&dir.path().join("res/tiny/runs.csv")).unwrap();
    assert!(rows.iter().all(|r| r.probe_s.is_some_and(|p| p > 0.0)));
    for (name, factor, probe) in [("a", 1.0, 0.010), ("b", 1.2, 0.010), ("c", 1.2, 0.012)] {
        let d = dir.path().join(name).join("tiny");
        std::fs::create_dir_all(&d).unwrap();
        // The forged rows are of other configurations: the copied meta must not name the
        // original ones as current (it would leave every forged row out as retired).
        let meta = std::fs::read_to_string(dir.path().join("res/tiny/meta.toml")).unwrap();
        let mut meta: toml::Table = toml::from_str(&meta).unwrap();
        meta.remove("configs");
        std::fs::write(d.join("meta.toml"), toml::to_string(&meta).unwrap()).unwrap();
        let (mut f, _) = RunsFile::open(&d.join("runs.csv"), true).unwrap();
        for r in &rows {
            let mut r = r.clone();
            r.wall_s = 1e-3 * (1.0 + f64::from(r.repetition) / 1000.0) * factor;
            r.probe_s = Some(probe);
            f.append(&r).unwrap();
        }
    }
    let cmp = |a: &str, b: &str, extra: &[&str]| {
        let mut args = vec!["compare", a, b, "--json"];
        args.extend(extra);
        run(&args, dir.path())
    };
    let same = cmp("a/tiny", "a/tiny", &["--fail-on-regression"]);
    assert_ok(&same);
    let v: serde_json::Value = serde_json::from_slice(&same.stdout).unwrap();
    let changes = v["changes"].as_array().unwrap();
    assert_eq!(changes.len(), 2 * (1 + 8 + 2));
    assert!(changes.iter().all(|c| c["verdict"] == "equivalent"), "{v}");
    assert!((v["margin"].as_f64().unwrap() - 0.05).abs() < 1e-12, "{v}");
    let slow = cmp("a/tiny", "b/tiny", &[]);
    assert!(slow.status.success());
    let v: serde_json::Value = serde_json::from_slice(&slow.stdout).unwrap();
    for c in v["changes"].as_array().unwrap() {
        assert_eq!(c["verdict"], "slower", "{c}");
        assert!(c["p_value"].as_f64().unwrap() < 0.01, "{c}");
        let r = &c["wall_ratio"];
        assert!((r["value"].as_f64().unwrap() - 1.2).abs() < 1e-9, "{c}");
        assert!(
            r["lo"].as_f64().unwrap() <= 1.2 && r["hi"].as_f64().unwrap() >= 1.2,
            "{c}"
        );
    }
    let fail = cmp("a/tiny", "b/tiny", &["--fail-on-regression"]);
    assert_eq!(fail.status.code(), Some(1));
    let drift = cmp("a/tiny", "c/tiny", &["--fail-on-regression"]);
    assert!(drift.status.success());
    let v: serde_json::Value = serde_json::from_slice(&drift.stdout).unwrap();
    assert!(
        (v["machine_factor"].as_f64().unwrap() - 1.2).abs() < 1e-9,
        "{v}"
    );
    for c in v["changes"].as_array().unwrap() {
        assert_eq!(c["verdict"], "equivalent", "{c}");
        assert!((c["wall_ratio"]["value"].as_f64().unwrap() - 1.0).abs() < 1e-9);
        assert!((c["raw_wall_ratio"].as_f64().unwrap() - 1.2).abs() < 1e-9);
    }
    let raw = cmp("a/tiny", "c/tiny", &["--raw"]);
    let v: serde_json::Value = serde_json::from_slice(&raw.stdout).unwrap();
    assert!(v["machine_factor"].is_null());
    assert!(v["changes"]
        .as_array()
        .unwrap()
        .iter()
        .all(|c| c["verdict"] == "slower"));
    // Markdown by default, one table row per configuration.
    let md = run(&["compare", "b/tiny", "a/tiny"], dir.path());
    let text = String::from_utf8_lossy(&md.stdout);
    assert!(
        text.contains("22 faster, 0 slower, 0 equivalent within ±5.0 %, 0 undecided")
            && text.contains("Mann–Whitney")
            && text.contains("TOST"),
        "{text}"
    );
    // Three runs a side: the rank test cannot reach p < 0.01 at all, so not even 20 % is
    // "slower"; each verdict names the runs it would need.
    for (name, factor) in [("a3", 1.0), ("b3", 1.2)] {
        let d = dir.path().join(name).join("tiny");
        std::fs::create_dir_all(&d).unwrap();
        // The forged rows are of other configurations: the copied meta must not name the
        // original ones as current (it would leave every forged row out as retired).
        let meta = std::fs::read_to_string(dir.path().join("res/tiny/meta.toml")).unwrap();
        let mut meta: toml::Table = toml::from_str(&meta).unwrap();
        meta.remove("configs");
        std::fs::write(d.join("meta.toml"), toml::to_string(&meta).unwrap()).unwrap();
        let (mut f, _) = RunsFile::open(&d.join("runs.csv"), true).unwrap();
        for r in rows.iter().filter(|r| r.repetition < 3) {
            let mut r = r.clone();
            r.wall_s = 1e-3 * (1.0 + f64::from(r.repetition) / 1000.0) * factor;
            r.probe_s = Some(0.010);
            f.append(&r).unwrap();
        }
    }
    let few = cmp("a3/tiny", "b3/tiny", &["--fail-on-regression"]);
    assert_ok(&few);
    let v: serde_json::Value = serde_json::from_slice(&few.stdout).unwrap();
    for c in v["changes"].as_array().unwrap() {
        assert_eq!(c["verdict"], "undecided", "{c}");
        assert_eq!(c["runs_needed"], 6, "{c}");
        assert_eq!(
            c["verdict_text"], "undecided (need ≥ 6 runs per side)",
            "{c}"
        );
    }
    assert_eq!(
        run(&["compare", "a/tiny", "nowhere"], dir.path())
            .status
            .code(),
        Some(2)
    );
}

/// The class "`compare` that compares nothing": folders without a configuration in common
/// (another experiment, other scenes, another grid) exit 2 with one line saying which, and how
/// to compare across them, `--fail-on-regression` or not.
#[test]
fn compare_that_compares_nothing_exits_2_saying_why() {
    use raysched::experiment::results::RunsFile;
    let (dir, _) = run_tiny(1);
    let (rows, _) = read_runs(&dir.path().join("res/tiny/runs.csv")).unwrap();
    type Edit = fn(&mut raysched::experiment::results::RunRow);
    let cases: [(&str, Edit, &str); 3] = [
        (
            "exp",
            |r| r.experiment = "other".into(),
            "different experiments",
        ),
        (
            "scene",
            |r| r.scene = "elsewhere".into(),
            "different scenes",
        ),
        ("grid", |_| {}, "different grids"),
    ];
    for (name, edit, why) in cases {
        let d = dir.path().join(name).join("tiny");
        std::fs::create_dir_all(&d).unwrap();
        // The forged rows are of other configurations: the copied meta must not name the
        // original ones as current (it would leave every forged row out as retired).
        let meta = std::fs::read_to_string(dir.path().join("res/tiny/meta.toml")).unwrap();
        let mut meta: toml::Table = toml::from_str(&meta).unwrap();
        meta.remove("configs");
        std::fs::write(d.join("meta.toml"), toml::to_string(&meta).unwrap()).unwrap();
        let (mut f, _) = RunsFile::open(&d.join("runs.csv"), true).unwrap();
        for r in &rows {
            let mut r = r.clone();
            edit(&mut r);
            // Another configuration id: what another scene or grid gives.
            r.config = format!("{:016x}", u64::from_str_radix(&r.config, 16).unwrap() ^ 1);
            f.append(&r).unwrap();
        }
        let b = format!("{name}/tiny");
        for extra in [&[][..], &["--fail-on-regression"], &["--json"]] {
            let mut args = vec!["compare", "res/tiny", b.as_str()];
            args.extend(extra);
            let out = run(&args, dir.path());
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{name} {extra:?}: {err}");
            assert_eq!(err.trim_end().lines().count(), 1, "{name}: {err}");
            assert!(
                err.contains("no configuration in common") && err.contains(why),
                "{name}: {err}"
            );
            assert!(err.contains("--out"), "{name}: says how to compare: {err}");
            assert!(out.stdout.is_empty(), "{name}: wrote a report anyway");
        }
    }
    // One configuration in common is a comparison.
    assert_ok(&run(&["compare", "res/tiny", "res/tiny"], dir.path()));
}

/// `run --dry-run` prints the plan and measures nothing.
#[test]
fn dry_run_plans_without_measuring() {
    let dir = tempfile::tempdir().unwrap();
    let exp = write_tiny(dir.path(), 3);
    let out = run(
        &["run", exp.to_str().unwrap(), "--dry-run", "--out", "res"],
        dir.path(),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_ok(&out);
    assert!(
        stdout.contains("22 configurations; estimated") && stdout.contains("Nothing was measured"),
        "{stdout}"
    );
    assert!(stdout.contains("exactly 3 timed runs"), "{stdout}");
    assert!(!dir.path().join("res/tiny/runs.csv").exists());
}

/// The published snapshots are read by this version, those whose runs.csv predates the sample
/// columns (seed, frames) and the current one (quick), and are where the README says.
#[test]
fn published_snapshots_still_read() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("results/published");
    for name in ["quick", "seed", "frames"] {
        let (rows, _) = read_runs(&root.join(name).join("runs.csv")).unwrap();
        assert!(!rows.is_empty(), "{name}");
        let old = rows.iter().all(|r| r.inner == 1 && r.timestamp.is_empty());
        let new = rows
            .iter()
            .all(|r| !r.timestamp.is_empty() && r.user_s.is_some());
        assert!(if name == "quick" { new } else { old }, "{name}");
    }
}

/// The report's warnings and equivalences, on forged wall times: serial 3 ms and every
/// configuration 1 ms (± 0.1 %) gives 3× on 2 workers (efficiency above 100 % beyond noise)
/// and a fastest configuration the others are equivalent to by the two one-sided tests (issue
/// 58: "equivalent within ±X %", never "tied"); `plot` prints them in report.md.
#[test]
fn report_warns_of_impossible_efficiency_and_lists_equivalents() {
    use raysched::experiment::results::RunsFile;
    let (dir, _) = run_tiny(6);
    let res = dir.path().join("res/tiny");
    let (rows, _) = read_runs(&res.join("runs.csv")).unwrap();
    let (mut f, _) = RunsFile::open(&res.join("runs.csv"), true).unwrap();
    for r in &rows {
        let mut r = r.clone();
        let jitter = 1.0 + f64::from(r.repetition % 3) / 1000.0;
        r.wall_s = if r.scheduler == "serial" { 3e-3 } else { 1e-3 } * jitter;
        f.append(&r).unwrap();
    }
    drop(f);
    let out = run(&["plot", res.to_str().unwrap()], dir.path());
    assert_ok(&out);
    let report = std::fs::read_to_string(res.join("report.md")).unwrap();
    assert!(report.contains("## Warnings"), "{report}");
    assert!(
        report.contains("×2: efficiency 150 %") && report.contains("above 100 % beyond noise"),
        "{report}"
    );
    assert!(report.contains("×1: efficiency 300 %"), "{report}");
    assert!(
        report.contains("4 of 4: equivalent within ±5.0 % (two one-sided tests at 95 %)"),
        "{report}"
    );
    assert!(!report.to_lowercase().contains("tied"), "{report}");
    assert!(
        report.contains("speedup 3.00× (95 % CI 3.00–3.00)"),
        "{report}"
    );
}

/// Resume never mixes (issue 58, item 4): the experiment changed from B = 2 to B = 4 and from
/// 3 to 4 repetitions, resumed into the same `--out`, keeps the B = 2 rows in runs.csv, and
/// leaves them out of summary.csv, report.md and `compare`, the report saying how many; the
/// runs it states are what each configuration got.
#[test]
fn a_changed_experiment_resumed_reports_only_its_current_configurations() {
    let dir = tempfile::tempdir().unwrap();
    let exp = dir.path().join("mix.toml");
    let write = |buffer: u32, reps: u32| {
        let text = format!(
            "name = \"mix\"\nrepetitions = {reps}\nci_target = 0\nmin_sample_s = 0\nwarmup = 0\n\
             workers = [2]\n[[scenes]]\npath = \"{}\"\nwidth = 16\nheight = 16\nspp = 1\n\
             [[schedulers]]\nkind = \"master\"\nchunk = \"4\"\nbuffer = {buffer}\n",
            scene_path().display()
        );
        std::fs::write(&exp, text).unwrap();
    };
    let go = || run(&["run", "mix.toml", "--quiet", "--out", "res"], dir.path());
    let res = dir.path().join("res/mix");
    write(2, 3);
    assert_ok(&go());
    let (old, _) = read_runs(&res.join("runs.csv")).unwrap();
    assert_eq!(old.len(), 6, "serial + master B=2, 3 runs each");
    let old_master = old.iter().find(|r| !r.is_serial()).unwrap().clone();
    write(4, 4);
    assert_ok(&go());
    let (all, _) = read_runs(&res.join("runs.csv")).unwrap();
    assert_eq!(
        all.len(),
        6 + 1 + 4,
        "one more serial run, four of master B=4"
    );
    assert!(
        all.iter().any(|r| r.config == old_master.config),
        "old rows kept"
    );
    let summary = std::fs::read_to_string(res.join("summary.csv")).unwrap();
    assert_eq!(summary.lines().count(), 1 + 2, "{summary}");
    assert!(!summary.contains(&old_master.config), "{summary}");
    let report = std::fs::read_to_string(res.join("report.md")).unwrap();
    assert!(
        report.contains(
            "3 row(s) of runs.csv belong to configurations the experiment file no longer names"
        ),
        "{report}"
    );
    assert!(
        !report.contains(&format!("`{}`", old_master.label)),
        "{report}"
    );
    assert!(
        report.contains("(measured: 4 per configuration)"),
        "{report}"
    );
    // compare sees the current configurations only: the folder against itself has two.
    let out = run(&["compare", "res/mix", "res/mix", "--json"], dir.path());
    assert_ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["changes"].as_array().unwrap().len(), 2, "{v}");
}

/// `compare --interleave`: both sides measured in alternated rounds, one more run per
/// configuration each round, then compared; the same build twice is never faster or slower
/// (what its verdicts are, equivalent or undecided, depends on the machine's noise).
#[test]
fn interleaved_compare_measures_both_sides_round_by_round() {
    let dir = tempfile::tempdir().unwrap();
    let exp = dir.path().join("il.toml");
    std::fs::write(
        &exp,
        format!(
            "name = \"il\"\nrepetitions = 1\nci_target = 0\nmin_sample_s = 0\nwarmup = 0\n\
             workers = [1]\n[[scenes]]\npath = \"{}\"\nwidth = 8\nheight = 8\nspp = 1\n\
             [[schedulers]]\nkind = \"static\"\nchunk = \"rows:1\"\n",
            scene_path().display()
        ),
    )
    .unwrap();
    let out = run(
        &[
            "compare",
            "a",
            "b",
            "--interleave",
            "il.toml",
            "--rounds",
            "3",
            "--json",
        ],
        dir.path(),
    );
    assert_ok(&out);
    let err = String::from_utf8_lossy(&out.stderr);
    let order: Vec<&str> = err.lines().filter(|l| l.starts_with("round ")).collect();
    assert_eq!(
        order,
        [
            "round 1/3: A",
            "round 1/3: B",
            "round 2/3: B",
            "round 2/3: A",
            "round 3/3: A",
            "round 3/3: B"
        ]
    );
    for side in ["a", "b"] {
        let (rows, _) = read_runs(&dir.path().join(side).join("il/runs.csv")).unwrap();
        let mut reps: Vec<u32> = rows.iter().map(|r| r.repetition).collect();
        reps.sort_unstable();
        assert_eq!(
            reps,
            [0, 0, 1, 1, 2, 2],
            "{side}: serial and static, 3 runs each"
        );
    }
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let changes = v["changes"].as_array().unwrap();
    assert_eq!(changes.len(), 2);
    for c in changes {
        assert!(
            c["verdict"] == "equivalent" || c["verdict"] == "undecided",
            "{c}"
        );
    }
    let bad = run(
        &[
            "compare",
            "a",
            "b",
            "--interleave",
            "il.toml",
            "--env-b",
            "NOEQUALS",
        ],
        dir.path(),
    );
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--env-b"));
}
