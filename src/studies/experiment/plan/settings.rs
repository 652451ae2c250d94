//! The settings of an experiment file besides its scenes and schedulers: workers, tracers,
//! source sets, the adaptive-repetition statistics, convergence and MPI, each checked.

use super::*;

/// What the file says besides its scenes and schedulers, checked.
pub(super) struct Settings {
    pub(super) stats: StatsSettings,
    pub(super) workers: Vec<usize>,
    pub(super) tracers: Vec<TracerKind>,
    /// The source sets of the grid, in file order, no repeats.
    pub(super) sources: Vec<SourceSet>,
    pub(super) mpi: Option<MpiSettings>,
    pub(super) convergence: Option<ConvergenceSettings>,
}

pub(super) fn check_settings(file: &ExperimentFile) -> Result<Settings, FieldError> {
    if !(1..=MAX_REPETITIONS).contains(&file.repetitions) {
        return Err(field(
            "repetitions",
            format!(
                "must be in 1..={MAX_REPETITIONS} (got {})",
                file.repetitions
            ),
        ));
    }
    if file.warmup > MAX_REPETITIONS {
        return Err(field(
            "warmup",
            format!("must be in 0..={MAX_REPETITIONS} (got {})", file.warmup),
        ));
    }
    let mpi = file
        .mpi
        .as_ref()
        .map(|m| validate_mpi(m, file))
        .transpose()?;
    let workers = match (&file.workers, &mpi) {
        (Some(_), Some(_)) => {
            return Err(field(
                "workers",
                "set by mpi.ranks under [mpi] (ranks − 1 per launch); remove it",
            ))
        }
        (None, Some(m)) => m.ranks.iter().map(|r| r - 1).collect(),
        (Some(w), None) => expand_workers(w).map_err(|m| field("workers", m))?,
        (None, None) => {
            return Err(field(
                "workers",
                "missing (e.g. workers = [1, 2] or \"1..max\")",
            ))
        }
    };
    if file.tracers.is_empty() {
        return Err(field("tracers", "must name at least one tracer"));
    }
    let tracers = file
        .tracers
        .iter()
        .enumerate()
        .map(|(i, t)| {
            TracerKind::from_id(t)
                .and_then(TracerKind::available)
                .map_err(|e| field(&format!("tracers[{i}]"), e.to_string()))
        })
        .collect::<Result<Vec<_>, _>>()?;
    if file.scenes.is_empty() {
        return Err(field(
            "scenes",
            "must list at least one scene ([[scenes]] path = …)",
        ));
    }
    Ok(Settings {
        stats: check_stats(file)?,
        workers,
        tracers,
        sources: check_sources(file)?,
        mpi,
        convergence: check_convergence(file)?,
    })
}

/// The `sources` axis: each entry a set of kinds (`threads`, `gpu`, `threads+gpu`), parsed by
/// the one definition ([`SourceSet::parse`]); `["threads"]` when absent.
pub(super) fn check_sources(file: &ExperimentFile) -> Result<Vec<SourceSet>, FieldError> {
    let Some(axis) = &file.sources else {
        if file.gpu_adapter.is_some() {
            return Err(field(
                "gpu_adapter",
                "applies only with gpu among the sources (e.g. sources = [\"threads\", \"threads+gpu\"])",
            ));
        }
        return Ok(vec![SourceSet::threads()]);
    };
    let many = matches!(axis, super::super::config::OneOrMany::Many(_));
    let name = |i: usize| {
        if many {
            format!("sources[{i}]")
        } else {
            "sources".to_string()
        }
    };
    let texts = axis.values();
    if texts.is_empty() {
        return Err(field(
            "sources",
            "must list at least one set (e.g. [\"threads\"])",
        ));
    }
    if file.mpi.is_some() {
        return Err(field(
            "sources",
            "an [mpi] experiment renders on its ranks and the local-thread baseline; remove sources",
        ));
    }
    if file.kind == ExperimentKind::Convergence {
        return Err(field(
            "sources",
            "a convergence experiment renders on threads; remove sources",
        ));
    }
    let mut sets: Vec<SourceSet> = Vec::new();
    for (i, t) in texts.iter().enumerate() {
        let set = SourceSet::parse(t).map_err(|e| field(&name(i), e.msg))?;
        if set.has(SourceKind::Mpi) {
            return Err(field(
                &name(i),
                "'mpi': MPI ranks are set by an [mpi] table (mpi.ranks), not by sources",
            ));
        }
        if !sets.contains(&set) {
            sets.push(set);
        }
    }
    if file.gpu_adapter.is_some() && !sets.iter().any(|s| s.has(SourceKind::Gpu)) {
        return Err(field(
            "gpu_adapter",
            "applies only with gpu among the sources",
        ));
    }
    Ok(sets)
}

/// The adaptive-repetition settings of a timing experiment.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StatsSettings {
    /// Timed runs per configuration at least.
    pub min_runs: u32,
    /// At most.
    pub max_runs: u32,
    /// Relative 95 % CI half-width of the median to reach (0: fixed `min_runs`).
    pub ci_target: f64,
    /// Seconds of timed runs per configuration at most.
    pub budget_s: f64,
    /// Renders shorter than this are repeated inside one timed sample.
    pub min_sample_s: f64,
    /// Seeds each round's shuffled order (bootstrap intervals are seeded by the configuration
    /// id, so `raysched plot` reproduces them from the CSV alone).
    pub seed: u64,
    /// Which process takes the samples (absent in `meta.toml` files before it: one process).
    #[serde(default = "one_process")]
    pub isolation: super::super::config::Isolation,
}

pub(super) fn one_process() -> super::super::config::Isolation {
    super::super::config::Isolation::None
}

/// Default relative CI half-width: ±2 % of the median.
pub const DEFAULT_CI_TARGET: f64 = 0.02;
/// Default cap on timed runs per configuration.
pub const DEFAULT_MAX_RUNS: u32 = 30;
/// Default seconds of timed runs per configuration.
pub const DEFAULT_BUDGET_S: f64 = 10.0;
/// Default shortest timed sample: below ~50 ms, scheduling noise of a shared machine (a 4 ms
/// time slice, a page-cache flush) is a large fraction of the sample.
pub const DEFAULT_MIN_SAMPLE_S: f64 = 0.05;

impl StatsSettings {
    /// Is the number of runs fixed (no CI target)?
    pub fn fixed(&self) -> bool {
        self.ci_target == 0.0
    }
}

pub(super) fn check_stats(file: &ExperimentFile) -> Result<StatsSettings, FieldError> {
    let ci_target = file.ci_target.unwrap_or(DEFAULT_CI_TARGET);
    if !(0.0..=0.5).contains(&ci_target) {
        return Err(field(
            "ci_target",
            format!("must be in [0, 0.5] (a fraction of the median; got {ci_target})"),
        ));
    }
    let min_runs = file.repetitions;
    let max_runs = match file.max_repetitions {
        Some(m) if m < min_runs => {
            return Err(field(
                "max_repetitions",
                format!("must be ≥ repetitions ({min_runs}; got {m})"),
            ))
        }
        Some(m) if m > 10_000 => {
            return Err(field(
                "max_repetitions",
                format!("must be ≤ 10000 (got {m})"),
            ))
        }
        Some(m) => m,
        None if ci_target == 0.0 => min_runs,
        None => DEFAULT_MAX_RUNS.max(min_runs),
    };
    let budget_s = file.budget_s.unwrap_or(DEFAULT_BUDGET_S);
    if !(budget_s > 0.0 && budget_s <= 86_400.0) {
        return Err(field(
            "budget_s",
            format!("must be in (0, 86400] seconds (got {budget_s})"),
        ));
    }
    let min_sample_s = file.min_sample_s.unwrap_or(DEFAULT_MIN_SAMPLE_S);
    if !(0.0..=10.0).contains(&min_sample_s) {
        return Err(field(
            "min_sample_s",
            format!("must be in [0, 10] seconds (got {min_sample_s})"),
        ));
    }
    Ok(StatsSettings {
        min_runs,
        max_runs,
        ci_target,
        budget_s,
        min_sample_s,
        seed: file.seed.unwrap_or(1),
        isolation: file.isolation,
    })
}

/// `kind = "convergence"` and its sample counts; a timing experiment must not set them.
pub(super) fn check_convergence(
    file: &ExperimentFile,
) -> Result<Option<ConvergenceSettings>, FieldError> {
    match file.kind {
        ExperimentKind::Timing => {
            if file.schedulers.is_empty() {
                return Err(field(
                    "schedulers",
                    "must list at least one scheduler ([[schedulers]] kind = …)",
                ));
            }
            for (f, set) in [
                ("max_spp", file.max_spp.is_some()),
                ("ref_spp", file.ref_spp.is_some()),
            ] {
                if set {
                    return Err(field(f, "applies only to kind = \"convergence\""));
                }
            }
            Ok(None)
        }
        ExperimentKind::Convergence => {
            let max_spp = file
                .max_spp
                .ok_or_else(|| field("max_spp", "kind = \"convergence\" needs max_spp"))?;
            let ref_spp = file.ref_spp.unwrap_or(1024);
            for (f, v) in [("max_spp", max_spp), ("ref_spp", ref_spp)] {
                if !(1..=MAX_SPP).contains(&v) {
                    return Err(field(f, format!("must be in 1..={MAX_SPP} (got {v})")));
                }
            }
            Ok(Some(ConvergenceSettings { max_spp, ref_spp }))
        }
    }
}
pub(super) fn validate_mpi(m: &MpiEntry, file: &ExperimentFile) -> Result<MpiSettings, FieldError> {
    let f = |field: &str, msg: String| (format!("mpi.{field}"), msg);
    if file.kind == ExperimentKind::Convergence {
        return Err((
            "mpi".into(),
            "a convergence experiment has no MPI part".into(),
        ));
    }
    let mut ranks = Vec::new();
    for r in m.ranks.values() {
        if !(2..=4096).contains(&r) {
            return Err(f(
                "ranks",
                format!(
                    "must be between 2 and 4096 (got {r}): rank 0 schedules, ranks 1…K−1 render"
                ),
            ));
        }
        ranks.push(r as usize);
    }
    if ranks.is_empty() {
        return Err(f("ranks", "must list at least one rank count".into()));
    }
    ranks.sort_unstable();
    ranks.dedup();
    if m.transports.is_empty() {
        return Err(f(
            "transports",
            "must list at least one transport (e.g. [\"shared_memory\", \"tcp_loopback\"])".into(),
        ));
    }
    for t in &m.transports {
        if t.is_empty()
            || !t
                .chars()
                .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
        {
            return Err(f(
                "transports",
                format!("'{t}': use lower-case letters, digits and '_'"),
            ));
        }
    }
    let silence_ms = match m.silence_ms {
        None => DEFAULT_SILENCE_MS,
        Some(v) if v >= MIN_SILENCE_MS as i64 => v as u64,
        Some(v) => {
            return Err(f(
                "silence_ms",
                format!("must be ≥ {MIN_SILENCE_MS} (5 heartbeats of 200 ms; got {v})"),
            ))
        }
    };
    for (i, s) in file.schedulers.iter().enumerate() {
        if let Ok(k) = SchedulerKind::from_id(&s.kind) {
            if !crate::sched::kinds::over_sources(k) {
                return Err((
                    format!("schedulers[{i}].kind"),
                    format!(
                        "'{}' steals between workers that share memory, which MPI ranks do not (use master or a scheduler without stealing)",
                        k.id()
                    ),
                ));
            }
            let lists = |key: &str, id: &str| {
                let id = toml::Value::String(id.into());
                s.grid
                    .get(key)
                    .is_some_and(|v| *v == id || v.as_array().is_some_and(|a| a.contains(&id)))
            };
            if let Some(r) = Runner::Mpi
                .refusals()
                .iter()
                .find(|r| lists(r.param, r.value))
            {
                return Err((format!("schedulers[{i}].{}", r.param), r.as_value()));
            }
        }
    }
    let mut transports = m.transports.clone();
    transports.dedup();
    Ok(MpiSettings {
        ranks,
        transports,
        silence_ms,
    })
}
