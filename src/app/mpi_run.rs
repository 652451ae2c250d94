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
use super::mpi_render::{gather_ready, input, lead, STOP_WAIT};
use raysched::experiment::plan::RunConfig;
use raysched::experiment::{
    load_plan, run_experiment_with, ExperimentPlan, Launch, Remote, RunError, RunOptions,
};
use raysched::metrics::{Probe, RunStats};
use raysched::mpi::comm::{tag, Comm};
use raysched::mpi::hub::{run_on_ranks, stop_ranks, Hub, HubEnd, Peer};
use raysched::render::Image;
use raysched::sched::{assemble, decompose, SchedulerSpec};
use raysched::tracer::Tracer;
use std::time::Duration;

/// Env: names the transport of a launch outright (a cluster's InfiniBand, a netem link).
pub(crate) const ENV_TRANSPORT: &str = "RAYSCHED_MPI_TRANSPORT";
/// Longest one MPI run of an experiment may take before the master gives up.
const RUN_DEADLINE: Duration = Duration::from_secs(600);

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
    let mut remote = MpiRemote {
        comm,
        launch: Launch {
            ranks: comm.size as usize,
            transport: String::new(),
        },
        peers: Vec::new(),
        current: None,
        silence: Duration::from_millis(m.silence_ms),
        lost: Vec::new(),
        stopped: false,
    };
    // The first scene also tells who runs where (the transport depends on it).
    if let Err(e) = remote.ship(&plan, 0) {
        return Err(CliError::runtime(e));
    }
    let me = raysched::util::host::hostname();
    let one_host = remote.peers.iter().all(|p| p.host == me);
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
    remote.launch.transport = t;
    if !args.quiet {
        out!(
            "{}: mpirun launch of {} ranks over {} ({} worker ranks on {})",
            plan.name,
            comm.size,
            remote.launch.transport,
            remote.peers.len(),
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
    *lost = !remote.lost.is_empty();
    remote.stop();
    super::experiment::finish_experiment(&plan, outcome, args.quiet)
}

/// The MPI side of one launch, as the runner's [`Remote`].
struct MpiRemote<'c> {
    comm: &'c Comm,
    launch: Launch,
    peers: Vec<Peer>,
    /// The baseline (scene, tracer) every worker holds now.
    current: Option<usize>,
    silence: Duration,
    /// (rank, why) of ranks lost; the launch ends after the run that lost them.
    lost: Vec<(i32, String)>,
    stopped: bool,
}

impl MpiRemote<'_> {
    /// Send baseline `b`'s scene and tracer to every worker and wait for all READYs.
    fn ship(&mut self, plan: &ExperimentPlan, b: usize) -> Result<(), RunError> {
        let base = &plan.baselines[b];
        let ps = &plan.scenes[base.scene];
        let file = plan
            .file
            .parent()
            .unwrap_or(std::path::Path::new(""))
            .join(&ps.file);
        let (scene, pkg) = raysched::mpi::scene::package(&file, &ps.overrides, &base.tracer_id)
            .map_err(|e| RunError::Mpi(format!("{e:#}")))?;
        if scene.hash != ps.scene.hash {
            return Err(RunError::Mpi(format!(
                "{}: changed on disk during the experiment (hash {:016x} → {:016x})",
                file.display(),
                ps.scene.hash,
                scene.hash
            )));
        }
        let bytes = pkg.encode();
        for r in 1..self.comm.size {
            self.comm
                .send(r, tag::SCENE, &bytes)
                .map_err(|e| RunError::Mpi(format!("sending the scene to rank {r}: {e}")))?;
        }
        match gather_ready(self.comm) {
            Ok(peers) => {
                self.peers = peers;
                self.current = Some(b);
                Ok(())
            }
            Err(e) => {
                self.stopped = true; // gather_ready stopped the ranks
                Err(RunError::Mpi(format!("{:#}", e.error)))
            }
        }
    }

    fn stop(&mut self) {
        if self.stopped {
            return;
        }
        self.stopped = true;
        let live: Vec<i32> = self
            .peers
            .iter()
            .map(|p| p.rank)
            .filter(|r| !self.lost.iter().any(|(l, _)| l == r))
            .collect();
        stop_ranks(self.comm, &live, self.lost.is_empty(), STOP_WAIT);
    }
}

impl Remote for MpiRemote<'_> {
    fn launch(&self) -> &Launch {
        &self.launch
    }

    fn measure(
        &mut self,
        plan: &ExperimentPlan,
        c: &RunConfig,
        spec: &SchedulerSpec,
    ) -> Result<(Image, RunStats), RunError> {
        if self.stopped || !self.lost.is_empty() {
            return Err(RunError::Mpi(
                "the MPI ranks are no longer available".into(),
            ));
        }
        if self.current != Some(c.baseline) {
            self.ship(plan, c.baseline)?;
        }
        let scene = &plan.scene_of(c).scene;
        let items = decompose(scene.width(), scene.height(), spec.chunk, spec.order);
        let probe = Probe::new(true, spec.timeline);
        let (hub, sources) = Hub::new(self.comm, &self.peers, 0, probe, self.silence);
        let opts = raysched::sched::RunOptions {
            stats: true,
            deadline: Some(RUN_DEADLINE),
            faults: None,
        };
        let (outcome, report) = run_on_ranks(
            hub,
            HubEnd::KeepWorkers,
            spec,
            &items,
            sources,
            &opts,
            probe,
        );
        let config = format!("{} {} over {} ranks", c.id, spec.label(), spec.workers);
        if !report.lost.is_empty() {
            // The run may have finished on the survivors, but its timing is not that of K
            // ranks: it is not recorded, and the launch ends (relaunch to resume).
            let why: Vec<String> = report
                .lost
                .iter()
                .map(|(r, w)| format!("rank {r}: {w}"))
                .collect();
            self.lost = report.lost;
            return Err(RunError::Mpi(format!(
                "{config}: MPI rank(s) lost ({}); rows measured so far are kept, relaunch to resume",
                why.join("; ")
            )));
        }
        let (results, mut stats) = outcome.map_err(|source| RunError::Sched {
            config: config.clone(),
            source,
        })?;
        let image = assemble(scene.width(), scene.height(), &items, &results)
            .map_err(|source| RunError::Sched { config, source })?;
        let tracer = &plan.baselines[c.baseline].tracer;
        (stats.features_used, stats.features_left_out) = scene.feature_report(tracer.accelerated());
        Ok((image, stats))
    }
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
