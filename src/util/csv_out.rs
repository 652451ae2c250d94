//! Writing a list of serde rows as a CSV file (with its folder), shared by every table the
//! harness writes in one go (convergence, stability).

use serde::Serialize;
use std::path::Path;

/// Writing or reading a CSV table failed; shown as the underlying error.
#[derive(Debug, thiserror::Error)]
pub enum CsvError {
    /// Creating the folder or flushing the file.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// The CSV layer (opening, a record, a field).
    #[error(transparent)]
    Csv(#[from] csv::Error),
}

/// Write `rows` to `path` as CSV with a header, creating the parent folder.
///
/// # Errors
/// I/O or CSV errors.
pub fn write_rows<T: Serialize>(path: &Path, rows: &[T]) -> Result<(), CsvError> {
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
