//! Running one SimGrid simulation in a child process (`raysched simgrid-child …`): SimGrid's
//! engine runs once per process, and a malformed platform aborts the process that loads it.

use super::job::{PlatformInfo, SimJob, SimOutcome};
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};

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

fn run_child<T: serde::de::DeserializeOwned>(exe: &Path, args: &[&str]) -> Result<T, String> {
    let out = Command::new(exe)
        .arg(CHILD_COMMAND)
        .args(args)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("starting {}: {e}", exe.display()))?;
    if !out.status.success() {
        return Err(last_line(&out.stderr));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    toml::from_str(&text).map_err(|e| format!("reading the simulation's answer: {e}"))
}

/// Load `platform` in a child and list its hosts; a malformed file is an error with
/// SimGrid's message.
pub fn inspect(exe: &Path, platform: &Path) -> Result<PlatformInfo, String> {
    std::fs::metadata(platform).map_err(|e| e.to_string())?;
    let info: PlatformInfo = run_child(exe, &["inspect", &platform.to_string_lossy()])?;
    if info.worker_slots() == 0 {
        return Err("the platform has no host with a core".into());
    }
    Ok(info)
}

/// Simulate `job` in a child process.
pub fn simulate(exe: &Path, job: &SimJob) -> Result<SimOutcome, String> {
    let path = scratch("simjob");
    let text = toml::to_string(job).map_err(|e| e.to_string())?;
    std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
    let out = run_child(exe, &["run", &path.to_string_lossy()]);
    let _ = std::fs::remove_file(&path);
    out
}
