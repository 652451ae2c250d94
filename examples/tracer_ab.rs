//! Interleaved A/B of tracers on one scene, one thread: each tracer is built (timed) and then
//! traces the same rays in turn for `rounds` rounds; prints the best and median ray rate per
//! ray set, each tracer's build time, and every tracer's rate and build time as a ratio to the
//! last one named (the peer). The best of interleaved rounds is what survives a loaded machine.
//!
//! Ray sets (`--rays`, default both):
//! - `primary`: one camera ray through every pixel centre (coherent).
//! - `diffuse`: from every primary hit, one cosine-distributed bounce about the surface normal
//!   (facing the camera), leaving from the offset origin the renderer uses (incoherent: the
//!   rays of one screen tile scatter over the whole scene).
//! - `shadow`: from every primary hit, an occlusion query (`occluded`) towards the scene's
//!   first point light, as the renderer's next-event estimation makes it (offset origin, the
//!   segment to the light, stopped `SHADOW_EPSILON` short); its "hits" are the blocked rays.
//!
//! Tracer ids are those of `--tracer`; `bvh@avx2` and `bvh@sse` step the native tracer down
//! from the widest path this CPU runs (AVX-512 where it has it) to compare paths in one run.
//!
//! `--build-only`: build the tracers and print their build times and the process's peak
//! resident memory, trace nothing (one tracer per process: `benches/peers/peers.py`).
//! `--threads N`: the build's thread budget (Embree's; the native build is serial).
//!
//! Measured (quiet 2-core Intel Xeon KVM guest with AVX-512, `taskset -c 0`, 5 rounds, 1 M
//! triangles, 3 runs, load 3.7–1.8, SAH collapse into wide nodes): bvh/embree best rate
//! primary 0.70–0.73 at 256², 0.87–0.94 at 1024²; diffuse 0.61–0.64 and 0.67–0.70; build
//! 0.72–0.78 s, 1.63–2.00× Embree's. The code before it gave 0.66–0.67, 0.85–0.89,
//! 0.58–0.60 and 0.61–0.65 in the same runs, and 0.87–0.93, 0.99–1.01, 0.79–0.81 and
//! 0.75–0.79 on a 2-core AMD EPYC: only ratios from one machine compare. Full
//! table: `benches/peers/results.md`.
//!
//! `cargo run --release --features embree --example tracer_ab -- complex 1000000 256 9 bvh embree`
//! `… --example tracer_ab -- --rays diffuse complex 1000000 1024 5 bvh embree`

use glam::Vec3;
use raysched::geometry::{basis, Ray};
use raysched::render::integrator::{interaction, SHADOW_EPSILON};
use raysched::scene::{load_scene, Light, Scene, SceneOverrides};
use raysched::tracer::{AnyTracer, Tracer, TracerKind};
use std::path::Path;
use std::time::Instant;

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut sets = vec!["primary".to_string(), "diffuse".to_string()];
    if let Some(k) = args.iter().position(|a| a == "--rays") {
        let Some(v) = args.get(k + 1).cloned() else {
            eprintln!("--rays: expected primary, diffuse or primary,diffuse");
            std::process::exit(2);
        };
        sets = v.split(',').map(str::to_string).collect();
        if let Some(bad) = sets
            .iter()
            .find(|s| !matches!(s.as_str(), "primary" | "diffuse" | "shadow"))
        {
            eprintln!("--rays: unknown ray set '{bad}' (expected primary, diffuse or shadow)");
            std::process::exit(2);
        }
        args.drain(k..k + 2);
    }
    // `--build-only`: load, build the tracers, print each build and the process's peak
    // resident memory, trace nothing (one tracer per process measures that tracer's memory).
    let build_only = take_flag(&mut args, "--build-only");
    // `--threads N`: the build's thread budget (Embree's; the native build is serial).
    let threads: usize = match take_value(&mut args, "--threads").map(|v| v.parse()) {
        None => 1,
        Some(Ok(n)) if n > 0 => n,
        Some(_) => {
            eprintln!("--threads: expected a whole number ≥ 1");
            std::process::exit(2);
        }
    };
    let name = args.first().map_or("complex", |s| s.as_str());
    let count: u64 = args
        .get(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let side: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(256);
    let rounds: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(9);
    let ids: Vec<&str> = if args.len() > 4 {
        args[4..].iter().map(|s| s.as_str()).collect()
    } else {
        vec!["bvh", "embree"]
    };
    let o = SceneOverrides {
        width: Some(side),
        height: Some(side),
        generator_count: Some(count),
        ..Default::default()
    };
    let scene = match load_scene(Path::new(&format!("scenes/{name}.toml")), &o) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    let mut builds = Vec::new();
    let tracers: Vec<AnyTracer> = ids
        .iter()
        .map(|id| {
            let t0 = Instant::now();
            // `bvh@avx2`, `bvh@sse`: the native tracer stepped down to that path.
            let (id, isa) = id.split_once('@').unwrap_or((id, ""));
            let mut t = TracerKind::from_id(id)
                .and_then(|kind| AnyTracer::build(kind, &scene, threads))
                .unwrap_or_else(|e| {
                    eprintln!("{e}");
                    std::process::exit(2)
                });
            let stepped = match &mut t {
                AnyTracer::Bvh(b) if !isa.is_empty() => b.step_down(isa),
                _ => false,
            };
            if !isa.is_empty() && !stepped {
                eprintln!("{id}@{isa}: only bvh steps down, to a path this CPU runs (avx2, sse)");
                std::process::exit(2);
            }
            builds.push(t0.elapsed().as_secs_f64());
            t
        })
        .collect();
    let peer = ids.len() - 1;
    for (k, id) in ids.iter().enumerate() {
        println!(
            "build {id}: {:.3} s ({:.2}× {}'s)",
            builds[k],
            builds[k] / builds[peer],
            ids[peer]
        );
    }
    for (t, id) in tracers.iter().zip(&ids) {
        if let AnyTracer::Bvh(b) = t {
            println!("path {id}: {}", b.isa());
        }
    }
    if build_only {
        println!("peak_rss_mib {:.1}", peak_rss_mib());
        return;
    }
    let primary: Vec<Ray> = (0..side * side)
        .map(|i| scene.camera.pixel_ray(i % side, i / side, 0.5, 0.5))
        .collect();
    for set in &sets {
        let (rays, t_max, occlusion) = match set.as_str() {
            "primary" => (primary.clone(), f32::INFINITY, false),
            "diffuse" => (
                diffuse_bounces(&scene, &tracers[0], &primary),
                f32::INFINITY,
                false,
            ),
            _ => {
                let Some(light) = scene.lights.iter().find_map(|l| match l {
                    Light::Point { position, .. } => Some(*position),
                    _ => None,
                }) else {
                    eprintln!("--rays shadow: scene '{name}' has no point light");
                    std::process::exit(2);
                };
                let rays = shadow_rays(&scene, &tracers[0], &primary, light);
                (rays, 1.0 - SHADOW_EPSILON, true)
            }
        };
        let best = time_rounds(&tracers, &rays, rounds, |t, r| {
            if occlusion {
                t.occluded(r, t_max)
            } else {
                t.intersect(r, t_max).is_some()
            }
        });
        let rate = |s: f64| rays.len() as f64 / s / 1e6;
        for (k, id) in ids.iter().enumerate() {
            println!(
                "{name} {} prims, {side}², {set} ({} rays), {id}: best {:.2} Mrays/s, median {:.2} ({} hits); best {:.2}× {}",
                scene.geometry.len(),
                rays.len(),
                rate(best[k].0),
                rate(best[k].1),
                best[k].2,
                best[peer].0 / best[k].0,
                ids[peer]
            );
        }
    }
}

/// Every tracer traces `rays` once per round by `trace` (true: a hit), in turn; per tracer
/// (best s, median s, hits).
fn time_rounds(
    tracers: &[AnyTracer],
    rays: &[Ray],
    rounds: usize,
    trace: impl Fn(&AnyTracer, &Ray) -> bool,
) -> Vec<(f64, f64, usize)> {
    let mut times = vec![Vec::new(); tracers.len()];
    let mut hits = vec![0usize; tracers.len()];
    for _ in 0..rounds {
        for (k, t) in tracers.iter().enumerate() {
            let t0 = Instant::now();
            hits[k] = rays.iter().filter(|r| trace(t, r)).count();
            times[k].push(t0.elapsed().as_secs_f64());
        }
    }
    times
        .into_iter()
        .zip(hits)
        .map(|(mut v, h)| {
            v.sort_by(f64::total_cmp);
            (v[0], v[v.len() / 2], h)
        })
        .collect()
}

/// From each primary hit that `tracer` finds, the shadow ray towards `light`: from the offset
/// origin on the side facing the light, direction the segment to it (`t_max` 1 − ε).
fn shadow_rays(scene: &Scene, tracer: &AnyTracer, primary: &[Ray], light: Vec3) -> Vec<Ray> {
    primary
        .iter()
        .filter_map(|ray| {
            let hit = tracer.intersect(ray, f32::INFINITY)?;
            let it = interaction(scene, ray, &hit);
            let wi = (light - it.p).normalize_or_zero();
            Some(it.spawn(wi, |o| light - o))
        })
        .collect()
}

/// One diffuse bounce from each primary hit that `tracer` finds: a cosine-distributed
/// direction about the normal turned towards the camera, from the renderer's offset origin.
fn diffuse_bounces(scene: &Scene, tracer: &AnyTracer, primary: &[Ray]) -> Vec<Ray> {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut uniform = move || {
        // splitmix64: a fixed sequence, so every run traces the same rays.
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    };
    primary
        .iter()
        .filter_map(|ray| {
            let hit = tracer.intersect(ray, f32::INFINITY)?;
            let it = interaction(scene, ray, &hit);
            let n = if ray.d.dot(it.n) < 0.0 { it.n } else { -it.n };
            let (u1, u2) = (uniform(), uniform());
            let (t, b) = basis(n);
            let r = u1.sqrt();
            let phi = 2.0 * std::f32::consts::PI * u2;
            let z = (1.0 - u1).max(0.0).sqrt();
            let d: Vec3 = (t * (r * phi.cos()) + b * (r * phi.sin()) + n * z).normalize();
            Some(it.spawn(d, |_| d))
        })
        .collect()
}

/// Remove `flag` from `args`; whether it was there.
fn take_flag(args: &mut Vec<String>, flag: &str) -> bool {
    let at = args.iter().position(|a| a == flag);
    if let Some(k) = at {
        args.remove(k);
    }
    at.is_some()
}

/// Remove `flag` and its value from `args`; the value (exit 2 where it is missing).
fn take_value(args: &mut Vec<String>, flag: &str) -> Option<String> {
    let k = args.iter().position(|a| a == flag)?;
    let Some(v) = args.get(k + 1).cloned() else {
        eprintln!("{flag}: expected a value");
        std::process::exit(2);
    };
    args.drain(k..k + 2);
    Some(v)
}

/// The process's peak resident set so far, in MiB (`VmHWM` of `/proc/self/status`; NaN where
/// that cannot be read).
fn peak_rss_mib() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(f64::NAN, |kib| kib / 1024.0)
}
