//! One `raysched run` per results folder at a time: a second run on the same folder would
//! append the same rows again (and every later resume would refuse the duplicates). The lock
//! is a file holding the owner's process id; a lock whose process is gone is stale and taken.

use std::io::Write;
use std::path::{Path, PathBuf};

/// The lock file's name inside a results folder.
pub const LOCK_FILE: &str = ".raysched.lock";

/// Held while a run writes a results folder; released on drop.
#[derive(Debug)]
pub struct ResultsLock {
    path: PathBuf,
}

/// Why a results folder could not be locked.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{path}: {msg}")]
pub struct LockError {
    /// The lock file.
    pub path: String,
    /// What is wrong.
    pub msg: String,
}

impl ResultsLock {
    /// Lock `dir` (created if needed) for this process.
    ///
    /// # Errors
    /// A [`LockError`] naming the lock file and its owner when another live process holds
    /// it, or when the file cannot be written.
    pub fn acquire(dir: &Path) -> Result<Self, LockError> {
        let path = dir.join(LOCK_FILE);
        let fail = |msg: String| LockError {
            path: path.display().to_string(),
            msg,
        };
        std::fs::create_dir_all(dir).map_err(|e| fail(e.to_string()))?;
        // Two tries: the second after removing a stale lock.
        for _ in 0..2 {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(mut f) => {
                    writeln!(f, "{}", std::process::id()).map_err(|e| fail(e.to_string()))?;
                    return Ok(Self { path });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let owner = std::fs::read_to_string(&path).unwrap_or_default();
                    match owner.trim().parse::<u32>() {
                        Ok(pid) if alive(pid) => {
                            return Err(fail(format!(
                                "another raysched run (process {pid}) is writing this results \
                                 folder; wait for it to finish (remove the lock file if that \
                                 process is not raysched)"
                            )))
                        }
                        // Stale (its process is gone) or torn: take it over.
                        _ => {
                            let _ = std::fs::remove_file(&path);
                        }
                    }
                }
                Err(e) => return Err(fail(e.to_string())),
            }
        }
        Err(fail("another process keeps creating this lock file".into()))
    }
}

impl Drop for ResultsLock {
    fn drop(&mut self) {
        let ours = std::fs::read_to_string(&self.path)
            .is_ok_and(|t| t.trim() == std::process::id().to_string());
        if ours {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// Is process `pid` running? Where `/proc` is absent, any pid counts as running.
fn alive(pid: u32) -> bool {
    let proc = Path::new("/proc");
    !proc.is_dir() || proc.join(pid.to_string()).exists()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_held_lock_refuses_a_second_owner_and_a_stale_one_is_taken() {
        let dir = tempfile::tempdir().unwrap();
        let lock = ResultsLock::acquire(dir.path()).unwrap();
        let err = ResultsLock::acquire(dir.path()).unwrap_err();
        assert!(err.msg.contains("another raysched run"), "{err}");
        drop(lock);
        assert!(!dir.path().join(LOCK_FILE).exists());
        // A pid above Linux's pid_max (2²²) is never running.
        std::fs::write(dir.path().join(LOCK_FILE), "99999999\n").unwrap();
        let lock = ResultsLock::acquire(dir.path()).unwrap();
        drop(lock);
    }
}
