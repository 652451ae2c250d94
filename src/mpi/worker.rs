//! A worker rank (rank ≠ 0): build the scene rank 0 sends (broadcast for `render`, a SCENE
//! message per scene for `run`), answer READY, render items until STOP.
//!
//! Two threads: the MPI thread (the one that initialised MPI, `FUNNELED`) moves messages and
//! sends a HEARTBEAT whenever it has work and has said nothing for [`HEARTBEAT`]; the render
//! thread builds scenes and renders items one at a time, in arrival order. A slow item thus
//! never silences the rank, and rank 0 can treat a short silence as death.

use super::comm::{backoff, tag, Comm, MpiError, Pending};
use super::wire::{decode_items, Ready, ScenePackage};
use crate::core::render::{render_item, TileResult, WorkItem};
use crate::core::tracer::{AnyTracer, TracerKind};
use crate::sched::wire::encode_result;
use crossbeam::channel::{Receiver, Sender};
use std::time::{Duration, Instant};

/// How often a rank with work says it is alive. Measured cost: one empty message, a few µs of
/// the MPI thread per 200 ms.
pub const HEARTBEAT: Duration = Duration::from_millis(200);

/// Test hook: this rank corrupts the scene it received (a "bad scene on one rank").
pub const ENV_CORRUPT_RANK: &str = "RAYSCHED_MPI_TEST_CORRUPT_RANK";
/// Test hook: each worker writes `rank<r>.pid` into this folder after its first result and then
/// stalls for 2 s (a slow node), so a test can `kill -9` it mid-run.
pub const ENV_PID_DIR: &str = "RAYSCHED_MPI_PID_DIR";
/// Measurement hook: workers return black pixels without rendering, so a run measures the
/// pure dispatch cost over MPI (the image is then wrong, by design).
pub const ENV_ZERO_WORK: &str = "RAYSCHED_MPI_ZERO_WORK";
/// Measurement hook: workers spin this many nanoseconds per pixel instead of rendering
/// (black pixels), so a launch measures a source's period per item over MPI with items of a
/// known cost (the simulation's MPI refill period, `experiments/mpi_sweep.py --spin`).
pub const ENV_SPIN_NS_PER_PX: &str = "RAYSCHED_MPI_SPIN_NS_PER_PX";

/// Why a rank has no scene to render: shown to rank 0 as one line.
#[derive(Debug, thiserror::Error)]
enum BuildError {
    /// Nothing received yet, or the build panicked.
    #[error("{0}")]
    Failed(String),
    /// The package did not decode.
    #[error(transparent)]
    Wire(#[from] super::wire::WireError),
    /// The scene did not rebuild.
    #[error(transparent)]
    Pack(#[from] super::scene::PackError),
    /// The tracer did not build.
    #[error(transparent)]
    Tracer(#[from] crate::core::tracer::TracerError),
}

fn build(rank: i32, bytes: &[u8]) -> Result<(crate::core::scene::Scene, AnyTracer), BuildError> {
    let mut pkg = ScenePackage::decode(bytes)?;
    if std::env::var(ENV_CORRUPT_RANK)
        .ok()
        .and_then(|r| r.parse::<i32>().ok())
        == Some(rank)
    {
        pkg.text.push_str("\n[corrupted_on_purpose]\n");
    }
    let scene = super::scene::unpack(&pkg, rank)?;
    let tracer = AnyTracer::build(TracerKind::from_id(&pkg.tracer)?, &scene, 1)?;
    Ok((scene, tracer))
}

/// `render`: the scene comes by broadcast; an empty one means rank 0 failed and finalises.
pub fn run(comm: Comm) -> ! {
    let bytes = match comm.broadcast(None) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("rank {}: {e}", comm.rank);
            comm.shutdown(false, 1)
        }
    };
    if bytes.is_empty() {
        // Rank 0 could not load the scene; it reports why and finalises.
        comm.shutdown(true, 0)
    }
    serve(comm, Some(bytes))
}

/// Work for the render thread, and what it hands back for the MPI thread to send.
enum Job {
    Scene(Vec<u8>),
    Item(WorkItem),
}

/// Build scenes and render items until the MPI thread goes away (the process exits).
fn render_thread(rank: i32, jobs: Receiver<Job>, out: Sender<(i32, Vec<u8>)>) {
    let pid_dir = std::env::var_os(ENV_PID_DIR);
    let zero_work = std::env::var_os(ENV_ZERO_WORK).is_some();
    let spin_ns = std::env::var(ENV_SPIN_NS_PER_PX)
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|v| *v > 0.0);
    let mut built: Result<(crate::core::scene::Scene, AnyTracer), BuildError> =
        Err(BuildError::Failed("no scene received yet".into()));
    let mut served = 0u64;
    for job in jobs {
        match job {
            Job::Scene(bytes) => {
                // A panic while building (a tracer bug) is reported like an error.
                built =
                    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| build(rank, &bytes)))
                        .unwrap_or_else(|p| {
                            Err(BuildError::Failed(format!(
                                "panicked: {}",
                                crate::source::local::panic_message(&p)
                            )))
                        });
                let ready = Ready {
                    pid: std::process::id(),
                    host: crate::util::host::hostname(),
                    error: built
                        .as_ref()
                        .err()
                        .map(ToString::to_string)
                        .unwrap_or_default(),
                };
                if out.send((tag::READY, ready.encode())).is_err() {
                    return;
                }
            }
            Job::Item(item) => {
                let Ok((scene, tracer)) = &built else {
                    continue;
                };
                let t0 = Instant::now();
                let r = if zero_work || spin_ns.is_some() {
                    if let Some(ns) = spin_ns {
                        let d = Duration::from_nanos((ns * item.pixel_count() as f64) as u64);
                        while t0.elapsed() < d {
                            std::hint::spin_loop();
                        }
                    }
                    TileResult {
                        item: item.id,
                        pixels: crate::core::render::PixelValues::from_elem(
                            [0.0; 3],
                            item.pixel_count(),
                        ),
                        rays: 0,
                        nonfinite: 0,
                    }
                } else {
                    render_item(scene, tracer, &item)
                };
                let busy = t0.elapsed().as_nanos() as u64;
                let mut msg = Vec::new();
                encode_result(&r, &mut msg);
                msg.extend_from_slice(&busy.to_le_bytes());
                if out.send((tag::RESULT, msg)).is_err() {
                    return;
                }
                served += 1;
                if served == 1 {
                    if let Some(dir) = &pid_dir {
                        let path = std::path::Path::new(dir).join(format!("rank{rank}.pid"));
                        let _ = std::fs::write(path, std::process::id().to_string());
                        // A slow node: hold on to the items still queued here so the test's
                        // kill lands mid-run even when the whole render takes milliseconds
                        // (heartbeats go on meanwhile: slow is not dead).
                        std::thread::sleep(Duration::from_secs(2));
                    }
                }
            }
        }
    }
}

/// Send the results gathered so far as one RESULT message (none when there are none).
fn flush_results(comm: &Comm, results: &mut Vec<u8>) -> Result<(), MpiError> {
    if !results.is_empty() {
        comm.send(0, tag::RESULT, results)?;
        results.clear();
    }
    Ok(())
}

/// Serve rank 0 until it says STOP; never returns. `scene`: a package to build first.
pub fn serve(comm: Comm, scene: Option<Vec<u8>>) -> ! {
    let rank = comm.rank;
    let (job_tx, job_rx) = crossbeam::channel::unbounded();
    let (out_tx, out_rx) = crossbeam::channel::unbounded();
    if let Err(e) = std::thread::Builder::new()
        .name(format!("render-rank-{rank}"))
        .spawn(move || render_thread(rank, job_rx, out_tx))
    {
        eprintln!("rank {rank}: cannot start the render thread: {e}");
        comm.shutdown(false, 1)
    }
    // Jobs handed to the render thread and not answered yet.
    let mut busy = 0usize;
    if let Some(bytes) = scene {
        let _ = job_tx.send(Job::Scene(bytes));
        busy += 1;
    }
    let mut last_sent = Instant::now();
    let mut idle = 0u32;
    loop {
        let mut any = false;
        // 1. Everything rank 0 sent. A STOP skips the items still queued (re-issued copies
        //    nobody waits for any more), so the run ends without rendering them.
        loop {
            let got: Result<Option<(Pending, Vec<u8>)>, _> = comm
                .iprobe(Some(0))
                .and_then(|p| p.map(|p| comm.recv(p).map(|b| (p, b))).transpose());
            let (p, body) = match got {
                Ok(Some(m)) => m,
                Ok(None) => break,
                Err(e) => {
                    eprintln!("rank {rank}: lost rank 0: {e}");
                    comm.shutdown(false, 1)
                }
            };
            any = true;
            match p.tag {
                tag::ITEM => match decode_items(&body) {
                    // One hand-out of the master: one or more items.
                    Ok(items) => {
                        for item in items {
                            busy += 1;
                            let _ = job_tx.send(Job::Item(item));
                        }
                    }
                    Err(e) => eprintln!("rank {rank}: {e}"),
                },
                tag::SCENE => {
                    busy += 1;
                    let _ = job_tx.send(Job::Scene(body));
                }
                tag::STOP => {
                    let finalize = body.first() == Some(&1);
                    let _ = comm.send(0, tag::BYE, &[]);
                    comm.shutdown(finalize, 0)
                }
                _ => {} // nothing else is sent to a worker
            }
        }
        // 2. Whatever the render thread finished; results waiting together go as one message
        //    (per-ray items: one message per result was the cost over MPI).
        //    Anything else (READY) goes in order, after the results before it.
        let mut results = Vec::new();
        let mut sent = false;
        while let Ok((t, msg)) = out_rx.try_recv() {
            any = true;
            sent = true;
            busy = busy.saturating_sub(1);
            if t == tag::RESULT {
                results.extend_from_slice(&msg);
                continue;
            }
            if flush_results(&comm, &mut results).is_err() || comm.send(0, t, &msg).is_err() {
                comm.shutdown(false, 1)
            }
        }
        if flush_results(&comm, &mut results).is_err() {
            comm.shutdown(false, 1)
        }
        // Only what this rank sent counts: rank 0 keeps handing items to a slow rank.
        if sent {
            last_sent = Instant::now();
        }
        // 3. Alive, though busy with a long item.
        if busy > 0 && last_sent.elapsed() >= HEARTBEAT {
            if comm.send(0, tag::HEARTBEAT, &[]).is_err() {
                comm.shutdown(false, 1)
            }
            last_sent = Instant::now();
        }
        idle = if any { 0 } else { idle.saturating_add(1) };
        backoff(idle);
    }
}
