//! The command line: parse, run, print errors once with their chain, map them to exit codes.
//! Bad input (scene, config, parameters) exits with code 2; other failures with 1.

use crate::scene::{load_scene, SceneOverrides};
use crate::sched::{run_scheduler_with, Chunk, Order, Requeue, RunOptions, SchedError, SchedulerKind, SchedulerSpec, Wait};
use crate::tracer::AnyTracer;
use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(name = "raysched", version, about = "Measure how parallel ray-tracing work should be handed out, and by whom")]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render one scene and write OUT (.exr or .pfm, linear) plus an sRGB .png preview beside it.
    Render(RenderArgs),
}

#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    /// Scene file (TOML), see scenes/.
    pub scene: PathBuf,
    /// Samples per pixel (overrides the scene's render.spp).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Worker threads.
    #[arg(long, default_value_t = default_threads())]
    pub threads: usize,
    /// Tracer: bvh (native CWBVH), brute (reference), embree (feature `embree`).
    #[arg(long, default_value = "bvh")]
    pub tracer: String,
    /// Output image; the format follows the extension (.exr or .pfm).
    #[arg(short, long, default_value = "results/render.exr")]
    pub output: PathBuf,
    /// Scheduler: static, static_cyclic, master, work_stealing (rayon), work_stealing_deque,
    /// self_scheduling, guided.
    #[arg(long, default_value = "work_stealing")]
    pub scheduler: String,
    /// Work item size: N (N×N tile; 1 = per ray), WxH, rows:N, frame.
    #[arg(long, default_value = "16")]
    pub chunk: String,
    /// Hand-out order of the items: scanline, morton, hilbert.
    #[arg(long, default_value = "scanline")]
    pub order: String,
    /// Master: items outstanding per compute source.
    #[arg(long, default_value_t = 2)]
    pub buffer: usize,
    /// Master: re-queue policy: seed, never, timeout:<ms>.
    #[arg(long, default_value = "seed")]
    pub requeue: String,
    /// Master: wait strategy: spin, yield, block.
    #[arg(long, default_value = "block")]
    pub wait: String,
    /// self_scheduling: items per grab; guided: minimum grab; work_stealing: minimum split.
    #[arg(long, default_value_t = 1)]
    pub grab: usize,
    /// guided: k in chunk = max(grab, remaining / (k·threads)).
    #[arg(long, default_value_t = 2)]
    pub guided_k: usize,
    /// Record a (worker, item, start, end) timeline.
    #[arg(long)]
    pub timeline: bool,
    /// Do not time items (busy/idle and master times read 0).
    #[arg(long)]
    pub stats_off: bool,
    /// Master: give up after this many milliseconds.
    #[arg(long)]
    pub deadline_ms: Option<u64>,
    /// Compute sources: local (threads) or mpi (ranks 1…K−1 under `mpirun -n K`; feature `mpi`).
    #[arg(long, default_value = "local")]
    pub sources: String,
    /// With --sources mpi: worker threads on rank 0 besides the ranks (a heterogeneous run).
    #[arg(long, default_value_t = 0)]
    pub local_threads: usize,
}

impl RenderArgs {
    /// The scheduler spec, every value checked; errors name the flag.
    pub fn scheduler_spec(&self) -> Result<SchedulerSpec, CliError> {
        let flag = |e: crate::sched::SpecError| {
            let name = match e.field.as_str() {
                "workers" => "threads".to_string(),
                f => f.replace('_', "-"),
            };
            CliError::input(anyhow::anyhow!("--{name}: {}", e.msg))
        };
        let spec = SchedulerSpec {
            kind: SchedulerKind::from_id(&self.scheduler).map_err(flag)?,
            chunk: Chunk::parse(&self.chunk).map_err(flag)?,
            order: Order::from_id(&self.order).map_err(flag)?,
            workers: self.threads,
            buffer: self.buffer,
            requeue: Requeue::parse(&self.requeue).map_err(flag)?,
            wait: Wait::from_id(&self.wait).map_err(flag)?,
            grab: self.grab,
            guided_k: self.guided_k,
            timeline: self.timeline,
        };
        spec.validate().map_err(flag)?;
        Ok(spec)
    }
}

pub fn default_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// An error with the exit code it maps to.
#[derive(Debug)]
pub struct CliError {
    pub code: u8,
    pub error: anyhow::Error,
}

impl CliError {
    pub fn input(error: impl Into<anyhow::Error>) -> Self {
        Self {
            code: 2,
            error: error.into(),
        }
    }
    pub fn runtime(error: impl Into<anyhow::Error>) -> Self {
        Self {
            code: 1,
            error: error.into(),
        }
    }
}

pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {:#}", e.error);
            ExitCode::from(e.code)
        }
    }
}

pub fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Render(args) => render(args),
    }
}

fn render(args: RenderArgs) -> Result<(), CliError> {
    match args.sources.as_str() {
        "local" => {}
        #[cfg(feature = "mpi")]
        "mpi" => return crate::mpi::run::render(args),
        #[cfg(not(feature = "mpi"))]
        "mpi" => {
            return Err(CliError::input(anyhow::anyhow!(
                "--sources mpi: this raysched was built without feature `mpi` (cargo build --features mpi)"
            )))
        }
        s => return Err(CliError::input(anyhow::anyhow!("--sources: unknown '{s}' (expected local or mpi)"))),
    }
    if args.threads == 0 {
        return Err(CliError::input(anyhow::anyhow!("--threads: must be ≥ 1 (got 0)")));
    }
    let ext = args
        .output
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if !matches!(ext.as_deref(), Some("exr" | "pfm")) {
        return Err(CliError::input(anyhow::anyhow!(
            "--output {}: unsupported extension (use .exr or .pfm)",
            args.output.display()
        )));
    }
    let overrides = SceneOverrides {
        spp: args.spp,
        ..Default::default()
    };
    if args.spp == Some(0) {
        return Err(CliError::input(anyhow::anyhow!("--spp: must be ≥ 1 (got 0)")));
    }
    let spec = args.scheduler_spec()?;
    let scene = std::sync::Arc::new(load_scene(&args.scene, &overrides).map_err(CliError::input)?);
    let t0 = Instant::now();
    let tracer =
        std::sync::Arc::new(AnyTracer::build(&args.tracer, &scene, args.threads).map_err(CliError::input)?);
    let build = t0.elapsed();
    let opts = RunOptions {
        stats: !args.stats_off,
        deadline: args.deadline_ms.map(std::time::Duration::from_millis),
        faults: None,
    };
    let (image, stats) = run_scheduler_with(&spec, &scene, &tracer, &opts).map_err(|e| match e {
        SchedError::Spec(_) => CliError::input(e),
        _ => CliError::runtime(e),
    })?;
    let (wall, rays, nonfinite) = (stats.wall_s, stats.rays, stats.nonfinite);
    if let Some(dir) = args.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(CliError::runtime)?;
    }
    let png = image
        .save_with_preview(&args.output)
        .map_err(CliError::runtime)?;
    println!(
        "scene {} ({}×{}, {} spp, max_depth {}), tracer {} built in {:.3} s, {} threads",
        scene.name,
        scene.width(),
        scene.height(),
        scene.settings.spp,
        scene.settings.max_depth,
        args.tracer,
        build.as_secs_f64(),
        args.threads
    );
    println!("scheduler {}, order {}, image hash {:016x}", spec.label(), spec.order.id(), image.hash());
    println!(
        "wall {:.3} s, rays {}, {:.2} Mrays/s, non-finite samples {}",
        wall,
        rays,
        rays as f64 / wall / 1e6,
        nonfinite
    );
    print!("{}", stats.summary());
    println!("wrote {} and {}", args.output.display(), png.display());
    Ok(())
}
