//! Which master settings a kind of source cannot run, and why: one table that every entry
//! point (the CLI's `render` for a GPU or MPI ranks, the experiment plan, the simulation's
//! config, the fault injector) reads, each wording the place (flag or TOML key) its own way.

use super::param::{Passes, Returns};
use super::spec::Policy;

/// What drives a run's items besides local threads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Runner {
    /// A GPU source among the sources (under the master).
    Gpu,
    /// MPI ranks.
    Mpi,
    /// The SimGrid simulation of the master's protocol.
    Simulation,
    /// The fault injector around local threads.
    Faults,
}

/// One parameter value a [`Runner`] cannot run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Refusal {
    /// The parameter: TOML key and CSV column; the flag is `--` and it with `_` → `-`.
    pub param: &'static str,
    /// The value refused.
    pub value: &'static str,
    /// Why, and what to use instead.
    pub why: &'static str,
}

/// The passes run by the workers need local threads and nothing between them and the lock.
const fn passes_workers(why: &'static str) -> Refusal {
    Refusal {
        param: "passes",
        value: Passes::Workers.id(),
        why,
    }
}

/// Per-hand-out results need a source that can hold a hand-out's results back together.
const fn returns_hand_out(why: &'static str) -> Refusal {
    Refusal {
        param: "returns",
        value: Returns::HandOut.id(),
        why,
    }
}

const GPU: &[Refusal] = &[passes_workers(
    "a GPU source needs the master's own thread (use thread)",
)];
const MPI: &[Refusal] = &[
    returns_hand_out("MPI ranks hand their results back item by item (use item)"),
    passes_workers("MPI ranks need the master's own thread (use thread)"),
];
const SIMULATION: &[Refusal] = &[
    returns_hand_out(
        "not simulated: the simulated master's protocol returns each result alone (use item)",
    ),
    passes_workers("not simulated: the simulated master is a thread of its own (use thread)"),
];
const FAULTS: &[Refusal] = &[passes_workers(
    "the fault injector wraps sources that a master thread drives (use thread)",
)];

impl Runner {
    /// Every parameter value this runner cannot run.
    pub fn refusals(self) -> &'static [Refusal] {
        match self {
            Self::Gpu => GPU,
            Self::Mpi => MPI,
            Self::Simulation => SIMULATION,
            Self::Faults => FAULTS,
        }
    }

    /// The first of [`Self::refusals`] that `policy` has, if any.
    pub fn refuses(self, policy: &Policy) -> Option<Refusal> {
        let params = policy.params()?;
        self.refusals()
            .iter()
            .find(|r| params.get(r.param).as_deref() == Some(r.value))
            .copied()
    }

    /// The refusal of `param` = `value`, if this runner has one (the run path asks it of a
    /// rule's settings, which are no kind's parameters).
    pub fn refuses_value(self, param: &str, value: &str) -> Option<Refusal> {
        self.refusals()
            .iter()
            .find(|r| r.param == param && r.value == value)
            .copied()
    }
}

impl Refusal {
    /// As the command line says it: `--passes workers: why`.
    pub fn as_flag(&self) -> String {
        format!(
            "--{} {}: {}",
            self.param.replace('_', "-"),
            self.value,
            self.why
        )
    }

    /// As a TOML value is refused under its key: `workers: why`.
    pub fn as_value(&self) -> String {
        format!("{}: {}", self.value, self.why)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::{MasterParams, SchedulerKind};

    /// Each runner refuses exactly the master settings it cannot run, the defaults never, and
    /// no other kind at all.
    #[test]
    fn each_runner_refuses_what_it_cannot_run() {
        let master = |returns, passes| {
            Policy::Master(MasterParams {
                returns,
                passes,
                ..MasterParams::DEFAULT
            })
        };
        let all = [Runner::Gpu, Runner::Mpi, Runner::Simulation, Runner::Faults];
        for r in all {
            assert_eq!(r.refuses(&master(Returns::Item, Passes::Thread)), None);
            let p = r.refuses(&master(Returns::Item, Passes::Workers)).unwrap();
            assert_eq!((p.param, p.value), ("passes", "workers"));
            for k in SchedulerKind::ALL {
                if k != SchedulerKind::Master {
                    assert_eq!(r.refuses(&Policy::defaults(k)), None, "{k:?}");
                }
            }
        }
        let hand_out = master(Returns::HandOut, Passes::Thread);
        let refused: Vec<_> = all
            .iter()
            .filter(|r| r.refuses(&hand_out).is_some())
            .collect();
        assert_eq!(refused, [&Runner::Mpi, &Runner::Simulation]);
        assert_eq!(
            Runner::Mpi.refuses(&hand_out).unwrap().as_flag(),
            "--returns hand_out: MPI ranks hand their results back item by item (use item)"
        );
        assert_eq!(
            Runner::Gpu.refusals()[0].as_value(),
            "workers: a GPU source needs the master's own thread (use thread)"
        );
    }
}
