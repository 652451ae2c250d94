//! `runs.csv` opened for appending: the rows already in it, upgraded from an earlier header
//! and cut back to the last whole row before anything is appended.

use super::*;

/// runs.csv opened for appending, with the (config, repetition) pairs already in it.
pub struct RunsFile {
    /// The runs.csv path.
    pub path: PathBuf,
    file: File,
    done: HashSet<(String, u32)>,
}

impl RunsFile {
    /// Open (or create) `path`. With `fresh` any old content is discarded; otherwise a trailing
    /// partial row is dropped and the rest kept. Returns the file and the rows already in it.
    pub fn open(path: &Path, fresh: bool) -> Result<(Self, Vec<RunRow>), ResultsError> {
        Self::read(path, fresh)?.open()
    }

    /// Read `path` (one read) without changing it, so a caller can check its rows before
    /// [`OldRuns::open`] appends to it; with `fresh`, or where it does not exist, no rows.
    pub fn read(path: &Path, fresh: bool) -> Result<OldRuns, ResultsError> {
        let (rows, valid, legacy) = if fresh || !path.exists() {
            (vec![], 0, false)
        } else {
            let bytes = std::fs::read(path).map_err(io(path))?;
            let legacy = bytes
                .split(|&c| c == b'\n')
                .next()
                .is_some_and(is_legacy_header);
            let (rows, valid) = parse_runs_of(path, &bytes)?;
            (rows, valid, legacy)
        };
        // Checked here, before anything is written: a refused resume changes no file.
        let mut seen = HashSet::new();
        for r in &rows {
            if !seen.insert((&r.config, r.repetition)) {
                return Err(ResultsError::Corrupt {
                    path: path.display().to_string(),
                    msg: format!(
                        "config {} repetition {} appears twice; rerun with --fresh",
                        r.config, r.repetition
                    ),
                });
            }
        }
        Ok(OldRuns {
            path: path.to_path_buf(),
            rows,
            valid,
            legacy,
        })
    }
}

/// runs.csv as [`RunsFile::read`] found it: its rows, and what opening it for appending does.
pub struct OldRuns {
    path: PathBuf,
    /// The complete rows already in it.
    pub rows: Vec<RunRow>,
    /// Bytes up to the end of its last complete row.
    valid: u64,
    /// Its header is an earlier version's: it is rewritten in this version's columns.
    legacy: bool,
}

impl OldRuns {
    /// Open the file for appending: a legacy file rewritten (atomically), a trailing partial
    /// row cut off, a header written to an empty one. Returns the file and its rows.
    pub fn open(self) -> Result<(RunsFile, Vec<RunRow>), ResultsError> {
        let Self {
            path,
            rows,
            valid,
            legacy,
        } = self;
        let path = path.as_path();
        if legacy {
            // Rewrite in this version's columns (atomically) before appending to it.
            let mut text = RunRow::header().join(",").into_bytes();
            text.push(b'\n');
            for r in &rows {
                text.extend(r.to_line());
            }
            let tmp = path.with_extension("csv.tmp");
            std::fs::write(&tmp, &text).map_err(io(&tmp))?;
            std::fs::rename(&tmp, path).map_err(io(path))?;
        }
        let valid = if legacy {
            std::fs::metadata(path).map_err(io(path))?.len()
        } else {
            valid
        };
        let done = rows
            .iter()
            .map(|r| (r.config.clone(), r.repetition))
            .collect();
        let mut file = OpenOptions::new()
            .create(true)
            .read(true)
            .write(true)
            .truncate(false)
            .open(path)
            .map_err(io(path))?;
        file.set_len(valid).map_err(io(path))?;
        drop(file);
        file = OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(io(path))?;
        if valid == 0 {
            let mut h = RunRow::header().join(",").into_bytes();
            h.push(b'\n');
            file.write_all(&h).map_err(io(path))?;
            file.flush().map_err(io(path))?;
        }
        Ok((
            RunsFile {
                path: path.to_path_buf(),
                file,
                done,
            },
            rows,
        ))
    }
}

impl RunsFile {
    /// Is repetition `repetition` of configuration `config` already in the file?
    pub fn is_done(&self, config: &str, repetition: u32) -> bool {
        self.done.contains(&(config.to_string(), repetition))
    }

    /// Append one row: one `write_all` of the whole line, then flush.
    pub fn append(&mut self, row: &RunRow) -> Result<(), ResultsError> {
        self.file
            .write_all(&row.to_line())
            .map_err(io(&self.path))?;
        self.file.flush().map_err(io(&self.path))?;
        self.done.insert((row.config.clone(), row.repetition));
        Ok(())
    }
}
