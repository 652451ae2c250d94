//! Loading cost per format: one mesh (the displaced sphere of `scenes/complex.toml`, `count`
//! triangles, vertices shared) written as OBJ, ASCII PLY, binary PLY and glTF binary, then each
//! loaded as a scene (parse + checks + placement) and given a BVH, `rounds` times interleaved.
//! Prints the median and the spread (min–max) of each step in seconds per million triangles.
//! Model files named after the arguments are timed too.
//!
//! `cargo run --release --example load_cost -- 1000000 5 [MODEL.obj|.ply|.glb …]`

use glam::DVec3;
use raysched::scene::generators::displaced_sphere;
use raysched::scene::{load_scene_str, SceneOverrides};
use raysched::tracer::BvhTracer;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Shared vertices and triangles as index triples (the generator emits triangle soup).
fn indexed(tris: &[[DVec3; 3]]) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let mut ids: HashMap<[u64; 3], u32> = HashMap::new();
    let mut verts = Vec::new();
    let faces = tris
        .iter()
        .map(|t| {
            t.map(|p| {
                *ids.entry(p.to_array().map(f64::to_bits))
                    .or_insert_with(|| {
                        verts.push(p);
                        verts.len() as u32 - 1
                    })
            })
        })
        .collect();
    (verts, faces)
}

fn write_obj(path: &Path, v: &[DVec3], f: &[[u32; 3]]) {
    let mut s = String::new();
    for p in v {
        writeln!(s, "v {} {} {}", p.x as f32, p.y as f32, p.z as f32).unwrap();
    }
    for t in f {
        writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1).unwrap();
    }
    std::fs::write(path, s).unwrap();
}

fn ply_header(format: &str, v: usize, f: usize) -> String {
    format!(
        "ply\nformat {format} 1.0\nelement vertex {v}\nproperty float x\nproperty float y\n\
         property float z\nelement face {f}\nproperty list uchar uint vertex_indices\nend_header\n"
    )
}

fn write_ply_ascii(path: &Path, v: &[DVec3], f: &[[u32; 3]]) {
    let mut s = ply_header("ascii", v.len(), f.len());
    for p in v {
        writeln!(s, "{} {} {}", p.x as f32, p.y as f32, p.z as f32).unwrap();
    }
    for t in f {
        writeln!(s, "3 {} {} {}", t[0], t[1], t[2]).unwrap();
    }
    std::fs::write(path, s).unwrap();
}

fn write_ply_binary(path: &Path, v: &[DVec3], f: &[[u32; 3]]) {
    let mut b = ply_header("binary_little_endian", v.len(), f.len()).into_bytes();
    for p in v {
        for x in p.to_array() {
            b.extend((x as f32).to_le_bytes());
        }
    }
    for t in f {
        b.push(3);
        for i in t {
            b.extend(i.to_le_bytes());
        }
    }
    std::fs::write(path, b).unwrap();
}

fn write_glb(path: &Path, v: &[DVec3], f: &[[u32; 3]]) {
    let mut bin: Vec<u8> = Vec::new();
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for p in v {
        for (k, x) in p.to_array().into_iter().enumerate() {
            let x = x as f32;
            lo[k] = lo[k].min(x);
            hi[k] = hi[k].max(x);
            bin.extend(x.to_le_bytes());
        }
    }
    let pos_len = bin.len();
    for t in f {
        for i in t {
            bin.extend(i.to_le_bytes());
        }
    }
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],"buffers":[{{"byteLength":{}}}],"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{pos_len}}},{{"buffer":0,"byteOffset":{pos_len},"byteLength":{}}}],"accessors":[{{"bufferView":0,"componentType":5126,"count":{},"type":"VEC3","min":{lo:?},"max":{hi:?}}},{{"bufferView":1,"componentType":5125,"count":{},"type":"SCALAR"}}]}}"#,
        bin.len(),
        bin.len() - pos_len,
        v.len(),
        f.len() * 3
    );
    let mut json = json.into_bytes();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    std::fs::write(path, out).unwrap();
}

fn shape_type(p: &Path) -> &'static str {
    match p.extension().and_then(|e| e.to_str()).unwrap_or("") {
        "ply" => "ply",
        "gltf" | "glb" => "gltf",
        _ => "mesh",
    }
}

/// (triangles, load seconds, BVH build seconds) of a scene around `file`.
fn time_once(file: &Path) -> (usize, f64, f64) {
    let kind = shape_type(file);
    let material = if kind == "gltf" {
        ""
    } else {
        "material = \"m\"\n"
    };
    let text = format!(
        "[camera]\norigin = [0, 0, 10]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov_deg = 40\n\
         width = 4\nheight = 4\n[materials.m]\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n\
         [[shapes]]\ntype = \"{kind}\"\n{material}path = {:?}\n",
        file.display().to_string()
    );
    let t0 = Instant::now();
    let scene = load_scene_str(
        &text,
        "load_cost",
        Path::new("."),
        "load_cost",
        &SceneOverrides::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let t1 = Instant::now();
    let bvh = BvhTracer::new(&scene.geometry);
    let t2 = Instant::now();
    std::hint::black_box(&bvh);
    (
        scene.geometry.triangles.len(),
        (t1 - t0).as_secs_f64(),
        (t2 - t1).as_secs_f64(),
    )
}

fn spread(mut v: Vec<f64>) -> String {
    v.sort_by(f64::total_cmp);
    format!("{:.3} ({:.3}–{:.3})", v[v.len() / 2], v[0], v[v.len() - 1])
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let count: u64 = args
        .first()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let rounds: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(5);
    let dir = tempfile::tempdir().unwrap();
    let (v, f) = indexed(&displaced_sphere(count, 0.1));
    let mut files: Vec<(String, PathBuf)> = Vec::new();
    type Writer = fn(&Path, &[DVec3], &[[u32; 3]]);
    let writers: [(&str, &str, Writer); 4] = [
        ("obj", "m.obj", write_obj),
        ("ply ascii", "a.ply", write_ply_ascii),
        ("ply binary", "b.ply", write_ply_binary),
        ("glb", "m.glb", write_glb),
    ];
    for (name, file, write) in writers {
        let p = dir.path().join(file);
        write(&p, &v, &f);
        files.push((name.to_string(), p));
    }
    for extra in args.iter().skip(2) {
        files.push((extra.clone(), PathBuf::from(extra)));
    }
    let mut loads = vec![Vec::new(); files.len()];
    let mut builds = vec![Vec::new(); files.len()];
    let mut tris = vec![0; files.len()];
    for _ in 0..rounds {
        for (k, (_, p)) in files.iter().enumerate() {
            let (n, l, b) = time_once(p);
            tris[k] = n;
            loads[k].push(l / n as f64 * 1e6);
            builds[k].push(b / n as f64 * 1e6);
        }
    }
    println!("s per million triangles, median (min–max) of {rounds} interleaved rounds");
    println!("format | triangles | file MB | load (parse + place) | BVH build");
    for (k, (name, p)) in files.iter().enumerate() {
        let mb = std::fs::metadata(p).map_or(0.0, |m| m.len() as f64 / 1e6);
        println!(
            "{name} | {} | {mb:.1} | {} | {}",
            tris[k],
            spread(loads[k].clone()),
            spread(builds[k].clone())
        );
    }
}
