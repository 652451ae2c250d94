//! A sweep's measured inputs ([`Inputs`]), one simulated configuration ([`simulate_one`]) and
//! its rows ([`SimRow`]): what the sweep, its validation and its plots share.

use super::child;
use super::config::{Platform, SimPlan};
use super::error::SimError;
use super::inputs::{self, ItemInputs, PixelCosts};
use super::job::{SimJob, SimOutcome};
use crate::sched::{param_columns, Chunk, Order, SchedulerSpec};
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

/// The measured inputs every simulated run of one experiment shares.
pub struct Inputs {
    /// Per-pixel costs of the probe render on one thread.
    pub pixels: PixelCosts,
    /// Per-pixel costs with that many threads rendering at once, used for runs of that many
    /// workers (the validation's; see [`PixelCosts::probe`]).
    pub concurrent: BTreeMap<usize, PixelCosts>,
    /// The master's h per buffer size, seconds.
    pub master_h_s: BTreeMap<usize, f64>,
    /// The shared counter's cost per grab, seconds.
    pub counter_s: f64,
    /// The fixed cost of a local-thread run, seconds: the master's per buffer size, and the
    /// threaded schedulers' (zero-work self-scheduling).
    pub fixed_s: (BTreeMap<usize, f64>, f64),
    /// Simulating this machine's local threads (the validation against local-thread runs):
    /// each simulated wall gets the measured launch cost, and a master's sources their
    /// measured refill period ([`Inputs::refill`]). A simulated cluster has neither measured.
    pub local_threads: bool,
    /// Item inputs per (chunk, order, probe threads, the order their cost factor was measured
    /// in), computed once.
    items: BTreeMap<(String, String, usize, String), Arc<ItemInputs>>,
    /// Each item layout's measured cost factor per (chunk, order, probe threads), measured on
    /// first use ([`crate::studies::model::probe::layout_factor`]); it does not depend on the level.
    layouts: BTreeMap<(String, String, usize), f64>,
    /// The probe's scene and tracer, for measuring layouts; `None`: every factor 1.
    scene: Option<(
        Arc<crate::core::scene::Scene>,
        Arc<crate::core::tracer::AnyTracer>,
    )>,
    /// Pairs of passes per layout factor.
    layout_reps: u32,
    /// The master's measured refill period per (configuration label, workers), seconds.
    refill: BTreeMap<(String, usize), f64>,
    /// Repetitions of each hand-out probe.
    reps: u32,
    /// The MPI launch being simulated: its measured period per item and source with spinning
    /// items, and those items' mean cost (`experiments/mpi_sweep.py --spin`), seconds. Over
    /// MPI a source's round trip is rank 0's hub, the worker's MPI thread and their polling
    /// on the node's cores, none of which the platform's ping-pong latency holds.
    pub mpi_period: Option<(f64, f64)>,
}

/// The master's measured h per buffer, `B=2: 212.0 ns, …`, or that none was probed (a sweep
/// without the master).
pub fn master_h_text(master_h_s: &BTreeMap<usize, f64>) -> String {
    if master_h_s.is_empty() {
        return "not probed (no master in the sweep)".to_string();
    }
    master_h_s
        .iter()
        .map(|(b, h)| format!("B={b}: {:.1} ns", h * 1e9))
        .collect::<Vec<_>>()
        .join(", ")
}

impl Inputs {
    /// Measure everything `specs` need: the probe render of the plan's scene (on one thread,
    /// and at each of `concurrency` threads at once), h for each buffer size, the counter's
    /// cost.
    pub fn measure(
        plan: &SimPlan,
        overrides: &crate::core::scene::SceneOverrides,
        specs: &[SchedulerSpec],
        concurrency: &[usize],
        quiet: bool,
    ) -> Result<Self, SimError> {
        let scene = Arc::new(
            crate::core::scene::load_scene(&plan.scene, overrides)
                .map_err(|e| SimError::Failed(format!("{}: {e}", plan.scene.display())))?,
        );
        let tracer = Arc::new(crate::core::tracer::AnyTracer::build(
            plan.tracer,
            &scene,
            1,
        )?);
        let reps = (plan.probe_repetitions, plan.probe_level_repetitions);
        let pixels = PixelCosts::probe(&scene, &tracer, reps.0, reps.1, 1)?;
        if !quiet {
            println!(
                "probe: Σ pixels timed one by one {:.4} s, bulk render in rows {:.4} s ({:+.1} %; {} bulk passes {:.4}–{:.4} s): the costs sum to the bulk render",
                pixels.timed_s,
                pixels.bulk_s,
                100.0 * (pixels.timed_s / pixels.bulk_s - 1.0),
                reps.1,
                pixels.bulk_range_s.0,
                pixels.bulk_range_s.1,
            );
        }
        let mut concurrent = BTreeMap::new();
        for &t in concurrency.iter().filter(|&&t| t > 1) {
            let px = PixelCosts::probe(&scene, &tracer, reps.0, reps.1, t)?;
            if !quiet {
                println!(
                    "probe on {t} threads at once: Σ pixels {:.4} s ({:+.1} % against one thread; bulk passes {:.4}–{:.4} s)",
                    px.serial_s(),
                    100.0 * (px.serial_s() / pixels.serial_s() - 1.0),
                    px.bulk_range_s.0,
                    px.bulk_range_s.1,
                );
            }
            concurrent.insert(t, px);
        }
        let (n, workers, reps) = plan.dispatch;
        let mut master_h_s = BTreeMap::new();
        let mut master_fixed_s = BTreeMap::new();
        for s in specs {
            if let Some(b) = s.policy.needs().outstanding {
                if let std::collections::btree_map::Entry::Vacant(e) = master_h_s.entry(b) {
                    let z = inputs::master_zero_work(s.kind(), b, n, workers, reps)?;
                    e.insert(z.per_item_s);
                    master_fixed_s.insert(b, z.fixed_s);
                }
            }
        }
        let counter = inputs::counter_zero_work(n, workers, reps)?;
        let counter_s = counter.per_item_s;
        if !quiet {
            println!(
                "probe: {}×{} px, Σ pixels {:.4} s; counter {:.1} ns/grab; master h {}",
                pixels.width,
                pixels.height,
                pixels.serial_s(),
                counter_s * 1e9,
                master_h_text(&master_h_s)
            );
        }
        Ok(Self {
            pixels,
            concurrent,
            master_h_s,
            counter_s,
            fixed_s: (master_fixed_s, counter.fixed_s),
            local_threads: false,
            items: BTreeMap::new(),
            layouts: BTreeMap::new(),
            scene: Some((scene, tracer)),
            layout_reps: plan.layout_repetitions,
            refill: BTreeMap::new(),
            reps,
            mpi_period: None,
        })
    }

    /// The same inputs with every pixel cost scaled so that one thread's pixels sum to
    /// `serial_s` (the costs with more threads at once keep their ratio to one thread's).
    pub fn at_level(&self, serial_s: f64) -> Self {
        let k = serial_s / self.pixels.serial_s();
        Self {
            pixels: self.pixels.scaled(k),
            concurrent: self
                .concurrent
                .iter()
                .map(|(t, px)| (*t, px.scaled(k)))
                .collect(),
            master_h_s: self.master_h_s.clone(),
            counter_s: self.counter_s,
            fixed_s: self.fixed_s.clone(),
            local_threads: self.local_threads,
            items: BTreeMap::new(),
            layouts: self.layouts.clone(),
            scene: self.scene.clone(),
            layout_reps: self.layout_reps,
            refill: self.refill.clone(),
            reps: self.reps,
            mpi_period: self.mpi_period,
        }
    }

    /// Every refill period measured so far: (configuration label, workers, seconds).
    pub fn refills(&self) -> Vec<(String, usize, f64)> {
        self.refill
            .iter()
            .map(|((l, w), r)| (l.clone(), *w, *r))
            .collect()
    }

    /// A master's refill period on this machine: a source's measured time per item under
    /// `spec`'s master on `spec.workers` threads, with spinning items of `mean_s` each (the
    /// cost model's probe, [`crate::studies::model::probe::loaded_refill_for`], with runs as long as
    /// the zero-work runs', M-129): the sleeping master's wake-up and its round trip per
    /// item, which zero-work items never show. Measured once per configuration; 0 for other
    /// schedulers.
    pub fn refill(&mut self, spec: &SchedulerSpec, mean_s: f64) -> Result<f64, SimError> {
        if !spec.policy.needs().hand_out_thread {
            return Ok(0.0);
        }
        let key = (spec.label(), spec.workers);
        if let Some(r) = self.refill.get(&key) {
            return Ok(*r);
        }
        let zero = crate::studies::model::probe::overheads(spec.policy, spec.workers, self.reps)?;
        let loaded = crate::studies::model::probe::loaded_refill_for(
            spec.policy,
            spec.workers,
            mean_s,
            &zero,
            self.reps,
            inputs::ZERO_WORK_RUN_S,
        )?;
        let r = hidden_refill(loaded, mean_s, zero.refill_s);
        self.refill.insert(key, r);
        Ok(r)
    }

    /// The period per item a source under `spec`'s master keeps to at least (the job's
    /// `refill_s`), for items of costs `cost_s`: on local threads the measured refill period;
    /// over MPI the launch's period with spinning items, unless it is hidden behind the item
    /// ([`hidden_refill`]; the floor below is then 0, no zero-work run over MPI being
    /// measured); else 0 (a cluster's master, whose round trip is the simulated network's)
    /// (M-130).
    pub fn source_floor(&mut self, spec: &SchedulerSpec, cost_s: &[f64]) -> Result<f64, SimError> {
        if cost_s.is_empty() || !spec.policy.needs().hand_out_thread {
            return Ok(0.0);
        }
        if self.local_threads {
            let mean = cost_s.iter().sum::<f64>() / cost_s.len() as f64;
            return self.refill(spec, mean);
        }
        Ok(self
            .mpi_period
            .map_or(0.0, |(period, mean)| hidden_refill(period, mean, 0.0)))
    }

    /// Every layout factor measured so far: (chunk, order, probe threads, factor).
    pub fn layout_factors(&self) -> Vec<(String, String, usize, f64)> {
        self.layouts
            .iter()
            .map(|((c, o, t), k)| (c.clone(), o.clone(), *t, *k))
            .collect()
    }

    /// The cost factor of `chunk` in `order` on `threads` threads, measured once.
    fn layout(&mut self, chunk: Chunk, order: Order, threads: usize) -> Result<f64, SimError> {
        let key = (chunk.to_string(), order.id().to_string(), threads);
        if let Some(k) = self.layouts.get(&key) {
            return Ok(*k);
        }
        let k = match &self.scene {
            Some((scene, tracer)) => crate::studies::model::probe::layout_factor(
                scene,
                tracer,
                threads,
                (chunk, order),
                self.layout_reps,
            )?,
            None => 1.0,
        };
        self.layouts.insert(key, k);
        Ok(k)
    }

    /// The items of `chunk` in `order` for `workers` workers, costed at the layout factor of
    /// `chunk` in `cost_order`: the order the workers run them in.
    fn items(
        &mut self,
        (chunk, order): (Chunk, Order),
        workers: usize,
        cost_order: Order,
    ) -> Result<Arc<ItemInputs>, SimError> {
        let threads = if self.concurrent.contains_key(&workers) {
            workers
        } else {
            1
        };
        let key = (
            chunk.to_string(),
            order.id().to_string(),
            threads,
            cost_order.id().to_string(),
        );
        if let Some(items) = self.items.get(&key) {
            return Ok(items.clone());
        }
        let layout = self.layout(chunk, cost_order, threads)?;
        let px = self.concurrent.get(&threads).unwrap_or(&self.pixels);
        let items = Arc::new(ItemInputs::new(px, chunk, order, layout));
        self.items.insert(key, items.clone());
        Ok(items)
    }

    /// The job simulating `spec` on `platform`.
    pub fn job(
        &mut self,
        spec: &SchedulerSpec,
        platform: &Path,
        plan: &SimPlan,
    ) -> Result<SimJob, SimError> {
        // pbrt and mitsuba choose their own tiles, as in a measured run.
        let (chunk, order) = spec.layout(self.pixels.width, self.pixels.height);
        // Workers that run each hand-out in scanline order pay the layout's scanline cost (an
        // approximation: a hand-out is a sparse share of the image; on one worker factoring
        // over scattered pixels, so run, took 1.003× its scanline time, 1.04× as handed out).
        let cost_order = if spec.kind().runs_hand_outs_in_scanline() {
            Order::Scanline
        } else {
            order
        };
        let items = self.items((chunk, order), spec.workers, cost_order)?;
        let params = spec
            .policy
            .info()
            .iter()
            .filter_map(|p| Some((p.name.to_string(), spec.get(p.name)?)))
            .collect();
        let (master_h_s, fixed_s) = if let Some(b) = spec.policy.needs().outstanding {
            (
                self.master_h_s.get(&b).copied().unwrap_or(0.0),
                self.fixed_s.0.get(&b).copied().unwrap_or(0.0),
            )
        } else {
            (0.0, self.fixed_s.1)
        };
        let refill_s = self.source_floor(spec, &items.cost_s)?;
        Ok(SimJob {
            platform: platform.to_path_buf(),
            scheduler: spec.kind().id().to_string(),
            params,
            workers: spec.workers,
            cost_s: items.cost_s.clone(),
            item_bytes: items.item_bytes.clone(),
            result_bytes: items.result_bytes.clone(),
            master_h_s,
            counter_s: self.counter_s,
            start_s: if self.local_threads { fixed_s } else { 0.0 },
            refill_s,
            lost: plan.lost.clone(),
            seed: plan.seed,
            network: plan.network(spec.workers),
        })
    }
}

/// The floor a source's period per item gets from a refill period `loaded` measured with
/// spinning items of `mean_s` each. A period within 5 % of the item cost says the refill is
/// hidden behind the item: the master's wake-up is shorter than the mean item, by how much is
/// not measured, so the floor is the zero-work period `zero_s`; taken as the floor, such a
/// period raised every item cheaper than the mean to it (M-131).
pub fn hidden_refill(loaded: f64, mean_s: f64, zero_s: f64) -> f64 {
    if loaded < 1.05 * mean_s {
        zero_s
    } else {
        loaded
    }
}

/// One simulated run as a row of `sim_runs.csv`.
#[derive(Clone, Debug, PartialEq)]
pub struct SimRow {
    /// The platform file's stem.
    pub platform: String,
    /// The configuration simulated.
    pub spec: SchedulerSpec,
    /// Pixels per item.
    pub chunk_px: u64,
    /// Σ pixel costs of the probe: what speedup is relative to.
    pub serial_s: f64,
    /// Items in the decomposition.
    pub items: usize,
    /// The network it was simulated on.
    pub network: super::job::Network,
    /// What the simulation reported.
    pub out: SimOutcome,
}

impl SimRow {
    /// serial / wall.
    pub fn speedup(&self) -> f64 {
        // NaN stays NaN (a run stopped at run_limit_s has no wall): `max` would drop it.
        if self.out.wall_s.is_nan() {
            return f64::NAN;
        }
        self.serial_s / self.out.wall_s.max(1e-300)
    }
    /// speedup / workers.
    pub fn efficiency(&self) -> f64 {
        self.speedup() / self.spec.workers as f64
    }
    /// Σ (wall − busy) over workers.
    pub fn idle_s(&self) -> f64 {
        self.out
            .busy_s
            .iter()
            .map(|b| (self.out.wall_s - b).max(0.0))
            .sum()
    }
    /// max busy / mean busy.
    pub fn imbalance(&self) -> f64 {
        let b = &self.out.busy_s;
        let mean = b.iter().sum::<f64>() / b.len().max(1) as f64;
        let max = b.iter().cloned().fold(0.0, f64::max);
        if mean > 0.0 {
            max / mean
        } else {
            1.0
        }
    }

    /// Column names of `sim_runs.csv`.
    pub fn header() -> Vec<String> {
        let mut h: Vec<String> = [
            "simulated",
            "platform",
            "scheduler",
            "label",
            "chunk",
            "chunk_px",
            "order",
        ]
        .map(String::from)
        .to_vec();
        h.extend(param_columns().iter().map(|p| p.name.to_string()));
        h.extend(
            [
                "workers",
                "network",
                "wall_s",
                "serial_s",
                "speedup",
                "efficiency",
                "dispatch_s",
                "idle_s",
                "imbalance",
                "items",
                "issued",
                "reissued",
                "duplicates",
                "bytes",
                "messages",
                "lost_workers",
                "completed",
                "error",
                "host_s",
            ]
            .map(String::from),
        );
        h
    }

    /// The row's cells in [`Self::header`] order.
    pub fn record(&self) -> Vec<String> {
        let s = &self.spec;
        let o = &self.out;
        let mut r = vec![
            "true".into(),
            self.platform.clone(),
            s.kind().id().into(),
            s.label(),
            s.chunk.to_string(),
            self.chunk_px.to_string(),
            s.order.id().into(),
        ];
        r.extend(
            param_columns()
                .iter()
                .map(|p| s.get(p.name).unwrap_or_default()),
        );
        r.extend([
            s.workers.to_string(),
            self.network.id().to_string(),
            format!("{:.9}", o.wall_s),
            format!("{:.9}", self.serial_s),
            format!("{:.4}", self.speedup()),
            format!("{:.4}", self.efficiency()),
            format!("{:.9}", o.dispatch_s),
            format!("{:.9}", self.idle_s()),
            format!("{:.4}", self.imbalance()),
            self.items.to_string(),
            o.issued.to_string(),
            o.reissued.to_string(),
            o.duplicates.to_string(),
            o.bytes.to_string(),
            o.messages.to_string(),
            o.lost_workers.to_string(),
            o.error.is_none().to_string(),
            o.error.clone().unwrap_or_default(),
            format!("{:.3}", o.host_s),
        ]);
        r
    }
}

/// Simulate `spec` (its worker count set) on `platform`.
pub fn simulate_one(
    inputs: &mut Inputs,
    plan: &SimPlan,
    exe: &Path,
    platform: &Platform,
    spec: &SchedulerSpec,
) -> Result<SimRow, SimError> {
    let job = inputs.job(spec, &platform.path, plan)?;
    let limit = plan.run_limit_s.map(std::time::Duration::from_secs_f64);
    let out = match child::simulate(exe, &job, limit) {
        Ok(out) => out,
        Err(child::Failure::OverLimit) => SimOutcome {
            wall_s: f64::NAN,
            error: Some(format!(
                "not simulated: still running after run_limit_s = {} s of real time",
                plan.run_limit_s.unwrap_or_default()
            )),
            host_s: plan.run_limit_s.unwrap_or_default(),
            ..Default::default()
        },
        Err(child::Failure::Error(m)) => {
            return Err(SimError::Failed(format!(
                "simulating {} on {} workers of {}: {m}",
                spec.label(),
                spec.workers,
                platform.name
            )))
        }
    };
    Ok(SimRow {
        platform: platform.name.clone(),
        spec: spec.clone(),
        chunk_px: {
            let (w, h) = (inputs.pixels.width, inputs.pixels.height);
            spec.layout(w, h).0.pixels(w, h)
        },
        serial_s: inputs.pixels.serial_s(),
        items: job.cost_s.len(),
        network: job.network,
        out,
    })
}

/// Write `rows` as CSV (atomically: a failed run leaves no partial file).
pub fn write_rows(path: &Path, rows: &[SimRow]) -> Result<(), SimError> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(SimRow::header())?;
    for r in rows {
        w.write_record(r.record())?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| SimError::Failed(format!("{e}")))?;
    crate::util::fs::write_atomic(path, &bytes)?;
    Ok(())
}

/// `/proc/loadavg`'s first three fields (the machine is shared: measured inputs are noisy).
pub fn load_average() -> String {
    crate::util::host::load_average_text()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::SchedulerKind;

    /// The inputs line names each buffer's h, and says so where no master was probed (the
    /// report read "master h ." there).
    #[test]
    fn the_master_h_line_is_never_empty() {
        assert_eq!(
            master_h_text(&BTreeMap::new()),
            "not probed (no master in the sweep)"
        );
        let h = BTreeMap::from([(2, 212e-9), (64, 20.5e-9)]);
        assert_eq!(master_h_text(&h), "B=2: 212.0 ns, B=64: 20.5 ns");
    }

    #[test]
    fn an_mpi_master_keeps_to_its_launchs_spinning_period_unless_the_item_hides_it() {
        let one = 13.3e-6;
        let mut inputs = Inputs {
            pixels: PixelCosts {
                width: 1,
                height: 1,
                cost_s: vec![one],
                timed_s: one,
                bulk_s: one,
                bulk_range_s: (one, one),
            },
            concurrent: BTreeMap::new(),
            master_h_s: BTreeMap::new(),
            counter_s: 0.0,
            fixed_s: (BTreeMap::new(), 0.0),
            local_threads: false,
            items: BTreeMap::new(),
            layouts: BTreeMap::new(),
            scene: None,
            layout_reps: 0,
            refill: BTreeMap::new(),
            reps: 1,
            mpi_period: None,
        };
        let master = SchedulerSpec::new(SchedulerKind::Master, Chunk::Tile { w: 1, h: 1 }, 1);
        let costs = [one; 4];
        // A cluster's master: its round trip is the simulated network's.
        assert_eq!(inputs.source_floor(&master, &costs).unwrap(), 0.0);
        // The per-ray launch over shared memory (Xeon dev VM, 16:05): 21.5 µs per item.
        inputs.mpi_period = Some((21.5e-6, one));
        assert_eq!(inputs.source_floor(&master, &costs).unwrap(), 21.5e-6);
        // 16² tiles on one rendering rank: the period is the item's, the refill hidden.
        inputs.mpi_period = Some((3443e-6, 3415e-6));
        assert_eq!(inputs.source_floor(&master, &costs).unwrap(), 0.0);
        // Only the master's sources wait for a refill.
        inputs.mpi_period = Some((21.5e-6, one));
        let ss = SchedulerSpec::new(SchedulerKind::SelfScheduling, Chunk::Tile { w: 1, h: 1 }, 1);
        assert_eq!(inputs.source_floor(&ss, &costs).unwrap(), 0.0);
    }

    #[test]
    fn a_refill_period_at_the_item_cost_is_hidden_and_one_above_it_is_the_floor() {
        // The 06:45 window's master at 16² tiles: 2981 µs measured over items of 2972 µs.
        assert_eq!(hidden_refill(2981e-6, 2972e-6, 1e-6), 1e-6);
        // The per-ray master at B = 2: 21.1 µs over items of 11.6 µs, the wake-up showing.
        assert_eq!(hidden_refill(21.1e-6, 11.6e-6, 1e-6), 21.1e-6);
    }
}
