//! `mpirun -n K raysched run EXPERIMENT`: rank 0 runs the experiment runner with ranks
//! 1…K−1 as compute sources; the other ranks serve as workers until rank 0 ends the run.
//!
//! One launch measures the configurations of its (K, transport) — the transport is read from
//! the launch's environment ([`transport`]) — plus the serial and the local-thread baselines
//! (K − 1 threads, same scheduler) when not yet in runs.csv; a driver launches every pair of
//! `[mpi] ranks × transports` and each launch appends (experiments/mpi_sweep.py). No shared
//! filesystem is assumed: each (scene, tracer) travels as a SCENE message and every worker
//! answers READY. While rank 0 times local threads the workers sleep in 200 µs steps.

use super::error::CliError;
use super::experiment::RunArgs;
use super::mpi_render::{input, lead};
use raysched::mpi::comm::Comm;
use raysched::mpi::hub::stop_ranks;
use raysched::mpi::launch::STOP_WAIT;
use raysched::mpi::MpiRemote;
use raysched::studies::experiment::{load_plan, run_experiment_with, RunOptions};
use std::time::Duration;

/// Env: names the transport of a launch outright (a cluster's InfiniBand, a netem link).
pub(crate) const ENV_TRANSPORT: &str = "RAYSCHED_MPI_TRANSPORT";

/// The transport of this launch, from its environment: `RAYSCHED_MPI_TRANSPORT` if set, else
/// OpenMPI's `OMPI_MCA_btl` (`pml` other than ob1 means no BTL at all): only shared-memory
/// BTLs (vader/sm) → `shared_memory`; only tcp → `tcp_loopback` when every rank is on this
/// host, else `tcp`; anything else → `unknown`.
pub(crate) fn transport(env: impl Fn(&str) -> Option<String>, one_host: bool) -> String {
    if let Some(t) = env(ENV_TRANSPORT).filter(|t| !t.trim().is_empty()) {
        return t.trim().to_string();
    }
    if env("OMPI_MCA_pml").is_some_and(|p| p.trim() != "ob1") {
        return "unknown".into();
    }
    let Some(btl) = env("OMPI_MCA_btl") else {
        return "unknown".into();
    };
    if btl.trim_start().starts_with('^') {
        return "unknown".into();
    }
    let parts: Vec<&str> = btl
        .split(',')
        .map(str::trim)
        .filter(|p| !p.is_empty() && *p != "self")
        .collect();
    let shm = |p: &&str| matches!(*p, "vader" | "sm" | "smcuda");
    if parts.is_empty() {
        "unknown".into()
    } else if one_host && parts.iter().any(shm) {
        // On one host the shared-memory BTL carries every message it can.
        "shared_memory".into()
    } else if parts == ["tcp"] {
        if one_host { "tcp_loopback" } else { "tcp" }.into()
    } else {
        "unknown".into()
    }
}

/// Every rank enters here under `mpirun … raysched run`; never returns.
pub(crate) fn run(args: RunArgs) -> ! {
    let comm = match Comm::init() {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1)
        }
    };
    if comm.rank != 0 {
        raysched::mpi::worker::serve(comm, None)
    }
    lead(comm, |comm, lost| rank0(comm, &args, lost))
}

fn rank0(comm: &Comm, args: &RunArgs, lost: &mut bool) -> Result<(), CliError> {
    let all: Vec<i32> = (1..comm.size).collect();
    let path = args.experiment.display().to_string();
    let plan = (|| {
        let mut plan = load_plan(&args.experiment).map_err(CliError::input)?;
        super::experiment::apply_stats_flags(&mut plan, args)?;
        let Some(m) = &plan.mpi else {
            return Err(input(format!(
                "{path}: mpi: missing: started by mpirun with {} rank(s), but the experiment has no [mpi] table (run it without mpirun, or add [mpi])",
                comm.size
            )));
        };
        if comm.size < 2 {
            return Err(input(format!(
                "{path}: mpi.ranks: started with {} rank; need ≥ 2 (rank 0 schedules, ranks 1…K−1 render)",
                comm.size
            )));
        }
        if !m.ranks.contains(&(comm.size as usize)) {
            return Err(input(format!(
                "{path}: mpi.ranks: started with {} ranks, but the experiment lists {:?}",
                comm.size, m.ranks
            )));
        }
        Ok(plan)
    })();
    let plan = match plan {
        Ok(p) => p,
        Err(e) => {
            stop_ranks(comm, &all, true, STOP_WAIT);
            return Err(e);
        }
    };
    let m = plan.mpi.clone().expect("checked above");
    let mut remote = MpiRemote::new(comm, Duration::from_millis(m.silence_ms));
    // The first scene also tells who runs where (the transport depends on it).
    if let Err(e) = remote.ship(&plan, 0) {
        return Err(CliError::runtime(e));
    }
    let me = raysched::util::host::hostname();
    let one_host = remote.peers().iter().all(|p| p.host == me);
    let t = transport(|v| std::env::var(v).ok(), one_host);
    if !m.transports.contains(&t) {
        stop_ranks(comm, &all, true, STOP_WAIT);
        return Err(input(format!(
            "{path}: mpi.transports: this launch's transport is '{t}' (OMPI_MCA_btl={}, {}), not one of {:?}; list it or set {ENV_TRANSPORT}",
            std::env::var("OMPI_MCA_btl").unwrap_or_else(|_| "unset".into()),
            if one_host { "one host" } else { "several hosts" },
            m.transports
        )));
    }
    remote.set_transport(t.clone());
    if !args.quiet {
        out!(
            "{}: mpirun launch of {} ranks over {} ({} worker ranks on {})",
            plan.name,
            comm.size,
            t,
            remote.peers().len(),
            if one_host {
                "this host"
            } else {
                "several hosts"
            }
        );
    }
    let opts = RunOptions {
        out: args.out.clone(),
        fresh: args.fresh,
        quiet: args.quiet,
        child_round: None,
    };
    let outcome = run_experiment_with(&plan, &opts, Some(&mut remote));
    *lost = remote.lost_any();
    remote.stop();
    super::experiment::finish_experiment(&plan, outcome, args.quiet)
}

#[cfg(test)]
mod tests {
    use super::transport;

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |k| {
            vars.iter()
                .find(|(n, _)| *n == k)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    fn the_transport_is_read_from_the_launch_environment() {
        let vader = ("OMPI_MCA_btl", "self,vader");
        // (environment, all ranks on one host, transport)
        type Vars<'a> = &'a [(&'a str, &'a str)];
        let cases: &[(Vars, bool, &str)] = &[
            (&[vader], true, "shared_memory"),
            (&[("OMPI_MCA_btl", "vader,self")], true, "shared_memory"),
            (&[("OMPI_MCA_btl", "self,tcp")], true, "tcp_loopback"),
            (&[("OMPI_MCA_btl", "tcp,self")], false, "tcp"),
            (&[("OMPI_MCA_btl", "self,vader,tcp")], true, "shared_memory"),
            (&[("OMPI_MCA_btl", "self,vader,tcp")], false, "unknown"),
            (&[("OMPI_MCA_btl", "^openib")], true, "unknown"),
            (&[], true, "unknown"),
            (&[vader, ("OMPI_MCA_pml", "ucx")], true, "unknown"),
            (&[vader, (super::ENV_TRANSPORT, "ib")], true, "ib"),
        ];
        for (vars, one_host, want) in cases {
            assert_eq!(
                transport(env(vars), *one_host),
                *want,
                "{vars:?} {one_host}"
            );
        }
    }
}
