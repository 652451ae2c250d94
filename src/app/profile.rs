//! `raysched profile SCENE`: the per-pixel and per-item cost distribution of a scene, and a
//! heat map of cost per pixel.

use super::error::CliError;
use raysched::core::scene::{load_scene, SceneOverrides};
use raysched::core::tracer::{AnyTracer, TracerKind};
use raysched::sched::Chunk;
use raysched::studies::profile::{CostStats, Profile};
use std::path::PathBuf;
use std::sync::Arc;

#[derive(clap::Args, Debug)]
pub(crate) struct ProfileArgs {
    /// Scene file (TOML), see scenes/.
    scene: PathBuf,
    /// Samples per pixel (overrides the scene's render.spp).
    #[arg(long, value_parser = super::spp_arg())]
    spp: Option<u32>,
    /// Tracer id (bvh, brute, embree, embree_robust).
    #[arg(long, default_value_t = TracerKind::Bvh, value_parser = |s: &str| TracerKind::from_id(s).map_err(|e| e.to_string()))]
    tracer: TracerKind,
    /// Granularities whose per-item distribution to show, comma-separated.
    #[arg(long, default_value = "1,2,4,8,16,32,64,rows:1,frame", value_delimiter = ',',
          value_parser = super::parse_chunk)]
    chunks: Vec<Chunk>,
    /// Renders of the image; each pixel keeps its cheapest (drops preemption spikes).
    #[arg(long, default_value_t = 3, value_parser = super::whole::<u32>(1, 100))]
    repeats: u32,
    /// Renamed --repeats (`--passes` names who runs the master's passes in render and advise).
    #[arg(long = "passes", hide = true, value_name = "N", value_parser = renamed_passes)]
    passes: Option<u32>,
    /// The heat map of cost per pixel (PNG).
    #[arg(short, long, default_value = "results/profile.png")]
    output: PathBuf,
}

/// The old spelling of `--repeats`: refused with the new one.
fn renamed_passes(_: &str) -> Result<u32, String> {
    Err("profile's count is now --repeats (--passes is who runs the master's passes, in render and advise), did you mean --repeats?".into())
}

fn line(what: &str, s: &CostStats) -> String {
    format!(
        "{what:>10} {:>8} {:>10.3} {:>10.3} {:>6.2} {:>10.3} {:>9.1}",
        s.n,
        s.mean * 1e6,
        s.sd * 1e6,
        s.cv(),
        s.max * 1e6,
        s.max_over_mean()
    )
}

pub(crate) fn profile(args: ProfileArgs) -> Result<(), CliError> {
    if args.spp == Some(0) {
        return Err(CliError::message("--spp: must be ≥ 1 (got 0)"));
    }
    if args.output.extension().and_then(|e| e.to_str()) != Some("png") {
        return Err(CliError::message(format!(
            "--output {}: the heat map is a .png",
            raysched::util::one_line::escape_controls(&args.output.to_string_lossy())
        )));
    }
    super::out_path::check("--output", &args.output, super::out_path::Kind::File)?;
    super::out_path::check_input("SCENE", &args.scene)?;
    let overrides = SceneOverrides {
        spp: args.spp,
        ..Default::default()
    };
    let kind = args.tracer.available().map_err(CliError::input)?;
    let scene = Arc::new(load_scene(&args.scene, &overrides).map_err(CliError::input)?);
    let tracer = Arc::new(AnyTracer::build(kind, &scene, 1).map_err(CliError::input)?);
    let p = Profile::measure_min(&scene, &tracer, args.repeats).map_err(CliError::runtime)?;
    out!(
        "scene {} ({}×{}, {} spp, max_depth {}), tracer {}, one worker, one pixel per item, \
         cheapest of {} renders per pixel",
        scene.name,
        scene.width(),
        scene.height(),
        scene.settings.spp,
        scene.settings.max_depth,
        args.tracer,
        args.repeats
    );
    out!(
        "{:>10} {:>8} {:>10} {:>10} {:>6} {:>10} {:>9}",
        "chunk",
        "items",
        "mean µs",
        "σ µs",
        "CV",
        "max µs",
        "max/mean"
    );
    out!("{}", line("pixel", &p.pixels()));
    for c in &args.chunks {
        out!("{}", line(&c.to_string(), &p.items(*c)));
    }
    out!(
        "total {:.3} s; the costliest 1 % of pixels hold {:.1} % of it, the costliest 10 % {:.1} %; \
         the costliest 1 % cost {:.0}× the median pixel, the costliest 10 % {:.0}×",
        p.pixels().total,
        100.0 * p.share_of_top(0.01),
        100.0 * p.share_of_top(0.10),
        p.hot_over_median(0.01),
        p.hot_over_median(0.10)
    );
    if let Some(dir) = args.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| CliError::runtime(anyhow::anyhow!("{}: {e}", dir.display())))?;
    }
    p.save_heat_map(&args.output)
        .map_err(|e| CliError::runtime(anyhow::anyhow!(e)))?;
    out!(
        "wrote {} (cost per pixel on a log scale; the colour bar beside the image gives µs per pixel)",
        args.output.display()
    );
    Ok(())
}
