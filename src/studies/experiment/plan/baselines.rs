//! The scenes loaded, one baseline per (scene, tracer), and the configurations that time
//! each baseline's grid.

use super::*;

pub(super) fn load_scenes(
    file: &ExperimentFile,
    base: &Path,
) -> Result<Vec<PlannedScene>, FieldError> {
    let mut scenes = Vec::new();
    for (i, s) in file.scenes.iter().enumerate() {
        let overrides = s.overrides();
        let t0 = Instant::now();
        let scene =
            load_scene(&base.join(&s.path), &overrides).map_err(|e| scene_error(i, s, e))?;
        scenes.push(PlannedScene {
            file: s.path.clone(),
            overrides,
            scene: Arc::new(scene),
            load_s: t0.elapsed().as_secs_f64(),
        });
    }
    Ok(scenes)
}

/// Scene `i`'s load error as a field error of the experiment: a value the experiment overrides
/// (`width = 0`) is the experiment's field, not the scene file's.
pub(super) fn scene_error(
    i: usize,
    s: &super::super::config::SceneEntry,
    e: crate::core::scene::SceneError,
) -> FieldError {
    let ours = e.line.is_none().then_some(()).and_then(|()| {
        Some(match e.field.as_str() {
            "camera.width" if s.width.is_some() => "width",
            "camera.height" if s.height.is_some() => "height",
            "render.spp" if s.spp.is_some() => "spp",
            "render.max_depth" if s.max_depth.is_some() => "max_depth",
            "render.seed" if s.seed.is_some() => "seed",
            f if f.ends_with(".count") && s.generator_count.is_some() => "generator_count",
            _ => return None,
        })
    });
    match ours {
        Some(key) => field(&format!("scenes[{i}].{key}"), e.msg),
        None => field(&format!("scenes[{i}]"), e.to_string()),
    }
}

/// One tracer per (scene, tracer), built with the largest worker count as its thread budget.
pub(super) fn build_baselines(
    tracers: &[TracerKind],
    scenes: &[PlannedScene],
    max_workers: usize,
) -> Result<Vec<Baseline>, FieldError> {
    let mut baselines = Vec::new();
    for (si, sc) in scenes.iter().enumerate() {
        for (ti, &kind) in tracers.iter().enumerate() {
            let t0 = Instant::now();
            let tracer = AnyTracer::build(kind, &sc.scene, max_workers)
                .map_err(|e| field(&format!("tracers[{ti}]"), format!("scene {}: {e}", sc.file)))?;
            baselines.push(Baseline {
                scene: si,
                tracer_id: kind.id().to_string(),
                tracer: Arc::new(tracer),
                build_s: t0.elapsed().as_secs_f64(),
            });
        }
    }
    Ok(baselines)
}

/// Serial baselines first (so a scheduler run always finds its baseline measured), then every
/// baseline × grid entry; under `[mpi]` each entry is the local-thread baseline of its launch
/// size followed by one configuration per transport.
pub(super) fn configurations(
    baselines: usize,
    grids: &[Grid],
    mpi: Option<&MpiSettings>,
) -> Vec<RunConfig> {
    let config = |baseline, spec, sources, ranks| RunConfig {
        id: String::new(),
        baseline,
        spec,
        sources,
        ranks,
    };
    let mut configs: Vec<RunConfig> = (0..baselines)
        .map(|b| config(b, None, Sources::threads(), None))
        .collect();
    for b in 0..baselines {
        for (spec, setup) in grids.iter().flatten() {
            let Some(m) = mpi else {
                let sources = Sources::Local(setup.clone());
                configs.push(config(b, Some(spec.clone()), sources, None));
                continue;
            };
            // Under [mpi], spec.workers = ranks − 1.
            let ranks = Some(spec.workers + 1);
            configs.push(config(b, Some(spec.clone()), Sources::threads(), ranks));
            for t in &m.transports {
                let sources = Sources::Mpi {
                    transport: t.clone(),
                };
                configs.push(config(b, Some(spec.clone()), sources, ranks));
            }
        }
    }
    configs
}
