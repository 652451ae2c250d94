//! MPI compute sources under a real `mpirun` (feature `mpi`). Skipped, with a message, only when
//! `mpirun` is missing; CI installs OpenMPI, so CI runs them. Every mpirun has a deadline and
//! its whole process group is killed past it.
#![cfg(feature = "mpi")]

use crate::support::assert_ok;
use raysched::render::{render_serial, render_serial_frames, Image};
use raysched::scene::{load_scene, SceneOverrides};
use raysched::tracer::{AnyTracer, TracerKind};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const DEADLINE: Duration = Duration::from_secs(60);

/// One mpirun at a time: concurrent ones race on OpenMPI's session directory and, on 2 cores,
/// on CPU time.
static MPIRUN: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// How every test here starts: `None` (the test is skipped) without `mpirun`, else the turn
/// to run mpirun ([`MPIRUN`]) and a fresh folder.
fn mpi_test() -> Option<(std::sync::MutexGuard<'static, ()>, tempfile::TempDir)> {
    if !have_mpirun() {
        return None;
    }
    let turn = MPIRUN.lock().unwrap_or_else(|e| e.into_inner());
    Some((turn, tempfile::tempdir().unwrap()))
}

fn have_mpirun() -> bool {
    let ok = Command::new("mpirun")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        eprintln!("SKIPPED: `mpirun` not found (apt-get install openmpi-bin libopenmpi-dev)");
    }
    ok
}

/// A scene with a mesh, written to a fresh folder: the ranks get it only through the broadcast.
fn scene(dir: &Path, w: u32, h: u32, spp: u32) -> PathBuf {
    std::fs::write(
        dir.join("tri.obj"),
        "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let text = format!(
        r#"
[camera]
origin = [0, 0, 4]
target = [0, 0, 0]
up = [0, 1, 0]
fov_deg = 40
width = {w}
height = {h}
[render]
spp = {spp}
max_depth = 4
seed = 7
[materials.white]
type = "diffuse"
reflectance = [0.8, 0.8, 0.8]
[materials.red]
type = "diffuse"
reflectance = [0.8, 0.2, 0.2]
[[shapes]]
type = "sphere"
center = [0.8, 0, 0]
radius = 0.7
material = "white"
[[shapes]]
type = "mesh"
path = "tri.obj"
material = "red"
[[lights]]
type = "environment"
radiance = [1, 1, 1]
"#
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn serial_hash(path: &Path) -> String {
    let scene = load_scene(path, &SceneOverrides::default()).unwrap();
    let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
    format!("{:016x}", render_serial(&scene, &tracer).0.hash())
}

fn mpirun(
    session: &Path,
    ranks: usize,
    extra_mpirun: &[&str],
    env: &[(&str, &str)],
    args: &[&str],
) -> Command {
    let mut c = Command::new("mpirun");
    c.args(extra_mpirun).arg("-n").arg(ranks.to_string());
    for (k, v) in env {
        c.env(k, v).arg("-x").arg(k);
    }
    c.arg(env!("CARGO_BIN_EXE_raysched"))
        .arg("render")
        .args(args)
        .arg("--sources")
        .arg("mpi");
    c.env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("OMPI_MCA_rmaps_base_oversubscribe", "1")
        .env("OMPI_MCA_mpi_yield_when_idle", "1")
        .env("OMPI_MCA_btl", "self,vader")
        // A private session directory: no clash with other mpiruns on the machine.
        .env("OMPI_MCA_orte_tmpdir_base", session)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .process_group(0);
    c
}

/// Wait for `child` at most `DEADLINE`; past it, kill its process group and fail.
fn finish(mut child: Child, what: &str) -> Output {
    let end = Instant::now() + DEADLINE;
    while child.try_wait().unwrap().is_none() {
        if Instant::now() > end {
            let _ = Command::new("kill")
                .args(["-9", "--", &format!("-{}", child.id())])
                .status();
            let out = child.wait_with_output().unwrap();
            panic!(
                "{what}: mpirun still running after {DEADLINE:?}, killed\nstdout:\n{}\nstderr:\n{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn image_hash(stdout: &str) -> Option<String> {
    stdout
        .split("image hash ")
        .nth(1)
        .map(|s| s.split_whitespace().next().unwrap_or("").to_string())
}

/// `mpirun -n 3 raysched render SCENE -o OUT CASE…` must succeed with the image hash `want`;
/// returns its stdout for further checks.
fn render_matches(dir: &Path, scene: &Path, case: &[&str], want: &str) -> String {
    let out_img = dir.join("out.pfm");
    let mut args = vec![scene.to_str().unwrap(), "-o", out_img.to_str().unwrap()];
    args.extend_from_slice(case);
    let child = mpirun(dir, 3, &[], &[], &args).spawn().unwrap();
    let o = finish(child, &case.join(" "));
    let (stdout, stderr) = text(&o);
    assert!(
        o.status.success(),
        "{case:?} failed\nstdout:\n{stdout}\nstderr:\n{stderr}"
    );
    assert_eq!(
        image_hash(&stdout).as_deref(),
        Some(want),
        "{case:?}\n{stdout}"
    );
    stdout
}

/// The render of the fault tests: the master on 4² tiles, B = 2, a 50 s deadline, plus `extra`.
fn fault_args<'a>(scene: &'a Path, out: &'a Path, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--scheduler",
        "master",
        "--chunk",
        "4",
        "--buffer",
        "2",
        "--deadline-ms",
        "50000",
    ];
    args.extend_from_slice(extra);
    args
}

/// Wait (within the deadline) for rank 1 to write its pid into `pids`, then `kill -9` it.
fn kill_rank1(pids: &std::path::Path) {
    let pid_file = pids.join("rank1.pid");
    let end = Instant::now() + DEADLINE;
    let pid = loop {
        if let Some(pid) = std::fs::read_to_string(&pid_file)
            .ok()
            .filter(|s| !s.is_empty())
        {
            break pid;
        }
        assert!(Instant::now() < end, "rank 1 never wrote its pid");
        std::thread::sleep(Duration::from_millis(5));
    };
    assert!(Command::new("kill")
        .args(["-9", pid.trim()])
        .status()
        .unwrap()
        .success());
}

#[test]
fn three_ranks_give_the_serial_image_for_every_scheduler_and_granularity() {
    let Some((_one, dir)) = mpi_test() else {
        return;
    };
    let path = scene(dir.path(), 24, 16, 4);
    let want = serial_hash(&path);
    let cases: &[&[&str]] = &[
        &["--scheduler", "master", "--chunk", "1", "--buffer", "4"],
        &["--scheduler", "master", "--chunk", "8", "--buffer", "2"],
        &[
            "--scheduler",
            "master",
            "--chunk",
            "rows:3",
            "--buffer",
            "1",
            "--local-threads",
            "1",
        ],
        &["--scheduler", "static", "--chunk", "4"],
        &[
            "--scheduler",
            "self_scheduling",
            "--chunk",
            "4",
            "--grab",
            "2",
        ],
    ];
    for case in cases {
        let stdout = render_matches(dir.path(), &path, case, &want);
        assert!(
            stdout.contains("source 0 = mpi-rank-1") && stdout.contains("source 1 = mpi-rank-2"),
            "{stdout}"
        );
        // Each worker's statistics name its kind, which the per-kind CSV columns sum by: the
        // ranks are mpi, rank 0's own thread is threads.
        assert!(
            stdout.contains("worker 0 (mpi):") && stdout.contains("worker 1 (mpi):"),
            "{stdout}"
        );
        if case.contains(&"--local-threads") {
            assert!(stdout.contains("worker 2 (threads):"), "{stdout}");
        }
        // Under static both ranks must have rendered their band (under the master a slow rank
        // may legitimately see all its items re-issued and done elsewhere first).
        let is_static = case.contains(&"static");
        for w in stdout
            .lines()
            .filter(|l| l.trim_start().starts_with("worker "))
            .take(2)
            .filter(|_| is_static)
        {
            assert!(
                !w.contains("items 0 "),
                "{case:?}: a rank rendered nothing: {w}"
            );
        }
        if case.contains(&"--local-threads") {
            assert!(stdout.contains("source 2 = local-thread-2"), "{stdout}");
        }
    }
}

#[test]
fn a_rank_killed_mid_run_loses_no_work() {
    let Some((_one, dir)) = mpi_test() else {
        return;
    };
    let path = scene(dir.path(), 48, 32, 48);
    let want = serial_hash(&path);
    let pids = dir.path().join("pids");
    std::fs::create_dir(&pids).unwrap();
    let out_img = dir.path().join("out.pfm");
    let args = fault_args(&path, &out_img, &["--requeue", "timeout:300"]);
    let env = [("RAYSCHED_MPI_PID_DIR", pids.to_str().unwrap())];
    let child = mpirun(dir.path(), 3, &["--enable-recovery"], &env, &args)
        .spawn()
        .unwrap();
    // Rank 1 writes its pid after its first result: it is mid-run when it dies.
    kill_rank1(&pids);
    let o = finish(child, "kill test");
    let (stdout, stderr) = text(&o);
    assert_eq!(
        image_hash(&stdout).as_deref(),
        Some(want.as_str()),
        "stdout:\n{stdout}\nstderr:\n{stderr}"
    );
    assert!(
        stdout.contains("lost MPI rank 1"),
        "stdout:\n{stdout}\nstderr:\n{stderr}"
    );
    let lost: u64 = stdout
        .split("lost sources ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap();
    assert!(lost >= 1, "{stdout}");
}

/// An animated scene travels to the ranks with its camera path: whole frames and tiles cut
/// per frame give the serial film strip (every frame, its own camera and seed).
#[test]
fn three_ranks_render_an_animation_like_the_serial_frames() {
    let Some((_one, dir)) = mpi_test() else {
        return;
    };
    let still = scene(dir.path(), 16, 12, 2);
    let animated = std::fs::read_to_string(&still).unwrap()
        + "[animation]\nframes = 3\n[[animation.keys]]\nframe = 2\norigin = [0.4, 0.1, 3.5]\n";
    let path = dir.path().join("animated.toml");
    std::fs::write(&path, animated).unwrap();
    let scene = load_scene(&path, &SceneOverrides::default()).unwrap();
    assert_eq!(scene.frames(), 3);
    let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
    let frames = render_serial_frames(&scene, &tracer).0;
    assert_ne!(frames[0].hash(), frames[2].hash(), "the camera moves");
    let want = format!("{:016x}", Image::stack(frames).hash());
    for case in [
        ["--scheduler", "master", "--chunk", "frame", "--buffer", "1"],
        [
            "--scheduler",
            "self_scheduling",
            "--chunk",
            "4",
            "--grab",
            "3",
        ],
    ] {
        let stdout = render_matches(dir.path(), &path, &case, &want);
        assert!(stdout.contains("× 3 frames"), "{stdout}");
    }
}

#[test]
fn a_bad_scene_on_one_rank_is_a_clear_error_on_rank_0() {
    let Some((_one, dir)) = mpi_test() else {
        return;
    };
    let path = scene(dir.path(), 8, 8, 1);
    let out_img = dir.path().join("out.pfm");
    let args = [
        path.to_str().unwrap(),
        "-o",
        out_img.to_str().unwrap(),
        "--scheduler",
        "master",
    ];
    let child = mpirun(
        dir.path(),
        3,
        &[],
        &[("RAYSCHED_MPI_TEST_CORRUPT_RANK", "2")],
        &args,
    )
    .spawn()
    .unwrap();
    let o = finish(child, "bad scene on rank 2");
    let (stdout, stderr) = text(&o);
    assert!(!o.status.success(), "{stdout}");
    assert!(
        stderr.contains("rank 2") && stderr.contains("corrupted_on_purpose"),
        "stderr:\n{stderr}"
    );
    assert!(!out_img.exists());

    // A bad scene on rank 0 itself: an input error naming the field; the workers exit too.
    let bad = std::fs::read_to_string(&path)
        .unwrap()
        .replace("width = 8", "width = 0");
    std::fs::write(&path, bad).unwrap();
    let child = mpirun(dir.path(), 2, &[], &[], &args).spawn().unwrap();
    let o = finish(child, "bad scene on rank 0");
    let (_, stderr) = text(&o);
    assert!(!o.status.success());
    assert!(
        stderr.contains("camera.width: must be in 1..="),
        "stderr:\n{stderr}"
    );
    assert_eq!(
        o.status.code(),
        Some(2),
        "an input error exits 2 through mpirun"
    );
}

/// `mpirun -n ranks raysched run EXPERIMENT --out OUT` over the BTLs `btl`.
fn mpirun_run(session: &Path, ranks: usize, btl: &str, experiment: &Path, out: &Path) -> Command {
    let mut c = Command::new("mpirun");
    c.arg("-n")
        .arg(ranks.to_string())
        .arg(env!("CARGO_BIN_EXE_raysched"))
        .arg("run")
        .arg(experiment)
        .arg("--out")
        .arg(out)
        .arg("--quiet");
    c.env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("OMPI_MCA_rmaps_base_oversubscribe", "1")
        .env("OMPI_MCA_mpi_yield_when_idle", "1")
        .env("OMPI_MCA_btl", btl)
        .env("OMPI_MCA_btl_tcp_if_include", "lo")
        .env("OMPI_MCA_orte_tmpdir_base", session)
        .env_remove("RAYSCHED_MPI_TRANSPORT")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .process_group(0);
    c
}

/// A tiny MPI experiment beside `scene.toml` in `dir`, with `mpi` (its [mpi] table).
fn mpi_experiment(dir: &Path, mpi: &str) -> PathBuf {
    // Keys before "[mpi]" go to the top level.
    let (top, mpi) = match mpi.split_once("[mpi]") {
        Some((top, rest)) => (top.to_string(), format!("[mpi]{rest}")),
        None => (String::new(), mpi.to_string()),
    };
    let text = format!(
        r#"
{top}
name = "tiny_mpi"
repetitions = 1
ci_target = 0
min_sample_s = 0
[[scenes]]
path = "scene.toml"
[[schedulers]]
kind = "master"
chunk = ["1", "4"]
buffer = 2
[[schedulers]]
kind = "static"
chunk = "4"
{mpi}
"#
    );
    let path = dir.join("tiny_mpi.toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[derive(Debug, serde::Deserialize)]
struct Row {
    config: String,
    scheduler: String,
    workers: usize,
    repetition: u32,
    image_hash: String,
    identical: bool,
    sources: String,
    ranks: Option<usize>,
    transport: Option<String>,
    threads_items: Option<u64>,
    mpi_items: Option<u64>,
}

fn rows(path: &Path) -> Vec<Row> {
    csv::Reader::from_path(path)
        .unwrap()
        .deserialize()
        .collect::<Result<_, _>>()
        .unwrap()
}

#[test]
fn mpirun_raysched_run_appends_mpi_rows_per_transport_beside_the_local_baseline() {
    let Some((_one, dir)) = mpi_test() else {
        return;
    };
    let scene_path = scene(dir.path(), 16, 12, 2);
    let want = serial_hash(&scene_path);
    let exp = mpi_experiment(
        dir.path(),
        "[mpi]\nranks = 3\ntransports = [\"shared_memory\", \"tcp_loopback\"]",
    );
    let out = dir.path().join("out");
    let runs = out.join("tiny_mpi/runs.csv");
    for (btl, transport, total) in [
        ("self,vader", "shared_memory", 7),
        ("self,tcp", "tcp_loopback", 10),
    ] {
        let child = mpirun_run(dir.path(), 3, btl, &exp, &out).spawn().unwrap();
        let o = finish(child, transport);
        let (stdout, stderr) = text(&o);
        assert!(
            o.status.success(),
            "{transport}\nstdout:\n{stdout}\nstderr:\n{stderr}"
        );
        let rs = rows(&runs);
        // serial + 3 local-thread (2 threads) + 3 MPI rows per launch so far, none twice.
        assert_eq!(rs.len(), total, "{transport}: {rs:#?}");
        let mut keys: Vec<(&str, u32)> = rs
            .iter()
            .map(|r| (r.config.as_str(), r.repetition))
            .collect();
        keys.sort();
        keys.dedup();
        assert_eq!(keys.len(), total, "a (config, repetition) appears twice");
        for r in &rs {
            assert!(
                r.identical && r.image_hash == want,
                "{r:?} vs serial {want}"
            );
        }
        let mpi: Vec<&Row> = rs
            .iter()
            .filter(|r| r.transport.as_deref() == Some(transport))
            .collect();
        assert_eq!(mpi.len(), 3, "{transport}: {rs:#?}");
        assert!(mpi
            .iter()
            .all(|r| r.sources == "mpi" && r.ranks == Some(3) && r.workers == 2));
        // Who rendered what is summed per kind: the ranks' items under mpi, none under threads.
        assert!(
            mpi.iter()
                .all(|r| r.mpi_items.is_some_and(|n| n > 0) && r.threads_items.is_none()),
            "{transport}: {mpi:#?}"
        );
        let local: Vec<&Row> = rs
            .iter()
            .filter(|r| r.sources == "local" && r.scheduler != "serial")
            .collect();
        assert_eq!(local.len(), 3);
        assert!(local
            .iter()
            .all(|r| r.workers == 2 && r.ranks == Some(3) && r.transport.is_none()));
    }
    let report = std::fs::read_to_string(out.join("tiny_mpi/report.md")).unwrap();
    assert!(
        report.contains("## MPI ranks vs local threads") && report.contains("tcp_loopback"),
        "{report}"
    );
    let plot = |d: &Path| {
        std::fs::read_dir(d.join("plots"))
            .unwrap()
            .filter_map(|e| e.ok())
            .any(|e| {
                e.file_name()
                    .to_string_lossy()
                    .starts_with("mpi_throughput_")
                    && e.path().extension().is_some_and(|x| x == "png")
            })
    };
    assert!(plot(&out.join("tiny_mpi")));
    // `raysched plot` redraws it from the CSV alone.
    std::fs::remove_dir_all(out.join("tiny_mpi/plots")).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_raysched"))
        .arg("plot")
        .arg(out.join("tiny_mpi"))
        .output()
        .unwrap();
    assert_ok(&o);
    assert!(plot(&out.join("tiny_mpi")));
}

#[test]
fn bad_mpi_experiments_are_clear_errors_naming_file_and_field() {
    let Some((_one, dir)) = mpi_test() else {
        return;
    };
    scene(dir.path(), 8, 8, 1);
    let out = dir.path().join("out");
    let bin = env!("CARGO_BIN_EXE_raysched");
    // Without mpirun, and plan-level mistakes (no mpirun needed to find them).
    let cases = [
        (
            "[mpi]\nranks = 3\ntransports = [\"shared_memory\"]",
            "tiny_mpi.toml: mpi: this experiment needs `mpirun",
        ),
        (
            "[mpi]\nranks = [1, 3]\ntransports = [\"shared_memory\"]",
            "tiny_mpi.toml: mpi.ranks: must be between 2",
        ),
        (
            "[mpi]\nranks = 3\ntransports = []",
            "tiny_mpi.toml: mpi.transports: must list",
        ),
        (
            "[mpi]\nranks = 3\ntransports = [\"shared_memory\"]\nsilence_ms = 10",
            "tiny_mpi.toml: mpi.silence_ms: must be ≥ 1000",
        ),
        (
            "workers = 2\n[mpi]\nranks = 3\ntransports = [\"shared_memory\"]",
            "tiny_mpi.toml: workers: set by mpi.ranks",
        ),
        (
            "[mpi]\nranks = 3\ntransports = [\"shared_memory\"]\n[[schedulers]]\nkind = \"master\"\nchunk = \"1\"\nreturns = [\"item\", \"hand_out\"]",
            "tiny_mpi.toml: schedulers[2].returns: hand_out: MPI ranks hand their results back item by item",
        ),
        (
            "[mpi]\nranks = 3\ntransports = [\"shared_memory\"]\n[[schedulers]]\nkind = \"master\"\nchunk = \"1\"\npasses = \"workers\"",
            "tiny_mpi.toml: schedulers[2].passes: workers: MPI ranks need the master's own thread",
        ),
    ];
    for (mpi, want) in cases {
        let exp = mpi_experiment(dir.path(), mpi);
        let o = Command::new(bin)
            .arg("run")
            .arg(&exp)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{mpi}: {stderr}");
        assert!(stderr.contains(want), "{mpi}:\n{stderr}");
    }
    // Under mpirun: a launch size the experiment does not list, a transport it does not list.
    let exp = mpi_experiment(
        dir.path(),
        "[mpi]\nranks = 3\ntransports = [\"tcp_loopback\"]",
    );
    for (ranks, want) in [
        (
            2,
            "tiny_mpi.toml: mpi.ranks: started with 2 ranks, but the experiment lists [3]",
        ),
        (
            3,
            "tiny_mpi.toml: mpi.transports: this launch's transport is 'shared_memory'",
        ),
    ] {
        let child = mpirun_run(dir.path(), ranks, "self,vader", &exp, &out)
            .spawn()
            .unwrap();
        let o = finish(child, want);
        let (_, stderr) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains(want), "{stderr}");
    }
    assert!(!out.join("tiny_mpi/runs.csv").exists());
}

/// A rank on another host cannot be checked by pid: with the pid check off, a killed rank is
/// still found within seconds (a failed MPI call or a missed heartbeat), and a slow rank that
/// keeps sending heartbeats is not taken for dead.
#[test]
fn a_remote_rank_is_found_dead_in_seconds_and_a_slow_one_is_not() {
    let Some((_one, dir)) = mpi_test() else {
        return;
    };
    let path = scene(dir.path(), 32, 16, 8);
    let want = serial_hash(&path);
    let out_img = dir.path().join("out.pfm");
    // The master must re-queue the killed rank's items to finish the image.
    let args = fault_args(&path, &out_img, &["--requeue", "revisit"]);
    for kill in [false, true] {
        let pids = dir.path().join(format!("pids{kill}"));
        std::fs::create_dir(&pids).unwrap();
        let env = [
            ("RAYSCHED_MPI_PID_DIR", pids.to_str().unwrap()),
            ("RAYSCHED_MPI_NO_PID_CHECK", "1"),
            // Shorter than the 2 s stall of the slow rank: only heartbeats keep it alive.
            ("RAYSCHED_MPI_SILENCE_MS", "1000"),
        ];
        let child = mpirun(dir.path(), 3, &["--enable-recovery"], &env, &args)
            .spawn()
            .unwrap();
        let mut killed_at = None;
        if kill {
            kill_rank1(&pids);
            killed_at = Some(Instant::now());
        }
        let o = finish(child, if kill { "remote kill" } else { "slow rank" });
        let (stdout, stderr) = text(&o);
        assert_eq!(
            image_hash(&stdout).as_deref(),
            Some(want.as_str()),
            "kill={kill}\nstdout:\n{stdout}\nstderr:\n{stderr}"
        );
        assert_eq!(
            stdout.contains("lost MPI rank 1"),
            kill,
            "kill={kill}\nstdout:\n{stdout}\nstderr:\n{stderr}"
        );
        if let Some(t) = killed_at {
            // Was 60 s of silence before heartbeats.
            assert!(
                t.elapsed() < Duration::from_secs(20),
                "took {:?}",
                t.elapsed()
            );
        }
    }
}
