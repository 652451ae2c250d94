//! Running one SimGrid simulation in a child process (`raysched simgrid-child …`): SimGrid's
//! engine runs once per process, and a malformed platform aborts the process that loads it.

use super::job::{PlatformInfo, SimJob, SimOutcome};
use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// The hidden subcommand the child runs.
pub const CHILD_COMMAND: &str = "simgrid-child";

fn scratch(what: &str) -> std::path::PathBuf {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    std::env::temp_dir().join(format!(
        "raysched-{what}-{}-{}.toml",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    ))
}

/// The last non-empty line a failed child wrote. SimGrid reports a malformed platform by a
/// C++ exception, which Rust cannot catch: the child aborts without SimGrid's message.
fn last_line(stderr: &[u8]) -> String {
    let line = String::from_utf8_lossy(stderr)
        .lines()
        .rev()
        .map(str::trim)
        .find(|l| !l.is_empty())
        .unwrap_or("no message")
        .trim_start_matches("error: ")
        .to_string();
    if line.contains("foreign exception") {
        return "SimGrid rejected it (not a valid platform file: check the XML and every attribute against https://simgrid.org/simgrid.dtd)".into();
    }
    line
}

/// Why a child gave no answer.
#[derive(Debug, thiserror::Error)]
pub enum Failure {
    /// It failed, with this message.
    #[error("{0}")]
    Error(String),
    /// It was still running after the limit and was stopped.
    #[error("over the time limit")]
    OverLimit,
}

fn run_child<T: serde::de::DeserializeOwned>(
    exe: &Path,
    args: &[&str],
    limit: Option<Duration>,
) -> Result<T, Failure> {
    let mut child = Command::new(exe)
        .arg(CHILD_COMMAND)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| Failure::Error(format!("starting {}: {e}", exe.display())))?;
    // Read both pipes while waiting: an answer larger than a pipe's buffer would block it.
    let drain = |mut r: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut b = Vec::new();
            let _ = r.read_to_end(&mut b);
            b
        })
    };
    let stdout = drain(Box::new(child.stdout.take().expect("piped")));
    let stderr = drain(Box::new(child.stderr.take().expect("piped")));
    let start = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(s)) => break s,
            Ok(None) if limit.is_some_and(|l| start.elapsed() > l) => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(Failure::OverLimit);
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => return Err(Failure::Error(format!("waiting for the simulation: {e}"))),
        }
    };
    let out = stdout.join().unwrap_or_default();
    let err = stderr.join().unwrap_or_default();
    if !status.success() {
        return Err(Failure::Error(last_line(&err)));
    }
    let text = String::from_utf8_lossy(&out);
    toml::from_str(&text)
        .map_err(|e| Failure::Error(format!("reading the simulation's answer: {e}")))
}

/// Load `platform` in a child and list its hosts; a malformed file is an error with
/// SimGrid's message.
///
/// # Errors
/// The file cannot be read, the child failed (SimGrid's message), no host has a core.
pub fn inspect(exe: &Path, platform: &Path) -> Result<PlatformInfo, Failure> {
    std::fs::metadata(platform).map_err(|e| Failure::Error(e.to_string()))?;
    let info: PlatformInfo = run_child(exe, &["inspect", &platform.to_string_lossy()], None)?;
    if info.worker_slots() == 0 {
        return Err(Failure::Error(
            "the platform has no host with a core".into(),
        ));
    }
    Ok(info)
}

/// Simulate `job` in a child process, stopping it after `limit` of real time.
pub fn simulate(exe: &Path, job: &SimJob, limit: Option<Duration>) -> Result<SimOutcome, Failure> {
    let path = scratch("simjob");
    let text = toml::to_string(job).map_err(|e| Failure::Error(e.to_string()))?;
    std::fs::write(&path, text).map_err(|e| Failure::Error(format!("{}: {e}", path.display())))?;
    let out = run_child(exe, &["run", &path.to_string_lossy()], limit);
    let _ = std::fs::remove_file(&path);
    out
}
