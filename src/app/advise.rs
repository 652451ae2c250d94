//! `raysched advise SCENE`: probe the scene and the schedulers for a few seconds, then predict
//! the wall time of every scheduler × chunk with the cost model (`raysched::studies::model`) and name
//! the fastest, or the set within a few per cent of it when the curve is flat.

use super::error::CliError;
use raysched::core::scene::{load_scene, Scene, SceneOverrides};
use raysched::core::tracer::{AnyTracer, TracerKind};
use raysched::sched::{Chunk, MasterParams, Passes, Policy, SchedulerKind, SchedulerSpec, Slow};
use raysched::studies::model::advise::{advise, Advice, Probed};
use raysched::studies::model::probe;
use std::path::PathBuf;
use std::sync::Arc;

/// Who renders: only local threads are modelled. The words are `render --sources`' words.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum AdviseSources {
    /// Worker threads of this process.
    Threads,
    /// MPI ranks (not modelled: refused).
    Mpi,
}

/// Every kind `advise` weighs unless told otherwise ([`SchedulerKind::advised_by_default`]).
fn default_schedulers() -> &'static str {
    static LIST: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    LIST.get_or_init(|| {
        let ids: Vec<&str> = SchedulerKind::ALL
            .into_iter()
            .filter(|k| k.advised_by_default())
            .map(SchedulerKind::id)
            .collect();
        ids.join(",")
    })
}
/// `--sources`: `threads` or `mpi`, parsed as `render --sources` is (`local` is refused there
/// too, with a did-you-mean).
fn parse_advise_sources(s: &str) -> Result<AdviseSources, String> {
    let set = super::render::parse_sources(s)?;
    if set.has(raysched::sched::SourceKind::Mpi) {
        Ok(AdviseSources::Mpi)
    } else if *set.kinds() == [raysched::sched::SourceKind::Threads] {
        Ok(AdviseSources::Threads)
    } else {
        Err(format!("'{s}': the cost model covers threads only"))
    }
}

#[derive(clap::Args, Debug)]
pub(crate) struct AdviseArgs {
    /// Scene file (TOML), see scenes/.
    scene: PathBuf,
    /// Worker threads the prediction is for.
    #[arg(long, default_value_t = raysched::util::host::available_threads(), value_parser = super::threads_arg(1))]
    workers: usize,
    /// Schedulers to consider, comma-separated.
    #[arg(long = "scheduler", default_value = default_schedulers(), value_delimiter = ',',
          value_parser = |s: &str| SchedulerKind::from_id(s).map_err(|e| e.msg))]
    schedulers: Vec<SchedulerKind>,
    /// Chunks to consider, comma-separated (N = N×N tiles, WxH, rows:N, frame).
    #[arg(long, default_value = "1,2,4,8,16,32,64,rows:1,rows:4,frame", value_delimiter = ',',
          value_parser = super::parse_chunk)]
    chunks: Vec<Chunk>,
    /// The master's buffer B (items outstanding per source).
    #[arg(long, default_value_t = MasterParams::DEFAULT.buffer,
          value_parser = super::whole::<usize>(1, 65536))]
    buffer: usize,
    /// Who runs the master's passes: thread (its own) or workers (each for itself, under a lock).
    #[arg(long, default_value = MasterParams::DEFAULT.passes.id(), value_parser = |s: &str| Passes::from_id(s).map_err(|e| e.msg))]
    passes: Passes,
    /// Compute sources: threads (the only ones modelled).
    #[arg(long, default_value = "threads", value_parser = parse_advise_sources)]
    sources: AdviseSources,
    /// Workers slowed by a known factor, K:F (K workers F× slower), or none.
    #[arg(long, default_value = "none", value_parser = |s: &str| Slow::parse(s).map_err(|e| e.msg))]
    slow: Slow,
    /// Samples per pixel the prediction is for (default: the scene's render.spp).
    #[arg(long, value_parser = super::spp_arg())]
    spp: Option<u32>,
    /// Samples per pixel of the probe render (default: min(spp, 4)); costs scale linearly
    /// beyond a fixed part per pixel that a 1-spp render of the probe measures.
    #[arg(long, value_parser = super::spp_arg())]
    probe_spp: Option<u32>,
    /// Tracer id (bvh, brute, embree, …).
    #[arg(long, default_value_t = TracerKind::Bvh, value_parser = |s: &str| TracerKind::from_id(s).map_err(|e| e.to_string()))]
    tracer: TracerKind,
    /// Configurations predicted within this many per cent of the fastest are listed beside it
    /// (a flat optimum).
    #[arg(long, default_value_t = 3.0, value_parser = super::real::<f64>())]
    tolerance_pct: f64,
}

fn specs(args: &AdviseArgs) -> Vec<SchedulerSpec> {
    let mut out = Vec::new();
    for &kind in &args.schedulers {
        for &chunk in &args.chunks {
            let mut s = SchedulerSpec::new(kind, chunk, args.workers);
            s.slow = args.slow;
            // The hand-out settings of a rule with sources topped up to B (the master's).
            if s.policy.needs().outstanding.is_some() {
                for (name, value) in [
                    ("buffer", args.buffer.to_string()),
                    ("passes", args.passes.id().into()),
                ] {
                    s.set(name, &value)
                        .expect("a valid buffer and passes, from their parsers");
                }
            }
            out.push(s);
        }
    }
    out
}

/// The chunk a run uses: its own, or `auto:<tile>` for a policy that picks its layout.
fn chunk_text(spec: &SchedulerSpec, scene: &raysched::core::scene::Scene) -> String {
    if spec.kind().picks_own_layout() {
        format!("auto:{}", spec.layout(scene.width(), scene.height()).0)
    } else {
        spec.chunk.to_string()
    }
}

fn ms(s: f64) -> String {
    format!("{:.3}", s * 1e3)
}

pub(crate) fn advise_cmd(args: AdviseArgs) -> Result<(), CliError> {
    let specs = checked_specs(&args)?;
    let (scene, probed, spp, probe_spp) = probe_scene(&args, &specs)?;
    let advice = advise(&probed, &specs, spp, args.tolerance_pct / 100.0);
    print_probe(&args, &scene, &probed, spp, probe_spp);
    print_overheads(&probed);
    print_candidates(&advice, &scene);
    print_verdict(&args, &advice, &scene)
}

/// The candidates, each checked as a run would check it (e.g. more slowed workers than
/// workers), and the flags no candidate covers, all before the scene is loaded.
fn checked_specs(args: &AdviseArgs) -> Result<Vec<SchedulerSpec>, CliError> {
    if args.sources == AdviseSources::Mpi {
        return Err(CliError::message(
            "--sources mpi: the cost model covers local threads only",
        ));
    }
    if !(args.tolerance_pct.is_finite() && (0.0..=100.0).contains(&args.tolerance_pct)) {
        return Err(CliError::message(format!(
            "--tolerance-pct: must be within 0 … 100 (got {})",
            args.tolerance_pct
        )));
    }
    let specs = specs(args);
    for s in &specs {
        s.validate().map_err(|e| {
            CliError::message(format!("--{}: {}", e.field.replace('_', "-"), e.msg))
        })?;
    }
    Ok(specs)
}

/// Load the scene at the probe's spp and probe it with every candidate's policy; also the spp
/// the prediction is for and the probe's spp.
fn probe_scene(
    args: &AdviseArgs,
    specs: &[SchedulerSpec],
) -> Result<(Arc<Scene>, Probed, u32, u32), CliError> {
    let kind = args.tracer.available().map_err(CliError::input)?;
    super::out_path::check_input("SCENE", &args.scene)?;
    let full = load_scene(&args.scene, &SceneOverrides::default()).map_err(CliError::input)?;
    if full.frames() > 1 {
        return Err(CliError::message(format!(
            "{}: an animation ({} frames); the cost model probes one frame",
            args.scene.display(),
            full.frames()
        )));
    }
    let spp = args.spp.unwrap_or(full.settings.spp);
    let probe_spp = args.probe_spp.unwrap_or(spp.min(4));
    let over = SceneOverrides {
        spp: Some(probe_spp),
        ..Default::default()
    };
    let scene = Arc::new(load_scene(&args.scene, &over).map_err(CliError::input)?);
    let tracer = Arc::new(AnyTracer::build(kind, &scene, args.workers).map_err(CliError::input)?);
    let policies: Vec<Policy> = specs.iter().map(|s| s.policy).collect();
    let probed =
        Probed::measure(&scene, &tracer, args.workers, &policies).map_err(CliError::runtime)?;
    Ok((scene, probed, spp, probe_spp))
}

/// The scene, the settings and what the probe measured.
fn print_probe(args: &AdviseArgs, scene: &Scene, probed: &Probed, spp: u32, probe_spp: u32) {
    let px = probed.pixels.profile.pixels();
    let work_s: f64 = (probed.pixels.profile.pixel_s.iter())
        .map(|&t| probe::scaled_pixel(t, probed.pixels.fixed_pixel_s, probe_spp, spp))
        .sum();
    out!(
        "scene {} ({}×{}, {spp} spp, max_depth {}), tracer {}, {} workers{}",
        scene.name,
        scene.width(),
        scene.height(),
        scene.settings.max_depth,
        args.tracer,
        args.workers,
        if args.slow.is_none() {
            String::new()
        } else {
            format!(", slow {}", args.slow)
        }
    );
    out!(
        "probe {:.2} s: pixels at {probe_spp} spp on {} workers (median of 3 passes, calibrated to a render in rows), scaled to {spp} spp: \
         mean {:.2} µs, CV {:.2}, max/mean {:.1}, run-to-run noise {:.1} %; work W = {} ms; \
         per pixel {:.0} ns not scaled with spp, per item c {:.0} ns",
        probed.probe_s,
        args.workers,
        work_s / px.n as f64 * 1e6,
        px.cv(),
        px.max_over_mean(),
        probed.pixels.noise_cv * 100.0,
        ms(work_s),
        probed.pixels.fixed_pixel_s * 1e9,
        probed.pixels.per_item_s * 1e9
    );
}

/// Each policy's measured hand-out overheads.
fn print_overheads(probed: &Probed) {
    for (p, o) in &probed.overheads {
        // The master's line always carries its r (a noisy probe can measure 0).
        let refill = if p.needs().outstanding.is_some() {
            format!(", refill period r {:.0} ns", o.refill_s * 1e9)
        } else {
            String::new()
        };
        out!(
            "  {:<20} h {:>7.1} ns per item, fixed F {:>7.1} µs{refill}",
            p.kind().id(),
            o.per_item_s * 1e9,
            o.fixed_s * 1e6
        );
    }
}

/// The prediction of every candidate, one line each.
fn print_candidates(advice: &Advice, scene: &Scene) {
    out!(
        "{:<20} {:>8} {:>8} {:>11} {:>9} {:>9} {:>9} {:>11}",
        "scheduler",
        "chunk",
        "items",
        "predicted",
        "work",
        "hand-out",
        "refill",
        "imbalance"
    );
    for c in &advice.candidates {
        let p = &c.prediction;
        let chunk = chunk_text(&c.spec, scene);
        out!(
            "{:<20} {:>8} {:>8} {:>8} ms {:>9} {:>9} {:>9} {:>11}",
            c.spec.kind().id(),
            chunk,
            p.items,
            ms(p.wall_s),
            ms(p.work_s),
            ms(p.handout_s),
            ms(p.refill_s),
            ms(p.imbalance_s)
        );
    }
}

/// The best candidate and those predicted within the tolerance of it.
fn print_verdict(args: &AdviseArgs, advice: &Advice, scene: &Scene) -> Result<(), CliError> {
    let Some(&best) = advice.near_best.first() else {
        return Err(CliError::message("no candidate to advise on"));
    };
    let b = &advice.candidates[best];
    out!(
        "best: {} chunk={} at {} ms predicted",
        b.spec.kind().id(),
        chunk_text(&b.spec, scene),
        ms(b.prediction.wall_s)
    );
    if advice.near_best.len() > 1 {
        let near: Vec<String> = advice.near_best[1..]
            .iter()
            .map(|&i| {
                let c = &advice.candidates[i];
                format!(
                    "{} chunk={}",
                    c.spec.kind().id(),
                    chunk_text(&c.spec, scene)
                )
            })
            .collect();
        out!(
            "flat: {} configurations within {} % of the best: {}",
            advice.near_best.len(),
            args.tolerance_pct,
            near.join(", ")
        );
    } else {
        out!(
            "a clear optimum: no other configuration within {} % of the best",
            args.tolerance_pct
        );
    }
    Ok(())
}
