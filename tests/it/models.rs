//! Real models from a peer's corpus: Debian's `assimp-testmodels` (assimp's own test files,
//! installed by `.ci/run`). Every OBJ, glTF/GLB and PLY file either loads, with triangle counts
//! and bounds checked on well-known ones, or fails with a one-line error naming the file: never
//! a panic, a hang or a silently empty mesh. The bvh and brute tracers agree on random rays
//! over every model that loads. Skipped, saying why, where the package is missing.

use crate::support::{CAMERA_4X4, GREY_M};
use glam::{DVec3, Vec3};
use raysched::geometry::Ray;
use raysched::rng::Sampler;
use raysched::scene::{load_scene_str, Scene, SceneOverrides};
use raysched::tracer::{BruteTracer, BvhTracer, Tracer};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

const CORPUS: &str = "/usr/share/assimp/models";

/// Generous: the largest corpus file loads in well under a second in a test build.
const LOAD_TIMEOUT: Duration = Duration::from_secs(60);

/// The corpus folder, or `None` (after saying why) where the package is not installed.
fn corpus() -> Option<&'static Path> {
    let p = Path::new(CORPUS);
    if p.is_dir() {
        Some(p)
    } else {
        eprintln!(
            "skipped: {CORPUS} is missing (install Debian's assimp-testmodels, as .ci/run does)"
        );
        None
    }
}

/// The shape type that reads a model file, by extension.
fn shape_type(p: &Path) -> Option<&'static str> {
    match p.extension()?.to_str()?.to_ascii_lowercase().as_str() {
        "obj" => Some("mesh"),
        "gltf" | "glb" => Some("gltf"),
        "ply" => Some("ply"),
        _ => None,
    }
}

/// Every model file under `dir`, sorted.
fn model_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if shape_type(&p).is_some() {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The scene text around one model file (glTF keeps its own materials).
fn scene_text(file: &Path) -> String {
    let kind = shape_type(file).unwrap();
    let material = if kind == "gltf" {
        ""
    } else {
        "material = \"m\"\n"
    };
    format!(
        "{CAMERA_4X4}{GREY_M}[[shapes]]\ntype = \"{kind}\"\n{material}path = {:?}\n",
        file.display().to_string()
    )
}

/// Load `file` in a thread bounded by [`LOAD_TIMEOUT`]: a panic or a hang fails the test.
fn load_bounded(file: &Path) -> Result<Scene, String> {
    let text = scene_text(file);
    let (tx, rx) = mpsc::channel();
    let name = file.display().to_string();
    std::thread::spawn(move || {
        let r = load_scene_str(
            &text,
            "corpus.toml",
            Path::new("."),
            "corpus",
            &SceneOverrides::default(),
        )
        .map_err(|e| e.to_string());
        let _ = tx.send(r);
    });
    match rx.recv_timeout(LOAD_TIMEOUT) {
        Ok(r) => r,
        Err(mpsc::RecvTimeoutError::Timeout) => panic!("{name}: no answer in {LOAD_TIMEOUT:?}"),
        Err(mpsc::RecvTimeoutError::Disconnected) => panic!("{name}: the loader panicked"),
    }
}

/// World-space bounds of a scene's triangles.
fn bounds(s: &Scene) -> (DVec3, DVec3) {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = -lo;
    for t in &s.geometry.triangles {
        for p in t.vertices() {
            let w = p.as_dvec3() + s.origin;
            lo = lo.min(w);
            hi = hi.max(w);
        }
    }
    (lo, hi)
}

/// Files with a known triangle count (zero-area ones included: the loader drops and counts
/// them) and world bounds. Counts read off the files with a separate script: Σ(n − 2) over OBJ
/// `f` lines, PLY face counts, Σ index count / 3 over the default scene's glTF primitives; the
/// three Wuson files are one model in three formats.
const WUSON_LO: [f64; 3] = [-0.459976, -0.000566, -1.622242];
const WUSON_HI: [f64; 3] = [0.459976, 1.515251, 1.622242];
const KNOWN: &[(&str, usize, [f64; 3], [f64; 3])] = &[
    ("OBJ/box.obj", 12, [-0.5; 3], [0.5; 3]),
    ("OBJ/box_UTF16BE.obj", 12, [-0.5; 3], [0.5; 3]),
    ("OBJ/box_without_lineending.obj", 12, [-0.5; 3], [0.5; 3]),
    ("OBJ/WusonOBJ.obj", 3732, WUSON_LO, WUSON_HI),
    (
        "OBJ/spider.obj",
        1368,
        [-92.655, -42.234, -106.691],
        [57.936, 37.504, 86.691],
    ),
    ("PLY/Wuson.ply", 3732, WUSON_LO, WUSON_HI),
    ("PLY/cube.ply", 12, [0.0; 3], [1.0; 3]),
    ("PLY/cube_binary.ply", 12, [0.0; 3], [1.0; 3]),
    (
        "glTF2/BoxTextured-glTF-Binary/BoxTextured.glb",
        12,
        [-0.5; 3],
        [0.5; 3],
    ),
    (
        "glTF2/BoxTextured-glTF/BoxTextured.gltf",
        12,
        [-0.5; 3],
        [0.5; 3],
    ),
    (
        "glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb",
        121_496,
        [-371.692, -180.972, -140.0],
        [371.692, 92.042, 128.0],
    ),
    // Strip and fan modes, indexed or not: each a unit quad of 2 triangles.
    (
        "glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_04.gltf",
        2,
        [-0.5, -0.5, 0.0],
        [0.5, 0.5, 0.0],
    ),
    (
        "glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_05.gltf",
        2,
        [-0.5, -0.5, 0.0],
        [0.5, 0.5, 0.0],
    ),
    (
        "glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_06.gltf",
        2,
        [-0.5, -0.5, 0.0],
        [0.5, 0.5, 0.0],
    ),
    (
        "glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_13.gltf",
        2,
        [-0.5, -0.5, 0.0],
        [0.5, 0.5, 0.0],
    ),
    (
        "glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_14.gltf",
        2,
        [-0.5, -0.5, 0.0],
        [0.5, 0.5, 0.0],
    ),
];

/// Files that must fail, and a part of their error.
const MUST_FAIL: &[(&str, &str)] = &[
    (
        "glTF2/draco/2CylinderEngine.gltf",
        "requires the glTF extension KHR_draco_mesh_compression",
    ),
    (
        "glTF2/IndexOutOfRange/IndexOutOfRange.gltf",
        "mesh 0 primitive 0: index 255 is out of range",
    ),
    (
        "glTF2/IndexOutOfRange/AllIndicesOutOfRange.gltf",
        "is out of range",
    ),
    (
        "glTF2/RecursiveNodes/RecursiveNodes.gltf",
        "its own ancestor",
    ),
    ("glTF2/MissingBin/BoxTextured.gltf", "No such file"),
    (
        "glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_00.gltf",
        "only point or line",
    ),
    ("glTF/TwoBoxes/TwoBoxes.gltf", "is glTF 1.0"),
    ("glTF/CesiumMilkTruck/CesiumMilkTruck.gltf", "is glTF 1.0"),
    (
        "glTF/BoxTextured-glTF-Binary/BoxTextured.glb",
        "is glTF 1.0",
    ),
    ("OBJ/testpoints.obj", "no triangles"),
    ("invalid/empty.obj", "no triangles"),
    ("invalid/malformed.obj", "out of bounds"),
    ("invalid/empty.ply", "header"),
    ("PLY/points.ply", "point cloud"),
    ("PLY/pond.0.ply", "point cloud"),
];

#[test]
fn every_corpus_model_loads_or_fails_with_one_line_naming_it() {
    let Some(dir) = corpus() else { return };
    let files = model_files(dir);
    assert!(
        files.len() >= 80,
        "only {} model files under {CORPUS}",
        files.len()
    );
    let (mut loaded, mut failed) = (0, 0);
    for file in &files {
        let rel = file.strip_prefix(dir).unwrap().display().to_string();
        match load_bounded(file) {
            Ok(scene) => {
                loaded += 1;
                let n = scene.geometry.triangles.len();
                let (lo, hi) = bounds(&scene);
                eprintln!(
                    "{rel}: {n} triangles, bounds {lo:.3?} {hi:.3?}, ignored {:?}",
                    scene.ignored_input
                );
                assert!(n > 0, "{rel}: loaded with no triangle");
                assert!(
                    MUST_FAIL.iter().all(|(f, _)| *f != rel),
                    "{rel}: loaded, but must fail"
                );
                if let Some((_, count, want_lo, want_hi)) = KNOWN.iter().find(|k| k.0 == rel) {
                    let dropped = scene.load_stats.degenerate_triangles as usize;
                    assert_eq!(
                        n + dropped,
                        *count,
                        "{rel}: triangle count ({dropped} zero-area)"
                    );
                    let close = |a: DVec3, b: [f64; 3]| {
                        (a - DVec3::from_array(b)).abs().max_element()
                            <= 1e-4 * (1.0 + a.abs().max_element())
                    };
                    assert!(
                        close(lo, *want_lo) && close(hi, *want_hi),
                        "{rel}: bounds {lo:?} {hi:?}"
                    );
                }
            }
            Err(e) => {
                failed += 1;
                eprintln!("{rel}: ERROR {e}");
                assert!(!e.contains('\n'), "{rel}: error of several lines: {e}");
                assert!(
                    e.contains(&file.display().to_string()),
                    "{rel}: error does not name the file: {e}"
                );
                assert!(
                    KNOWN.iter().all(|k| k.0 != rel),
                    "{rel}: known model failed: {e}"
                );
                if let Some((_, part)) = MUST_FAIL.iter().find(|(f, _)| *f == rel) {
                    assert!(e.contains(part), "{rel}: error lacks '{part}': {e}");
                }
            }
        }
    }
    eprintln!("{loaded} loaded, {failed} failed");
}

/// Largest model the brute-force tracer is run over: 200 rays × 200 000 triangles is about
/// 0.1 s in a test build.
const BRUTE_MAX_TRIANGLES: usize = 200_000;

#[test]
fn bvh_matches_brute_force_over_every_corpus_model() {
    let Some(dir) = corpus() else { return };
    let mut models: u64 = 0;
    for file in model_files(dir) {
        let rel = file.strip_prefix(dir).unwrap().display().to_string();
        let Ok(scene) = load_bounded(&file) else {
            continue;
        };
        let tris = &scene.geometry.triangles;
        if tris.len() > BRUTE_MAX_TRIANGLES {
            eprintln!("{rel}: {} triangles, too many for brute force", tris.len());
            continue;
        }
        models += 1;
        let bvh = BvhTracer::new(&scene.geometry);
        let brute = BruteTracer::new(&scene.geometry);
        let (lo, hi) = bounds(&scene);
        let (lo, hi) = ((lo - scene.origin).as_vec3(), (hi - scene.origin).as_vec3());
        let size = (hi - lo).max(Vec3::splat(1e-3));
        let mut s = Sampler::new(7, models, 0);
        let mut hits = 0;
        for i in 0..200 {
            let u = Vec3::new(s.next(), s.next(), s.next());
            let o = lo - size * 0.25 + u * size * 1.5;
            // Half the rays aim at a random triangle's centroid, so most of them hit.
            let d = if i % 2 == 0 {
                let t = &tris[(s.next() * tris.len() as f32) as usize % tris.len()];
                let c = t.v0 + (t.e1() + t.e2()) / 3.0;
                (c - o).try_normalize().unwrap_or(Vec3::Z)
            } else {
                crate::tracers::random_dir(&mut s)
            };
            let ray = Ray::new(o, d);
            crate::tracers::assert_agree(&scene, &bvh, &brute, &ray, &format!("{rel} ray {i}"));
            hits += brute.intersect(&ray, f32::INFINITY).is_some() as u32;
        }
        assert!(hits > 0, "{rel}: no ray hit the model");
    }
    assert!(models >= 30, "only {models} corpus models compared");
}

/// The shipped glTF binary with one byte changed, as the model fuzz found it: byte 573, the
/// first letter of the key `accessors`, made `#`, so the file has no accessors and
/// `gltf-json`'s validator indexed the missing `POSITION` accessor and panicked. Now a one-line
/// error names the field.
#[test]
fn a_gltf_whose_position_accessor_is_missing_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let glb = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/models/wuson.glb");
    let mut bytes = std::fs::read(glb).unwrap();
    assert_eq!(&bytes[573..582], b"accessors");
    bytes[573] = b'#';
    std::fs::write(dir.path().join("m.glb"), &bytes).unwrap();
    let text = format!(
        "{CAMERA_4X4}{GREY_M}[[shapes]]\ntype = \"gltf\"\nmaterial = \"m\"\npath = \"m.glb\"\n"
    );
    let loaded = std::panic::catch_unwind(|| {
        load_scene_str(&text, "s.toml", dir.path(), "s", &SceneOverrides::default())
            .map(|_| ())
            .map_err(|e| e.to_string())
    });
    let err = loaded.expect("no panic").expect_err("refused");
    assert!(!err.contains('\n'), "{err}");
    assert!(err.contains("m.glb") && err.contains("POSITION"), "{err}");
}
