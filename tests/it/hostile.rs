//! Hostile input, one test per class: sizes beyond the stated limits, values beyond f32,
//! broken mesh data and vector lengths, lossless scenes with unlimited depth, non-finite
//! results, write failures, concurrent runs and one-line messages. Each bad input must give a
//! one-line error naming the file and the field (or flag), no panic, no hang, no partial file.

use crate::support::assert_ok;
use raysched::limits::{
    MAX_DEPTH, MAX_GENERATOR_COUNT, MAX_IMAGE_SIDE, MAX_PIXELS, MAX_SPP, MAX_THREADS,
};
use raysched::scene::{load_scene_str, SceneError, SceneOverrides};
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const SCENE: &str = crate::support::sphere_scene_8x8!();

fn load(text: &str, base: &Path) -> Result<raysched::scene::Scene, SceneError> {
    load_scene_str(
        text,
        "hostile.toml",
        base,
        "hostile",
        &SceneOverrides::default(),
    )
}

/// `text` must fail to load with a one-line error naming `needle` (a field) and, when given,
/// `limit` (the stated bound).
fn assert_refused(what: &str, text: &str, needle: &str, limit: Option<String>) {
    let dir = tempfile::tempdir().unwrap();
    let t0 = Instant::now();
    let err = match load(text, dir.path()) {
        Ok(_) => panic!("{what}: loaded"),
        Err(e) => e.to_string(),
    };
    assert!(
        t0.elapsed() < Duration::from_secs(5),
        "{what}: took {:?}",
        t0.elapsed()
    );
    assert!(!err.contains('\n'), "{what}: not one line: {err}");
    assert!(
        err.starts_with("hostile.toml"),
        "{what}: file not named: {err}"
    );
    assert!(err.contains(needle), "{what}: '{needle}' not in: {err}");
    if let Some(l) = limit {
        assert!(err.contains(&l), "{what}: limit {l} not stated: {err}");
    }
}

fn raysched(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_raysched"))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap()
}

/// Exit code 2, one line on stderr containing every needle, no panic.
fn assert_bad_input(what: &str, out: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{what}: {stderr}");
    assert_eq!(
        stderr.trim_end().lines().count(),
        1,
        "{what}: not one line: {stderr}"
    );
    assert!(!stderr.contains("panicked"), "{what}: {stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{what}: '{n}' not in: {stderr}");
    }
}

#[test]
fn sizes_beyond_the_stated_limits_are_refused_before_anything_is_allocated() {
    let side = MAX_IMAGE_SIDE.to_string();
    let cases: Vec<(&str, String, &str, Option<String>)> = vec![
        (
            "width 4e9",
            SCENE.replace("width = 8", "width = 4000000000"),
            "camera.width",
            Some(side.clone()),
        ),
        (
            "height over",
            SCENE.replace("height = 8", &format!("height = {}", MAX_IMAGE_SIDE + 1)),
            "camera.height",
            Some(side),
        ),
        (
            "width × height",
            SCENE
                .replace("width = 8", "width = 60000")
                .replace("height = 8", "height = 60000"),
            "camera.width",
            Some(MAX_PIXELS.to_string()),
        ),
        (
            "pixels × frames",
            format!(
                "{}\n[animation]\nframes = 100000\n",
                SCENE.replace("width = 8", "width = 1000")
            ),
            "frames",
            Some(MAX_PIXELS.to_string()),
        ),
        (
            "spp",
            SCENE.replace("spp = 1", "spp = 4000000000"),
            "render.spp",
            Some(MAX_SPP.to_string()),
        ),
        (
            "generator count",
            SCENE.replace(
                "type = \"sphere\"\nmaterial = \"white\"\nradius = 1",
                &format!(
                    "type = \"random_triangles\"\nmaterial = \"white\"\ncount = {}",
                    MAX_GENERATOR_COUNT + 1
                ),
            ),
            "shapes[0].count",
            Some(MAX_GENERATOR_COUNT.to_string()),
        ),
        (
            "generator count u64 max",
            SCENE.replace(
                "type = \"sphere\"\nmaterial = \"white\"\nradius = 1",
                "type = \"sphere_grid\"\nmaterial = \"white\"\ncount = 9223372036854775807",
            ),
            "shapes[0].count",
            None,
        ),
        (
            "max_depth huge",
            SCENE.replace("spp = 1", "spp = 1\nmax_depth = 2147483647"),
            "render.max_depth",
            Some(MAX_DEPTH.to_string()),
        ),
    ];
    for (what, text, needle, limit) in cases {
        assert_refused(what, &text, needle, limit);
    }
}

#[test]
fn flags_beyond_the_stated_limits_name_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.toml"), SCENE).unwrap();
    let threads = MAX_THREADS.to_string();
    let cases: &[(&[&str], &[&str])] = &[
        (&["--threads", "100000000"], &["--threads", &threads]),
        (&["--threads", "-3"], &["--threads"]),
        (&["--threads", "0"], &["--threads"]),
        (&["--spp", "4000000000"], &["--spp"]),
        (
            &["--scheduler", "master", "--buffer", "99999999999"],
            &["--buffer", "1048576"],
        ),
        (&["--scheduler", "master", "--buffer", "-3"], &["--buffer"]),
        (&["--chunk", "4000000000x4000000000"], &["--chunk", "65536"]),
        (&["--chunk", "-5"], &["--chunk"]),
        (&["--local-threads", "99999999"], &["--local-threads"]),
        (
            &["--slow", "3:2", "--threads", "2"],
            &["--slow", "3 slowed workers of only 2"],
        ),
    ];
    for (flags, needles) in cases {
        let mut args = vec!["render", "s.toml", "-o", "o.exr"];
        args.extend_from_slice(flags);
        let out = raysched(&args, dir.path());
        assert_bad_input(&format!("{flags:?}"), &out, needles);
        assert!(!dir.path().join("o.exr").exists());
    }
}

/// A tiny scene and an experiment file around it, in `dir`.
fn experiment(dir: &Path, body: &str) -> std::path::PathBuf {
    std::fs::write(dir.join("s.toml"), SCENE).unwrap();
    let p = dir.join("e.toml");
    std::fs::write(&p, body).unwrap();
    p
}

const EXP_TAIL: &str =
    "[[scenes]]\npath = \"s.toml\"\n[[schedulers]]\nkind = \"static\"\nchunk = 8\n";

#[test]
fn experiment_counts_beyond_the_limits_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let big_list = (1..=2000)
        .map(|i| i.to_string())
        .collect::<Vec<_>>()
        .join(", ");
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "worker range",
            format!("workers = \"1..99999999999\"\n{EXP_TAIL}"),
            "workers",
        ),
        (
            "worker range max..huge",
            format!("workers = \"max..99999999999\"\n{EXP_TAIL}"),
            "workers",
        ),
        (
            "repetitions",
            format!("workers = [1]\nrepetitions = 4000000000\n{EXP_TAIL}"),
            "repetitions",
        ),
        (
            "warmup",
            format!("workers = [1]\nwarmup = 4000000000\n{EXP_TAIL}"),
            "warmup",
        ),
        (
            "grid product",
            format!(
                "workers = [1]\n[[scenes]]\npath = \"s.toml\"\n[[schedulers]]\nkind = \"master\"\n\
                 chunk = [{big_list}]\nbuffer = [{big_list}]\n"
            ),
            "schedulers[0]",
        ),
        (
            "scene override width",
            format!(
                "workers = [1]\n{}",
                EXP_TAIL.replace("path = \"s.toml\"", "path = \"s.toml\"\nwidth = 4000000000")
            ),
            "scenes[0].width",
        ),
        (
            "scene override generator count",
            format!(
                "workers = [1]\n{}",
                EXP_TAIL.replace("path = \"s.toml\"", "path = \"s.toml\"\nspp = 0")
            ),
            "scenes[0].spp",
        ),
    ];
    for (what, body, needle) in cases {
        let p = experiment(dir.path(), &body);
        let t0 = Instant::now();
        let err = match raysched::experiment::load_plan(&p) {
            Ok(_) => panic!("{what}: planned"),
            Err(e) => e.to_string(),
        };
        assert!(
            t0.elapsed() < Duration::from_secs(5),
            "{what}: {:?}",
            t0.elapsed()
        );
        assert!(!err.contains('\n'), "{what}: {err}");
        assert!(
            err.contains("e.toml") && err.contains(needle),
            "{what}: {err}"
        );
    }
}

#[test]
fn values_infinite_in_f32_are_errors_naming_the_field() {
    let cases: Vec<(&str, String, &str)> = vec![
        ("emission", SCENE.replace("radius = 1", "radius = 1\nemission = [1e39, 1, 1]"), "shapes[0].emission"),
        ("radius", SCENE.replace("radius = 1", "radius = 1e39"), "shapes[0].radius"),
        ("center", SCENE.replace("radius = 1", "radius = 1\ncenter = [0, -1e39, 0]"), "shapes[0].center"),
        ("ior", SCENE.replace("ior = 1.5", "ior = 1e39"), "materials.glass.ior"),
        ("origin", SCENE.replace("origin = [0, 0, 4]", "origin = [0, 0, 1e39]"), "camera.origin"),
        ("fov", SCENE.replace("fov_deg = 40", "fov_deg = 1e39"), "camera.fov_deg"),
        (
            "scale composed beyond f32",
            SCENE.replace("radius = 1", "radius = 1\ntransform = [{ scale = 1e30 }, { scale = 1e30 }]"),
            "shapes[0]",
        ),
        (
            "cube placed beyond f32",
            format!("{SCENE}\n[[shapes]]\ntype = \"cube\"\nmaterial = \"white\"\ntransform = [{{ translate = [1, 0, 0] }}, {{ scale = 1e30 }}, {{ scale = 1e30 }}]\n"),
            "shapes[1].transform",
        ),
        (
            "point light",
            format!("{SCENE}\n[[lights]]\ntype = \"point\"\nposition = [0, 0, -1e39]\nintensity = [1, 1, 1]\n"),
            "lights[0].position",
        ),
        (
            "environment",
            format!("{SCENE}\n[[lights]]\ntype = \"environment\"\nradiance = [1, 1e39, 1]\n"),
            "lights[0].radiance",
        ),
        ("nan still refused", SCENE.replace("reflectance = [0.8, 0.8, 0.8]", "reflectance = [0.8, nan, 0.8]"), "materials.white.reflectance"),
    ];
    for (what, text, needle) in cases {
        assert_refused(what, &text, needle, None);
    }
}

#[test]
fn obj_vertices_beyond_f32_and_vectors_of_the_wrong_length_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = |name: &str| {
        SCENE.replace(
            "radius = 1",
            &format!(
                "radius = 1\n[[shapes]]\ntype = \"mesh\"\nmaterial = \"white\"\npath = \"{name}\""
            ),
        )
    };
    for (name, obj) in [
        ("nan.obj", "v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n"),
        ("inf.obj", "v 0 0 0\nv 1 0 0\nv 0 1 inf\nf 1 2 3\n"),
        ("big.obj", "# big\nv 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n"),
    ] {
        std::fs::write(dir.path().join(name), obj).unwrap();
        let err = load(&mesh(name), dir.path())
            .err()
            .unwrap_or_else(|| panic!("{name}: loaded"))
            .to_string();
        assert!(!err.contains('\n'), "{err}");
        assert!(
            err.contains("shapes[1].path") && err.contains(name) && err.contains("line 3"),
            "{name}: {err}"
        );
    }
    let cases: Vec<(&str, String, &str)> = vec![
        ("origin 4", SCENE.replace("origin = [0, 0, 4]", "origin = [0, 0, 4, 5]"), "camera.origin"),
        ("origin 2", SCENE.replace("origin = [0, 0, 4]", "origin = [0, 4]"), "camera.origin"),
        ("up 4", SCENE.replace("up = [0, 1, 0]", "up = [0, 1, 0, 0]"), "camera.up"),
        ("colour 2", SCENE.replace("reflectance = [0.8, 0.8, 0.8]", "reflectance = [0.8, 0.8]"), "reflectance"),
        ("emission 4", SCENE.replace("radius = 1", "radius = 1\nemission = [1, 1, 1, 1]"), "shapes[0]"),
        ("center 2", SCENE.replace("radius = 1", "radius = 1\ncenter = [1, 1]"), "shapes[0]"),
        (
            "key origin 4",
            format!("{SCENE}\n[animation]\nframes = 2\n[[animation.keys]]\nframe = 1\norigin = [0, 0, 5, 1]\n"),
            "animation.keys[0].origin",
        ),
        (
            "matrix row 5",
            SCENE.replace("radius = 1", "radius = 1\nmatrix = [[1,0,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]"),
            "shapes[0]",
        ),
        (
            "light 4",
            format!("{SCENE}\n[[lights]]\ntype = \"point\"\nposition = [0, 0, 1, 2]\nintensity = [1, 1, 1]\n"),
            "lights",
        ),
    ];
    for (what, text, needle) in cases {
        assert_refused(what, &text, needle, None);
    }
}

#[test]
fn a_lossless_scene_with_unlimited_depth_terminates_at_the_stated_cap() {
    // Albedo 1 inside a closed emitting sphere: every segment adds radiance 1 and Russian
    // roulette never ends a path, so only the hard cap does.
    let text = "[camera]\norigin = [0, 0, 0]\ntarget = [0, 0, -1]\nup = [0, 1, 0]\nfov_deg = 90\n\
                width = 2\nheight = 2\n[render]\nspp = 2\nmax_depth = -1\n\
                [materials.white]\ntype = \"diffuse\"\nreflectance = [1, 1, 1]\n\
                [[shapes]]\ntype = \"sphere\"\nmaterial = \"white\"\nradius = 1\n\
                flip_normals = true\nemission = [1, 1, 1]\n";
    let scene = load(text, Path::new(".")).unwrap();
    let warning = scene
        .depth_warning()
        .expect("a lossless unlimited scene warns");
    assert!(warning.contains(&MAX_DEPTH.to_string()), "{warning}");
    let tracer = raysched::tracer::BruteTracer::new(&scene.geometry);
    let t0 = Instant::now();
    let mut rays = 0;
    let l = raysched::render::sample_pixel(&scene, &tracer, 0, 0, &mut rays);
    assert!(t0.elapsed() < Duration::from_secs(10));
    assert!(l.is_finite(), "{l}");
    // One unit of emission per segment, MAX_DEPTH segments (MIS splits each unit between
    // the light sample and the BSDF sample, so the sum is exact up to f32 rounding).
    let expected = MAX_DEPTH as f32;
    assert!(
        (l.x - expected).abs() < 0.01 * expected,
        "{l} vs {expected}"
    );
    assert!(rays <= 2 * MAX_DEPTH as u64 + 2, "{rays} rays");
    // A bounded depth gives no warning.
    let bounded = load(
        &text.replace("max_depth = -1", "max_depth = 8"),
        Path::new("."),
    )
    .unwrap();
    assert_eq!(bounded.depth_warning(), None);
}

/// A finished tiny experiment's results folder under `dir`.
fn measured_results(dir: &Path) -> std::path::PathBuf {
    let p = experiment(
        dir,
        &format!(
            "name = \"x\"\nworkers = [1, 2]\ntimeline = false\n{}",
            EXP_TAIL.replace("chunk = 8", "chunk = [1, 8]")
        ),
    );
    let out = raysched(
        &["run", p.to_str().unwrap(), "--out", "res", "--quiet"],
        dir,
    );
    assert_ok(&out);
    dir.join("res/x")
}

/// Wait for `child` at most `limit`; kill it and fail when it runs longer.
fn wait_bounded(mut child: std::process::Child, limit: Duration, what: &str) -> Output {
    let t0 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() > limit {
            child.kill().unwrap();
            panic!("{what}: still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

#[test]
fn plot_on_rows_holding_inf_and_nan_ends_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let res = measured_results(dir.path());
    let csv = std::fs::read_to_string(res.join("runs.csv")).unwrap();
    let mut lines: Vec<String> = csv.lines().map(str::to_string).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let (wall, speedup, imb) = (col("wall_s"), col("speedup"), col("imbalance"));
    for (row, (c, v)) in [
        (1, (wall, "inf")),
        (2, (speedup, "NaN")),
        (3, (imb, "-inf")),
        (4, (wall, "1e308")),
    ] {
        let mut cells: Vec<String> = lines[row].split(',').map(str::to_string).collect();
        cells[c] = v.to_string();
        lines[row] = cells.join(",");
    }
    std::fs::write(res.join("runs.csv"), lines.join("\n") + "\n").unwrap();
    let child = Command::new(env!("CARGO_BIN_EXE_raysched"))
        .args(["plot", res.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let out = wait_bounded(child, Duration::from_secs(60), "plot");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("4 row(s)") && stderr.contains("left out"),
        "{stderr}"
    );
    let report = std::fs::read_to_string(res.join("report.md")).unwrap();
    assert!(report.contains("4 row(s) of runs.csv"), "{report}");
}

#[test]
fn a_closed_stdout_ends_quietly_and_write_errors_are_one_line_without_partial_files() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.toml"), SCENE).unwrap();
    // `raysched render … | head -0`: the reader is gone before the report is printed.
    let mut child = Command::new(env!("CARGO_BIN_EXE_raysched"))
        .args(["render", "s.toml", "-o", "o.exr", "--threads", "1"])
        .current_dir(dir.path())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = wait_bounded(child, Duration::from_secs(60), "render into a closed pipe");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(stderr.is_empty(), "{stderr}");
    // An output folder that is a file: one line, exit 2 (checked before the render).
    std::fs::write(dir.path().join("file"), "").unwrap();
    let out = raysched(
        &["render", "s.toml", "-o", "file/o.exr", "--threads", "1"],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    // The preview's name is taken by a folder: neither the image nor the preview is written.
    std::fs::create_dir(dir.path().join("p.png")).unwrap();
    let out = raysched(
        &["render", "s.toml", "-o", "p.exr", "--threads", "1"],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(
        !dir.path().join("p.exr").exists(),
        "a partial set was written"
    );
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".raysched-staging"))
        .collect();
    assert!(left.is_empty(), "staging left behind: {left:?}");
}

#[test]
fn a_second_run_on_a_locked_results_folder_is_refused_and_a_stale_lock_is_taken() {
    let dir = tempfile::tempdir().unwrap();
    let p = experiment(
        dir.path(),
        &format!("name = \"x\"\nworkers = [1]\ntimeline = false\n{EXP_TAIL}"),
    );
    let lock = dir
        .path()
        .join("res/x")
        .join(raysched::experiment::lock::LOCK_FILE);
    std::fs::create_dir_all(lock.parent().unwrap()).unwrap();
    // This test's own process is alive: its pid holds the lock.
    std::fs::write(&lock, format!("{}\n", std::process::id())).unwrap();
    let out = raysched(
        &["run", p.to_str().unwrap(), "--out", "res", "--quiet"],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("another raysched run") && stderr.contains(".raysched.lock"),
        "{stderr}"
    );
    assert!(
        !dir.path().join("res/x/runs.csv").exists(),
        "the refused run wrote rows"
    );
    // A lock whose process is gone (no pid is above Linux's pid_max of 2²²) is taken over.
    std::fs::write(&lock, "99999999\n").unwrap();
    let out = raysched(
        &["run", p.to_str().unwrap(), "--out", "res", "--quiet"],
        dir.path(),
    );
    assert_ok(&out);
    assert!(!lock.exists(), "the lock outlived its run");
}

#[test]
fn every_message_is_one_line_and_names_the_right_field() {
    let dir = tempfile::tempdir().unwrap();
    // A TOML syntax error in an experiment: file:line:column, one line.
    let p = experiment(dir.path(), "name = \"x\"\nworkers = [1\nscenes = []\n");
    let err = raysched::experiment::load_plan(&p)
        .err()
        .unwrap()
        .to_string();
    assert!(!err.contains('\n'), "{err}");
    assert!(err.contains("e.toml:3:"), "{err}");
    let out = raysched(&["run", p.to_str().unwrap(), "--out", "res"], dir.path());
    assert_bad_input("experiment syntax", &out, &["e.toml:3:"]);
    // A wrong type names its key.
    let p = experiment(
        dir.path(),
        &format!("workers = [1]\nrepetitions = \"many\"\n{EXP_TAIL}"),
    );
    let err = raysched::experiment::load_plan(&p)
        .err()
        .unwrap()
        .to_string();
    assert!(
        err.contains("e.toml:2:") && err.contains("repetitions"),
        "{err}"
    );
    // An unknown shape type names `type`, whatever other fields the shape has.
    for extra in ["", "radius = 2\n", "path = \"a.obj\"\ncount = 3\n"] {
        let text = format!("{SCENE}\n[[shapes]]\ntype = \"torus\"\nmaterial = \"white\"\n{extra}");
        assert_refused(
            "unknown type",
            &text,
            "shapes[1].type: unknown shape type 'torus'",
            None,
        );
    }
    assert_refused(
        "type not a string",
        &format!("{SCENE}\n[[shapes]]\ntype = 3\nmaterial = \"white\"\n"),
        "shapes[1].type",
        None,
    );
    // A scene syntax error: file:line, one line.
    assert_refused(
        "scene syntax",
        &SCENE.replace("fov_deg = 40", "fov_deg = = 40"),
        "hostile.toml:6",
        None,
    );
    // A negative number after a flag names the flag, on the other commands too.
    std::fs::write(dir.path().join("s.toml"), SCENE).unwrap();
    for args in [
        &["converge", "s.toml", "--max-spp", "-4"][..],
        &["stability", "--threads", "-1"][..],
        &["stability", "--size", "-1"][..],
        &["render", "s.toml", "--spp", "-1"][..],
    ] {
        let out = raysched(args, dir.path());
        assert_bad_input(&format!("{args:?}"), &out, &[args[args.len() - 2]]);
    }
}
