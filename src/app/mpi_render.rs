//! `raysched render SCENE --sources mpi` under `mpirun -n K`: rank 0 runs the scheduler, ranks
//! 1…K−1 are compute sources (plus `--local-threads` threads on rank 0: a heterogeneous run).

use super::error::CliError;
use super::render::RenderArgs;
use raysched::metrics::Probe;
use raysched::mpi::comm::{tag, Comm};
use raysched::mpi::hub::{run_on_ranks, stop_ranks, Hub, HubEnd, Peer};
use raysched::mpi::wire::Ready;
use raysched::mpi::wire::ScenePackage;
use raysched::scene::Scene;
use raysched::sched::{assemble, decompose_frames, render_job};
use raysched::sched::{Runner, SchedulerSpec};
use raysched::source::{ComputeSource, LocalThreadSource};
use raysched::tracer::AnyTracer;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How long a worker may take to build its scene and tracer.
const READY_WAIT: Duration = Duration::from_secs(600);
/// How long rank 0 waits for the workers' goodbyes after STOP.
pub(crate) const STOP_WAIT: Duration = Duration::from_secs(10);
/// A rank with work outstanding that says nothing this long is lost (env
/// `RAYSCHED_MPI_SILENCE_MS`); local ranks are also checked by pid, which is much faster.
/// Busy workers send a heartbeat every 200 ms from a thread that does not render, so a
/// slow item does not count as silence (it was 60 s before heartbeats).
const SILENCE: Duration = Duration::from_millis(raysched::experiment::plan::DEFAULT_SILENCE_MS);

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
    let (scene, pkg, spec) = match prepare(comm, args) {
        Ok(p) => p,
        Err(e) => {
            let _ = comm.broadcast(Some(Vec::new()));
            return Err(e);
        }
    };
    // 2. Ship the scene; every rank builds it and answers READY.
    comm.broadcast(Some(pkg.encode()))
        .map_err(CliError::runtime)?;
    let peers = gather_ready(comm)?;
    // 3. The ranks (and any local threads) as compute sources under the scheduler.
    let scene = Arc::new(scene);
    let probe = Probe::new(!args.stats_off, args.timeline);
    let silence = std::env::var("RAYSCHED_MPI_SILENCE_MS")
        .ok()
        .and_then(|v| v.parse().ok())
        .map_or(SILENCE, Duration::from_millis);
    let (hub, mut sources) = Hub::new(comm, &peers, 0, probe, silence);
    add_local_threads(args, &scene, probe, &mut sources)?;
    let labels: Vec<String> = sources.iter().map(|s| s.label()).collect();
    let (w, h) = (scene.width(), scene.height());
    let items = decompose_frames(w, h, scene.frames(), spec.chunk, spec.order);
    let t0 = Instant::now();
    let (outcome, hub_report) = run_on_ranks(
        hub,
        HubEnd::Stop(STOP_WAIT),
        &spec,
        &items,
        sources,
        &args.run_options(),
        probe,
    );
    *lost = !hub_report.lost.is_empty();
    let (results, mut stats) = outcome.map_err(CliError::runtime)?;
    stats.lost_sources = stats.lost_sources.max(hub_report.lost.len() as u64);
    // 4. The image and the report.
    let image =
        assemble(scene.width(), scene.height(), &items, &results).map_err(CliError::runtime)?;
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

/// The checked input of an MPI render: the scene, its package for the ranks and the spec.
fn prepare(
    comm: &Comm,
    args: &RenderArgs,
) -> Result<(Scene, ScenePackage, SchedulerSpec), CliError> {
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
    Ok((scene, pkg, spec))
}

/// `--local-threads` threads on rank 0 as extra sources (a heterogeneous run).
fn add_local_threads(
    args: &RenderArgs,
    scene: &Arc<Scene>,
    probe: Probe,
    sources: &mut Vec<Box<dyn ComputeSource>>,
) -> Result<(), CliError> {
    if args.local_threads == 0 {
        return Ok(());
    }
    let tracer = Arc::new(
        AnyTracer::build(args.tracer, scene, args.local_threads).map_err(CliError::input)?,
    );
    let job = render_job(scene, &tracer);
    for _ in 0..args.local_threads {
        let id = sources.len() as u32;
        sources.push(Box::new(LocalThreadSource::spawn(id, job.clone(), probe)));
    }
    Ok(())
}

/// Wait for every worker's READY; a rank that could not build the scene stops the run with
/// its own message.
pub(crate) fn gather_ready(comm: &Comm) -> Result<Vec<Peer>, CliError> {
    let mut peers: Vec<Option<Peer>> = vec![None; comm.size as usize];
    let mut errors = Vec::new();
    let end = Instant::now() + READY_WAIT;
    let mut missing = comm.size as usize - 1;
    while missing > 0 {
        if Instant::now() > end {
            errors.push(format!(
                "{missing} rank(s) did not report ready within {} s",
                READY_WAIT.as_secs()
            ));
            break;
        }
        let Some(p) = comm.iprobe(None).map_err(CliError::runtime)? else {
            std::thread::sleep(Duration::from_micros(200));
            continue;
        };
        let body = comm.recv(p).map_err(CliError::runtime)?;
        if p.tag != tag::READY || peers[p.source as usize].is_some() {
            continue;
        }
        missing -= 1;
        match Ready::decode(&body) {
            Ok(r) if r.error.is_empty() => {
                peers[p.source as usize] = Some(Peer {
                    rank: p.source,
                    pid: r.pid,
                    host: r.host,
                })
            }
            Ok(r) => errors.push(format!(
                "rank {} ({}, pid {}): {}",
                p.source, r.host, r.pid, r.error
            )),
            Err(e) => errors.push(format!("rank {}: {e}", p.source)),
        }
        if peers[p.source as usize].is_none() {
            // Keep the slot marked as answered.
            peers[p.source as usize] = Some(Peer {
                rank: -1,
                pid: 0,
                host: String::new(),
            });
        }
    }
    if !errors.is_empty() {
        let all: Vec<i32> = (1..comm.size).collect();
        stop_ranks(comm, &all, true, STOP_WAIT);
        return Err(CliError::runtime(anyhow::anyhow!(
            "the scene could not be built on every rank:\n  {}",
            errors.join("\n  ")
        )));
    }
    Ok(peers.into_iter().flatten().filter(|p| p.rank > 0).collect())
}
