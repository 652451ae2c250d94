//! `mpirun -n K raysched run EXPERIMENT` on rank 0: the launch's worker ranks as the
//! experiment runner's [`Remote`]. Each (scene, tracer) travels as a SCENE message, every worker
//! answers READY; each MPI configuration is rendered by `sched::render_scene_with` over the
//! ranks ([`MpiRanks`]), the workers kept for the next run.

use super::comm::{tag, Comm};
use super::hub::{stop_ranks, HubEnd, Peer};
use super::launch::{gather_ready, MpiRanks, STOP_WAIT};
use crate::core::metrics::RunStats;
use crate::core::render::Image;
use crate::sched::{render_scene_with, RenderOn, SchedulerSpec, SourceSet, SourceSetup};
use crate::studies::experiment::plan::RunConfig;
use crate::studies::experiment::{ExperimentPlan, Launch, Remote, RunError};
use std::time::Duration;

/// Longest one MPI run of an experiment may take before the master gives up.
const RUN_DEADLINE: Duration = Duration::from_secs(600);

/// The MPI side of one launch, as the runner's [`Remote`].
pub struct MpiRemote<'c> {
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

impl<'c> MpiRemote<'c> {
    /// The launch of `comm`'s ranks (its transport still to be named, [`Self::set_transport`]);
    /// a rank with work outstanding that says nothing for `silence` is lost.
    pub fn new(comm: &'c Comm, silence: Duration) -> Self {
        Self {
            comm,
            launch: Launch {
                ranks: comm.size as usize,
                transport: String::new(),
            },
            peers: Vec::new(),
            current: None,
            silence,
            lost: Vec::new(),
            stopped: false,
        }
    }

    /// The ready worker ranks (after the first [`Self::ship`]).
    pub fn peers(&self) -> &[Peer] {
        &self.peers
    }

    /// Name the launch's transport.
    pub fn set_transport(&mut self, transport: String) {
        self.launch.transport = transport;
    }

    /// Has a rank been lost?
    pub fn lost_any(&self) -> bool {
        !self.lost.is_empty()
    }

    /// Send baseline `b`'s scene and tracer to every worker and wait for all READYs.
    ///
    /// # Errors
    /// The scene cannot be packaged or changed on disk, a send failed, a rank could not build
    /// it (the ranks are then stopped).
    pub fn ship(&mut self, plan: &ExperimentPlan, b: usize) -> Result<(), RunError> {
        let base = &plan.baselines[b];
        let ps = &plan.scenes[base.scene];
        let file = plan
            .file
            .parent()
            .unwrap_or(std::path::Path::new(""))
            .join(&ps.file);
        let (scene, pkg) = super::scene::package(&file, &ps.overrides, &base.tracer_id)
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
                Err(RunError::Mpi(format!("{e:#}")))
            }
        }
    }

    /// Stop the live workers (once).
    pub fn stop(&mut self) {
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
        let tracer = &plan.baselines[c.baseline].tracer;
        let opts = crate::sched::RunOptions {
            stats: true,
            deadline: Some(RUN_DEADLINE),
            faults: None,
        };
        let setup = SourceSetup {
            set: SourceSet::mpi_launch(false),
            ..SourceSetup::default()
        };
        let on = RenderOn {
            setup: &setup,
            #[cfg(feature = "gpu")]
            gpu: None,
        };
        let ranks = MpiRanks::new(self.comm, &self.peers, self.silence, HubEnd::KeepWorkers);
        let outcome = render_scene_with(spec, scene, tracer, &on, &opts, Some(&ranks));
        let report = ranks.finish();
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
        let (frames, stats) = outcome.map_err(|source| RunError::Sched { config, source })?;
        Ok((Image::stack(frames), stats))
    }
}
