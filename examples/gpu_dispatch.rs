//! What one GPU dispatch costs and how big a hand-out must be to fill the device (feature
//! `gpu`). Prints CSV rows (`measure,param,value,unit,…`) to stdout and, with `--out F`, to F:
//!
//! - `overhead`: submit → readback mapped for the empty kernel, µs (median, p10, p90);
//! - `batch`: pixels per second against pixels per dispatch (1 … the whole image), one
//!   dispatch in flight;
//! - `depth`: pixels per second against dispatches in flight (the source's buffer depth in
//!   hand-outs) at a fixed batch size;
//! - `knee`: the smallest batch reaching 90 % of the best batch's throughput;
//! - `rays`: tracer queries per second at the whole-image batch (primary rays only with
//!   `--max-depth 1`).
//!
//! ```sh
//! cargo run --release --features gpu --example gpu_dispatch -- --scene scenes/cornell_box.toml \
//!     --width 64 --spp 1 [--max-depth 1] [--adapter NAME] [--min-s 0.3] [--out gpu.csv] \
//!     [--bvh wide|binary]
//! ```

use raysched::gpu::{BvhLayout, Entry, GpuContext, GpuRenderer};
use raysched::scene::{load_scene, SceneOverrides};
use std::collections::VecDeque;
use std::io::Write;
use std::time::Instant;

struct Args {
    scene: String,
    width: Option<u32>,
    spp: u32,
    max_depth: Option<i32>,
    adapter: Option<String>,
    min_s: f64,
    depth_batch: usize,
    out: Option<String>,
    bvh: BvhLayout,
}

fn parse() -> Result<Args, String> {
    let mut a = Args {
        scene: "scenes/cornell_box.toml".into(),
        width: Some(64),
        spp: 1,
        max_depth: None,
        adapter: None,
        min_s: 0.3,
        depth_batch: 1024,
        out: None,
        bvh: BvhLayout::Wide,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut val = || it.next().ok_or(format!("{flag}: needs a value"));
        match flag.as_str() {
            "--scene" => a.scene = val()?,
            "--width" => {
                let v = val()?;
                a.width = if v == "scene" {
                    None
                } else {
                    Some(v.parse().map_err(|e| format!("--width: {e}"))?)
                }
            }
            "--spp" => a.spp = val()?.parse().map_err(|e| format!("--spp: {e}"))?,
            "--max-depth" => {
                a.max_depth = Some(val()?.parse().map_err(|e| format!("--max-depth: {e}"))?)
            }
            "--adapter" => a.adapter = Some(val()?),
            "--min-s" => a.min_s = val()?.parse().map_err(|e| format!("--min-s: {e}"))?,
            "--depth-batch" => {
                a.depth_batch = val()?.parse().map_err(|e| format!("--depth-batch: {e}"))?
            }
            "--out" => a.out = Some(val()?),
            "--bvh" => {
                a.bvh = match val()?.as_str() {
                    "wide" => BvhLayout::Wide,
                    "binary" => BvhLayout::Binary,
                    v => return Err(format!("--bvh: wide or binary, not {v}")),
                }
            }
            f => return Err(format!("unknown flag {f}")),
        }
    }
    Ok(a)
}

fn quantile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

fn main() {
    let args = parse().unwrap_or_else(|e| {
        eprintln!("error: {e}");
        std::process::exit(2)
    });
    let overrides = SceneOverrides {
        width: args.width,
        height: args.width,
        spp: Some(args.spp),
        max_depth: args.max_depth,
        ..Default::default()
    };
    let scene = load_scene(std::path::Path::new(&args.scene), &overrides).unwrap_or_else(|e| {
        eprintln!("error: {e}");
        std::process::exit(2)
    });
    let ctx = GpuContext::open(args.adapter.as_deref()).unwrap_or_else(|e| {
        eprintln!("error: {e}");
        std::process::exit(2)
    });
    let t0 = Instant::now();
    let r = GpuRenderer::with_layout(ctx, &scene, args.bvh).unwrap_or_else(|e| {
        eprintln!("error: {e}");
        std::process::exit(2)
    });
    let info = r.info().clone();
    let mut rows: Vec<String> = vec![
        "measure,param,value,unit,adapter,driver,backend,scene,width,spp,max_depth,bvh".into(),
    ];
    let tail = format!(
        "\"{}\",\"{}\",{},{},{},{},{},{}",
        info.name,
        info.driver,
        info.backend,
        scene.name,
        scene.width(),
        scene.settings.spp,
        scene.settings.max_depth,
        args.bvh.id()
    );
    let mut row = |m: &str, p: String, v: f64, unit: &str| {
        let line = format!("{m},{p},{v:.6},{unit},{tail}");
        println!("{line}");
        rows.push(line);
    };
    row("upload", "-".into(), t0.elapsed().as_secs_f64(), "s");
    let n = scene.pixel_count();
    let all: Vec<[u32; 2]> = (0..n as u32).map(|p| [p, 0]).collect();
    // Warm-up: pipeline creation and first-touch costs stay out of every number.
    let warm = r.submit(&all[..1], Entry::Empty).unwrap();
    r.wait(warm).unwrap();
    let warm = r.submit(&all, Entry::Render).unwrap();
    r.wait(warm).unwrap();

    // Per-dispatch overhead: the empty kernel, submit → mapped.
    let mut us: Vec<f64> = (0..200)
        .map(|_| {
            let t = Instant::now();
            let d = r.submit(&all[..1], Entry::Empty).unwrap();
            r.wait(d).unwrap();
            t.elapsed().as_secs_f64() * 1e6
        })
        .collect();
    row("overhead", "median".into(), quantile(&mut us, 0.5), "us");
    row("overhead", "p10".into(), quantile(&mut us, 0.1), "us");
    row("overhead", "p90".into(), quantile(&mut us, 0.9), "us");

    // Throughput against pixels per dispatch, one dispatch in flight.
    let mut sizes: Vec<usize> = std::iter::successors(Some(1usize), |s| Some(s * 4))
        .take_while(|&s| s < n)
        .collect();
    sizes.push(n);
    let mut best = (0usize, 0.0f64);
    let mut by_size = Vec::new();
    let mut rays_per_s = 0.0;
    for &size in &sizes {
        let (mut pixels, mut rays, t) = (0usize, 0u64, Instant::now());
        let mut at = 0;
        while t.elapsed().as_secs_f64() < args.min_s || pixels == 0 {
            let tasks: Vec<[u32; 2]> = (0..size).map(|k| all[(at + k) % n]).collect();
            at = (at + size) % n;
            let px = r.wait(r.submit(&tasks, Entry::Render).unwrap()).unwrap();
            rays += px.iter().map(|p| p.rays as u64).sum::<u64>();
            pixels += size;
        }
        let s = t.elapsed().as_secs_f64();
        let pps = pixels as f64 / s;
        row("batch", size.to_string(), pps, "pixels/s");
        if size == n {
            rays_per_s = rays as f64 / s;
        }
        if pps > best.1 {
            best = (size, pps);
        }
        by_size.push((size, pps));
    }
    let knee = by_size
        .iter()
        .find(|(_, p)| *p >= 0.9 * best.1)
        .map_or(n, |(s, _)| *s);
    row("knee", "90%".into(), knee as f64, "pixels");
    row("rays", n.to_string(), rays_per_s, "rays/s");

    // Throughput against dispatches in flight at one batch size.
    let size = args.depth_batch.min(n);
    for depth in [1usize, 2, 4, 8] {
        let (mut pixels, t) = (0usize, Instant::now());
        let mut inflight = VecDeque::new();
        let mut at = 0;
        while t.elapsed().as_secs_f64() < args.min_s || pixels == 0 {
            while inflight.len() < depth {
                let tasks: Vec<[u32; 2]> = (0..size).map(|k| all[(at + k) % n]).collect();
                at = (at + size) % n;
                inflight.push_back(r.submit(&tasks, Entry::Render).unwrap());
            }
            let d = inflight.pop_front().unwrap();
            pixels += d.tasks();
            r.wait(d).unwrap();
        }
        for d in inflight {
            r.wait(d).unwrap();
        }
        row(
            "depth",
            format!("{depth}x{size}"),
            pixels as f64 / t.elapsed().as_secs_f64(),
            "pixels/s",
        );
    }
    if let Some(path) = &args.out {
        let mut f = std::fs::File::create(path).unwrap_or_else(|e| {
            eprintln!("error: {path}: {e}");
            std::process::exit(1)
        });
        for l in &rows {
            writeln!(f, "{l}").expect("writing the CSV");
        }
    }
}
