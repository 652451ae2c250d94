//! `raysched render`: one scene under one scheduler, on local threads or (feature `mpi`) on
//! MPI ranks.

use super::error::CliError;
use super::sched_flags::SchedulerFlags;
use raysched::core::render::Image;
use raysched::core::scene::{load_scene, Scene, SceneOverrides};
use raysched::core::tracer::{AnyTracer, Tracer, TracerKind};
use raysched::sched::{
    render_scene, RenderOn, RunOptions, SchedError, SchedulerSpec, SourceKind, SourceSet,
};
use raysched::util::limits::{MAX_DEPTH, MAX_IMAGE_SIDE};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// `--sources`: the library's parser and its one-line error. `local`, which the library reads
/// back from old CSV files, is not a second name on the command line: `threads` is the one
/// word for local threads in every command.
pub(crate) fn parse_sources(s: &str) -> Result<SourceSet, String> {
    if s.split([',', '+']).any(|k| k.trim() == "local") {
        return Err("unknown compute source 'local', did you mean threads?".into());
    }
    SourceSet::parse(s).map_err(|e| e.msg)
}

/// Longest `--deadline-ms`: a year (a deadline past the clock's range would overflow it).
const MAX_DEADLINE_MS: u64 = 365 * 86_400_000;

/// `--max-depth`: -1 (unlimited, capped at [`MAX_DEPTH`]) or 1 … [`MAX_DEPTH`], as `render.max_depth`.
fn parse_max_depth(s: &str) -> Result<i32, String> {
    match s.trim().parse::<i64>() {
        Ok(d) if d == -1 || (1..=i64::from(MAX_DEPTH)).contains(&d) => Ok(d as i32),
        _ => Err(format!(
            "expected -1 (unlimited) or a whole number from 1 to {MAX_DEPTH}"
        )),
    }
}

#[derive(clap::Args, Debug)]
pub(crate) struct RenderArgs {
    /// Scene file (TOML), see scenes/.
    pub(crate) scene: PathBuf,
    /// Samples per pixel (overrides the scene's render.spp).
    #[arg(long, value_parser = super::spp_arg())]
    pub(crate) spp: Option<u32>,
    /// Image width in pixels (overrides the scene's camera.width).
    #[arg(long, value_parser = super::whole::<u32>(1, MAX_IMAGE_SIDE as u64))]
    pub(crate) width: Option<u32>,
    /// Image height in pixels (overrides the scene's camera.height).
    #[arg(long, value_parser = super::whole::<u32>(1, MAX_IMAGE_SIDE as u64))]
    pub(crate) height: Option<u32>,
    /// Path segments, -1 for unlimited (overrides the scene's render.max_depth).
    #[arg(long, value_parser = parse_max_depth, allow_negative_numbers = true)]
    pub(crate) max_depth: Option<i32>,
    /// Worker threads.
    #[arg(long, default_value_t = raysched::util::host::available_threads(), value_parser = super::threads_arg(1))]
    pub(crate) threads: usize,
    /// Tracer: bvh (native: obvhs build, own 8-wide traversal), brute (reference), embree and
    /// embree_robust (feature `embree`, Embree 3), embree4 and embree4_robust (feature `embree4`).
    #[arg(long, default_value_t = TracerKind::Bvh, value_parser = parse_tracer)]
    pub(crate) tracer: TracerKind,
    /// Output image; the format follows the extension: .exr or .pfm (linear), with an sRGB
    /// .png preview beside it; or .png, with the linear .exr beside it (both are written).
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
    /// Master: give up after this many milliseconds (≥ 1).
    #[arg(long, value_parser = super::whole::<u64>(1, MAX_DEADLINE_MS))]
    pub(crate) deadline_ms: Option<u64>,
    /// Compute sources: threads, gpu (feature `gpu`), threads,gpu (a
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
    /// The scheduler spec for `workers`, every value checked; errors name the flag. With a
    /// GPU among the sources and no `--scheduler`, the master: it gives each kind of source
    /// its own buffer and grain.
    pub(crate) fn scheduler_spec(&self, workers: usize) -> Result<SchedulerSpec, CliError> {
        let flags = if self.sources.has(SourceKind::Threads) && self.sources.kinds().len() == 1 {
            self.scheduler.clone()
        } else {
            self.scheduler
                .defaulting_to(raysched::sched::SchedulerKind::FOR_MIXED_SOURCES)
        };
        flags
            .spec(workers, self.timeline)
            .map_err(CliError::message)
    }

    /// The checks every render makes before loading anything: output format and paths (the
    /// image and its companion can be written), sample count; the scene overrides.
    pub(crate) fn check_output(&self) -> Result<SceneOverrides, CliError> {
        let ext = self
            .output
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        if !matches!(ext.as_deref(), Some("exr" | "pfm" | "png")) {
            return Err(CliError::message(format!(
                "--output {}: unsupported extension (use .exr, .pfm or .png)",
                raysched::util::one_line::escape_controls(&self.output.to_string_lossy())
            )));
        }
        super::out_path::check_input("SCENE", &self.scene)?;
        let linear = linear_path(&self.output);
        for p in [linear.clone(), linear.with_extension("png")] {
            super::out_path::check("--output", &p, super::out_path::Kind::File)?;
        }
        if self.spp == Some(0) {
            return Err(CliError::message("--spp: must be ≥ 1 (got 0)"));
        }
        Ok(SceneOverrides {
            spp: self.spp,
            width: self.width,
            height: self.height,
            max_depth: self.max_depth,
            ..Default::default()
        })
    }

    /// A scene error caused by an override names the flag rather than the scene's field.
    pub(crate) fn blame_overrides(&self, e: raysched::core::scene::SceneError) -> CliError {
        let flag = match e.field.as_str() {
            "camera.width" if self.width.is_some() => "--width",
            "camera.height" if self.height.is_some() => "--height",
            "camera.width" | "camera.height" | "animation.frames"
                if self.width.is_some() || self.height.is_some() =>
            {
                "--width/--height"
            }
            "render.spp" if self.spp.is_some() => "--spp",
            _ => return CliError::input(e),
        };
        CliError::message(format!("{flag}: {} ({})", e.msg, e.path))
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
    // With feature `mpi`, `--sources mpi` is dispatched to the MPI launch before this.
    if args.sources.has(SourceKind::Mpi) {
        return Err(CliError::message(
            "--sources mpi: this raysched was built without feature `mpi` (cargo build --features mpi)",
        ));
    }
    let gpu_asked = args.sources.has(SourceKind::Gpu);
    if args.gpu_adapter.is_some() && !gpu_asked {
        return Err(CliError::message(
            "--gpu-adapter: needs gpu among --sources",
        ));
    }
    if args.gpu_counters && !gpu_asked {
        return Err(CliError::message(
            "--gpu-counters: needs gpu among --sources",
        ));
    }
    // The per-source flags (--gpu-chunk, --gpu-buffer, --balance) say why they do not apply.
    let setup = args.source_setup()?;
    let threads = if args.sources.has(SourceKind::Threads) {
        if args.threads == 0 {
            return Err(CliError::message("--threads: must be ≥ 1 (got 0)"));
        }
        args.threads
    } else {
        0
    };
    let overrides = args.check_output()?;
    let spec = args.scheduler_spec(threads.max(1))?;
    if setup.set != SourceSet::threads() {
        if !raysched::sched::kinds::over_sources(spec.kind()) {
            return Err(CliError::message(format!(
                "--scheduler {}: stealing needs workers that share memory, not a GPU (use \
                 master or a scheduler without stealing)",
                spec.kind().id()
            )));
        }
        if let Some(r) = gpu_asked
            .then(|| raysched::sched::Runner::Gpu.refuses(&spec.policy))
            .flatten()
        {
            return Err(CliError::message(r.as_flag()));
        }
    }
    let kind = args.tracer.available().map_err(CliError::input)?;
    let scene = Arc::new(load_scene(&args.scene, &overrides).map_err(|e| args.blame_overrides(e))?);
    if let Some(w) = scene.depth_warning() {
        eprintln!("warning: {}: {w}", args.scene.display());
    }
    let gpu = super::gpu::open(
        &args.sources,
        (args.gpu_adapter.as_deref(), args.gpu_counters),
        (&scene, &args.scene),
    )?;
    warn_few_items(&spec, &scene, args.threads);
    let t0 = Instant::now();
    let tracer = Arc::new(AnyTracer::build(kind, &scene, threads.max(1)).map_err(CliError::input)?);
    let build = t0.elapsed();
    let as_cli = |e: SchedError| match e {
        SchedError::Spec(_) => CliError::input(e),
        _ => CliError::runtime(e),
    };
    let on = RenderOn {
        setup: &setup,
        #[cfg(feature = "gpu")]
        gpu: gpu.as_ref().map(|g| g.renderer.clone()),
    };
    let (frames, stats) =
        render_scene(&spec, &scene, &tracer, &on, &args.run_options()).map_err(as_cli)?;
    let image = Image::stack(frames);
    let wrote = save_render(&args.output, &image, scene.frames()).map_err(CliError::runtime)?;
    let mut tracer_line = format!(
        "{} built in {:.3} s, {threads} threads",
        args.tracer,
        build.as_secs_f64(),
    );
    if let Some(g) = &gpu {
        tracer_line += &format!("; {}", g.line);
    }
    print_render_header(&scene, &tracer_line, &spec, &image);
    print_render_footer(&scene, &stats, tracer.accelerated(), &wrote);
    Ok(())
}

/// The rest of a local render's report after [`print_render_header`]: throughput, the
/// statistics (per worker, with its kind of source), the scene features used and the files
/// written.
pub(crate) fn print_render_footer(
    scene: &Scene,
    stats: &raysched::core::metrics::RunStats,
    accelerated: bool,
    wrote: &str,
) {
    // The summary's first line holds the wall time and the rays: said once.
    super::write_stdout(format_args!("{}", stats.summary()));
    out!(
        "{:.2} Mrays/s, non-finite samples {}",
        stats.rays as f64 / stats.wall_s / 1e6,
        stats.nonfinite
    );
    let (used, left_out) = scene.feature_report(accelerated);
    out!(
        "features used: {}; left out: {}",
        used.join(","),
        left_out.join(",")
    );
    out!("wrote {wrote}");
}

/// The linear image of a render to `output`: itself, or for `-o c.png` the `c.exr` beside
/// it (the PNG preview is always written beside the linear image).
fn linear_path(output: &Path) -> PathBuf {
    let png = output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if png {
        output.with_extension("exr")
    } else {
        output.to_path_buf()
    }
}

/// A warning when the run has fewer items than workers (`--chunk 512` on a 128² image is one
/// item: one worker renders, the others wait). The run is valid, just not parallel.
pub(crate) fn warn_few_items(spec: &SchedulerSpec, scene: &Scene, workers: usize) {
    if spec.kind().picks_own_layout() || workers < 2 {
        return;
    }
    let (w, h, frames) = (scene.width(), scene.height(), scene.frames());
    let items = raysched::studies::experiment::dry_run::item_count(spec, w, h, frames);
    if items < workers as u64 {
        let (chunk, _) = spec.layout(w, h);
        eprintln!(
            "warning: --chunk {chunk} cuts the {w}×{h} image into {items} item(s): {items} of {workers} workers busy, the rest wait (a smaller --chunk gives each one work)"
        );
    }
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
    let output = &linear_path(output);
    let root = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let staging = raysched::util::staging::Staging::new(&root)
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
