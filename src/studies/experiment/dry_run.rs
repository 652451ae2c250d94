//! `raysched run --dry-run`: what a run would do (configurations, samples, time) without timing
//! anything. The time estimate rests on one untimed serial render per (scene, tracer), of at
//! most [`PROBE_SPP`] samples per pixel scaled to the scene's: a configuration with w workers
//! is guessed at serial / min(w, cores, items), the guess a real run replaces with its own
//! samples (a chunk as large as the image is one item: serial, however many workers).

use super::meta::{self, Meta};
use super::plan::{ExperimentPlan, RunConfig};
use super::run::{inner_count, RunError, RunOptions, MIN_ADAPTIVE_RUNS};
use crate::core::render::{render_item_spp, serial_rows};
use crate::core::scene::Scene;
use crate::core::tracer::Tracer;
use std::fmt::Write;
use std::time::Instant;

/// Samples per pixel a probe renders at most, scaled to the scene's own count beyond it, so a
/// dry run stays quick at any spp (a mutated `spp = 65536` made one probe take minutes). The
/// scenes of every shipped experiment (≤ 16 spp) are probed whole, as before: a render's
/// per-pixel and per-item costs do not scale with spp, so a scaled probe reads high.
const PROBE_SPP: u32 = 16;

/// How a plan's closing line states its probes: `probe_s`, their scaled sum.
pub(crate) fn probe_label(probe_s: f64) -> String {
    format!(
        "one serial render per scene and tracer, est. from a probe of ≤ {PROBE_SPP} spp: {probe_s:.2} s"
    )
}

/// Seconds one serial render of `scene` would take: a render of at most [`PROBE_SPP`] samples
/// per pixel (row by row, as [`crate::core::render::render_serial`] renders, the scene read in place
/// rather than copied with a lower count), untimed by the caller, scaled to the scene's count.
pub(crate) fn probe_render_s<T: Tracer + ?Sized>(scene: &Scene, tracer: &T) -> f64 {
    let spp = scene.settings.spp.max(1);
    let probe = spp.min(PROBE_SPP);
    let t0 = Instant::now();
    for f in 0..scene.frames() {
        for item in serial_rows(scene, f) {
            std::hint::black_box(render_item_spp(scene, tracer, &item, probe));
        }
    }
    t0.elapsed().as_secs_f64() * f64::from(spp) / f64::from(probe)
}

/// How many items `spec` cuts `frames` frames of a `width`×`height` image into (counted, not
/// listed: the image may hold 2²⁵ pixels).
pub fn item_count(spec: &crate::sched::SchedulerSpec, width: u32, height: u32, frames: u32) -> u64 {
    use crate::sched::Chunk;
    let (chunk, _) = spec.layout(width, height);
    let per_frame = match chunk {
        Chunk::Tile { w, h } => u64::from(width.div_ceil(w)) * u64::from(height.div_ceil(h)),
        Chunk::Rows(n) => u64::from(height.div_ceil(n)),
        Chunk::Frame => 1,
    };
    per_frame * u64::from(frames.max(1))
}

/// The plan as text, ending with the estimated total.
pub fn plan_text(plan: &ExperimentPlan, opts: &RunOptions) -> Result<String, RunError> {
    let dir = opts.out.join(&plan.name);
    let mut out = String::new();
    let _ = writeln!(out, "experiment {} → {}", plan.name, dir.display());
    let _ = writeln!(out, "{}", sampling_line(plan));
    if let Some(line) = resume_line(plan, &dir, opts)? {
        let _ = writeln!(out, "{line}");
    }
    let probes: Vec<f64> = plan
        .baselines
        .iter()
        .map(|b| probe_render_s(plan.scenes[b.scene].scene.as_ref(), b.tracer.as_ref()))
        .collect();
    let cores = crate::util::host::available_threads();
    let _ = writeln!(
        out,
        "\n{:<17} {:>9} {:>6} {:>9} {:>14}  configuration",
        "config", "est. run", "inner", "samples", "est. time"
    );
    let (mut lo_total, mut hi_total) = (0.0, 0.0);
    for c in &plan.configs {
        let (line, lo, hi) = config_estimate(plan, c, probes[c.baseline], cores);
        lo_total += lo;
        hi_total += hi;
        let _ = writeln!(out, "{line}");
    }
    let _ = writeln!(
        out,
        "\n{} configurations; estimated {:.0}–{:.0} s of rendering ({}). Nothing was measured.",
        plan.configs.len(),
        lo_total,
        hi_total,
        probe_label(probes.iter().sum::<f64>())
    );
    Ok(out)
}

/// How many timed runs each configuration gets, the warm-ups, the seed and the processes.
fn sampling_line(plan: &ExperimentPlan) -> String {
    let st = &plan.stats;
    let rule = if st.fixed() {
        format!("exactly {} timed runs per configuration", st.min_runs)
    } else {
        format!(
            "{}–{} timed runs per configuration: until the median's 95 % CI is within ±{:.1} % (checked from {} runs on) or {:.0} s are spent",
            st.min_runs,
            st.max_runs,
            st.ci_target * 100.0,
            MIN_ADAPTIVE_RUNS.max(st.min_runs),
            st.budget_s
        )
    };
    let procs = match st.isolation {
        super::config::Isolation::Round if plan.gpu.is_none() => "a fresh process per round",
        _ => "every round in one process",
    };
    format!(
        "{rule}; {} warm-up(s); seed {}; {procs}",
        plan.warmup, st.seed
    )
}

/// Whether a run into `dir` would resume the rows already there or be refused; `None` when
/// there is nothing to resume (or `--fresh`).
fn resume_line(
    plan: &ExperimentPlan,
    dir: &std::path::Path,
    opts: &RunOptions,
) -> Result<Option<String>, RunError> {
    let runs = dir.join("runs.csv");
    if !runs.exists() || opts.fresh {
        return Ok(None);
    }
    let rows = super::results::read_runs(&runs)?.0.len();
    let old: Option<Meta> = std::fs::read_to_string(dir.join("meta.toml"))
        .ok()
        .and_then(|t| toml::from_str(&t).ok());
    let conflict = old
        .map(|m| meta::resume_conflict(&m, &meta::Start::now(rows, plan.stats)))
        .unwrap_or_else(|| vec!["meta.toml missing".into()]);
    Ok(Some(if conflict.is_empty() {
        format!("resumes {rows} rows already in {}", runs.display())
    } else {
        format!(
            "would be refused: {} has {rows} rows measured elsewhere ({}); use --fresh or another --out",
            runs.display(),
            conflict.join(", ")
        )
    }))
}

/// One configuration's table line and its estimated least and most seconds of rendering,
/// from its baseline's serial probe `t_serial`.
fn config_estimate(
    plan: &ExperimentPlan,
    c: &RunConfig,
    t_serial: f64,
    cores: usize,
) -> (String, f64, f64) {
    let st = &plan.stats;
    let t = match &c.spec {
        None => t_serial,
        Some(s) => {
            let sc = plan.scenes[plan.baselines[c.baseline].scene].scene.as_ref();
            let items = item_count(s, sc.width(), sc.height(), sc.frames());
            let busy = (s.workers.min(cores) as u64).min(items).max(1);
            t_serial / busy as f64
        }
    };
    let inner = if st.min_sample_s > 0.0 {
        inner_count(t, st.min_sample_s)
    } else {
        1
    };
    let per_sample = t * f64::from(inner);
    let by_budget = (st.budget_s / per_sample).ceil() as u32;
    let most = st.max_runs.min(by_budget.max(st.min_runs));
    let setup = f64::from(plan.warmup.max(u32::from(st.min_sample_s > 0.0))) * t;
    let lo = setup + f64::from(st.min_runs) * per_sample;
    let hi = setup + f64::from(most) * per_sample;
    let setup_label = match &c.sources {
        super::plan::Sources::Local(setup) => setup.label(),
        super::plan::Sources::Mpi { transport } => format!(" over MPI ({transport})"),
    };
    let label = c
        .spec
        .as_ref()
        .map_or(super::results::SERIAL.to_string(), |s| {
            format!("{}{setup_label} ×{}", s.label(), s.workers)
        });
    let line = format!(
        "{:<17} {:>8.1}ms {:>6} {:>9} {:>14}  {} · {label}",
        c.id,
        t * 1e3,
        inner,
        format!("{}–{most}", st.min_runs),
        format!("{:.1}–{:.1} s", lo, hi),
        plan.scenes[plan.baselines[c.baseline].scene].scene.name
    );
    (line, lo, hi)
}
