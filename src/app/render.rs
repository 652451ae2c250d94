//! `raysched render`: one scene under one scheduler, on local threads or (feature `mpi`) on
//! MPI ranks.

use super::error::CliError;
use super::sched_flags::SchedulerFlags;
use raysched::render::Image;
use raysched::scene::{load_scene, Scene, SceneOverrides};
use raysched::sched::{
    run_scheduler_with, RunOptions, SchedError, SchedulerSpec, SourceKind, SourceSet,
};
use raysched::tracer::{AnyTracer, Tracer, TracerKind};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// `--sources`: the library's parser and its one-line error.
fn parse_sources(s: &str) -> Result<SourceSet, String> {
    SourceSet::parse(s).map_err(|e| e.msg)
}

#[derive(clap::Args, Debug)]
pub(crate) struct RenderArgs {
    /// Scene file (TOML), see scenes/.
    pub(crate) scene: PathBuf,
    /// Samples per pixel (overrides the scene's render.spp).
    #[arg(long, value_parser = super::spp_arg())]
    pub(crate) spp: Option<u32>,
    /// Worker threads.
    #[arg(long, default_value_t = raysched::host::available_threads(), value_parser = super::threads_arg(1))]
    pub(crate) threads: usize,
    /// Tracer: bvh (native: obvhs build, own 8-wide traversal), brute (reference), embree and
    /// embree_robust (feature `embree`, Embree 3), embree4 and embree4_robust (feature `embree4`).
    #[arg(long, default_value_t = TracerKind::Bvh, value_parser = parse_tracer)]
    pub(crate) tracer: TracerKind,
    /// Output image; the format follows the extension (.exr or .pfm).
    #[arg(short, long, default_value = "results/runs/render.exr")]
    pub(crate) output: PathBuf,
    #[command(flatten)]
    pub(crate) scheduler: SchedulerFlags,
    /// Record a (worker, item, start, end) timeline.
    #[arg(long)]
    pub(crate) timeline: bool,
    /// Do not time items (busy/idle and master times read 0).
    #[arg(long)]
    pub(crate) stats_off: bool,
    /// Master: give up after this many milliseconds.
    #[arg(long)]
    pub(crate) deadline_ms: Option<u64>,
    /// Compute sources: threads (alias local), gpu (feature `gpu`), threads,gpu (a
    /// heterogeneous run under the master), or mpi (feature `mpi`, under mpirun).
    #[arg(long, default_value = "threads", value_parser = parse_sources)]
    pub(crate) sources: SourceSet,
    /// With gpu among --sources: the adapter whose name contains NAME (default: the
    /// high-performance one, discrete before integrated before a CPU implementation).
    #[arg(long, value_name = "NAME")]
    pub(crate) gpu_adapter: Option<String>,
    /// With gpu among --sources: first print per-ray traversal counters (node fetches, bytes,
    /// box and triangle tests, stack depth) of the binary and the wide BVH over the primary
    /// rays, from the kernel's debug pipeline and from the CPU walk of the same structure.
    #[arg(long)]
    pub(crate) gpu_counters: bool,
    #[command(flatten)]
    pub(crate) source_flags: super::sched_flags::SourceFlags,
    /// With --sources mpi: worker threads on rank 0 besides the ranks (a heterogeneous run).
    #[arg(long, default_value_t = 0, value_parser = super::threads_arg(0))]
    pub(crate) local_threads: usize,
}

impl RenderArgs {
    /// The scheduler spec for `workers`, every value checked; errors name the flag.
    pub(crate) fn scheduler_spec(&self, workers: usize) -> Result<SchedulerSpec, CliError> {
        self.scheduler
            .spec(workers, self.timeline)
            .map_err(CliError::message)
    }

    /// The checks every render makes before loading anything: output format and sample count.
    pub(crate) fn check_output(&self) -> Result<SceneOverrides, CliError> {
        let ext = self
            .output
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        if !matches!(ext.as_deref(), Some("exr" | "pfm")) {
            return Err(CliError::message(format!(
                "--output {}: unsupported extension (use .exr or .pfm)",
                self.output.display()
            )));
        }
        if self.spp == Some(0) {
            return Err(CliError::message("--spp: must be ≥ 1 (got 0)"));
        }
        Ok(SceneOverrides {
            spp: self.spp,
            ..Default::default()
        })
    }

    /// `--sources` with the per-source flags; errors name the flag.
    pub(crate) fn source_setup(&self) -> Result<raysched::sched::SourceSetup, CliError> {
        self.source_flags
            .setup(&self.sources)
            .map_err(CliError::message)
    }

    /// Run settings that are not part of the scheduler's identity.
    pub(crate) fn run_options(&self) -> RunOptions {
        RunOptions {
            stats: !self.stats_off,
            deadline: self.deadline_ms.map(Duration::from_millis),
            faults: None,
        }
    }
}

/// `--tracer`: the library's own message for an unknown id (it lists the ids).
fn parse_tracer(s: &str) -> Result<TracerKind, String> {
    TracerKind::from_id(s).map_err(|e| e.to_string())
}

pub(crate) fn render(args: RenderArgs) -> Result<(), CliError> {
    // With feature `mpi`, `--sources mpi` is dispatched to the MPI front-end before this.
    if args.sources.has(SourceKind::Mpi) {
        return Err(CliError::message(
            "--sources mpi: this raysched was built without feature `mpi` (cargo build --features mpi)",
        ));
    }
    if args.sources.has(SourceKind::Gpu) {
        return super::gpu_render::render(args);
    }
    if args.gpu_adapter.is_some() {
        return Err(CliError::message(
            "--gpu-adapter: needs gpu among --sources",
        ));
    }
    if args.gpu_counters {
        return Err(CliError::message(
            "--gpu-counters: needs gpu among --sources",
        ));
    }
    // The per-source flags (--gpu-chunk, --gpu-buffer, --balance) say why they do not apply.
    args.source_setup()?;
    if args.threads == 0 {
        return Err(CliError::message("--threads: must be ≥ 1 (got 0)"));
    }
    let overrides = args.check_output()?;
    let spec = args.scheduler_spec(args.threads)?;
    let kind = args.tracer.available().map_err(CliError::input)?;
    let scene = Arc::new(load_scene(&args.scene, &overrides).map_err(CliError::input)?);
    if let Some(w) = scene.depth_warning() {
        eprintln!("warning: {}: {w}", args.scene.display());
    }
    let t0 = Instant::now();
    let tracer = Arc::new(AnyTracer::build(kind, &scene, args.threads).map_err(CliError::input)?);
    let build = t0.elapsed();
    let (image, stats) =
        run_scheduler_with(&spec, &scene, &tracer, &args.run_options()).map_err(|e| match e {
            SchedError::Spec(_) => CliError::input(e),
            _ => CliError::runtime(e),
        })?;
    let wrote = save_render(&args.output, &image, scene.frames()).map_err(CliError::runtime)?;
    let tracer_line = format!(
        "{} built in {:.3} s, {} threads",
        args.tracer,
        build.as_secs_f64(),
        args.threads
    );
    print_render_header(&scene, &tracer_line, &spec, &image);
    print_render_footer(&scene, &stats, tracer.accelerated(), &wrote);
    Ok(())
}

/// The rest of a local render's report after [`print_render_header`]: throughput, the
/// statistics (per worker, with its kind of source), the scene features used and the files
/// written.
pub(crate) fn print_render_footer(
    scene: &Scene,
    stats: &raysched::metrics::RunStats,
    accelerated: bool,
    wrote: &str,
) {
    out!(
        "wall {:.3} s, rays {}, {:.2} Mrays/s, non-finite samples {}",
        stats.wall_s,
        stats.rays,
        stats.rays as f64 / stats.wall_s / 1e6,
        stats.nonfinite
    );
    super::write_stdout(format_args!("{}", stats.summary()));
    let (used, left_out) = scene.feature_report(accelerated);
    out!(
        "features used: {}; left out: {}",
        used.join(","),
        left_out.join(",")
    );
    out!("wrote {wrote}");
}

/// `name_fNNNN.ext` beside `output = name.ext`: the file of frame `frame` of an animation.
fn frame_path(output: &Path, frame: u32) -> PathBuf {
    let stem = output.file_stem().unwrap_or_default().to_string_lossy();
    let ext = output.extension().unwrap_or_default().to_string_lossy();
    output.with_file_name(format!("{stem}_f{frame:04}.{ext}"))
}

/// Write a render and its PNG preview: `output` for a static scene, [`frame_path`] per frame
/// for an animation (`image` is then the film strip of [`Image::stack`]). Every file is
/// written to a staging folder first and renamed into place once all were written, so a
/// failure leaves none. Returns what was written, for the report.
pub(crate) fn save_render(
    output: &Path,
    image: &Image,
    frames: u32,
) -> Result<String, anyhow::Error> {
    let root = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let staging = raysched::staging::Staging::new(&root)
        .map_err(|e| anyhow::anyhow!("{}: {e}", root.display()))?;
    let staged = |p: &Path| staging.path(p.file_name().unwrap_or_default());
    let summary = if frames <= 1 {
        image.save_with_preview(&staged(output))?;
        let png = output.with_extension("png");
        format!("{} and {}", output.display(), png.display())
    } else {
        for (k, frame) in image.unstack(frames).iter().enumerate() {
            frame.save_with_preview(&staged(&frame_path(output, k as u32)))?;
        }
        format!(
            "{frames} frames {} … {} (each with a .png preview)",
            frame_path(output, 0).display(),
            frame_path(output, frames - 1).display()
        )
    };
    staging
        .commit()
        .map_err(|e| anyhow::anyhow!("{}: {e}", root.display()))?;
    Ok(summary)
}

/// The first two lines of a render's report, shared by the local and the MPI path (tests read
/// the image hash from them).
pub(crate) fn print_render_header(
    scene: &Scene,
    tracer: &str,
    spec: &SchedulerSpec,
    image: &Image,
) {
    let frames = if scene.frames() > 1 {
        format!(" × {} frames", scene.frames())
    } else {
        String::new()
    };
    out!(
        "scene {} ({}×{}{frames}, {} spp, max_depth {}), tracer {tracer}",
        scene.name,
        scene.width(),
        scene.height(),
        scene.settings.spp,
        scene.settings.max_depth,
    );
    out!(
        "scheduler {}, order {}, image hash {:016x}",
        spec.label(),
        spec.order.id(),
        image.hash()
    );
}
