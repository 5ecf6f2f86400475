//! Files written whole or not at all: into a temporary file beside the target, synced, then
//! renamed over it, so an interrupted run leaves the old file or none, never half of one.

use std::fs;
use std::io::Write;
use std::path::Path;

use crate::TileError;

/// Writes `bytes` to `path` atomically (a temporary file in the same directory, renamed).
pub(crate) fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), TileError> {
    write_parts_atomically(path, &[bytes])
}

/// Writes `parts`, one after the other, to `path` atomically ([`write_atomically`]).
pub(crate) fn write_parts_atomically(path: &Path, parts: &[&[u8]]) -> Result<(), TileError> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    // Unique across processes and hosts sharing the directory (a cluster's scratch), and
    // across threads of one process.
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    let thread = format!("{:?}", std::thread::current().id());
    let tag: String = thread.chars().filter(char::is_ascii_digit).collect();
    let tmp = path.with_file_name(format!(".{name}.{}.{tag}.{nanos}.tmp", std::process::id()));
    let err = |p: &Path, e: std::io::Error| TileError::Store(format!("{}: {e}", p.display()));
    let write = || -> Result<(), TileError> {
        let mut f = fs::File::create(&tmp).map_err(|e| err(&tmp, e))?;
        for bytes in parts {
            f.write_all(bytes).map_err(|e| err(&tmp, e))?;
        }
        f.sync_all().map_err(|e| err(&tmp, e))?;
        drop(f);
        fs::rename(&tmp, path).map_err(|e| err(path, e))
    };
    let done = write();
    if done.is_err() {
        // Nothing half-written is left behind.
        let _ = fs::remove_file(&tmp);
    }
    done
}
