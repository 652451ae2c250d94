//! `raysched render SCENE --sources gpu` or `--sources threads,gpu`: the master hands out to a
//! GPU (feature `gpu`), alone or beside local threads, each source with its own buffer.

use super::error::CliError;
use super::render::RenderArgs;

/// Mesa's Vulkan drivers probe for a Wayland display and print a line when
/// `XDG_RUNTIME_DIR` is unset (a headless machine, CI); pointing it at the temp folder keeps
/// stderr to raysched's own one line. Call before any thread is spawned.
pub(crate) fn quiet_vulkan_loader() {
    if cfg!(feature = "gpu") && std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
}

#[cfg(not(feature = "gpu"))]
pub(crate) fn render(_args: RenderArgs) -> Result<(), CliError> {
    // `SourceSet::parse` refuses `gpu` in such a build; this is the belt to its braces.
    Err(CliError::message(
        "--sources gpu: this raysched was built without feature `gpu` (cargo build --features gpu)",
    ))
}

#[cfg(feature = "gpu")]
pub(crate) fn render(args: RenderArgs) -> Result<(), CliError> {
    use raysched::gpu::{GpuContext, GpuRenderer};
    use raysched::scene::load_scene;
    use raysched::sched::{run_with_sources, Policy, Runner, SchedError, SourceKind};
    use raysched::tracer::{AnyTracer, Tracer};
    use std::sync::Arc;
    use std::time::Instant;

    let threads = if args.sources.has(SourceKind::Threads) {
        args.threads
    } else {
        0
    };
    let overrides = args.check_output()?;
    let setup = args.source_setup()?;
    let spec = args.scheduler_spec(threads.max(1))?;
    let Policy::Master(_) = spec.policy else {
        return Err(CliError::message(format!(
            "--scheduler {}: a GPU source runs under the master only (--scheduler master)",
            spec.kind().id()
        )));
    };
    if let Some(r) = Runner::Gpu.refuses(&spec.policy) {
        return Err(CliError::message(r.as_flag()));
    }
    let kind = args.tracer.available().map_err(CliError::input)?;
    let scene = Arc::new(load_scene(&args.scene, &overrides).map_err(CliError::input)?);
    if let Some(w) = scene.depth_warning() {
        eprintln!("warning: {}: {w}", args.scene.display());
    }
    quiet_vulkan_loader();
    let ctx = GpuContext::open(args.gpu_adapter.as_deref()).map_err(CliError::input)?;
    if args.gpu_counters {
        let r = raysched::gpu::counters::report(&scene, Some(&ctx))
            .map_err(|e| CliError::runtime(anyhow::anyhow!("{}: {e}", args.scene.display())))?;
        print!("{r}");
    }
    let t0 = Instant::now();
    let gpu = Arc::new(
        GpuRenderer::new(ctx, &scene)
            .map_err(|e| CliError::input(anyhow::anyhow!("{}: {e}", args.scene.display())))?,
    );
    let upload = t0.elapsed();
    let tracer = Arc::new(AnyTracer::build(kind, &scene, threads.max(1)).map_err(CliError::input)?);
    let info = gpu.info().clone();
    let (frames, stats) = run_with_sources(
        &spec,
        &setup,
        &scene,
        &tracer,
        Some(gpu),
        &args.run_options(),
    )
    .map_err(|e| match e {
        SchedError::Spec(_) => CliError::input(e),
        _ => CliError::runtime(e),
    })?;
    let image = raysched::render::Image::stack(frames);
    let wrote = super::render::save_render(&args.output, &image, scene.frames())
        .map_err(CliError::runtime)?;
    let tracer_line = format!(
        "{} for {threads} threads; gpu {} ({}, {}, {}), scene uploaded in {:.3} s",
        args.tracer,
        info.name,
        info.device_type,
        info.driver,
        info.backend,
        upload.as_secs_f64()
    );
    super::render::print_render_header(&scene, &tracer_line, &spec, &image);
    super::render::print_render_footer(&scene, &stats, tracer.accelerated(), &wrote);
    Ok(())
}
