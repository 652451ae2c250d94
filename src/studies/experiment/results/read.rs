//! Reading `runs.csv` leniently: this version's header or an earlier one, a torn last line
//! dropped.

use super::*;

/// Reading or writing `runs.csv` failed.
#[derive(Debug, thiserror::Error)]
pub enum ResultsError {
    /// The file's content cannot be resumed from (foreign header, bad row, duplicate row).
    #[error("{path}: {msg}")]
    Corrupt {
        /// The file.
        path: String,
        /// What is wrong, and how to recover.
        msg: String,
    },
    /// An I/O error on the file.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

pub(super) fn io(path: &Path) -> impl Fn(std::io::Error) -> ResultsError + '_ {
    move |source| ResultsError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// Rows of a runs.csv read leniently: a trailing partial line (a killed run) is ignored.
/// Returns the rows and the byte length of the valid prefix.
pub fn read_runs(path: &Path) -> Result<(Vec<RunRow>, u64), ResultsError> {
    let bytes = std::fs::read(path).map_err(io(path))?;
    parse_runs_of(path, &bytes)
}

/// [`parse_runs`] of the bytes read from `path`, a parse failure naming the file.
pub(super) fn parse_runs_of(path: &Path, bytes: &[u8]) -> Result<(Vec<RunRow>, u64), ResultsError> {
    parse_runs(bytes).map_err(|e| ResultsError::Corrupt {
        path: path.display().to_string(),
        msg: e.to_string(),
    })
}

/// Why `runs.csv` bytes cannot be resumed from ([`parse_runs`]); [`ResultsError::Corrupt`]
/// adds the file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RunsParseError {
    /// The header is neither this version's columns nor an earlier version's.
    #[error(
        "the header is not this version's columns (expected '{expected}'); rerun with --fresh"
    )]
    Header {
        /// This version's header.
        expected: String,
    },
    /// A line before the last has the wrong columns.
    #[error("line {line} is not a valid row; rerun with --fresh")]
    Row {
        /// The line, from 1 (the header).
        line: usize,
    },
    /// A whole row with a cell that does not read.
    #[error("line {line}, {cell}")]
    Cell {
        /// The line, from 1 (the header).
        line: usize,
        /// The column and why its cell does not read.
        cell: String,
    },
}

/// Parse runs.csv bytes; see [`read_runs`]. A missing or partial header gives no rows and length 0.
pub fn parse_runs(bytes: &[u8]) -> Result<(Vec<RunRow>, u64), RunsParseError> {
    let columns = RunRow::header();
    let header = columns.join(",");
    let Some(h_end) = bytes.iter().position(|&b| b == b'\n') else {
        return Ok((vec![], 0));
    };
    let Some(names) = known_header(&bytes[..h_end]) else {
        return Err(RunsParseError::Header { expected: header });
    };
    // Fields are matched by name, so the columns an earlier version's row lacks (parameters of
    // schedulers added since, the MPI and sample columns) take their defaults.
    let ncols = names.len();
    let mut rows = Vec::new();
    let mut valid = h_end as u64 + 1;
    let mut start = h_end + 1;
    let mut line_no = 1;
    while start < bytes.len() {
        line_no += 1;
        // No newline: the tail of a killed write. Dropped.
        let Some(len) = bytes[start..].iter().position(|&b| b == b'\n') else {
            break;
        };
        let line = &bytes[start..start + len];
        let end = start + len + 1;
        let is_last = end >= bytes.len();
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .from_reader(line);
        let parsed = match rdr.records().next() {
            Some(Ok(rec)) if rec.len() == ncols => RunRow::parse_record(&rec, &names).map_err(Some),
            _ => Err(None),
        };
        match parsed {
            Ok(row) => rows.push(row),
            // A complete-looking last line with the wrong columns is a torn write too; one
            // with every column but an unreadable cell was written whole, so it is corrupt.
            Err(None) if is_last => break,
            Err(None) => return Err(RunsParseError::Row { line: line_no }),
            Err(Some(cell)) => {
                return Err(RunsParseError::Cell {
                    line: line_no,
                    cell,
                })
            }
        }
        valid = end as u64;
        start = end;
    }
    Ok((rows, valid))
}

/// The names of a header this version reads: this version's columns, or an earlier version's
/// (a subset of them: every name known, none twice). `None` for anything else.
pub(super) fn known_header(line: &[u8]) -> Option<csv::StringRecord> {
    let columns = RunRow::header();
    let text = std::str::from_utf8(line).ok()?;
    let names: Vec<&str> = text.split(',').collect();
    let mut seen = HashSet::new();
    let known = names
        .iter()
        .all(|n| columns.iter().any(|c| c == n) && seen.insert(*n));
    (known && names.contains(&"config")).then(|| csv::StringRecord::from(names))
}

/// A readable header other than this version's: the file is rewritten before appending.
pub(super) fn is_legacy_header(line: &[u8]) -> bool {
    line != RunRow::header().join(",").as_bytes() && known_header(line).is_some()
}
