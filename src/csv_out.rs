//! Writing a list of serde rows as a CSV file (with its folder), shared by every table the
//! harness writes in one go (convergence, stability).

use serde::Serialize;
use std::path::Path;

/// Write `rows` to `path` as CSV with a header, creating the parent folder.
///
/// # Errors
/// I/O or CSV errors.
pub fn write_rows<T: Serialize>(path: &Path, rows: &[T]) -> anyhow::Result<()> {
    if let Some(d) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d)?;
    }
    let mut w = csv::Writer::from_path(path)?;
    for r in rows {
        w.serialize(r)?;
    }
    w.flush()?;
    Ok(())
}
