//! One timed sample of one configuration: the render, its statistics into the row, the
//! timeline text and the child's sample line.

use super::*;

/// A timeline file: one `worker,item,start_ns,end_ns,source` line per span, `source` being
/// the worker's kind of source (`threads`, `gpu`, …; `master` on the master's lane), so the
/// Gantt chart groups its lanes by kind.
pub fn timeline_text(spans: &[crate::core::metrics::Span], stats: &RunStats) -> String {
    let mut text = String::from("worker,item,start_ns,end_ns,source\n");
    for s in spans {
        let source = if s.worker == crate::core::metrics::MASTER_LANE {
            "master"
        } else {
            stats
                .workers
                .get(s.worker as usize)
                .and_then(|w| w.source)
                .map_or("", |k| k.id())
        };
        text += &format!(
            "{},{},{},{},{source}\n",
            s.worker, s.item, s.start_ns, s.end_ns
        );
    }
    text
}

/// What one timed sample recorded besides its renders.
pub(super) struct Sample {
    pub(super) rep: u32,
    pub(super) inner: u32,
    pub(super) timestamp: String,
    /// (user, system) CPU seconds of the process during the sample.
    pub(super) cpu: Option<(f64, f64)>,
    /// 1-minute load average before and after.
    pub(super) load: (Option<f64>, Option<f64>),
    /// Every render of the sample gave the same image.
    pub(super) same: bool,
}

/// Renders per timed sample for a render of `t` seconds: enough to fill `min_sample_s`.
pub fn inner_count(t: f64, min_sample_s: f64) -> u32 {
    if t.is_nan() || t <= 0.0 || t >= min_sample_s {
        return 1;
    }
    ((min_sample_s / t).ceil() as u32).clamp(1, MAX_INNER)
}

/// One timed run. Only the render is inside the timed section (scenes and tracers were built by
/// the plan).
pub(super) fn measure(
    plan: &ExperimentPlan,
    c: &RunConfig,
    timeline: bool,
    remote: &mut Option<&mut dyn Remote>,
) -> Result<(Image, RunStats), RunError> {
    let b = &plan.baselines[c.baseline];
    let scene = &plan.scene_of(c).scene;
    match &c.spec {
        None => {
            let t0 = Instant::now();
            let (image, counters) = render_serial(scene.as_ref(), b.tracer.as_ref());
            let wall_s = t0.elapsed().as_secs_f64();
            let rows = scene.height() as u64 * scene.frames() as u64; // render_serial's items
            let stats = RunStats {
                wall_s,
                workers: vec![WorkerStats {
                    busy_s: wall_s,
                    idle_s: 0.0,
                    items: rows,
                    pixels: scene.pixel_count() as u64 * scene.frames() as u64,
                    rays: counters.rays,
                    source: Some(crate::core::metrics::SourceKind::Threads),
                }],
                items: rows,
                issued: rows,
                rays: counters.rays,
                nonfinite: counters.nonfinite,
                ..Default::default()
            };
            let (used, left_out) = scene.feature_report(b.tracer.accelerated());
            Ok((
                image,
                RunStats {
                    features_used: used,
                    features_left_out: left_out,
                    ..stats
                },
            ))
        }
        Some(spec) if c.sources.has_gpu() => {
            let mut spec = spec.clone();
            spec.timeline = timeline;
            measure_gpu(plan, c, &spec)
        }
        Some(spec) if c.sources != Sources::threads() => {
            let mut spec = spec.clone();
            spec.timeline = timeline;
            let r = remote.as_deref_mut().ok_or_else(|| {
                RunError::Mpi(format!(
                    "{}: MPI configuration outside an mpirun launch",
                    c.id
                ))
            })?;
            r.measure(plan, c, &spec)
        }
        Some(spec) => {
            let mut spec = spec.clone();
            spec.timeline = timeline;
            render_scene(
                &spec,
                scene,
                &b.tracer,
                &RenderOn::threads(),
                &crate::sched::RunOptions::default(),
            )
            .map(|(frames, stats)| (Image::stack(frames), stats))
            .map_err(|source| RunError::Sched {
                config: format!("{} {}", c.id, spec.label()),
                source,
            })
        }
    }
}

/// One timed run of a configuration with a GPU source, on the plan's device.
#[cfg(feature = "gpu")]
pub(super) fn measure_gpu(
    plan: &ExperimentPlan,
    c: &RunConfig,
    spec: &SchedulerSpec,
) -> Result<(Image, RunStats), RunError> {
    let b = &plan.baselines[c.baseline];
    let scene = &plan.scene_of(c).scene;
    let (Sources::Local(setup), Some(gpu)) = (&c.sources, &plan.gpu) else {
        return Err(RunError::Refused(format!(
            "{}: a GPU configuration without the plan's GPU",
            c.id
        )));
    };
    let renderer = gpu.renderers[b.scene].clone();
    let on = RenderOn {
        setup,
        gpu: Some(renderer),
    };
    render_scene(
        spec,
        scene,
        &b.tracer,
        &on,
        &crate::sched::RunOptions::default(),
    )
    .map(|(frames, stats)| (Image::stack(frames), stats))
    .map_err(|source| RunError::Sched {
        config: format!("{} {}{}", c.id, spec.label(), setup.label()),
        source,
    })
}

/// Without feature `gpu` no configuration has a GPU source ([`crate::sched::SourceSet::new`]).
#[cfg(not(feature = "gpu"))]
pub(super) fn measure_gpu(
    _plan: &ExperimentPlan,
    c: &RunConfig,
    _spec: &SchedulerSpec,
) -> Result<(Image, RunStats), RunError> {
    Err(RunError::Refused(format!(
        "{}: a GPU configuration in a build without feature `gpu`",
        c.id
    )))
}

/// A round's process's line after each sample: the prefix, then the configuration's label
/// (`isolate` reads it).
pub(in crate::studies::experiment) const SAMPLE: &str = "sample\t";

/// A child's line for one sample of the configuration labelled `label`.
pub(super) fn sample_line(label: &str) -> String {
    format!("{SAMPLE}{label}")
}
