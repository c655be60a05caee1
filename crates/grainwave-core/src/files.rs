//! Bounded reads of the files the tool reads: a regular file only (a FIFO would block for ever,
//! a device such as `/dev/zero` would be read until memory runs out), and never more than a
//! stated number of bytes.
//!
//! Every reader of an input file uses [`read_bounded`] (or [`open_regular`] where it streams,
//! with its own bound): configs in a run directory, LAMMPS data files, checkpoints
//! ([`crate::checkpoint::read_bytes`], bounded by the file's size).

use crate::error::{CoreError, Result};
use std::fs::File;
use std::path::Path;

/// The error of a refused file: `CoreError::Io` with `action` "cannot read {what}".
fn refused(path: &Path, what: &str, kind: std::io::ErrorKind, message: String) -> CoreError {
    CoreError::Io { action: format!("cannot read {what}"), path: path.display().to_string(), error: std::io::Error::new(kind, message) }
}

/// Refuses `path` when it exists and is not a regular file (following symbolic links): a FIFO,
/// a device, a socket or a directory. `what` names the file in the message (e.g. "the run's
/// log"). Call it before opening a file for appending or writing, which blocks on a FIFO.
pub fn refuse_special(path: &Path, what: &str) -> Result<()> {
    match std::fs::metadata(path) {
        Ok(meta) if !meta.is_file() => {
            let kind = if meta.is_dir() { "a directory" } else { "not a regular file (a FIFO, a device or a socket)" };
            Err(refused(path, what, std::io::ErrorKind::InvalidInput, format!("{kind}; allowed: a regular file (remove or rename it)")))
        }
        _ => Ok(()),
    }
}

/// Opens `path` for reading when it is a regular file; returns it with its size. A FIFO, a
/// device, a socket or a directory is refused before it is opened (opening a FIFO blocks).
pub fn open_regular(path: &Path, what: &str) -> Result<(File, u64)> {
    let io = |e| CoreError::Io { action: format!("cannot read {what}"), path: path.display().to_string(), error: e };
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        refuse_special(path, what)?;
    }
    let file = File::open(path).map_err(io)?;
    Ok((file, meta.len()))
}

/// The bytes of the regular file `path`, at most `limit` of them: a longer file (or one that
/// grows past the limit while read) is refused with a message naming `what`, the limit and that
/// it is exceeded; nothing more than `limit + 1` bytes is ever held.
pub fn read_bounded(path: &Path, limit: u64, what: &str) -> Result<Vec<u8>> {
    let (file, len) = open_regular(path, what)?;
    let too_long = || {
        refused(path, what, std::io::ErrorKind::InvalidData, format!("longer than the {limit} bytes allowed ({} MiB)", limit >> 20))
    };
    if len > limit {
        return Err(too_long());
    }
    let mut bytes = Vec::with_capacity(len as usize);
    std::io::Read::read_to_end(&mut std::io::Read::take(file, limit.saturating_add(1)), &mut bytes)
        .map_err(|e| CoreError::Io { action: format!("cannot read {what}"), path: path.display().to_string(), error: e })?;
    if bytes.len() as u64 > limit {
        return Err(too_long());
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regular_files_are_read_within_the_limit_and_others_refused_by_name() {
        let dir = std::env::temp_dir().join(format!("grainwave-files-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("a.toml");
        std::fs::write(&f, b"0123456789").unwrap();
        assert_eq!(read_bounded(&f, 10, "the config").unwrap(), b"0123456789");
        let e = read_bounded(&f, 9, "the config").unwrap_err().to_string();
        assert!(e.contains("cannot read the config") && e.contains("a.toml") && e.contains("longer than the 9 bytes allowed"), "{e}");
        let e = read_bounded(&dir, 9, "the config").unwrap_err().to_string();
        assert!(e.contains("a directory"), "{e}");
        #[cfg(unix)]
        {
            let e = read_bounded(Path::new("/dev/zero"), 1 << 20, "the config").unwrap_err().to_string();
            assert!(e.contains("not a regular file") && e.contains("/dev/zero"), "{e}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
