//! Fuzz-style property tests: scene and experiment texts, random in structure or mutated from
//! the shipped files of scenes/ and experiments/ (byte flips, deleted, duplicated and swapped
//! lines, hostile numbers, wrong types), go through the library's loaders (and loaded scenes
//! through a tracer build and one sample). None may panic, and every error is one line.
//! Model files (OBJ, ASCII and binary PLY, glTF binary) are mutated byte by byte and line by
//! line and loaded as a scene's mesh the same way.
//! Random flags go through the binary the same way, and so do results folders whose files
//! were mutated, through `plot` and `compare`.
//!
//! `cargo test` runs a bounded number of cases. Longer runs:
//!
//! ```sh
//! RAYSCHED_FUZZ_CASES=100000 cargo test --release --test it fuzz:: -- --nocapture
//! RAYSCHED_FUZZ_SECS=600 cargo test --release --test it fuzz:: -- --nocapture  # 10 minutes
//! ```
//!
//! With `RAYSCHED_FUZZ_SECS` each property runs batches of cases until that time has passed
//! (split between the properties); the number of cases run is printed.

use crate::support::GREY_M;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestRunner};
use raysched::scene::{load_scene_str, SceneOverrides};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Values a hostile user types: beyond every limit, beyond f32, negative, NaN, wrong types.
const HOSTILE: &[&str] = &[
    "0",
    "-1",
    "-3",
    "1",
    "2",
    "nan",
    "inf",
    "-inf",
    "1e39",
    "-1e39",
    "1e308",
    "1e-320",
    "0.5",
    "65536",
    "65537",
    "33554433",
    "1048577",
    "16777217",
    "4294967296",
    "9223372036854775807",
    "-9223372036854775808",
    "\"x\"",
    "\"\"",
    "\"max\"",
    "\"1..99999999999\"",
    "\"frame\"",
    "\"rows:0\"",
    "\"0x0\"",
    "\"99999999x99999999\"",
    "true",
    "[]",
    "[1, 2]",
    "[1, 2, 3, 4]",
    "[nan, inf, 1e39]",
    "[0, 0, 0]",
    "[[1, 2], [3]]",
    "{ a = 1 }",
    "{ translate = [1e39, 0, 0] }",
    "[{ scale = 1e30 }, { scale = 1e30 }]",
];

/// Keys of both file formats, to build texts of random structure.
const KEYS: &[&str] = &[
    "origin",
    "target",
    "up",
    "fov_deg",
    "width",
    "height",
    "spp",
    "max_depth",
    "seed",
    "type",
    "material",
    "emission",
    "transform",
    "matrix",
    "center",
    "radius",
    "flip_normals",
    "path",
    "count",
    "displacement",
    "triangle_size",
    "reflectance",
    "checker",
    "ior",
    "position",
    "intensity",
    "radiance",
    "frames",
    "frame",
    "name",
    "workers",
    "repetitions",
    "warmup",
    "tracers",
    "timeline",
    "kind",
    "chunk",
    "order",
    "buffer",
    "grab",
    "guided_k",
    "requeue",
    "wait",
    "max_spp",
    "ref_spp",
    "ranks",
    "transports",
    "silence_ms",
    "generator_count",
];

const HEADERS: &[&str] = &[
    "",
    "[camera]",
    "[render]",
    "[materials.m]",
    "[[shapes]]",
    "[[lights]]",
    "[animation]",
    "[[animation.keys]]",
    "[[scenes]]",
    "[[schedulers]]",
    "[mpi]",
];

/// One edit of a text.
#[derive(Clone, Debug)]
enum Mutation {
    FlipByte(usize, u8),
    DeleteLine(usize),
    DuplicateLine(usize),
    SwapLines(usize, usize),
    /// Replace the value of the line's `key = value` by a hostile one.
    Value(usize, &'static str),
    /// Insert `key = value` before a line.
    Insert(usize, &'static str, &'static str),
    Truncate(usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let idx = any::<usize>();
    prop_oneof![
        1 => (idx, any::<u8>()).prop_map(|(i, b)| Mutation::FlipByte(i, b)),
        1 => idx.prop_map(Mutation::DeleteLine),
        1 => idx.prop_map(Mutation::DuplicateLine),
        1 => (idx, idx).prop_map(|(a, b)| Mutation::SwapLines(a, b)),
        4 => (idx, prop::sample::select(HOSTILE)).prop_map(|(i, v)| Mutation::Value(i, v)),
        2 => (idx, prop::sample::select(KEYS), prop::sample::select(HOSTILE))
            .prop_map(|(i, k, v)| Mutation::Insert(i, k, v)),
        1 => idx.prop_map(Mutation::Truncate),
    ]
}

fn apply(text: &[u8], m: &Mutation) -> Vec<u8> {
    let mut lines: Vec<Vec<u8>> = text.split(|&b| b == b'\n').map(<[u8]>::to_vec).collect();
    let n = lines.len().max(1);
    match *m {
        Mutation::FlipByte(i, b) => {
            let mut t = text.to_vec();
            if !t.is_empty() {
                let i = i % t.len();
                t[i] = b;
            }
            return t;
        }
        Mutation::DeleteLine(i) => {
            if !lines.is_empty() {
                lines.remove(i % n);
            }
        }
        Mutation::DuplicateLine(i) => {
            if !lines.is_empty() {
                let l = lines[i % n].clone();
                lines.insert(i % n, l);
            }
        }
        Mutation::SwapLines(a, b) => {
            if !lines.is_empty() {
                lines.swap(a % n, b % n);
            }
        }
        Mutation::Value(i, v) => {
            // The i-th `key = value` line (counting only such lines).
            let with_value: Vec<usize> = (0..lines.len())
                .filter(|&k| lines[k].contains(&b'=') && !lines[k].starts_with(b"#"))
                .collect();
            if !with_value.is_empty() {
                let k = with_value[i % with_value.len()];
                let eq = lines[k].iter().position(|&b| b == b'=').expect("has =");
                let mut l = lines[k][..=eq].to_vec();
                l.push(b' ');
                l.extend_from_slice(v.as_bytes());
                lines[k] = l;
            }
        }
        Mutation::Insert(i, k, v) => {
            let at = i % (lines.len() + 1);
            lines.insert(at, format!("{k} = {v}").into_bytes());
        }
        Mutation::Truncate(i) => {
            let mut t = text.to_vec();
            t.truncate(i % (text.len() + 1));
            return t;
        }
    }
    lines.join(&b'\n')
}

/// A text of random structure: headers and `key = value` lines drawn from both formats.
fn random_text() -> impl Strategy<Value = Vec<u8>> {
    let line = prop_oneof![
        prop::sample::select(HEADERS).prop_map(str::to_string),
        (prop::sample::select(KEYS), prop::sample::select(HOSTILE))
            .prop_map(|(k, v)| format!("{k} = {v}")),
    ];
    prop::collection::vec(line, 0..40).prop_map(|l| l.join("\n").into_bytes())
}

/// Shipped files (`dir` of the repository), made cheap to load: the 1 M-triangle generator
/// counts shrunk, so a case takes milliseconds.
fn shipped(dir: &str) -> Vec<(String, Vec<u8>)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let mut out: Vec<(String, Vec<u8>)> = std::fs::read_dir(&root)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            let cheap: String = text
                .lines()
                .map(|l| {
                    let key = l.split('=').next().unwrap_or("").trim();
                    if key == "count" || key == "generator_count" {
                        format!("{key} = 300")
                    } else {
                        l.to_string()
                    }
                })
                .collect::<Vec<_>>()
                .join("\n");
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                cheap.into_bytes(),
            )
        })
        .collect();
    out.sort();
    out
}

/// A text: a shipped file with 1 or 2 mutations, or one of random structure.
fn text_from(files: Vec<(String, Vec<u8>)>) -> impl Strategy<Value = Vec<u8>> {
    let files: Vec<Vec<u8>> = files.into_iter().map(|(_, t)| t).collect();
    prop_oneof![
        4 => (prop::sample::select(files), prop::collection::vec(mutation(), 1..3)).prop_map(
            |(base, ms)| ms.iter().fold(base, |t, m| apply(&t, m))
        ),
        1 => random_text(),
    ]
}

/// How many cases, or for how long: see the module docs. `share` splits a time budget.
fn budget(default_cases: u32, share: u32) -> (u32, Option<Duration>) {
    let secs = std::env::var("RAYSCHED_FUZZ_SECS")
        .ok()
        .and_then(|s| s.parse::<u64>().ok());
    let cases = std::env::var("RAYSCHED_FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse::<u32>().ok())
        .unwrap_or(default_cases);
    (cases, secs.map(|s| Duration::from_secs(s / share as u64)))
}

/// Run `test` over `strategy` in batches of `cases` until `time` (if any) has passed; returns
/// the number of cases run.
fn fuzz<S: Strategy>(
    what: &str,
    strategy: S,
    (cases, time): (u32, Option<Duration>),
    test: impl Fn(S::Value) -> Result<(), TestCaseError>,
) -> u64 {
    let t0 = Instant::now();
    let mut total = 0u64;
    let mut batch = 0u64;
    loop {
        let config = Config {
            cases,
            failure_persistence: None,
            // A different stream per batch; each batch is reproducible from its number.
            rng_algorithm: proptest::test_runner::RngAlgorithm::ChaCha,
            ..Config::default()
        };
        let seed: [u8; 32] = std::array::from_fn(|i| (batch >> (8 * (i % 8))) as u8 ^ i as u8);
        let rng = proptest::test_runner::TestRng::from_seed(
            proptest::test_runner::RngAlgorithm::ChaCha,
            &seed,
        );
        let mut runner = TestRunner::new_with_rng(config, rng);
        if let Err(e) = runner.run(&strategy, &test) {
            panic!("{what}: batch {batch}: {e}");
        }
        total += cases as u64;
        batch += 1;
        if time.is_none_or(|t| t0.elapsed() >= t) {
            break;
        }
    }
    eprintln!(
        "fuzz {what}: {total} cases in {:.1} s, 0 panics",
        t0.elapsed().as_secs_f64()
    );
    total
}

/// `f` must not panic; its error, if any, must be one line.
fn no_panic_one_line<T, E: std::fmt::Display>(
    what: &str,
    text: &[u8],
    f: impl FnOnce() -> Result<T, E>,
) -> Result<Option<T>, TestCaseError> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Err(_) => Err(TestCaseError::fail(format!(
            "{what} panicked on:\n{}",
            String::from_utf8_lossy(text)
        ))),
        Ok(Err(e)) => {
            let msg = e.to_string();
            if msg.contains('\n') || msg.is_empty() {
                Err(TestCaseError::fail(format!(
                    "{what}: not one line: {msg:?}"
                )))
            } else {
                Ok(None)
            }
        }
        Ok(Ok(v)) => Ok(Some(v)),
    }
}

/// One sample of each of `pixels` of a loaded `scene` (from input `text`), without a panic.
fn renders(
    scene: &raysched::scene::Scene,
    pixels: impl IntoIterator<Item = u32>,
    text: &[u8],
) -> Result<(), TestCaseError> {
    no_panic_one_line("render", text, || {
        let tracer = raysched::tracer::BvhTracer::new(&scene.geometry);
        let mut rays = 0;
        for p in pixels {
            let _ = raysched::render::sample_pixel(scene, &tracer, p, 0, &mut rays);
        }
        Ok::<_, String>(())
    })
    .map(|_| ())
}

/// The shipped scenes beside their (shrunk) copies, so mesh paths and `../scenes` resolve.
fn scratch() -> (tempfile::TempDir, PathBuf, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let scenes = dir.path().join("scenes");
    let exps = dir.path().join("experiments");
    std::fs::create_dir_all(&scenes).unwrap();
    std::fs::create_dir_all(&exps).unwrap();
    for (name, text) in shipped("scenes") {
        std::fs::write(scenes.join(name), text).unwrap();
    }
    (dir, scenes, exps)
}

#[test]
fn scene_texts_never_panic_and_every_error_is_one_line() {
    let (_dir, scenes, _) = scratch();
    let strategy = text_from(shipped("scenes"));
    let loaded_ok = AtomicU64::new(0);
    fuzz("scenes", strategy, budget(200, 3), |bytes| {
        let text = String::from_utf8_lossy(&bytes).into_owned();
        let over = SceneOverrides::default();
        let loaded = no_panic_one_line("load_scene_str", &bytes, || {
            load_scene_str(&text, "fuzz.toml", &scenes, "fuzz", &over)
        })?;
        if let Some(scene) = loaded {
            loaded_ok.fetch_add(1, Ordering::Relaxed);
            // A scene that loads renders: its first and last pixel, one sample each.
            renders(&scene, [0, scene.pixel_count() as u32 - 1], &bytes)?;
        }
        Ok(())
    });
    eprintln!("fuzz scenes: {} texts loaded", loaded_ok.into_inner());
}

#[test]
fn experiment_texts_never_panic_and_every_error_is_one_line() {
    let (_dir, _, exps) = scratch();
    let strategy = text_from(shipped("experiments"));
    let path = exps.join("fuzz.toml");
    let planned = AtomicU64::new(0);
    fuzz("experiments", strategy, budget(100, 3), |bytes| {
        std::fs::write(&path, &bytes).unwrap();
        let plan = no_panic_one_line("load_plan", &bytes, || {
            raysched::experiment::load_plan(&path)
        })?;
        if plan.is_some() {
            planned.fetch_add(1, Ordering::Relaxed);
        }
        Ok(())
    });
    eprintln!("fuzz experiments: {} texts planned", planned.into_inner());
}

#[test]
fn random_flags_exit_0_or_2_with_one_line_errors() {
    let dir = tiny_scene_dir();
    const FLAGS: &[&str] = &[
        "--threads",
        "--spp",
        "--chunk",
        "--buffer",
        "--grab",
        "--guided-k",
        "--order",
        "--scheduler",
        "--requeue",
        "--wait",
        "--tracer",
        "--deadline-ms",
        "--local-threads",
        "--slow",
        "--passes",
        "--returns",
        "--weights",
        "--fsc-warm",
        "--sources",
        "--gpu-chunk",
        "--gpu-buffer",
    ];
    let (cases, time) = budget(128, 3);
    let flag = (prop::sample::select(FLAGS), prop::sample::select(HOSTILE));
    fuzz(
        "flags",
        prop::collection::vec(flag, 1..3),
        (cases.div_ceil(8), time),
        |flags| {
            exits_0_or_2_in_one_line(
                &dir,
                &["render", "s.toml", "-o", "o.exr", "--threads", "1"],
                &flags,
            )
        },
    );
}

/// A small OBJ of every statement kind the loader reads: positions, texture coordinates,
/// normals, faces with and without them, negative indices, a polygon, groups and a material
/// library that is not there.
const OBJ: &str = "mtllib none.mtl\no cube\nv -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\n\
                   v -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 -1\n\
                   vn 0 0 1\ng front\nusemtl red\nf 1/1/1 2/2/1 3/3/1\nf 1//1 3//1 4//1\n\
                   g back\nf -4 -3 -2 -1\nf 5/1 6/2 7/3\ns off\nf 1 5 8 4\n";

/// A small ASCII PLY: a quad with per-vertex normals and a triangle fan face.
const PLY: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n\
                   property float y\nproperty float z\nproperty float nx\nproperty float ny\n\
                   property float nz\nelement face 2\nproperty list uchar int vertex_indices\n\
                   end_header\n0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n\
                   4 0 1 2 3\n";

/// Model files mutated (the OBJ and ASCII PLY above, the shipped binary PLY and glTF binary
/// of `scenes/models/`) go through the scene loader as a mesh of a scene that uses nothing
/// else: none may panic, every error is one line, and a model that loads renders.
#[test]
fn model_files_never_panic_and_every_error_is_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/models");
    let bases: Vec<(&str, &str, Vec<u8>)> = vec![
        ("mesh", "obj", OBJ.as_bytes().to_vec()),
        ("ply", "ply", PLY.as_bytes().to_vec()),
        (
            "ply",
            "ply",
            std::fs::read(models.join("wuson.ply")).unwrap(),
        ),
        (
            "gltf",
            "glb",
            std::fs::read(models.join("wuson.glb")).unwrap(),
        ),
    ];
    let strategy = (
        0..bases.len(),
        prop::collection::vec(
            prop_oneof![
                3 => (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Mutation::FlipByte(i, b)),
                1 => any::<usize>().prop_map(Mutation::DeleteLine),
                1 => any::<usize>().prop_map(Mutation::DuplicateLine),
                1 => (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::SwapLines(a, b)),
                1 => any::<usize>().prop_map(Mutation::Truncate),
            ],
            1..4,
        ),
    );
    let loaded_ok = AtomicU64::new(0);
    fuzz("models", strategy, budget(64, 1), |(k, ms)| {
        let (kind, ext, base) = &bases[k];
        let bytes = ms.iter().fold(base.clone(), |t, m| apply(&t, m));
        let name = format!("model.{ext}");
        std::fs::write(dir.path().join(&name), &bytes).unwrap();
        let text = tiny_scene(6, &format!("type = \"{kind}\"\npath = \"{name}\"\n"));
        let over = SceneOverrides::default();
        let shown = format!("{name} (mutated {ext}, {} bytes)", bytes.len());
        let loaded = no_panic_one_line("load_scene_str", shown.as_bytes(), || {
            load_scene_str(&text, "fuzz.toml", dir.path(), "fuzz", &over)
        })?;
        if let Some(scene) = loaded {
            loaded_ok.fetch_add(1, Ordering::Relaxed);
            renders(&scene, 0..scene.pixel_count() as u32, shown.as_bytes())?;
        }
        Ok(())
    });
    eprintln!("fuzz models: {} models loaded", loaded_ok.into_inner());
}

/// `advise` and `profile` with random flags and hostile values on a 4×4 scene: exit 0 or 2
/// (1 for a run-time failure), never a panic, every error one line.
#[test]
fn advise_and_profile_flags_exit_0_or_2_with_one_line_errors() {
    let dir = tiny_scene_dir();
    const ADVISE: &[&str] = &[
        "--workers",
        "--scheduler",
        "--chunks",
        "--buffer",
        "--passes",
        "--sources",
        "--slow",
        "--spp",
        "--probe-spp",
        "--tracer",
        "--tolerance-pct",
    ];
    const PROFILE: &[&str] = &["--spp", "--tracer", "--chunks", "--repeats"];
    let (cases, time) = budget(64, 3);
    let command = prop_oneof![
        prop::collection::vec(
            (prop::sample::select(ADVISE), prop::sample::select(HOSTILE)),
            1..3
        )
        .prop_map(|f| ("advise", f)),
        prop::collection::vec(
            (prop::sample::select(PROFILE), prop::sample::select(HOSTILE)),
            1..3
        )
        .prop_map(|f| ("profile", f)),
    ];
    fuzz(
        "advise/profile flags",
        command,
        (cases.div_ceil(8), time),
        |(sub, flags)| {
            let base: &[&str] = if sub == "advise" {
                &["advise", "s.toml", "--probe-spp", "1", "--spp", "1"]
            } else {
                &["profile", "s.toml", "-o", "p.png", "--repeats", "1"]
            };
            exits_0_or_2_in_one_line(&dir, base, &flags)
        },
    );
}

/// A 4×4 scene at 1 spp seen from (0, 0, `z`): one shape of material `m` (grey diffuse),
/// `shape` its keys besides `material`.
fn tiny_scene(z: u32, shape: &str) -> String {
    format!(
        "[camera]\norigin = [0, 0, {z}]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov_deg = 40\n\
         width = 4\nheight = 4\n[render]\nspp = 1\n{GREY_M}[[shapes]]\nmaterial = \"m\"\n{shape}"
    )
}

/// A temporary folder holding `s.toml`, a 4×4 scene of one sphere at 1 spp.
fn tiny_scene_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(4, "type = \"sphere\"\nradius = 1\n");
    std::fs::write(dir.path().join("s.toml"), scene).unwrap();
    dir
}

/// The binary run in `dir` with `base` arguments and `flags`: exit 0, 2 (bad input) or 1 (a
/// run-time failure), never a panic, and an error on one line.
fn exits_0_or_2_in_one_line(
    dir: &tempfile::TempDir,
    base: &[&str],
    flags: &[(&str, &str)],
) -> Result<(), TestCaseError> {
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_raysched"));
    cmd.current_dir(dir.path()).args(base);
    for (f, v) in flags {
        cmd.arg(f).arg(v.trim_matches('"'));
    }
    let out = cmd.output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let code = out.status.code();
    prop_assert!(
        code == Some(0) || code == Some(2) || code == Some(1),
        "{base:?} {flags:?}: exit {code:?}: {stderr}"
    );
    prop_assert!(!stderr.contains("panicked"), "{base:?} {flags:?}: {stderr}");
    if code != Some(0) {
        prop_assert_eq!(
            stderr.trim_end().lines().count(),
            1,
            "{:?} {:?}: {}",
            base,
            flags,
            stderr
        );
    }
    Ok(())
}

/// The results files `plot` and `compare` read, mutated: byte flips, deleted, duplicated and
/// swapped lines, truncation, and CSV fields or TOML values replaced by hostile ones. `plot` of
/// the mutated folder and `compare` of it against the intact one exit 0, 2 or 1, never panic,
/// and an error is one line.
#[test]
fn results_folders_never_panic_and_every_error_is_one_line() {
    let (dir, _) = crate::experiment::run_tiny(2);
    let base = dir.path().join("res/tiny");
    const FILES: &[&str] = &[
        "runs.csv",
        "summary.csv",
        "runs.json",
        "summary.json",
        "meta.toml",
    ];
    let texts: Vec<Vec<u8>> = FILES
        .iter()
        .map(|f| std::fs::read(base.join(f)).unwrap())
        .collect();
    let edit = prop_oneof![
        1 => mutation().prop_map(Ok),
        // The j-th comma-separated field of line i.
        2 => (any::<usize>(), any::<usize>(), prop::sample::select(HOSTILE))
            .prop_map(|(i, j, v)| Err((i, j, v))),
    ];
    let strategy = (0..FILES.len(), prop::collection::vec(edit, 1..3));
    let (cases, time) = budget(16, 3);
    let case_no = AtomicU64::new(0);
    fuzz("results folders", strategy, (cases, time), |(k, edits)| {
        let bytes = edits.iter().fold(texts[k].clone(), |t, e| match e {
            Ok(m) => apply(&t, m),
            Err((i, j, v)) => replace_field(&t, *i, *j, v),
        });
        let copy = dir
            .path()
            .join(format!("case{}", case_no.fetch_add(1, Ordering::Relaxed)));
        copy_folder(&base, &copy);
        std::fs::write(copy.join(FILES[k]), &bytes).unwrap();
        let (copy_s, base_s) = (copy.to_str().unwrap(), base.to_str().unwrap());
        exits_0_or_2_in_one_line(&dir, &["plot", copy_s], &[])?;
        exits_0_or_2_in_one_line(&dir, &["compare", copy_s, base_s], &[])?;
        std::fs::remove_dir_all(&copy).unwrap();
        Ok(())
    });
}

/// `text` with the `j`-th comma-separated field of its `i`-th line (both modulo) set to `v`.
fn replace_field(text: &[u8], i: usize, j: usize, v: &str) -> Vec<u8> {
    let mut lines: Vec<Vec<u8>> = text.split(|&b| b == b'\n').map(<[u8]>::to_vec).collect();
    let l = i % lines.len();
    let mut fields: Vec<Vec<u8>> = lines[l].split(|&b| b == b',').map(<[u8]>::to_vec).collect();
    let f = j % fields.len();
    fields[f] = v.as_bytes().to_vec();
    lines[l] = fields.join(&b',');
    lines.join(&b'\n')
}

/// Copy the files of `from`, subfolders included, into a new folder `to`.
fn copy_folder(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        let dest = to.join(p.file_name().unwrap());
        if p.is_dir() {
            copy_folder(&p, &dest);
        } else {
            std::fs::copy(&p, &dest).unwrap();
        }
    }
}
