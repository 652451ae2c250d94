//! Configuration ids: a stable hash of a configuration's columns, so that `resume` and
//! `compare` pair the rows of runs written by earlier versions.

use super::*;

/// Give every configuration its id; the same configuration listed twice (overlapping grids)
/// is timed once.
pub fn assign_ids(plan: &mut ExperimentPlan) {
    let mut seen = std::collections::HashSet::new();
    let mut unique = Vec::new();
    for mut c in std::mem::take(&mut plan.configs) {
        c.id = config_id(plan, &c);
        if seen.insert(c.id.clone()) {
            unique.push(c);
        }
    }
    plan.configs = unique;
}

/// The stable id of a configuration: FNV-1a of its config columns.
pub fn config_id(plan: &ExperimentPlan, c: &RunConfig) -> String {
    hex(fnv(RunRow::for_config(plan, c).config_key().as_bytes()))
}

/// The scheduler parameters whose values the config id joins by position, as the columns
/// stood when this scheme was fixed. A parameter added since enters the key by
/// name and only off its kind's default ([`named_params_key`]), so adding one to a scheduler
/// leaves every id of an earlier `runs.csv` as it was: `resume` and `compare` still pair them.
pub(super) const KEYED_BY_POSITION: [&str; 9] = [
    "buffer", "requeue", "wait", "returns", "passes", "grab", "guided_k", "weights", "fsc_warm",
];

/// `|name=value` for each parameter outside [`KEYED_BY_POSITION`] that has a value other
/// than `default(name)`; empty for a configuration at every newer parameter's default.
pub(super) fn named_params_key<'a>(
    params: impl Iterator<Item = (&'a str, Option<&'a str>)>,
    default: impl Fn(&str) -> Option<String>,
) -> String {
    params
        .filter(|(name, _)| !KEYED_BY_POSITION.contains(name))
        .filter_map(|(name, v)| {
            let v = v?;
            (default(name).as_deref() != Some(v)).then(|| format!("|{name}={v}"))
        })
        .collect()
}

/// Parameter `name`'s default text for scheduler `scheduler` (its id), if the kind has it.
pub(super) fn default_of(scheduler: &str, name: &str) -> Option<String> {
    let kind = crate::sched::SchedulerKind::from_id(scheduler).ok()?;
    crate::sched::Policy::defaults(kind).params()?.get(name)
}
