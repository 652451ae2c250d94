//! Simulated against measured: every configuration of a measured `runs.csv` (local threads)
//! simulated on the validation platform with the same scheduler, chunk and worker count.

use super::config::{Platform, SimPlan};
use super::error::SimError;
use super::rows::{simulate_one, Inputs};
use crate::core::scene::SceneOverrides;
use crate::sched::{param_columns, Chunk, Order, SchedulerKind, SchedulerSpec};
use crate::studies::experiment::results::{read_runs, RunRow};
use std::path::Path;

/// One measured configuration: its spec and its repetitions' wall times.
#[derive(Clone, Debug)]
pub struct Measured {
    /// The configuration (workers set).
    pub spec: SchedulerSpec,
    /// Wall time of each repetition, seconds.
    pub walls: Vec<f64>,
    /// Σ busy seconds over workers of each repetition (`work_s`).
    pub busy: Vec<f64>,
    /// The master's dispatch seconds of each repetition.
    pub dispatch: Vec<f64>,
    /// Round (repetition index) of each repetition.
    pub rounds: Vec<u32>,
    /// The MPI transport of its launches (`shared_memory`, `tcp_loopback`, …); `None` for
    /// local threads.
    pub transport: Option<String>,
    /// Median of every serial render of the measured set.
    pub serial_s: f64,
    /// Median of the serial renders of the rounds its repetitions were taken in: the
    /// machine's speed while this configuration ran. The serial of the published set went
    /// from 0.238 s in its first rounds to 0.27 s in its last (+13 % in 110 s), and the
    /// configurations that reached their CI target early were measured in the fast rounds
    /// only: against one level they came out 5 % fast.
    pub level_s: f64,
    /// Items of its decomposition (the last row's `items`).
    pub items: u64,
    /// Over MPI: the period per item and source of the same launch with spinning items,
    /// and those items' mean cost, seconds ([`attach_spin`]).
    pub spin_period: Option<(f64, f64)>,
}

fn median(v: &[f64]) -> f64 {
    crate::studies::model::probe::median(&mut v.to_vec())
}

fn spec_of(r: &RunRow) -> Result<SchedulerSpec, String> {
    let kind = SchedulerKind::from_id(&r.scheduler).map_err(|e| e.msg)?;
    let chunk = Chunk::parse(r.chunk.as_deref().unwrap_or("")).map_err(|e| e.msg)?;
    let mut spec = SchedulerSpec::new(kind, chunk, r.workers);
    if let Some(o) = &r.order {
        spec.order = Order::from_id(o).map_err(|e| e.msg)?;
    }
    for p in param_columns() {
        if let Some(v) = r.param(p.name) {
            spec.set(p.name, v).map_err(|e| e.msg)?;
        }
    }
    Ok(spec)
}

/// The local-thread configurations of `csv`, and the scene settings they were measured with
/// (one size for all: the validation's probe renders the scene at it).
pub fn measured_configs(csv: &Path) -> Result<(Vec<Measured>, SceneOverrides), SimError> {
    let (rows, _) = read_runs(csv)?;
    configs_of(&rows).map_err(|m| SimError::Failed(format!("{}: {m}", csv.display())))
}

/// [`measured_configs`] of rows already read. The serial time is the median of every serial
/// row: a row's own `serial_s` is the median of the serial samples taken before it, so the
/// first round's rows hold the first serial render alone (in an earlier validation set it
/// made the serial look slower than every 1-worker run). Each configuration's level is the median of the serial rows of its
/// own rounds (repetition k of every configuration is taken in round k, serial first).
///
/// # Errors
/// A row whose scheduler does not parse, rows of different scene settings, no row.
pub fn configs_of(rows: &[RunRow]) -> Result<(Vec<Measured>, SceneOverrides), SimError> {
    configs_where(rows, false).map_err(SimError::Failed)
}

/// The MPI configurations of `csv` (one per scheduler configuration, rank count and
/// transport) and their scene settings. Their level is every serial render's median: a
/// launch sequence measures the serial once, in its first launch, so rounds of different
/// launches share repetition numbers and no serial of their own.
pub fn mpi_configs(csv: &Path) -> Result<(Vec<Measured>, SceneOverrides), SimError> {
    let (rows, _) = read_runs(csv)?;
    configs_where(&rows, true).map_err(|m| SimError::Failed(format!("{}: {m}", csv.display())))
}

fn configs_where(rows: &[RunRow], mpi: bool) -> Result<(Vec<Measured>, SceneOverrides), String> {
    let local = |r: &&RunRow| r.on_threads_alone();
    let picked = |r: &&RunRow| {
        if mpi {
            r.on_mpi()
        } else {
            r.on_threads_alone()
        }
    };
    let mut out: Vec<Measured> = Vec::new();
    let mut size: Option<(u32, u32, u32, i32)> = None;
    for r in rows.iter().filter(picked).filter(|r| !r.is_serial()) {
        let this = (r.width, r.height, r.spp, r.max_depth);
        if *size.get_or_insert(this) != this {
            return Err(format!(
                "row {} renders {}×{} at {} spp, max_depth {}; a validation takes one scene setting",
                r.label, r.width, r.height, r.spp, r.max_depth
            ));
        }
        let spec = spec_of(r).map_err(|m| format!("{}: {m}", r.label))?;
        let transport = r.transport.clone().filter(|_| mpi);
        match out
            .iter_mut()
            .find(|m| m.spec == spec && m.transport == transport)
        {
            Some(m) => {
                m.walls.push(r.wall_s);
                m.busy.push(r.work_s);
                m.dispatch.push(r.dispatch_s);
                m.rounds.push(r.repetition);
                m.serial_s = r.serial_s;
                m.level_s = r.serial_s;
                m.items = r.items;
            }
            None => out.push(Measured {
                spec,
                walls: vec![r.wall_s],
                busy: vec![r.work_s],
                dispatch: vec![r.dispatch_s],
                rounds: vec![r.repetition],
                transport,
                serial_s: r.serial_s,
                level_s: r.serial_s,
                items: r.items,
                spin_period: None,
            }),
        }
    }
    let Some((width, height, spp, max_depth)) = size else {
        return Err(format!(
            "no {} scheduler rows to validate against",
            if mpi { "MPI" } else { "local-thread" }
        ));
    };
    let serial: Vec<&RunRow> = rows
        .iter()
        .filter(local)
        .filter(|r| r.is_serial())
        .filter(|r| (r.width, r.height, r.spp, r.max_depth) == (width, height, spp, max_depth))
        .collect();
    // Without serial rows each configuration keeps its last row's (the most samples).
    if !serial.is_empty() {
        let s = median(&serial.iter().map(|r| r.wall_s).collect::<Vec<_>>());
        for m in &mut out {
            m.serial_s = s;
            let own: Vec<f64> = serial
                .iter()
                .filter(|r| !mpi && m.rounds.contains(&r.repetition))
                .map(|r| r.wall_s)
                .collect();
            m.level_s = if own.is_empty() { s } else { median(&own) };
        }
    }
    let overrides = SceneOverrides {
        width: Some(width),
        height: Some(height),
        spp: Some(spp),
        max_depth: Some(max_depth),
        ..Default::default()
    };
    Ok((out, overrides))
}

/// Give every MPI configuration of `configs` the period per item and source of its launch
/// with spinning items (`spin`, the same configurations measured by
/// `experiments/mpi_sweep.py --spin`): workers × the median wall / items. The spinning items
/// cost, per pixel, the mean pixel of `configs`' serial renders, so their mean is the serial
/// over the items. A configuration without a spinning launch keeps none.
pub fn attach_spin(configs: &mut [Measured], spin: &[Measured]) {
    for m in configs.iter_mut() {
        let Some(s) = spin
            .iter()
            .find(|s| s.spec == m.spec && s.transport == m.transport && s.items > 0)
        else {
            continue;
        };
        let items = s.items as f64;
        m.spin_period = Some((
            s.spec.workers as f64 * median(&s.walls) / items,
            m.serial_s / items,
        ));
    }
}

/// One configuration, measured and simulated.
#[derive(Clone, Debug)]
pub struct Comparison {
    /// The configuration.
    pub spec: SchedulerSpec,
    /// The platform it was simulated on.
    pub platform: String,
    /// Who rendered: `threads`, or `MPI <transport>` (ranks = workers + 1).
    pub sources: String,
    /// Measured wall: median, min, max over repetitions.
    pub measured: (f64, f64, f64),
    /// The measured median's 95 % confidence interval (bootstrap, `experiment::stats`).
    pub ci: (f64, f64),
    /// Repetitions measured.
    pub repetitions: usize,
    /// Simulated wall, the pixel costs at the probe's own level.
    pub simulated: f64,
    /// The serial renders of its rounds, median ([`Measured::level_s`]).
    pub level_s: f64,
    /// Simulated wall with the pixel costs scaled to sum to `level_s` (the probe's shape at
    /// the machine's speed while this configuration was measured): the error left to the
    /// scheduling model.
    pub simulated_at_serial: f64,
    /// Measured speedup (`level_s` / median wall: the serial of the same rounds).
    pub measured_speedup: f64,
    /// Simulated speedup (Σ probe pixel costs / simulated wall).
    pub simulated_speedup: f64,
    /// Σ busy over workers: measured median, simulated.
    pub busy: (f64, f64),
    /// The master's dispatch seconds: measured median, simulated.
    pub dispatch: (f64, f64),
    /// Σ idle (wall − busy) over workers: measured median, simulated.
    pub idle: (f64, f64),
    /// Over MPI: its launch's period per item with spinning items, and their mean cost.
    pub spin_period: Option<(f64, f64)>,
}

impl Comparison {
    /// (simulated − measured) / measured wall.
    pub fn wall_error(&self) -> f64 {
        (self.simulated - self.measured.0) / self.measured.0
    }
    /// (simulated at the serial's level − measured) / measured wall.
    pub fn wall_error_at_serial(&self) -> f64 {
        (self.simulated_at_serial - self.measured.0) / self.measured.0
    }
    /// (simulated − measured) / measured speedup.
    pub fn speedup_error(&self) -> f64 {
        (self.simulated_speedup - self.measured_speedup) / self.measured_speedup
    }
}

/// The whole validation.
#[derive(Clone, Debug)]
pub struct Validation {
    /// The platform simulated on.
    pub platform: String,
    /// Every configuration.
    pub rows: Vec<Comparison>,
    /// Pairs (same worker count) whose measured medians' 95 % confidence intervals do not
    /// overlap, and how many of them the simulation orders the same way.
    pub ranking: (usize, usize),
    /// The machine's load average while the inputs were measured.
    pub load: String,
    /// The inputs checked against the measured serial baseline: (measured serial median,
    /// Σ probe pixel costs, Σ of the pixels as timed one by one before calibration).
    pub serial: (f64, f64, f64),
    /// Each master configuration's measured refill period: (label, workers, seconds).
    pub refill: Vec<(String, usize, f64)>,
    /// Σ pixel costs of the probe with that many threads rendering at once.
    pub concurrent: Vec<(usize, f64)>,
}

/// Simulate every measured configuration on its platform: local threads with this machine's
/// launch cost and refill period, MPI ranks with neither (their round trip is the platform's
/// loopback, their wall excludes the launch).
pub fn compare(
    measured: &[(Measured, Platform)],
    inputs: &mut Inputs,
    plan: &SimPlan,
    exe: &Path,
    quiet: bool,
) -> Result<Validation, SimError> {
    let serial_s = measured.first().map_or(f64::NAN, |m| m.0.serial_s);
    let mut rows = Vec::new();
    for (m, platform) in measured {
        inputs.local_threads = m.transport.is_none();
        inputs.mpi_period = m.spin_period;
        let sim = simulate_one(inputs, plan, exe, platform, &m.spec)?;
        // After `sim`: the scaled inputs share its measured refill period.
        let mut at_level = inputs.at_level(m.level_s);
        let sim_at_serial = simulate_one(&mut at_level, plan, exe, platform, &m.spec)?;
        let med = median(&m.walls);
        let lo = m.walls.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = m.walls.iter().cloned().fold(0.0, f64::max);
        let sim_busy: f64 = sim.out.busy_s.iter().sum();
        let measured_idle: Vec<f64> = m
            .walls
            .iter()
            .zip(&m.busy)
            .map(|(w, b)| w * m.spec.workers as f64 - b)
            .collect();
        let c = Comparison {
            spec: m.spec.clone(),
            platform: platform.name.clone(),
            sources: match &m.transport {
                Some(t) => format!("MPI {t}"),
                None => "threads".into(),
            },
            measured: (med, lo, hi),
            ci: crate::studies::experiment::stats::median_ci(&m.walls, 1),
            repetitions: m.walls.len(),
            simulated: sim.out.wall_s,
            level_s: m.level_s,
            simulated_at_serial: sim_at_serial.out.wall_s,
            measured_speedup: m.level_s / med,
            simulated_speedup: sim.speedup(),
            busy: (median(&m.busy), sim_busy),
            dispatch: (median(&m.dispatch), sim.out.dispatch_s),
            idle: (median(&measured_idle), sim.idle_s()),
            spin_period: m.spin_period,
        };
        if !quiet {
            println!(
                "validation {} {} workers={}: measured {:.4} s, simulated {:.4} s ({:+.1} %; at the serial's level {:+.1} %); busy {:.4}/{:.4}, dispatch {:.4}/{:.4}, idle {:.4}/{:.4}",
                c.sources,
                c.spec.label(),
                c.spec.workers,
                med,
                c.simulated,
                100.0 * c.wall_error(),
                100.0 * c.wall_error_at_serial(),
                c.busy.0,
                c.busy.1,
                c.dispatch.0,
                c.dispatch.1,
                c.idle.0,
                c.idle.1,
            );
        }
        rows.push(c);
    }
    let mut ranking = (0, 0);
    for (i, a) in rows.iter().enumerate() {
        for b in &rows[i + 1..] {
            if (a.spec.workers, &a.sources) != (b.spec.workers, &b.sources) {
                continue;
            }
            let separated = a.ci.1 < b.ci.0 || b.ci.1 < a.ci.0;
            if separated {
                ranking.0 += 1;
                if (a.measured.0 < b.measured.0) == (a.simulated < b.simulated) {
                    ranking.1 += 1;
                }
            }
        }
    }
    let mut platforms: Vec<String> = rows.iter().map(|c| c.platform.clone()).collect();
    platforms.dedup();
    Ok(Validation {
        platform: platforms.join(", "),
        rows,
        ranking,
        load: super::rows::load_average(),
        serial: (serial_s, inputs.pixels.serial_s(), inputs.pixels.timed_s),
        refill: inputs.refills(),
        concurrent: inputs
            .concurrent
            .iter()
            .map(|(t, px)| (*t, px.serial_s()))
            .collect(),
    })
}

/// `validation.csv` in `dir`.
pub fn write(dir: &Path, v: &Validation) -> Result<(), SimError> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "platform",
        "sources",
        "label",
        "workers",
        "repetitions",
        "measured_wall_s",
        "measured_min_s",
        "measured_max_s",
        "simulated_wall_s",
        "wall_error",
        "serial_level_s",
        "simulated_at_serial_wall_s",
        "wall_error_at_serial",
        "measured_speedup",
        "simulated_speedup",
        "speedup_error",
        "measured_busy_s",
        "simulated_busy_s",
        "measured_dispatch_s",
        "simulated_dispatch_s",
        "measured_idle_s",
        "simulated_idle_s",
    ])?;
    for c in &v.rows {
        w.write_record([
            c.platform.clone(),
            c.sources.clone(),
            c.spec.label(),
            c.spec.workers.to_string(),
            c.repetitions.to_string(),
            format!("{:.6}", c.measured.0),
            format!("{:.6}", c.measured.1),
            format!("{:.6}", c.measured.2),
            format!("{:.6}", c.simulated),
            format!("{:.4}", c.wall_error()),
            format!("{:.6}", c.level_s),
            format!("{:.6}", c.simulated_at_serial),
            format!("{:.4}", c.wall_error_at_serial()),
            format!("{:.4}", c.measured_speedup),
            format!("{:.4}", c.simulated_speedup),
            format!("{:.4}", c.speedup_error()),
            format!("{:.6}", c.busy.0),
            format!("{:.6}", c.busy.1),
            format!("{:.6}", c.dispatch.0),
            format!("{:.6}", c.dispatch.1),
            format!("{:.6}", c.idle.0),
            format!("{:.6}", c.idle.1),
        ])?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| SimError::Failed(format!("{e}")))?;
    crate::util::fs::write_atomic(&dir.join("validation.csv"), &bytes)?;
    Ok(())
}

/// How many rows satisfy `ok`.
fn count(v: &Validation, ok: impl Fn(&Comparison) -> bool) -> usize {
    v.rows.iter().filter(|c| ok(c)).count()
}

/// The validation table for `report.md`.
pub fn markdown(v: &Validation) -> String {
    let (serial, probe_sum, timed_sum) = v.serial;
    let spun: Vec<String> = v
        .rows
        .iter()
        .filter_map(|c| {
            let (p, mean) = c.spin_period?;
            Some(format!(
                "{} {} on {}: {:.1} µs over items of {:.1} µs",
                c.sources,
                c.spec.label(),
                c.spec.workers,
                p * 1e6,
                mean * 1e6
            ))
        })
        .collect();
    let spun = if spun.is_empty() {
        String::new()
    } else {
        format!(
            " Over MPI, each launch's period per item and source with spinning items (the floor of its sources unless within 5 % of the item): {}.",
            spun.join("; ")
        )
    };
    let mut s = format!(
        "## Validation: simulated ({}) vs measured\n\n{} configurations; wall error ≤ 5 %: {} (with the pixel costs at the level of the serial renders of each configuration's own rounds: {}); speedup error ≤ 10 %: {}; ranking of pairs whose measured medians' 95 % CIs do not overlap: {} of {} the same. Load average after the measurements: {}.\n\nInputs against the measured serial baseline (median {serial:.4} s): Σ of the probe's pixel costs {probe_sum:.4} s ({:+.1} %), calibrated to a bulk render in rows; as timed one pixel at a time {timed_sum:.4} s ({:+.1} %).{}{}{spun}\n\n| sources | configuration | workers | measured wall s (min–max) | simulated s | wall error | serial of its rounds s | at that level | speedup measured / simulated | Σ busy s measured / simulated | dispatch s m / s | Σ idle s m / s |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        v.platform,
        v.rows.len(),
        count(v, |c| c.wall_error().abs() <= 0.05),
        count(v, |c| c.wall_error_at_serial().abs() <= 0.05),
        count(v, |c| c.speedup_error().abs() <= 0.10),
        v.ranking.1,
        v.ranking.0,
        v.load,
        100.0 * (probe_sum - serial) / serial,
        100.0 * (timed_sum - serial) / serial,
        v.concurrent
            .iter()
            .map(|(t, sum)| format!(
                " With {t} threads rendering at once (the costs of the {t}-worker runs): Σ {sum:.4} s ({:+.1} %).",
                100.0 * (sum / probe_sum - 1.0)
            ))
            .collect::<String>(),
        if v.refill.is_empty() {
            String::new()
        } else {
            format!(
                " The master's refill period per source (spinning items of each configuration's mean cost): {}.",
                v.refill
                    .iter()
                    .map(|(l, w, r)| format!("{l} on {w}: {:.1} µs", r * 1e6))
                    .collect::<Vec<_>>()
                    .join("; ")
            )
        },
    );
    for c in &v.rows {
        s += &format!(
            "| {} | {} | {} | {:.4} ({:.4}–{:.4}) | {:.4} | {:+.1} % | {:.4} | {:+.1} % | {:.2} / {:.2} | {:.4} / {:.4} | {:.4} / {:.4} | {:.4} / {:.4} |\n",
            c.sources,
            c.spec.label(),
            c.spec.workers,
            c.measured.0,
            c.measured.1,
            c.measured.2,
            c.simulated,
            100.0 * c.wall_error(),
            c.level_s,
            100.0 * c.wall_error_at_serial(),
            c.measured_speedup,
            c.simulated_speedup,
            c.busy.0,
            c.busy.1,
            c.dispatch.0,
            c.dispatch.1,
            c.idle.0,
            c.idle.1,
        );
    }
    s + "\n"
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::studies::experiment::results::SERIAL;

    fn row(scheduler: &str, wall_s: f64, serial_s: f64) -> RunRow {
        let mut r = RunRow::example();
        (r.width, r.height, r.spp, r.max_depth) = (8, 8, 1, 4);
        r.scheduler = scheduler.into();
        r.workers = 1;
        if scheduler != SERIAL {
            r.chunk = Some("16".into());
        }
        r.wall_s = wall_s;
        r.serial_s = serial_s;
        r
    }

    #[test]
    fn the_serial_time_is_the_median_of_every_serial_row_not_the_first_rows_column() {
        // As a run writes them: the first round's rows carry the first serial render alone
        // (0.42), later rows the running median.
        let rows = [
            row(SERIAL, 0.42, 0.42),
            row("static", 0.38, 0.42),
            row(SERIAL, 0.33, 0.33),
            row("static", 0.39, 0.375),
            row(SERIAL, 0.36, 0.36),
            row("static", 0.37, 0.36),
        ];
        let (configs, o) = configs_of(&rows).unwrap();
        assert_eq!(configs.len(), 1);
        assert_eq!(configs[0].walls, [0.38, 0.39, 0.37]);
        assert_eq!(configs[0].serial_s, 0.36);
        assert_eq!((o.width, o.height, o.spp), (Some(8), Some(8), Some(1)));
        // Without serial rows the last row's running median stands.
        let (configs, _) = configs_of(&rows[1..2]).unwrap();
        assert_eq!(configs[0].serial_s, 0.42);
        let (configs, _) = configs_of(&[rows[1].clone(), rows[3].clone()]).unwrap();
        assert_eq!(configs[0].serial_s, 0.375);
        assert!(configs_of(&rows[..1]).is_err());
    }

    #[test]
    fn each_configurations_level_is_the_serial_of_its_own_rounds() {
        // The machine's speed moves between rounds; `rows:1` was measured in rounds 1 and 2
        // only. Each row's `serial_s` column is the running median, as a run writes it.
        let serials = [0.26, 0.24, 0.25, 0.27, 0.28];
        let mut rows = Vec::new();
        for (k, s) in serials.into_iter().enumerate() {
            let running = median(&serials[..=k]);
            let mut r = row(SERIAL, s, running);
            r.repetition = k as u32;
            rows.push(r);
            let mut r = row("static", s * 1.02, running);
            r.repetition = k as u32;
            rows.push(r);
            if (1..3).contains(&k) {
                let mut r = row("static", s * 0.98, running);
                r.chunk = Some("rows:1".into());
                r.repetition = k as u32;
                rows.push(r);
            }
        }
        let (configs, _) = configs_of(&rows).unwrap();
        let level = |chunk: &str| {
            let m = configs
                .iter()
                .find(|m| m.spec.label().ends_with(chunk))
                .unwrap();
            (m.serial_s, m.level_s)
        };
        assert_eq!(level("chunk=16"), (0.26, 0.26));
        assert_eq!(level("chunk=rows:1"), (0.26, 0.245));
        // A configuration without a serial render in its rounds takes every serial's median.
        let mut late = row("static", 0.3, 0.3);
        late.chunk = Some("8".into());
        late.repetition = 9;
        rows.push(late);
        let (configs, _) = configs_of(&rows).unwrap();
        let m = configs.iter().find(|m| m.spec.label().ends_with("=8"));
        assert_eq!(m.unwrap().level_s, 0.26);
    }

    #[test]
    fn mpi_rows_are_one_configuration_per_transport_at_every_serials_level() {
        let mut rows = vec![row(SERIAL, 0.24, 0.24), row(SERIAL, 0.28, 0.26)];
        rows[1].repetition = 1;
        for (t, wall) in [("shared_memory", 0.13), ("tcp_loopback", 0.15)] {
            for rep in 0..2 {
                let mut r = row("master", wall, 0.26);
                (r.sources, r.ranks, r.transport) = ("mpi".into(), Some(3), Some(t.into()));
                (r.workers, r.repetition) = (2, rep);
                rows.push(r);
            }
        }
        // The launch's local-thread baseline is not an MPI configuration.
        let mut local = row("master", 0.12, 0.26);
        local.ranks = Some(3);
        rows.push(local);
        let (mpi, _) = configs_where(&rows, true).unwrap();
        let got: Vec<(Option<&str>, usize, f64)> = mpi
            .iter()
            .map(|m| (m.transport.as_deref(), m.walls.len(), m.level_s))
            .collect();
        assert_eq!(
            got,
            [
                (Some("shared_memory"), 2, 0.26),
                (Some("tcp_loopback"), 2, 0.26)
            ]
        );
        let (threads, _) = configs_of(&rows).unwrap();
        assert_eq!(threads.len(), 1);
        assert_eq!(threads[0].transport, None);
        assert!(configs_where(&rows[..2], true).is_err());
    }

    #[test]
    fn an_mpi_configuration_takes_the_period_per_item_of_its_spinning_launch() {
        let mpi = |wall: f64, t: &str, workers: usize| {
            let mut r = row("master", wall, 0.26);
            (r.sources, r.ranks, r.transport) = ("mpi".into(), Some(workers + 1), Some(t.into()));
            (r.workers, r.items) = (workers, 64);
            r
        };
        let serial = row(SERIAL, 0.26, 0.26);
        let rendered = [
            serial.clone(),
            mpi(0.3, "tcp_loopback", 2),
            mpi(0.2, "shared_memory", 2),
        ];
        let spinning = [
            serial,
            mpi(0.32, "tcp_loopback", 2),
            mpi(0.40, "tcp_loopback", 2),
            mpi(0.36, "tcp_loopback", 2),
        ];
        let (mut configs, _) = configs_where(&rendered, true).unwrap();
        let (spin, _) = configs_where(&spinning, true).unwrap();
        attach_spin(&mut configs, &spin);
        let tcp = configs
            .iter()
            .find(|m| m.transport.as_deref() == Some("tcp_loopback"));
        // 2 workers × the median wall 0.36 s / 64 items; items of the serial 0.26 s / 64.
        assert_eq!(
            tcp.unwrap().spin_period,
            Some((2.0 * 0.36 / 64.0, 0.26 / 64.0))
        );
        let shm = configs
            .iter()
            .find(|m| m.transport.as_deref() == Some("shared_memory"));
        assert_eq!(shm.unwrap().spin_period, None);
    }
}
