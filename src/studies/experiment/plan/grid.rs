//! The scheduler grid: every scheduler entry's axes expanded over worker counts and source
//! setups, and the configuration count checked against the limit.

use super::*;

/// Every scheduler entry's grid × worker counts × source setups ([`expand_setups`]). A
/// progressive run records no timeline: a Gantt chart per step would be noise.
pub(super) fn expand_grids(
    file: &ExperimentFile,
    settings: &Settings,
) -> Result<Vec<Grid>, FieldError> {
    let timeline = file.timeline && settings.convergence.is_none();
    file.schedulers
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let at = |(f, m): FieldError| (format!("schedulers[{i}].{f}"), m);
            let (entry, source_axes) = split_source_keys(s).map_err(at)?;
            let specs = expand_scheduler(&entry, &settings.workers, timeline).map_err(at)?;
            let kind = specs
                .first()
                .map_or(SchedulerKind::FOR_MIXED_SOURCES, |s| s.kind());
            let setups = expand_setups(kind, &source_axes, &settings.sources).map_err(at)?;
            if (specs.len() as u64).saturating_mul(setups.len() as u64) > MAX_CONFIGS {
                return Err(at((
                    "kind".into(),
                    format!(
                        "{} scheduler configurations × {} source setups is more than the \
                         limit of {MAX_CONFIGS} run configurations",
                        specs.len(),
                        setups.len()
                    ),
                )));
            }
            let mut grid = Vec::with_capacity(specs.len() * setups.len());
            for setup in &setups {
                for spec in &specs {
                    let refusal = Runner::Gpu.refuses(&spec.policy);
                    if let Some(r) = refusal.filter(|_| setup.set.has(SourceKind::Gpu)) {
                        return Err(at((
                            r.param.into(),
                            format!("{} (sources = \"{}\")", r.as_value(), setup.set.id()),
                        )));
                    }
                    let mut spec = spec.clone();
                    if !setup.set.has(SourceKind::Threads) {
                        // A GPU alone is one source whatever the thread count: one
                        // configuration (the repeats are merged by their ids).
                        spec.workers = 1;
                    }
                    grid.push((spec, setup.clone()));
                }
            }
            Ok(grid)
        })
        .collect()
}

/// One scheduler entry's configurations: each spec with the source setup it runs on.
pub(super) type Grid = Vec<(SchedulerSpec, SourceSetup)>;

/// The entry without its per-source keys (`gpu_chunk`, …), and those keys as axes.
pub(super) fn split_source_keys(
    s: &SchedulerEntry,
) -> Result<(SchedulerEntry, Vec<Axis>), FieldError> {
    let mut entry = s.clone();
    let mut axes = Vec::new();
    for p in source_params() {
        if let Some(v) = entry.grid.remove(&p.name) {
            let values = axis_texts(&p.name, &v)?;
            for t in &values {
                SourceSetup::default()
                    .set_param(&p.name, t)
                    .map_err(|e| (e.field, e.msg))?;
            }
            axes.push(Axis {
                name: p.name.clone(),
                values,
            });
        }
    }
    Ok((entry, axes))
}

/// The source setups one entry of `kind` runs on: every set of the `sources` axis (those with
/// other sources than threads only for a rule that takes per-source settings, the master's)
/// crossed with the per-source axes that apply to it (a GPU's
/// chunk only to sets with a GPU, `balance` only to sets of several kinds).
pub(super) fn expand_setups(
    kind: SchedulerKind,
    axes: &[Axis],
    sets: &[SourceSet],
) -> Result<Vec<SourceSetup>, FieldError> {
    let per_source = Policy::defaults(kind).needs().per_source;
    let applies = |name: &str, set: &SourceSet| match source_params()
        .iter()
        .find(|p| p.name == name)
        .map(|p| p.field)
    {
        Some(SourceField::Chunk(k) | SourceField::Buffer(k)) => set.has(k),
        Some(SourceField::Balance) => set.kinds().len() > 1,
        None => false,
    };
    for a in axes {
        if !per_source {
            return Err((
                a.name.clone(),
                format!(
                    "'{}' has no {} (only master takes the per-source settings)",
                    kind.id(),
                    a.name
                ),
            ));
        }
        if !sets.iter().any(|s| applies(&a.name, s)) {
            let listed: Vec<String> = sets.iter().map(|s| s.id()).collect();
            return Err((
                a.name.clone(),
                format!(
                    "applies to none of sources = [{}] (a GPU's settings need gpu in a set,                      balance a set of several kinds)",
                    listed.join(", ")
                ),
            ));
        }
    }
    let sizes: Vec<u64> = axes.iter().map(|a| a.values.len() as u64).collect();
    let per_set = checked_product(&sizes).filter(|&n| n <= MAX_CONFIGS);
    if per_set.is_none() {
        return Err((
            "kind".into(),
            format!("the per-source settings have more than {MAX_CONFIGS} combinations"),
        ));
    }
    let mut out = Vec::new();
    for set in sets {
        if !per_source && set.kinds() != [SourceKind::Threads] {
            continue; // only a rule with per-source settings hands out to other sources
        }
        let mut setups = vec![SourceSetup::of(set.clone())];
        for a in axes.iter().filter(|a| applies(&a.name, set)) {
            let mut next = Vec::with_capacity(setups.len() * a.values.len());
            for s in &setups {
                for v in &a.values {
                    let mut s = s.clone();
                    s.set_param(&a.name, v).map_err(|e| (e.field, e.msg))?;
                    next.push(s);
                }
            }
            setups = next;
        }
        for s in &setups {
            s.validate().map_err(|e| (e.field, e.msg))?;
        }
        out.extend(setups);
    }
    if out.is_empty() {
        return Err((
            "kind".into(),
            format!(
                "'{}' hands out to its own threads only, and sources has no \"threads\" set \
                 (add one, or use master)",
                kind.id()
            ),
        ));
    }
    Ok(out)
}

/// Scenes × tracers × every grid entry within [`MAX_CONFIGS`], before any scene is loaded.
pub(super) fn check_config_count(file: &ExperimentFile, grids: &[Grid]) -> Result<(), FieldError> {
    let specs: u64 = grids.iter().map(|g| g.len() as u64).sum();
    let transports = file.mpi.as_ref().map_or(0, |m| m.transports.len() as u64);
    let n = checked_product(&[
        file.scenes.len() as u64,
        file.tracers.len() as u64,
        specs.saturating_add(1),
        transports + 1,
    ]);
    let runs = n.and_then(|n| n.checked_mul(file.repetitions as u64));
    if let (Some(n), Some(runs)) = (n, runs) {
        if n <= MAX_CONFIGS && runs > MAX_RUNS {
            return Err(field(
                "repetitions",
                format!(
                    "{n} run configurations × {} repetitions = {runs} runs is more than the \
                     limit of {MAX_RUNS}",
                    file.repetitions
                ),
            ));
        }
    }
    match n {
        Some(n) if n <= MAX_CONFIGS => Ok(()),
        _ => Err(field(
            "schedulers",
            format!(
                "{} scenes × {} tracers × {specs} scheduler configurations is more than the \
                 limit of {MAX_CONFIGS} run configurations",
                file.scenes.len(),
                file.tracers.len()
            ),
        )),
    }
}
pub(super) fn expand_workers(w: &WorkersSpec) -> Result<Vec<usize>, String> {
    let max = crate::util::host::available_threads() as i64;
    let word = |s: &str| -> Result<i64, String> {
        match s.trim() {
            "max" => Ok(max),
            t => t
                .parse::<i64>()
                .map_err(|_| format!("'{s}': expected a number or \"max\"")),
        }
    };
    let mut out: Vec<i64> = match w {
        WorkersSpec::One(n) => vec![*n],
        WorkersSpec::List(l) => l
            .iter()
            .map(|c| match c {
                WorkerCount::N(n) => Ok(*n),
                WorkerCount::Word(s) => word(s),
            })
            .collect::<Result<_, _>>()?,
        WorkersSpec::Range(r) => {
            let (a, b) = r.split_once("..").ok_or_else(|| {
                format!("'{r}': expected a list, a number or a range \"A..B\" (B may be max)")
            })?;
            let (a, b) = (word(a)?, word(b.trim_start_matches('='))?);
            if a > b {
                return Err(format!("'{r}': empty range ({a} > {b})"));
            }
            // Checked before the range is listed: "1..99999999999" must not allocate.
            if let Some(bad) = [a, b]
                .into_iter()
                .find(|n| !(1..=MAX_THREADS as i64).contains(n))
            {
                return Err(format!("must be between 1 and {MAX_THREADS} (got {bad})"));
            }
            (a..=b).collect()
        }
    };
    if out.is_empty() {
        return Err("must list at least one worker count".into());
    }
    if let Some(bad) = out
        .iter()
        .find(|&&n| !(1..=MAX_THREADS as i64).contains(&n))
    {
        return Err(format!("must be between 1 and {MAX_THREADS} (got {bad})"));
    }
    out.sort_unstable();
    out.dedup();
    Ok(out.into_iter().map(|n| n as usize).collect())
}

/// A grid field's values as text: one value or a list of numbers and strings.
pub(super) fn axis_texts(name: &str, v: &toml::Value) -> Result<Vec<String>, (String, String)> {
    let text = |v: &toml::Value| match v {
        toml::Value::String(s) => Ok(s.clone()),
        toml::Value::Integer(i) => Ok(i.to_string()),
        toml::Value::Boolean(b) => Ok(b.to_string()),
        other => Err((
            name.to_string(),
            format!(
                "expected a number, a string or a boolean, got {}",
                other.type_str()
            ),
        )),
    };
    match v {
        toml::Value::Array(vals) if vals.is_empty() => {
            Err((name.to_string(), "must not be an empty list".into()))
        }
        toml::Value::Array(vals) => vals.iter().map(text).collect(),
        one => Ok(vec![text(one)?]),
    }
}

/// One grid axis: a field's name and its values, each already checked on `base`.
pub(super) struct Axis {
    pub(super) name: String,
    pub(super) values: Vec<String>,
}

/// The grid keys every kind has: granularity, order and the heterogeneous-run setting.
pub(super) const COMMON: [&str; 3] = ["chunk", "order", "slow"];

/// Apply one axis value to `spec`: `chunk`, `order` and `slow` are common to every kind, the
/// rest are the kind's parameters.
pub(super) fn apply(
    spec: &mut SchedulerSpec,
    name: &str,
    value: &str,
) -> Result<(), (String, String)> {
    let fail = |e: crate::sched::SpecError| (name.to_string(), e.msg);
    match name {
        "chunk" => spec.chunk = Chunk::parse(value).map_err(fail)?,
        "order" => spec.order = Order::from_id(value).map_err(fail)?,
        "slow" => spec.slow = Slow::parse(value).map_err(fail)?,
        _ => spec.set(name, value).map_err(fail)?,
    }
    Ok(())
}

/// The axes of one scheduler entry, in grid order: chunk, order, then the kind's parameters
/// in column order; a parameter left out takes its default.
pub(super) fn axes(
    s: &SchedulerEntry,
    base: &SchedulerSpec,
) -> Result<Vec<Axis>, (String, String)> {
    for key in s.grid.keys() {
        if !COMMON.contains(&key.as_str()) {
            base.check_name(key).map_err(|e| (key.clone(), e.msg))?;
        }
    }
    let own = base.kind().picks_own_layout();
    if own && (s.grid.contains_key("chunk") || s.grid.contains_key("order")) {
        return Err((
            "chunk".to_string(),
            format!(
                "'{}' picks its own tile size and order from the image and the thread count; \
                 leave chunk and order out",
                base.kind().id()
            ),
        ));
    }
    if !own && !s.grid.contains_key("chunk") {
        return Err((
            "chunk".to_string(),
            "missing (e.g. chunk = [\"1\", \"8\", \"frame\"])".to_string(),
        ));
    }
    let mut names = if own {
        vec!["slow"]
    } else {
        vec!["chunk", "order", "slow"]
    };
    names.extend(base.policy.info().iter().map(|p| p.name));
    let mut out = Vec::new();
    for name in names {
        let values = match s.grid.get(name) {
            Some(v) => axis_texts(name, v)?,
            None if name == "order" => vec![base.order.id().to_string()],
            None if name == "slow" => vec![base.slow.to_string()],
            None => vec![base.get(name).unwrap_or_default()],
        };
        for v in &values {
            apply(&mut base.clone(), name, v)?;
        }
        out.push(Axis {
            name: name.to_string(),
            values,
        });
    }
    Ok(out)
}

/// The cartesian product of one scheduler's grid and the worker counts (workers vary
/// fastest). Parameters the kind does not have are rejected rather than multiplied in.
pub(super) fn expand_scheduler(
    s: &SchedulerEntry,
    workers: &[usize],
    timeline: bool,
) -> Result<Vec<SchedulerSpec>, (String, String)> {
    let kind = SchedulerKind::from_id(&s.kind).map_err(|e| ("kind".to_string(), e.msg))?;
    let base = SchedulerSpec {
        timeline,
        ..SchedulerSpec::new(kind, Chunk::Frame, 1)
    };
    let axes = axes(s, &base)?;
    let mut sizes: Vec<u64> = axes.iter().map(|a| a.values.len() as u64).collect();
    sizes.push(workers.len() as u64);
    if checked_product(&sizes).is_none_or(|n| n > MAX_CONFIGS) {
        let names: Vec<String> = axes
            .iter()
            .map(|a| format!("{} {}", a.values.len(), a.name))
            .collect();
        return Err((
            "kind".to_string(),
            format!(
                "the grid {} × {} worker counts has more than {MAX_CONFIGS} configurations",
                names.join(" × "),
                workers.len()
            ),
        ));
    }
    let mut specs = vec![base];
    for axis in &axes {
        let mut next = Vec::with_capacity(specs.len() * axis.values.len());
        for spec in &specs {
            for v in &axis.values {
                let mut spec = spec.clone();
                apply(&mut spec, &axis.name, v)?;
                next.push(spec);
            }
        }
        specs = next;
    }
    let mut out = Vec::with_capacity(specs.len() * workers.len());
    for spec in specs {
        for &w in workers {
            let spec = SchedulerSpec {
                workers: w,
                ..spec.clone()
            };
            spec.validate().map_err(|e| (e.field.clone(), e.msg))?;
            out.push(spec);
        }
    }
    Ok(out)
}
