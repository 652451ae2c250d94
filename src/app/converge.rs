//! `raysched converge`: error against run time for one scene and several tracers.

use super::error::CliError;
use raysched::core::scene::{load_scene, Scene, SceneOverrides};
use raysched::core::tracer::{AnyTracer, TracerKind};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub(crate) struct ConvergeArgs {
    /// Scene file (TOML).
    pub(crate) scene: PathBuf,
    /// Reference image (.exr); default: analytic, else a cached high-spp render.
    #[arg(long = "ref")]
    pub(crate) reference: Option<PathBuf>,
    /// Largest sample count of the progression.
    #[arg(long, default_value_t = 256, value_parser = super::spp_arg())]
    pub(crate) max_spp: u32,
    /// Samples of a rendered reference (cached under results/runs/refs/).
    #[arg(long, default_value_t = 4096, value_parser = super::spp_arg())]
    pub(crate) ref_spp: u32,
    /// Tracers to compare, comma separated.
    #[arg(long, default_value = "bvh,brute")]
    pub(crate) tracers: String,
    #[arg(long, default_value_t = raysched::util::host::available_threads(), value_parser = super::threads_arg(1))]
    pub(crate) threads: usize,
    /// Output folder for convergence.csv and convergence.png.
    #[arg(short, long, default_value = "results/runs/converge")]
    pub(crate) output: PathBuf,
    /// Replace a convergence.csv with more rows than this run.
    #[arg(long)]
    pub(crate) force: bool,
}

pub(crate) fn converge(args: ConvergeArgs) -> Result<(), CliError> {
    use raysched::studies::converge as cv;
    if args.threads == 0 || args.max_spp == 0 || args.ref_spp == 0 {
        return Err(CliError::input(anyhow::anyhow!(
            "--threads, --max-spp and --ref-spp must be ≥ 1"
        )));
    }
    super::out_path::check("--output", &args.output, super::out_path::Kind::Folder)?;
    super::out_path::check_input("SCENE", &args.scene)?;
    if let Some(r) = &args.reference {
        super::out_path::check_input("--ref", r)?;
    }
    let scene = load_scene(&args.scene, &SceneOverrides::default()).map_err(CliError::input)?;
    let kinds = args
        .tracers
        .split(',')
        .map(|id| TracerKind::from_id(id.trim()).and_then(TracerKind::available))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| CliError::input(anyhow::anyhow!("--tracers: {e}")))?;
    let scene = std::sync::Arc::new(scene);
    let first = AnyTracer::build(kinds[0], &scene, args.threads).map_err(CliError::input)?;
    let reference = reference_of(&args, &scene, &first)?;
    if reference.noise_mse > 0.0 {
        out!(
            "reference noise: RMSE {:.3e} (subtracted from every row's error)",
            reference.noise_mse.sqrt()
        );
    }
    let mut rows = Vec::new();
    for &kind in &kinds {
        let tracer = AnyTracer::build(kind, &scene, args.threads).map_err(CliError::input)?;
        let tracer = std::sync::Arc::new(tracer);
        rows.extend(
            cv::run_convergence(&scene, &tracer, &reference, args.max_spp, args.threads)
                .map_err(CliError::runtime)?,
        );
    }
    let csv = args.output.join("convergence.csv");
    let png = args.output.join("convergence.png");
    super::refuse_partial_overwrite(&csv, rows.len(), args.force)?;
    // Both files or neither: a failed write leaves the previous pair.
    let staging = raysched::util::staging::Staging::new(&args.output)
        .map_err(|e| CliError::runtime(anyhow::anyhow!("{}: {e}", args.output.display())))?;
    let staged_csv = staging.path("convergence.csv");
    cv::write_csv(&staged_csv, &rows).map_err(CliError::runtime)?;
    let staged_rows = cv::read_csv(&staged_csv).map_err(CliError::runtime)?;
    cv::plot(&staging.path("convergence.png"), &staged_rows).map_err(CliError::runtime)?;
    staging
        .commit()
        .map_err(|e| CliError::runtime(anyhow::anyhow!("{}: {e}", args.output.display())))?;
    out!("reference: {}", reference.kind.label());
    for s in cv::summarise(&rows) {
        out!(
            "{} {}: slope {}, RMSE at {:.3} s = {}",
            s.scene,
            s.config,
            s.slope.map_or("n/a".into(), |v| format!("{v:.3}")),
            s.budget_s,
            s.rmse_at_budget.map_or("n/a".into(), |v| format!("{v:.5}"))
        );
    }
    for line in cv::budget_winners(&rows) {
        out!("{line}");
    }
    out!("wrote {} and {}", csv.display(), png.display());
    Ok(())
}

/// The reference of a run: `--ref`'s image, else the analytic or cached rendered one.
fn reference_of(
    args: &ConvergeArgs,
    scene: &Scene,
    first: &AnyTracer,
) -> Result<raysched::studies::converge::Reference, CliError> {
    use raysched::studies::converge::{self as cv, Reference, ReferenceKind};
    Ok(match &args.reference {
        Some(p) => {
            let image = raysched::core::render::Image::load_exr(p)
                .map_err(|e| CliError::input(anyhow::anyhow!("--ref: {e}")))?;
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
                ambiguous: 0,
                noise_mse: 0.0,
            }
        }
        None => cv::reference::reference(
            scene,
            first,
            Path::new("results/runs/refs"),
            args.ref_spp,
            args.threads,
            &mut reference_progress(),
        )
        .map_err(|e| CliError::runtime(anyhow::anyhow!(e)))?,
    })
}

/// One stderr line per round of a rendered reference: done/total samples, elapsed, ETA.
fn reference_progress() -> impl FnMut(u32, u32) {
    let start = std::time::Instant::now();
    move |done, total| {
        let el = start.elapsed().as_secs_f64();
        let eta = el / done.max(1) as f64 * (total - done) as f64;
        eprintln!("reference: {done}/{total} spp, {el:.1} s elapsed, ETA {eta:.1} s");
    }
}
