//! A run's intermediate results on disk (a region's decisions, an octant's seeds): one value
//! per file with the fingerprint of what it was made from, its last 32 bytes the SHA-256 of
//! the rest, written atomically. A file that is missing, damaged or made from something else
//! is not taken: the value is made again.

use std::path::Path;

use serde::Serialize;
use serde::de::DeserializeOwned;
use sha2::{Digest, Sha256};

use crate::{TileError, write_atomically};

/// What a record file holds.
#[derive(Serialize, serde::Deserialize)]
struct Record<T> {
    fingerprint: String,
    value: T,
}

/// The value in the file at `path`, if it is there, whole and intact, and made from what
/// `print` names.
pub(crate) fn read_record<T: DeserializeOwned>(path: &Path, print: &str) -> Option<T> {
    let bytes = std::fs::read(path).ok()?;
    let (body, sum) = bytes.split_at(bytes.len().checked_sub(32)?);
    if Sha256::digest(body).as_slice() != sum {
        tracing::warn!("{}: checksum mismatch, made again", path.display());
        return None;
    }
    let record: Record<T> = postcard::from_bytes(body).ok()?;
    (record.fingerprint == print).then_some(record.value)
}

/// Writes `value`, made from what `print` names, to `path` (atomically).
pub(crate) fn write_record<T: Serialize>(
    path: &Path,
    print: &str,
    value: &T,
) -> Result<(), TileError> {
    let record = Record {
        fingerprint: print.to_string(),
        value,
    };
    let mut bytes = postcard::to_stdvec(&record).expect("serialisable");
    let sum = Sha256::digest(&bytes);
    bytes.extend_from_slice(&sum);
    write_atomically(path, &bytes)
}
