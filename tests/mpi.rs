//! MPI compute sources under a real `mpirun` (feature `mpi`). Skipped, with a message, only when
//! `mpirun` is missing; CI installs OpenMPI, so CI runs them. Every mpirun has a deadline and
//! its whole process group is killed past it.
#![cfg(feature = "mpi")]

use raysched::render::render_serial;
use raysched::scene::{load_scene, SceneOverrides};
use raysched::tracer::AnyTracer;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const DEADLINE: Duration = Duration::from_secs(60);

/// One mpirun at a time: concurrent ones race on OpenMPI's session directory and, on 2 cores,
/// on CPU time.
static MPIRUN: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    MPIRUN.lock().unwrap_or_else(|e| e.into_inner())
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
    let tracer = AnyTracer::build("bvh", &scene, 1).unwrap();
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

#[test]
fn three_ranks_give_the_serial_image_for_every_scheduler_and_granularity() {
    if !have_mpirun() {
        return;
    }
    let _one = serial();
    let dir = tempfile::tempdir().unwrap();
    let path = scene(dir.path(), 24, 16, 4);
    let want = serial_hash(&path);
    let p = path.to_str().unwrap();
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
        let out_img = dir.path().join("out.pfm");
        let mut args = vec![p, "-o", out_img.to_str().unwrap()];
        args.extend_from_slice(case);
        let child = mpirun(dir.path(), 3, &[], &[], &args).spawn().unwrap();
        let o = finish(child, &case.join(" "));
        let (stdout, stderr) = text(&o);
        assert!(
            o.status.success(),
            "{case:?} failed\nstdout:\n{stdout}\nstderr:\n{stderr}"
        );
        assert_eq!(
            image_hash(&stdout).as_deref(),
            Some(want.as_str()),
            "{case:?}\n{stdout}"
        );
        assert!(
            stdout.contains("source 0 = mpi-rank-1") && stdout.contains("source 1 = mpi-rank-2"),
            "{stdout}"
        );
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
    if !have_mpirun() {
        return;
    }
    let _one = serial();
    let dir = tempfile::tempdir().unwrap();
    let path = scene(dir.path(), 48, 32, 48);
    let want = serial_hash(&path);
    let pids = dir.path().join("pids");
    std::fs::create_dir(&pids).unwrap();
    let out_img = dir.path().join("out.pfm");
    let args = [
        path.to_str().unwrap(),
        "-o",
        out_img.to_str().unwrap(),
        "--scheduler",
        "master",
        "--chunk",
        "4",
        "--buffer",
        "2",
        "--requeue",
        "timeout:300",
        "--deadline-ms",
        "50000",
    ];
    let env = [("RAYSCHED_MPI_PID_DIR", pids.to_str().unwrap())];
    let child = mpirun(dir.path(), 3, &["--enable-recovery"], &env, &args)
        .spawn()
        .unwrap();
    // Rank 1 writes its pid after its first result: it is mid-run when it dies.
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

#[test]
fn a_bad_scene_on_one_rank_is_a_clear_error_on_rank_0() {
    if !have_mpirun() {
        return;
    }
    let _one = serial();
    let dir = tempfile::tempdir().unwrap();
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
        stderr.contains("camera.width: must be ≥ 1"),
        "stderr:\n{stderr}"
    );
    assert_eq!(
        o.status.code(),
        Some(2),
        "an input error exits 2 through mpirun"
    );
}
