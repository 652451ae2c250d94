//! `raysched render SCENE --sources mpi` under `mpirun -n K`: rank 0 runs the scheduler, ranks
//! 1…K−1 are compute sources (plus `--local-threads` threads on rank 0: a heterogeneous run).
//! The run is `sched::render_scene_with` over the launch's source set (the ranks, then the
//! local threads), like any other render.

use super::error::CliError;
use super::render::RenderArgs;
use raysched::core::render::Image;
use raysched::core::scene::Scene;
use raysched::core::tracer::AnyTracer;
use raysched::mpi::comm::Comm;
use raysched::mpi::hub::HubEnd;
use raysched::mpi::launch::{gather_ready, MpiRanks, STOP_WAIT};
use raysched::mpi::wire::ScenePackage;
use raysched::sched::{render_scene_with, RenderOn, SourceSet, SourceSetup};
use raysched::sched::{Runner, SchedulerSpec};
use raysched::source::local::thread_label;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A rank with work outstanding that says nothing this long is lost (env
/// `RAYSCHED_MPI_SILENCE_MS`); local ranks are also checked by pid, which is much faster.
/// Busy workers send a heartbeat every 200 ms from a thread that does not render, so a
/// slow item does not count as silence (it was 60 s before heartbeats).
const SILENCE: Duration =
    Duration::from_millis(raysched::studies::experiment::plan::DEFAULT_SILENCE_MS);

/// Every rank enters here; only rank 0 returns from MPI's point of view — all ranks end the
/// process themselves (with or without `MPI_Finalize`, see [`Comm::shutdown`]).
pub(crate) fn render(args: RenderArgs) -> Result<(), CliError> {
    let comm = Comm::init().map_err(CliError::runtime)?;
    if comm.rank != 0 {
        raysched::mpi::worker::run(comm)
    }
    lead(comm, |comm, lost| rank0(comm, &args, lost))
}

/// Rank 0's end of a job: run `body`, print its error, and end the process with its exit code
/// (finalizing MPI only when no rank was lost: `body` sets the flag).
pub(crate) fn lead(comm: Comm, body: impl FnOnce(&Comm, &mut bool) -> Result<(), CliError>) -> ! {
    let mut lost = false;
    let code = match body(&comm, &mut lost) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {:#}", e.error);
            e.code as i32
        }
    };
    comm.shutdown(!lost, code)
}

pub(crate) fn input(msg: String) -> CliError {
    CliError::input(anyhow::anyhow!(msg))
}

fn rank0(comm: &Comm, args: &RenderArgs, lost: &mut bool) -> Result<(), CliError> {
    // 1. Everything that can be wrong with the input is found before the broadcast; an empty
    //    broadcast tells the workers to finalise and exit.
    let (scene, tracer, pkg, spec) = match prepare(comm, args) {
        Ok(p) => p,
        Err(e) => {
            let _ = comm.broadcast(Some(Vec::new()));
            return Err(e);
        }
    };
    // 2. Ship the scene; every rank builds it and answers READY.
    comm.broadcast(Some(pkg.encode()))
        .map_err(CliError::runtime)?;
    let peers = gather_ready(comm).map_err(CliError::runtime)?;
    // 3. The ranks (and any local threads) as the run's sources.
    let silence = std::env::var("RAYSCHED_MPI_SILENCE_MS")
        .ok()
        .and_then(|v| v.parse().ok())
        .map_or(SILENCE, Duration::from_millis);
    // The launch's own order (ranks, then rank 0's threads), each source item by item under
    // the master's B: no balancer.
    let setup = SourceSetup {
        set: SourceSet::mpi_launch(args.local_threads > 0),
        balance: Some(false),
        ..SourceSetup::default()
    };
    let on = RenderOn {
        setup: &setup,
        #[cfg(feature = "gpu")]
        gpu: None,
    };
    let ranks = MpiRanks::new(comm, &peers, silence, HubEnd::Stop(STOP_WAIT));
    let t0 = Instant::now();
    let outcome = render_scene_with(
        &spec,
        &scene,
        &tracer,
        &on,
        &args.run_options(),
        Some(&ranks),
    );
    let mut labels = ranks.labels();
    let hub_report = ranks.finish();
    *lost = !hub_report.lost.is_empty();
    let (frames, mut stats) = outcome.map_err(CliError::runtime)?;
    stats.lost_sources = stats.lost_sources.max(hub_report.lost.len() as u64);
    let first = labels.len() as u32;
    labels.extend((first..).take(args.local_threads).map(thread_label));
    // 4. The image and the report.
    let image = Image::stack(frames);
    let wall = t0.elapsed().as_secs_f64();
    let wrote = super::render::save_render(&args.output, &image, scene.frames())
        .map_err(CliError::runtime)?;
    let tracer_line = format!(
        "{}, {} MPI ranks + {} local threads on rank 0",
        args.tracer,
        comm.size - 1,
        args.local_threads
    );
    super::render::print_render_header(&scene, &tracer_line, &spec, &image);
    // The summary's first line holds the scheduler's wall time, as on the local path, so the
    // two compare: said once. The total adds stopping the ranks and writing the image.
    super::write_stdout(format_args!("{}", stats.summary()));
    out!(
        "{:.2} Mrays/s, items/s {:.0}, MPI messages {}, total {:.3} s",
        stats.rays as f64 / stats.wall_s / 1e6,
        stats.items as f64 / stats.wall_s,
        hub_report.messages,
        wall
    );
    for (i, l) in labels.iter().enumerate() {
        out!("  source {i} = {l}");
    }
    for (r, why) in &hub_report.lost {
        out!("  lost MPI rank {r}: {why}");
    }
    out!("wrote {wrote}");
    Ok(())
}

/// The checked input of an MPI render.
type Prepared = (Arc<Scene>, Arc<AnyTracer>, ScenePackage, SchedulerSpec);

/// The checked input of an MPI render: the scene, rank 0's tracer (for its local threads),
/// the scene's package for the ranks and the spec.
fn prepare(comm: &Comm, args: &RenderArgs) -> Result<Prepared, CliError> {
    let mut spec = args.scheduler_spec(args.threads)?;
    if !raysched::sched::kinds::over_sources(spec.kind()) {
        return Err(input(format!(
            "--scheduler {}: stealing needs workers that share memory, not MPI ranks (use master or a scheduler without stealing)",
            spec.kind().id()
        )));
    }
    if let Some(r) = Runner::Mpi.refuses(&spec.policy) {
        return Err(input(r.as_flag()));
    }
    if comm.size < 2 && args.local_threads == 0 {
        return Err(input(format!(
            "--sources mpi: {} rank(s) and no --local-threads: nobody to render (run under mpirun -n K, K ≥ 2)",
            comm.size
        )));
    }
    let overrides = args.check_output()?;
    args.tracer.available().map_err(CliError::input)?;
    let (scene, pkg) = raysched::mpi::scene::package(&args.scene, &overrides, args.tracer.id())
        .map_err(CliError::input)?;
    spec.workers = comm.size as usize - 1 + args.local_threads;
    let scene = Arc::new(scene);
    let tracer = AnyTracer::build(args.tracer, &scene, args.local_threads.max(1))
        .map_err(CliError::input)?;
    Ok((scene, Arc::new(tracer), pkg, spec))
}
