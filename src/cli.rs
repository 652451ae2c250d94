//! The command line: parse, run, print errors once with their chain, map them to exit codes.
//! Bad input (scene, config, parameters) exits with code 2; other failures with 1.

use crate::render::{render_parallel, RenderCounters};
use crate::scene::{load_scene, SceneOverrides};
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
    let scene = load_scene(&args.scene, &overrides).map_err(CliError::input)?;
    let t0 = Instant::now();
    let tracer = AnyTracer::build(&args.tracer, &scene, args.threads).map_err(CliError::input)?;
    let build = t0.elapsed();
    let t1 = Instant::now();
    let (image, RenderCounters { rays, nonfinite }) =
        render_parallel(&scene, &tracer, args.threads).map_err(CliError::runtime)?;
    let wall = t1.elapsed().as_secs_f64();
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
    println!(
        "wall {:.3} s, rays {}, {:.2} Mrays/s, non-finite samples {}",
        wall,
        rays,
        rays as f64 / wall / 1e6,
        nonfinite
    );
    println!("wrote {} and {}", args.output.display(), png.display());
    Ok(())
}
