//! Writing result files so that a kill never leaves one half-written.

use std::io::Write;
use std::path::{Path, PathBuf};

/// Writing a file (or its temporary twin) failed: the file and the error, shown as
/// `path: error`.
#[derive(Debug, thiserror::Error)]
#[error("{}: {io}", path.display())]
pub struct WriteError {
    /// The file being written or renamed to.
    pub path: PathBuf,
    /// What failed.
    pub io: std::io::Error,
}

/// Write via a temporary file and a rename, so a kill never leaves a half-written file.
///
/// # Errors
/// Creating or writing the temporary file, or renaming it to `path`, failed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    let err = |path: &Path| {
        let path = path.to_path_buf();
        move |io| WriteError { path, io }
    };
    let tmp = path.with_extension("tmp");
    let mut f = std::fs::File::create(&tmp).map_err(err(&tmp))?;
    f.write_all(bytes).map_err(err(&tmp))?;
    drop(f);
    std::fs::rename(&tmp, path).map_err(err(path))
}
