//! A worker rank (rank ≠ 0): receive the scene package, build scene and tracer, answer READY,
//! then render items until STOP. One item at a time, in arrival order, on one thread.

use super::comm::{tag, Comm};
use super::wire::{decode_item, Ready, ScenePackage};
use crate::render::{render_item, TileResult};
use crate::sched::wire::encode_result;
use crate::tracer::AnyTracer;
use std::time::Instant;

/// Test hook: this rank corrupts the scene it received (a "bad scene on one rank").
pub const ENV_CORRUPT_RANK: &str = "RAYSCHED_MPI_TEST_CORRUPT_RANK";
/// Test hook: each worker writes `rank<r>.pid` into this folder after its first result and then
/// stalls for 2 s (a slow node), so a test can `kill -9` it mid-run.
pub const ENV_PID_DIR: &str = "RAYSCHED_MPI_PID_DIR";
/// Measurement hook: workers return black pixels without rendering, so a run measures the
/// pure dispatch cost over MPI (the image is then wrong, by design).
pub const ENV_ZERO_WORK: &str = "RAYSCHED_MPI_ZERO_WORK";

pub fn hostname() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|s| s.trim().to_string())
        .unwrap_or_default()
}

fn build(comm: &Comm, bytes: &[u8]) -> anyhow::Result<(crate::scene::Scene, AnyTracer)> {
    let mut pkg = ScenePackage::decode(bytes)?;
    if std::env::var(ENV_CORRUPT_RANK)
        .ok()
        .and_then(|r| r.parse::<i32>().ok())
        == Some(comm.rank)
    {
        pkg.text.push_str("\n[corrupted_on_purpose]\n");
    }
    let scene = super::scene::unpack(&pkg, comm.rank)?;
    let tracer = AnyTracer::build(&pkg.tracer, &scene, 1)?;
    Ok((scene, tracer))
}

/// Serve rank 0 until it says STOP; never returns.
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
    // A panic while building (a tracer bug) is reported like an error, not a silent death.
    let built = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| build(&comm, &bytes)))
        .unwrap_or_else(|p| {
            Err(anyhow::anyhow!(
                "panicked: {}",
                crate::source::local::panic_message(&p)
            ))
        });
    let ready = Ready {
        pid: std::process::id(),
        host: hostname(),
        error: built
            .as_ref()
            .err()
            .map(|e| format!("{e:#}"))
            .unwrap_or_default(),
    };
    if comm.send(0, tag::READY, &ready.encode()).is_err() {
        comm.shutdown(false, 1)
    }
    let pid_dir = std::env::var_os(ENV_PID_DIR);
    let mut served = 0u64;
    let mut out = Vec::new();
    let mut inbox = std::collections::VecDeque::new();
    let zero_work = std::env::var_os(ENV_ZERO_WORK).is_some();
    loop {
        // Take everything already waiting: a STOP queued behind items skips them (they are
        // re-issued copies nobody waits for any more), so the run ends without rendering them.
        let got = (|| {
            while let Some(p) = comm.iprobe(Some(0))? {
                inbox.push_back((p, comm.recv(p)?));
            }
            if inbox.is_empty() {
                let p = comm.probe(0)?;
                inbox.push_back((p, comm.recv(p)?));
            }
            Ok::<_, super::comm::MpiError>(())
        })();
        if let Err(e) = got {
            eprintln!("rank {}: lost rank 0: {e}", comm.rank);
            comm.shutdown(false, 1)
        }
        if let Some(k) = inbox.iter().position(|(p, _)| p.tag == tag::STOP) {
            let stop = inbox.remove(k).expect("position is in range");
            inbox.clear();
            inbox.push_back(stop);
        }
        let Some(msg) = inbox.pop_front() else {
            continue;
        };
        match msg {
            (p, body) if p.tag == tag::ITEM => {
                let Ok((scene, tracer)) = &built else {
                    continue;
                };
                let item = match decode_item(&body) {
                    Ok(i) => i,
                    Err(e) => {
                        eprintln!("rank {}: {e}", comm.rank);
                        continue;
                    }
                };
                let t0 = Instant::now();
                let r = if zero_work {
                    TileResult {
                        item: item.id,
                        pixels: vec![[0.0; 3]; item.pixel_count()],
                        rays: 0,
                        nonfinite: 0,
                    }
                } else {
                    render_item(scene, tracer, &item)
                };
                let busy = t0.elapsed().as_nanos() as u64;
                out.clear();
                encode_result(&r, &mut out);
                out.extend_from_slice(&busy.to_le_bytes());
                if comm.send(0, tag::RESULT, &out).is_err() {
                    comm.shutdown(false, 1)
                }
                served += 1;
                if served == 1 {
                    if let Some(dir) = &pid_dir {
                        let path = std::path::Path::new(dir).join(format!("rank{}.pid", comm.rank));
                        let _ = std::fs::write(path, std::process::id().to_string());
                        // A slow node: hold on to the items still queued here so the test's
                        // kill lands mid-run even when the whole render takes milliseconds.
                        std::thread::sleep(std::time::Duration::from_secs(2));
                    }
                }
            }
            (p, body) if p.tag == tag::STOP => {
                let finalize = body.first() == Some(&1);
                let _ = comm.send(0, tag::BYE, &[]);
                comm.shutdown(finalize, 0)
            }
            _ => {} // nothing else is sent to a worker
        }
    }
}
