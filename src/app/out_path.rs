//! Output paths checked before any work: a render, a profile or a sweep that ends by failing to
//! write its result wastes its whole run. Each check names the flag, and is bad input (exit 2).
//!
//! What is checked: the path's length; that it is not a folder (for a file) or a file (for a
//! folder); that the nearest existing folder on its way is a folder (`-o c.png/x.exr` with
//! `c.png` a file); that an existing destination is a regular file (`/dev/full` is a device:
//! renaming a render over it would replace the device); and that a file can be created in
//! that folder, found by creating and removing one (permissions, a read-only filesystem,
//! `/proc`). Nothing is left behind and no folder is created.

use super::error::CliError;
use std::io::ErrorKind;
use std::path::{Path, PathBuf};

/// Longest path and longest path component accepted, in bytes (Linux's PATH_MAX − 1 and
/// NAME_MAX): beyond them every write fails anyway.
const MAX_PATH: usize = 4095;
const MAX_NAME: usize = 255;

/// What the path will be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    /// A file (written, or replaced).
    File,
    /// A folder files are written into (created if missing).
    Folder,
}

/// Check `path`, given by `flag` (`--output`, `--out`, or a positional's name), as an output
/// of `kind`; the error is one line naming the flag and the path.
pub(crate) fn check(flag: &str, path: &Path, kind: Kind) -> Result<(), CliError> {
    check_path(path, kind)
        .map_err(|why| CliError::message(format!("{flag} {}: {why}", shown(path))))
}

fn check_path(path: &Path, kind: Kind) -> Result<(), String> {
    use std::os::unix::ffi::OsStrExt;
    let bytes = path.as_os_str().as_bytes();
    if bytes.is_empty() {
        return Err("empty path".into());
    }
    if bytes.len() > MAX_PATH {
        return Err(format!(
            "path too long ({} bytes, at most {MAX_PATH})",
            bytes.len()
        ));
    }
    if let Some(c) = path.components().find(|c| c.as_os_str().len() > MAX_NAME) {
        return Err(format!(
            "a name of {} bytes (at most {MAX_NAME})",
            c.as_os_str().len()
        ));
    }
    match std::fs::metadata(path) {
        Ok(m) => {
            return match kind {
                Kind::File if m.is_dir() => Err("is a folder, not a file".into()),
                Kind::File if !m.is_file() => {
                    Err("not a regular file (a device or pipe cannot take the output)".into())
                }
                Kind::Folder if !m.is_dir() => Err("exists and is not a folder".into()),
                // An existing file is replaced in its folder; an existing folder is written into.
                Kind::File => probe(parent_of(path)),
                Kind::Folder => probe(path.to_path_buf()),
            };
        }
        Err(e) if e.kind() == ErrorKind::NotFound => {}
        // ENOTDIR: a file on the way (`c.png/x.exr`); said below with the file's name.
        Err(e) if e.raw_os_error() == Some(libc::ENOTDIR) => {}
        Err(e) => return Err(e.to_string()),
    }
    let start = match kind {
        Kind::File => parent_of(path),
        Kind::Folder => path.to_path_buf(),
    };
    // The nearest existing ancestor: every folder below it will be created there.
    let mut dir = start.as_path();
    loop {
        match std::fs::metadata(dir) {
            Ok(m) if m.is_dir() => return probe(dir.to_path_buf()),
            Ok(_) => return Err(format!("{} is a file, not a folder", shown(dir))),
            Err(e)
                if e.kind() == ErrorKind::NotFound || e.raw_os_error() == Some(libc::ENOTDIR) =>
            {
                match dir.parent() {
                    Some(p) if !p.as_os_str().is_empty() => dir = p,
                    _ => return probe(PathBuf::from(".")),
                }
            }
            Err(e) => return Err(format!("{}: {e}", shown(dir))),
        }
    }
}

/// An input file named on the command line (`name`: the flag, or the positional's name) must
/// be a regular file: a device (`/dev/full`, `/dev/zero`) or a FIFO would be read forever. A
/// missing file with a sibling of a near name gets that name; other missing files are left to
/// the loader, which says so in its own words.
pub(crate) fn check_input(name: &str, path: &Path) -> Result<(), CliError> {
    match std::fs::metadata(path) {
        Ok(m) if !m.is_file() => Err(CliError::message(format!(
            "{name} {}: not a regular file",
            shown(path)
        ))),
        Err(e) if e.kind() == ErrorKind::NotFound => check_exists_or_suggest(name, path),
        _ => Ok(()),
    }
}

/// A missing input file with a sibling of a near name: `NAME PATH: no such file, did you mean
/// SIBLING?` (`run experiments/quik.toml`). Without one the loader's own message stands.
fn check_exists_or_suggest(name: &str, path: &Path) -> Result<(), CliError> {
    if path.exists() {
        return Ok(());
    }
    let (Some(file), dir) = (path.file_name().and_then(|f| f.to_str()), parent_of(path)) else {
        return Ok(());
    };
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return Ok(());
    };
    let names: Vec<String> = entries
        .flatten()
        .filter(|e| e.path().is_file())
        .filter_map(|e| e.file_name().to_str().map(str::to_owned))
        .collect();
    let Some(near) = raysched::util::suggest::nearest(file, names.iter().map(String::as_str))
    else {
        return Ok(());
    };
    Err(CliError::message(format!(
        "{name} {}: no such file, did you mean {}?",
        shown(path),
        shown(&path.with_file_name(near))
    )))
}

/// The folder a file path is written into (`.` for a bare name).
fn parent_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Can a file be created in `dir`? Found by creating one and removing it again.
fn probe(dir: PathBuf) -> Result<(), String> {
    let name = dir.join(format!(".raysched-write-check-{}", std::process::id()));
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&name)
    {
        Ok(f) => {
            drop(f);
            let _ = std::fs::remove_file(&name);
            Ok(())
        }
        // Left by a killed process with our pid: it was writable then; it is now if removable.
        Err(e) if e.kind() == ErrorKind::AlreadyExists => {
            std::fs::remove_file(&name).map_err(|e| format!("cannot write in {}: {e}", shown(&dir)))
        }
        Err(e) => Err(format!("cannot write in {}: {e}", shown(&dir))),
    }
}

/// A path for a one-line message: control characters escaped.
fn shown(p: &Path) -> String {
    raysched::util::one_line::escape_controls(&p.to_string_lossy()).into_owned()
}
