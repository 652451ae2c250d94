//! Advice before timing: probe a scene and the schedulers once, then predict the wall time of
//! every (scheduler, chunk) candidate with [`predict`] and name the fastest and every one
//! within a tolerance of it (a flat curve is reported as flat).

use super::probe::{self, PixelProbe};
use super::{near_best, predict, Overheads, Prediction, Workload};
use crate::core::scene::Scene;
use crate::core::tracer::Tracer;
use crate::sched::{Policy, SchedError, SchedulerKind, SchedulerSpec};
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

/// What the probe measured, for the report and for predictions of further configurations.
#[derive(Clone, Debug)]
pub struct Probed {
    /// Per-pixel costs at `probe_spp` on the run's workers, and their noise.
    pub pixels: PixelProbe,
    /// Samples per pixel of the probe render.
    pub probe_spp: u32,
    /// Hand-out costs per scheduler, keyed by its policy (the master's buffer matters).
    pub overheads: Vec<(Policy, Overheads)>,
    /// Seconds the probe took.
    pub probe_s: f64,
}

impl Probed {
    /// Probe `scene` at `probe_spp` (the scene as loaded must have that spp) on `workers`
    /// workers, and the hand-out costs of each of `policies`.
    pub fn measure<T: Tracer + 'static>(
        scene: &Arc<Scene>,
        tracer: &Arc<T>,
        workers: usize,
        policies: &[Policy],
    ) -> Result<Self, SchedError> {
        let t0 = Instant::now();
        let pixels = probe::pixels(scene, tracer, workers, 3)?;
        let mut overheads: Vec<(Policy, Overheads)> = Vec::new();
        for p in policies {
            if !overheads.iter().any(|(q, _)| q == p) {
                overheads.push((*p, probe::overheads(*p, workers, 3)?));
            }
        }
        Ok(Self {
            pixels,
            probe_spp: scene.settings.spp,
            overheads,
            probe_s: t0.elapsed().as_secs_f64(),
        })
    }

    /// The hand-out costs measured for `policy` (zero when it was not probed).
    pub fn overheads_of(&self, policy: &Policy) -> Overheads {
        self.overheads
            .iter()
            .find(|(p, _)| p == policy)
            .map(|(_, o)| *o)
            .unwrap_or_default()
    }

    /// The predicted wall time of `spec` at `spp` samples per pixel. For the master, the
    /// refill period is measured again with spinning items of this configuration's mean item
    /// cost ([`probe::loaded_refill`]); a failed run of that probe keeps the zero-work period.
    pub fn predict(&self, spec: &SchedulerSpec, spp: u32) -> Prediction {
        let items = probe::item_costs(
            &self.pixels.profile,
            spec,
            self.probe_spp,
            spp,
            self.pixels.fixed_pixel_s,
        );
        let work = Workload {
            item_s: &items,
            noise_cv: self.pixels.noise_cv,
            per_item_s: self.pixels.per_item_s,
        };
        let mut o = self.overheads_of(&spec.policy);
        if spec.policy.needs().hand_out_thread && !items.is_empty() {
            // The period that matters is that of the items that wait, the cheap ones: at the
            // median item's cost, not the mean's, which a hot spot pulls far above them.
            let typical = probe::median(&mut items.clone());
            let r = probe::loaded_refill(spec.policy, spec.workers, typical, &o, 3);
            o.refill_s = r.unwrap_or(o.refill_s);
        }
        predict(spec, &work, &o)
    }
}

/// One candidate and its prediction.
#[derive(Clone, Debug)]
pub struct Candidate {
    /// The configuration.
    pub spec: SchedulerSpec,
    /// Its predicted wall time and parts.
    pub prediction: Prediction,
}

/// Every candidate's prediction, the fastest and those near it.
#[derive(Clone, Debug)]
pub struct Advice {
    /// The candidates in the order asked for.
    pub candidates: Vec<Candidate>,
    /// Indices of the candidates within the tolerance of the fastest, fastest first
    /// (never empty when there are candidates).
    pub near_best: Vec<usize>,
}

/// Predict every spec in `specs` at `spp` from `probed` and rank them.
pub fn advise(probed: &Probed, specs: &[SchedulerSpec], spp: u32, tolerance: f64) -> Advice {
    // Policies that choose their own layout have one candidate whatever the chunk.
    let mut seen: HashMap<SchedulerKind, ()> = HashMap::new();
    let candidates: Vec<Candidate> = specs
        .iter()
        .filter(|s| !s.kind().picks_own_layout() || seen.insert(s.kind(), ()).is_none())
        .map(|s| Candidate {
            spec: s.clone(),
            prediction: probed.predict(s, spp),
        })
        .collect();
    let walls: Vec<f64> = candidates.iter().map(|c| c.prediction.wall_s).collect();
    Advice {
        near_best: near_best(&walls, tolerance),
        candidates,
    }
}
