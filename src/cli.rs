//! The command line: parse, run, print errors once with their chain, map them to exit codes.
//! Bad input (scene, config, parameters) exits with code 2; other failures with 1.

use crate::scene::{load_scene, SceneOverrides};
use crate::sched::{
    run_scheduler_with, Chunk, Order, Requeue, RunOptions, SchedError, SchedulerKind,
    SchedulerSpec, Wait,
};
use crate::tracer::{AnyTracer, TracerKind};
use clap::{Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(
    name = "raysched",
    version,
    about = "Measure how parallel ray-tracing work should be handed out, and by whom"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render one scene and write OUT (.exr or .pfm, linear) plus an sRGB .png preview beside it.
    Render(RenderArgs),
    /// Run an experiment (experiments/*.toml): runs.csv, summary.csv, plots and report.md under
    /// OUT/<experiment>/. Resumes where a previous run stopped.
    Run(RunArgs),
    /// Regenerate summary.csv, every plot and report.md of a results folder from its CSV files.
    Plot(PlotArgs),
    /// Error against run time: progressive render (1, 2, 4, … spp) vs a reference; CSV + plot.
    Converge(ConvergeArgs),
    /// The numerical stability suite: CSV + markdown table of every case.
    Stability(StabilityArgs),
}

#[derive(clap::Args, Debug)]
pub struct RunArgs {
    /// Experiment file (TOML), see experiments/.
    pub experiment: PathBuf,
    /// Discard earlier results of this experiment and start over.
    #[arg(long)]
    pub fresh: bool,
    /// No progress bar (for scripts).
    #[arg(long)]
    pub quiet: bool,
    /// Results root; the experiment writes to OUT/<experiment name>/.
    #[arg(long, default_value = "results")]
    pub out: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct PlotArgs {
    /// A results folder, e.g. results/quick.
    pub dir: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct ConvergeArgs {
    /// Scene file (TOML).
    pub scene: PathBuf,
    /// Reference image (.exr); default: analytic, else a cached high-spp render.
    #[arg(long = "ref")]
    pub reference: Option<PathBuf>,
    /// Largest sample count of the progression.
    #[arg(long, default_value_t = 256)]
    pub max_spp: u32,
    /// Samples of a rendered reference (cached under results/refs/).
    #[arg(long, default_value_t = 4096)]
    pub ref_spp: u32,
    /// Tracers to compare, comma separated.
    #[arg(long, default_value = "bvh,brute")]
    pub tracers: String,
    #[arg(long, default_value_t = crate::host::available_threads())]
    pub threads: usize,
    /// Output folder for convergence.csv and convergence.png.
    #[arg(short, long, default_value = "results/converge")]
    pub output: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct StabilityArgs {
    /// Only the fast subset (what `cargo test` runs).
    #[arg(long)]
    pub quick: bool,
    /// Image side of every case.
    #[arg(long, default_value_t = 48)]
    pub size: u32,
    #[arg(long, default_value_t = 32)]
    pub spp: u32,
    #[arg(long, default_value_t = crate::host::available_threads())]
    pub threads: usize,
    /// Output folder for stability.csv and stability.md.
    #[arg(short, long, default_value = "results/stability")]
    pub output: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    /// Scene file (TOML), see scenes/.
    pub scene: PathBuf,
    /// Samples per pixel (overrides the scene's render.spp).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Worker threads.
    #[arg(long, default_value_t = crate::host::available_threads())]
    pub threads: usize,
    /// Tracer: bvh (native: obvhs build, own 4-wide traversal), brute (reference), embree (feature `embree`).
    #[arg(long, default_value = "bvh")]
    pub tracer: String,
    /// Output image; the format follows the extension (.exr or .pfm).
    #[arg(short, long, default_value = "results/render.exr")]
    pub output: PathBuf,
    /// Scheduler: static, static_cyclic, master, work_stealing (rayon), work_stealing_deque,
    /// self_scheduling, guided.
    #[arg(long, default_value = "work_stealing")]
    pub scheduler: String,
    /// Work item size: N (N×N tile; 1 = per ray), WxH, rows:N, frame (alias frames: one whole
    /// frame per item; an animation is cut frame by frame for every size).
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
        Command::Run(args) => run_experiment(args),
        Command::Plot(args) => {
            let written = crate::experiment::finish(&args.dir)
                .map_err(|e| CliError::input(anyhow::anyhow!(e)))?;
            println!("wrote {} files under {}", written.len(), args.dir.display());
            Ok(())
        }
        Command::Converge(args) => converge(args),
        Command::Stability(args) => stability(args),
    }
}

/// Was this process started by `mpirun`/`srun` (OpenMPI, PMI or PMIx set these)?
pub fn under_mpirun() -> bool {
    ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"]
        .iter()
        .any(|v| std::env::var_os(v).is_some())
}

fn run_experiment(args: RunArgs) -> Result<(), CliError> {
    use crate::experiment::{self, RunOptions};
    if under_mpirun() {
        // Every rank lands here; rank 0 runs the experiment, the others render for it.
        #[cfg(feature = "mpi")]
        crate::mpi::experiment::run(args);
        #[cfg(not(feature = "mpi"))]
        return Err(CliError::input(anyhow::anyhow!(
            "{}: started by mpirun, but this raysched was built without feature `mpi` (cargo build --features mpi)",
            args.experiment.display()
        )));
    }
    let plan = experiment::load_plan(&args.experiment).map_err(CliError::input)?;
    if plan.mpi.is_some() {
        return Err(CliError::input(anyhow::anyhow!(
            "{}: mpi: this experiment needs `mpirun -n K raysched run {}` with K in mpi.ranks (this process was not started by mpirun)",
            args.experiment.display(),
            args.experiment.display()
        )));
    }
    if plan.convergence.is_some() {
        let dir = experiment::convergence::run(&plan, &args.out).map_err(CliError::runtime)?;
        if !args.quiet {
            let rows = crate::converge::read_csv(&dir.join("convergence.csv"))
                .map_err(CliError::runtime)?;
            for line in crate::converge::budget_winners(&rows) {
                println!("{line}");
            }
            println!("{}: wrote {}", plan.name, dir.join("report.md").display());
        }
        return Ok(());
    }
    let opts = RunOptions {
        out: args.out.clone(),
        fresh: args.fresh,
        quiet: args.quiet,
    };
    let outcome = experiment::run_experiment(&plan, &opts);
    finish_experiment(&plan, outcome, args.quiet)
}

/// Plots, report and the closing line of `raysched run` (also under mpirun, on rank 0).
pub(crate) fn finish_experiment(
    plan: &crate::experiment::ExperimentPlan,
    outcome: Result<crate::experiment::RunOutcome, crate::experiment::RunError>,
    quiet: bool,
) -> Result<(), CliError> {
    use crate::experiment::{self, RunError};
    let outcome = outcome.map_err(|e| match e {
        RunError::Refused(_) => CliError::input(e),
        _ => CliError::runtime(e),
    })?;
    let written =
        experiment::finish(&outcome.dir).map_err(|e| CliError::runtime(anyhow::anyhow!(e)))?;
    if !quiet {
        let others = if outcome.other_launches > 0 {
            format!(", {} left to other mpirun launches", outcome.other_launches)
        } else {
            String::new()
        };
        println!(
            "{}: {} runs measured, {} already done{others}; wrote {} files (report: {})",
            plan.name,
            outcome.measured,
            outcome.skipped,
            written.len(),
            outcome.dir.join("report.md").display()
        );
    }
    if outcome.mismatches > 0 {
        return Err(CliError::runtime(anyhow::anyhow!(
            "{} run(s) produced an image different from the serial baseline (identical=false in {})",
            outcome.mismatches,
            outcome.dir.join("runs.csv").display()
        )));
    }
    Ok(())
}

fn converge(args: ConvergeArgs) -> Result<(), CliError> {
    use crate::converge::{self as cv, Reference, ReferenceKind};
    if args.threads == 0 || args.max_spp == 0 || args.ref_spp == 0 {
        return Err(CliError::input(anyhow::anyhow!(
            "--threads, --max-spp and --ref-spp must be ≥ 1"
        )));
    }
    let scene = load_scene(&args.scene, &SceneOverrides::default()).map_err(CliError::input)?;
    let kinds = args
        .tracers
        .split(',')
        .map(|id| TracerKind::from_id(id.trim()).and_then(TracerKind::available))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| CliError::input(anyhow::anyhow!("--tracers: {e}")))?;
    let first = AnyTracer::build(kinds[0], &scene, args.threads).map_err(CliError::input)?;
    let reference = match &args.reference {
        Some(p) => {
            let image = crate::render::Image::load_exr(p).map_err(CliError::input)?;
            if image.width != scene.width() || image.height != scene.height() {
                return Err(CliError::input(anyhow::anyhow!(
                    "--ref {}: {}×{} does not match the scene's {}×{}",
                    p.display(),
                    image.width,
                    image.height,
                    scene.width(),
                    scene.height()
                )));
            }
            Reference {
                exact: vec![false; image.data.len()],
                image,
                kind: ReferenceKind::Rendered {
                    spp: 0,
                    path: Some(p.clone()),
                },
                leaks: 0,
            }
        }
        None => cv::reference::reference(
            &scene,
            &first,
            Path::new("results/refs"),
            args.ref_spp,
            args.threads,
        )
        .map_err(|e| CliError::runtime(anyhow::anyhow!(e)))?,
    };
    let mut rows = Vec::new();
    for &kind in &kinds {
        let tracer = AnyTracer::build(kind, &scene, args.threads).map_err(CliError::input)?;
        rows.extend(cv::run_convergence(
            &scene,
            &tracer,
            &reference,
            args.max_spp,
            args.threads,
        ));
    }
    let csv = args.output.join("convergence.csv");
    let png = args.output.join("convergence.png");
    cv::write_csv(&csv, &rows).map_err(CliError::runtime)?;
    cv::plot(&png, &cv::read_csv(&csv).map_err(CliError::runtime)?).map_err(CliError::runtime)?;
    println!("reference: {}", reference.kind.label());
    for s in cv::summarise(&rows) {
        println!(
            "{} {}: slope {}, RMSE at {:.3} s = {}",
            s.scene,
            s.config,
            s.slope.map_or("n/a".into(), |v| format!("{v:.3}")),
            s.budget_s,
            s.rmse_at_budget.map_or("n/a".into(), |v| format!("{v:.5}"))
        );
    }
    for line in cv::budget_winners(&rows) {
        println!("{line}");
    }
    println!("wrote {} and {}", csv.display(), png.display());
    Ok(())
}

fn stability(args: StabilityArgs) -> Result<(), CliError> {
    use crate::stability::{self as st, Budget};
    if args.threads == 0 || args.size == 0 || args.spp < 2 {
        return Err(CliError::input(anyhow::anyhow!(
            "--threads and --size must be ≥ 1, --spp ≥ 2"
        )));
    }
    let budget = if args.quick {
        Budget {
            threads: args.threads,
            ..Budget::QUICK
        }
    } else {
        Budget {
            size: args.size,
            spp: args.spp,
            threads: args.threads,
            quick: false,
        }
    };
    let rows = st::cases::run_suite(&budget);
    let table = st::markdown(&rows);
    let csv = args.output.join("stability.csv");
    st::write_csv(&csv, &rows).map_err(CliError::runtime)?;
    std::fs::write(args.output.join("stability.md"), &table).map_err(CliError::runtime)?;
    println!("{table}");
    let failed = rows.iter().filter(|r| r.required && !r.pass).count();
    println!(
        "wrote {} ({} cases, {} required failures)",
        csv.display(),
        rows.len(),
        failed
    );
    if failed > 0 {
        return Err(CliError::runtime(anyhow::anyhow!(
            "{failed} stability case(s) failed"
        )));
    }
    Ok(())
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
        return Err(CliError::input(anyhow::anyhow!(
            "--threads: must be ≥ 1 (got 0)"
        )));
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
        return Err(CliError::input(anyhow::anyhow!(
            "--spp: must be ≥ 1 (got 0)"
        )));
    }
    let spec = args.scheduler_spec()?;
    let scene = std::sync::Arc::new(load_scene(&args.scene, &overrides).map_err(CliError::input)?);
    let t0 = Instant::now();
    let tracer = std::sync::Arc::new(
        TracerKind::from_id(&args.tracer)
            .and_then(|kind| AnyTracer::build(kind, &scene, args.threads))
            .map_err(CliError::input)?,
    );
    let build = t0.elapsed();
    let opts = RunOptions {
        stats: !args.stats_off,
        deadline: args.deadline_ms.map(std::time::Duration::from_millis),
        faults: None,
    };
    let (image, stats) =
        run_scheduler_with(&spec, &scene, &tracer, &opts).map_err(|e| match e {
            SchedError::Spec(_) => CliError::input(e),
            _ => CliError::runtime(e),
        })?;
    let (wall, rays, nonfinite) = (stats.wall_s, stats.rays, stats.nonfinite);
    let wrote = save_render(&args.output, &image, scene.frames()).map_err(CliError::runtime)?;
    print_render_header(
        &scene,
        &format!(
            "{} built in {:.3} s, {} threads",
            args.tracer,
            build.as_secs_f64(),
            args.threads
        ),
        &spec,
        &image,
    );
    println!(
        "wall {:.3} s, rays {}, {:.2} Mrays/s, non-finite samples {}",
        wall,
        rays,
        rays as f64 / wall / 1e6,
        nonfinite
    );
    print!("{}", stats.summary());
    let (used, left_out) = scene
        .features
        .report(crate::tracer::Tracer::accelerated(&*tracer));
    println!(
        "features used: {}; left out: {}",
        used.join(","),
        left_out.join(",")
    );
    println!("wrote {wrote}");
    Ok(())
}

/// `name_fNNNN.ext` beside `output = name.ext`: the file of frame `frame` of an animation.
pub fn frame_path(output: &std::path::Path, frame: u32) -> std::path::PathBuf {
    let stem = output.file_stem().unwrap_or_default().to_string_lossy();
    let ext = output.extension().unwrap_or_default().to_string_lossy();
    output.with_file_name(format!("{stem}_f{frame:04}.{ext}"))
}

/// Write a render and its PNG preview: `output` for a static scene, [`frame_path`] per frame
/// for an animation (`image` is then the film strip of [`crate::render::Image::stack`]).
/// Returns what was written, for the report.
pub(crate) fn save_render(
    output: &std::path::Path,
    image: &crate::render::Image,
    frames: u32,
) -> Result<String, crate::render::image::ImageError> {
    if frames <= 1 {
        let png = image.save_with_preview(output)?;
        return Ok(format!("{} and {}", output.display(), png.display()));
    }
    for (k, frame) in image.unstack(frames).iter().enumerate() {
        frame.save_with_preview(&frame_path(output, k as u32))?;
    }
    Ok(format!(
        "{frames} frames {} … {} (each with a .png preview)",
        frame_path(output, 0).display(),
        frame_path(output, frames - 1).display()
    ))
}

/// The first two lines of a render's report, shared by the local and the MPI path (tests read
/// the image hash from them).
pub(crate) fn print_render_header(
    scene: &crate::scene::Scene,
    tracer: &str,
    spec: &SchedulerSpec,
    image: &crate::render::Image,
) {
    println!(
        "scene {} ({}×{}{}, {} spp, max_depth {}), tracer {tracer}",
        scene.name,
        scene.width(),
        scene.height(),
        if scene.frames() > 1 {
            format!(" × {} frames", scene.frames())
        } else {
            String::new()
        },
        scene.settings.spp,
        scene.settings.max_depth,
    );
    println!(
        "scheduler {}, order {}, image hash {:016x}",
        spec.label(),
        spec.order.id(),
        image.hash()
    );
}
