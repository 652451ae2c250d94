//! The adaptive rounds: each configuration's samples so far, and which configurations a
//! round still samples (CI target, budget, most runs).

use super::*;

/// One configuration's samples so far and whether it needs more.
pub(in crate::studies::experiment) struct ConfigState<'p> {
    pub(in crate::studies::experiment) config: &'p RunConfig,
    /// Wall times by repetition, in repetition order.
    pub(in crate::studies::experiment) walls: Vec<f64>,
    /// The next repetition's index.
    pub(in crate::studies::experiment) next_rep: u32,
    /// Seconds of timed renders spent (inner renders included).
    pub(in crate::studies::experiment) timed_s: f64,
    /// Renders per timed sample, once known.
    pub(in crate::studies::experiment) inner: Option<u32>,
    pub(in crate::studies::experiment) done: bool,
}

impl ConfigState<'_> {
    /// Enough samples by its own criteria (runs, budget, CI target).
    pub(in crate::studies::experiment) fn own_criteria_met(&self, plan: &ExperimentPlan) -> bool {
        let st = &plan.stats;
        let n = self.walls.len() as u32;
        if n < st.min_runs {
            return false;
        }
        if st.fixed() || n >= st.max_runs || self.timed_s >= st.budget_s {
            return true;
        }
        // The summary's own seed, so a configuration stopped here shows the same interval there.
        let seed = super::super::summary::seed_of(&self.config.id);
        n >= MIN_ADAPTIVE_RUNS && relative_half_width(&self.walls, seed) <= st.ci_target
    }
}

/// The fewest samples whose bootstrap interval the stopping rule trusts: with fewer, the
/// percentile interval of a median is the whole sample range or a single value.
pub const MIN_ADAPTIVE_RUNS: u32 = 5;

/// The most renders inside one timed sample.
pub const MAX_INNER: u32 = 1000;

/// What this launch measures.
pub(in crate::studies::experiment) struct Todo<'p> {
    pub(in crate::studies::experiment) states: Vec<ConfigState<'p>>,
    /// Configurations that belong to other `mpirun` launches.
    pub(in crate::studies::experiment) other_launches: usize,
}

impl<'p> Todo<'p> {
    pub(in crate::studies::experiment) fn of(
        plan: &'p ExperimentPlan,
        old_rows: &[RunRow],
        launch: Option<&Launch>,
    ) -> Self {
        let mine = |c: &&RunConfig| c.in_launch(launch);
        let other_launches = plan.configs.iter().filter(|c| !mine(c)).count();
        let mut by_id: HashMap<&str, Vec<&RunRow>> = HashMap::new();
        for r in old_rows {
            by_id.entry(r.config.as_str()).or_default().push(r);
        }
        let states = plan
            .configs
            .iter()
            .filter(mine)
            .map(|c| {
                let mut rows = by_id.remove(c.id.as_str()).unwrap_or_default();
                rows.sort_by_key(|r| r.repetition);
                ConfigState {
                    config: c,
                    walls: rows.iter().map(|r| r.wall_s).collect(),
                    next_rep: rows.last().map_or(0, |r| r.repetition + 1),
                    timed_s: rows.iter().map(|r| r.wall_s * f64::from(r.inner)).sum(),
                    inner: rows.first().map(|r| r.inner),
                    done: false,
                }
            })
            .collect();
        Self {
            states,
            other_launches,
        }
    }

    /// Mark what is done: a configuration by its own criteria, a serial baseline once every
    /// configuration compared with it is done too (or its runs are spent).
    pub(in crate::studies::experiment) fn update_done(&mut self, plan: &ExperimentPlan) {
        for s in &mut self.states {
            s.done = s.own_criteria_met(plan);
        }
        let open: Vec<usize> = self
            .states
            .iter()
            .filter(|s| s.config.spec.is_some() && !s.done)
            .map(|s| s.config.baseline)
            .collect();
        for s in &mut self.states {
            if s.config.spec.is_none()
                && s.done
                && open.contains(&s.config.baseline)
                && (s.walls.len() as u32) < plan.stats.max_runs
            {
                s.done = false;
            }
        }
    }

    /// This round's samples: the open baselines, then the open configurations, each shuffled.
    pub(in crate::studies::experiment) fn round_order(
        &self,
        plan: &ExperimentPlan,
        round: u64,
    ) -> Vec<usize> {
        let open = |serial: bool| -> Vec<usize> {
            self.states
                .iter()
                .enumerate()
                .filter(|(_, s)| !s.done && s.config.spec.is_none() == serial)
                .map(|(i, _)| i)
                .collect()
        };
        let seed = plan.stats.seed ^ round.wrapping_mul(0x9e37_79b9_7f4a_7c15);
        let (mut a, mut b) = (open(true), open(false));
        shuffle(&mut a, seed);
        shuffle(&mut b, seed.rotate_left(17));
        a.extend(b);
        a
    }

    /// The most samples still to come (every open configuration up to its run cap).
    pub(in crate::studies::experiment) fn upper_bound_now(&self, plan: &ExperimentPlan) -> u64 {
        self.states
            .iter()
            .filter(|s| match s.config.spec {
                Some(_) => !s.own_criteria_met(plan),
                None => !s.done,
            })
            .map(|s| u64::from(plan.stats.max_runs.saturating_sub(s.walls.len() as u32)))
            .sum()
    }

    pub(in crate::studies::experiment) fn upper_bound(&self, plan: &ExperimentPlan) -> u64 {
        self.upper_bound_now(plan)
    }
}
