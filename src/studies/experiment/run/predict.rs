//! The cost model's predictions for every configuration, probed once per (baseline, workers)
//! by the parent and read back by every child process.

use super::*;

/// The probe's samples per pixel: a few, scaled to the configuration's (see `model::probe`).
pub(super) const PROBE_SPP: u32 = 4;

/// Configurations sharing one probe: (baseline, workers), their specs and their ids.
pub(super) type ProbeGroup<'a> = ((usize, usize), Vec<&'a SchedulerSpec>, Vec<&'a str>);

/// The cost model's prediction for every local thread-scheduler configuration of `plan` not
/// yet done: one probe per (scene, tracer, workers), every configuration predicted from it.
/// Animations are not probed (the probe times one frame).
pub(in crate::studies::experiment) fn predictions(
    plan: &ExperimentPlan,
    todo: &Todo<'_>,
) -> Result<HashMap<String, Prediction>, RunError> {
    let mut out = HashMap::new();
    let mut groups: Vec<ProbeGroup<'_>> = Vec::new();
    for st in todo.states.iter().filter(|s| !s.done) {
        let c = st.config;
        let (Some(spec), Sources::Local(setup)) = (&c.spec, &c.sources) else {
            continue;
        };
        if setup.set != crate::sched::SourceSet::threads() {
            continue; // the cost model knows threads only
        }
        if plan.scene_of(c).scene.frames() > 1 {
            continue;
        }
        let key = (c.baseline, spec.workers);
        match groups.iter_mut().find(|g| g.0 == key) {
            Some(g) => {
                g.1.push(spec);
                g.2.push(&c.id);
            }
            None => groups.push((key, vec![spec], vec![&c.id])),
        }
    }
    for ((baseline, workers), specs, ids) in groups {
        let b = &plan.baselines[baseline];
        let full = &plan.scenes[b.scene].scene;
        let spp = full.settings.spp;
        let mut low = (**full).clone();
        low.settings.spp = spp.min(PROBE_SPP);
        let low = std::sync::Arc::new(low);
        let policies: Vec<_> = specs.iter().map(|s| s.policy).collect();
        let probed = Probed::measure(&low, &b.tracer, workers, &policies).map_err(|source| {
            RunError::Sched {
                config: format!("cost-model probe of {} ×{workers}", full.name),
                source,
            }
        })?;
        for (spec, id) in specs.iter().zip(ids) {
            out.insert(id.to_string(), probed.predict(spec, spp));
        }
    }
    Ok(out)
}

/// A configuration's label for the progress line.
pub(super) fn label_of(plan: &ExperimentPlan, c: &RunConfig) -> String {
    let label = c
        .spec
        .as_ref()
        .map_or(super::super::results::SERIAL.to_string(), |s| {
            match &c.sources {
                Sources::Local(setup) => format!("{}{} ×{}", s.label(), setup.label(), s.workers),
                Sources::Mpi { transport } => {
                    format!("{} over {} ranks ({transport})", s.label(), s.workers)
                }
            }
        });
    let b = &plan.baselines[c.baseline];
    format!(
        "{} · {} · {label}",
        plan.scene_of(c).scene.name,
        b.tracer_id
    )
}
/// The cost model's predictions, computed once by the parent for every child to record.
pub(in crate::studies::experiment) fn predictions_path(dir: &Path) -> PathBuf {
    dir.join(".predictions.json")
}

/// The predictions the parent left for the children (none when the plan records none).
pub(super) fn read_predictions(
    plan: &ExperimentPlan,
    dir: &Path,
) -> Result<HashMap<String, Prediction>, RunError> {
    if !plan.predict {
        return Ok(HashMap::new());
    }
    let path = predictions_path(dir);
    let text = std::fs::read_to_string(&path).map_err(|e| io_err(&path, e))?;
    serde_json::from_str(&text).map_err(|e| io_err(&path, e))
}
