//! All-or-none output: a command that writes several files writes them into a staging folder
//! beside their destination and renames them into place only once every one was written, so a
//! failure (a full disk, a bad path, a kill) leaves the old files or none, never half a set.
//!
//! ```no_run
//! # fn main() -> std::io::Result<()> {
//! let staging = raysched::util::staging::Staging::new(std::path::Path::new("results/x"))?;
//! std::fs::write(staging.path("report.md"), "…")?;
//! staging.commit()?; // results/x/report.md appears now
//! # Ok(())
//! # }
//! ```

use std::io;
use std::path::{Path, PathBuf};

/// A staging folder inside `root` (same filesystem, so a rename moves a file in one step);
/// removed on drop unless committed.
#[derive(Debug)]
pub struct Staging {
    root: PathBuf,
    tmp: PathBuf,
}

impl Staging {
    /// Create `root` (if needed) and an empty staging folder in it, named after this process.
    ///
    /// # Errors
    /// When either folder cannot be created.
    pub fn new(root: &Path) -> io::Result<Self> {
        std::fs::create_dir_all(root)?;
        let tmp = root.join(format!(".raysched-staging-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&tmp); // left by a killed process with our pid
        std::fs::create_dir(&tmp)?;
        Ok(Self {
            root: root.to_path_buf(),
            tmp,
        })
    }

    /// Where to write the file that ends up at `root/rel`.
    pub fn path(&self, rel: impl AsRef<Path>) -> PathBuf {
        self.tmp.join(rel)
    }

    /// The staging folder's counterpart of `root/rel` when `rel` is a folder: created.
    ///
    /// # Errors
    /// When the folder cannot be created.
    pub fn dir(&self, rel: impl AsRef<Path>) -> io::Result<PathBuf> {
        let d = self.tmp.join(rel);
        std::fs::create_dir_all(&d)?;
        Ok(d)
    }

    /// Move every staged file to its place under `root`; returns their final paths.
    ///
    /// # Errors
    /// When a file cannot be moved (those moved before it stay moved).
    pub fn commit(self) -> io::Result<Vec<PathBuf>> {
        let mut files = Vec::new();
        list_files(&self.tmp, &mut files)?;
        // What would make a rename fail is looked for first, so nothing is moved then.
        for f in &files {
            let dest = self
                .root
                .join(f.strip_prefix(&self.tmp).expect("listed under tmp"));
            if dest.is_dir() {
                return Err(io::Error::other(format!(
                    "{}: is a folder, cannot write a file there",
                    dest.display()
                )));
            }
        }
        let mut moved = Vec::with_capacity(files.len());
        for f in files {
            let rel = f.strip_prefix(&self.tmp).expect("listed under tmp");
            let dest = self.root.join(rel);
            if let Some(parent) = dest.parent() {
                std::fs::create_dir_all(parent)?;
            }
            std::fs::rename(&f, &dest)?;
            moved.push(dest);
        }
        Ok(moved)
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.tmp);
    }
}

fn list_files(dir: &Path, out: &mut Vec<PathBuf>) -> io::Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        let path = entry.path();
        if entry.file_type()?.is_dir() {
            list_files(&path, out)?;
        } else {
            out.push(path);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_appear_only_on_commit_and_a_dropped_staging_leaves_nothing() {
        let root = tempfile::tempdir().unwrap();
        let s = Staging::new(root.path()).unwrap();
        std::fs::write(s.path("a.txt"), "a").unwrap();
        std::fs::write(s.dir("plots").unwrap().join("b.txt"), "b").unwrap();
        assert!(!root.path().join("a.txt").exists());
        let moved = s.commit().unwrap();
        assert_eq!(moved.len(), 2);
        assert_eq!(
            std::fs::read_to_string(root.path().join("plots/b.txt")).unwrap(),
            "b"
        );
        let s = Staging::new(root.path()).unwrap();
        std::fs::write(s.path("c.txt"), "c").unwrap();
        drop(s);
        let left: Vec<_> = std::fs::read_dir(root.path()).unwrap().collect();
        assert_eq!(left.len(), 2, "a.txt and plots/ only");
        assert!(!root.path().join("c.txt").exists());
    }
}
