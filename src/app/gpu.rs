//! The GPU of `raysched render --sources gpu` (feature `gpu`): opened and the scene uploaded
//! before the common render path runs it beside any other sources.

use super::error::CliError;
use raysched::core::scene::Scene;
use raysched::sched::{SourceKind, SourceSet};
use std::path::Path;

/// Mesa's Vulkan drivers probe for a Wayland display and print a line when
/// `XDG_RUNTIME_DIR` is unset (a headless machine, CI); pointing it at the temp folder keeps
/// stderr to raysched's own one line. Call before any thread is spawned.
pub(crate) fn quiet_vulkan_loader() {
    if cfg!(feature = "gpu") && std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
}

/// The GPU of a render, opened and the scene uploaded, with its line for the report.
pub(crate) struct OpenGpu {
    #[cfg(feature = "gpu")]
    pub(crate) renderer: std::sync::Arc<raysched::core::gpu::GpuRenderer>,
    pub(crate) line: String,
}

/// Open the GPU when `--sources` has one (`None` otherwise) and upload `scene` to it.
#[cfg(feature = "gpu")]
pub(crate) fn open(
    sources: &SourceSet,
    (adapter, counters): (Option<&str>, bool),
    (scene, path): (&Scene, &Path),
) -> Result<Option<OpenGpu>, CliError> {
    use raysched::core::gpu::{GpuContext, GpuRenderer};
    if !sources.has(SourceKind::Gpu) {
        return Ok(None);
    }
    quiet_vulkan_loader();
    let ctx = GpuContext::open(adapter).map_err(CliError::input)?;
    if counters {
        // Per-ray traversal counters of both BVH layouts, before the render (`--gpu-counters`).
        let r = raysched::core::gpu::counters::report(scene, Some(&ctx))
            .map_err(|e| CliError::runtime(anyhow::anyhow!("{}: {e}", path.display())))?;
        print!("{r}");
    }
    let t0 = std::time::Instant::now();
    let renderer = GpuRenderer::new(ctx, scene)
        .map_err(|e| CliError::input(anyhow::anyhow!("{}: {e}", path.display())))?;
    let info = renderer.info().clone();
    let line = format!(
        "gpu {} ({}, {}, {}), scene uploaded in {:.3} s",
        info.name,
        info.device_type,
        info.driver,
        info.backend,
        t0.elapsed().as_secs_f64()
    );
    Ok(Some(OpenGpu {
        renderer: std::sync::Arc::new(renderer),
        line,
    }))
}

/// Without feature `gpu`, `--sources gpu` is refused (`SourceSet::parse` already refuses it;
/// this is the belt to its braces).
#[cfg(not(feature = "gpu"))]
pub(crate) fn open(
    sources: &SourceSet,
    _adapter: (Option<&str>, bool),
    _scene: (&Scene, &Path),
) -> Result<Option<OpenGpu>, CliError> {
    if sources.has(SourceKind::Gpu) {
        return Err(CliError::message(
            "--sources gpu: this raysched was built without feature `gpu` (cargo build --features gpu)",
        ));
    }
    Ok(None)
}
