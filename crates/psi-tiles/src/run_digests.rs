//! A point file's checksums by run, so that a reader checks exactly the bytes it reads: the
//! file is its records followed by a trailer of one CRC-32 per run of records (the sub-cell
//! runs of a tile file, `sub_cells.rs`; one run for the coarse points' file), and the
//! manifest holds the SHA-256 of that trailer. A task that reads a few sub-cells of a
//! neighbouring tile (a halo) checks the trailer and those runs, not the whole file: a tile
//! task on a cluster used to read and hash its 26 neighbours whole.
//!
//! The runs' checksums detect damage (a flipped bit, a torn write, a truncation), not
//! tampering: CRC-32 (IEEE 802.3, `crc32fast`, with the CPU's carry-less multiply where it
//! has one), far cheaper than the SHA-256 the runs had before
//! (`docs/notes/2026-12-05-run-checksums.md`).

use sha2::{Digest, Sha256};

use crate::tile_records::RECORD;

/// Bytes of one run's digest in the trailer (its CRC-32, little-endian).
pub(crate) const DIGEST: usize = 4;

/// The digest of one run's bytes.
fn run_digest(bytes: &[u8]) -> [u8; DIGEST] {
    crc32fast::hash(bytes).to_le_bytes()
}

/// One run's digest from its bytes given piece by piece (a file streamed).
#[derive(Default)]
pub(crate) struct RunDigest(crc32fast::Hasher);

impl RunDigest {
    /// Takes the run's next bytes.
    pub(crate) fn update(&mut self, bytes: &[u8]) {
        self.0.update(bytes);
    }

    /// The digest of the bytes taken ([`run_digest`] of them all at once).
    pub(crate) fn finish(self) -> [u8; DIGEST] {
        self.0.finalize().to_le_bytes()
    }
}

/// The trailer of a file whose records are `records` (whole records) split by `runs`
/// (`runs[s]..runs[s + 1]` records form run `s`; shape runs + 1): the CRC-32 of each run's
/// bytes, in run order (shape (runs.len() − 1) × [`DIGEST`] bytes).
pub(crate) fn run_digests(records: &[u8], runs: &[u64]) -> Vec<u8> {
    runs.windows(2)
        .flat_map(|w| run_digest(&records[w[0] as usize * RECORD..w[1] as usize * RECORD]))
        .collect()
}

/// The manifest's checksum of a file with trailer `trailer`: its SHA-256, hexadecimal.
pub(crate) fn trailer_sum(trailer: &[u8]) -> String {
    Sha256::digest(trailer)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The bytes of the trailer of a file with `runs` run boundaries (shape runs + 1).
pub(crate) fn trailer_len(runs: usize) -> u64 {
    (runs.saturating_sub(1) * DIGEST) as u64
}

/// Checks `bytes`, the records `ranges` (first, end; records) of a file read one after the
/// other: every run they hold must match its digest in the file's trailer (which `trailer`
/// reads and checks, called at most once and only when a run is not yet in `checked`), and
/// every range must be a union of whole runs (`runs` as in [`run_digests`]). Marks the runs it
/// checked in `checked` (shape runs − 1). Returns what fails, if anything.
pub(crate) fn check_runs(
    bytes: &[u8],
    ranges: &[(u64, u64)],
    runs: &[u64],
    checked: &mut [bool],
    trailer: &mut dyn FnMut() -> Result<Vec<u8>, String>,
) -> Result<(), String> {
    let mut loaded: Option<Vec<u8>> = None;
    let mut at = 0usize;
    for &(first, end) in ranges {
        // The runs inside this range, found by their starts (empty runs share a start).
        let mut s = runs.partition_point(|&r| r < first);
        let mut covered = first;
        while s + 1 < runs.len() && runs[s + 1] <= end {
            let (a, b) = (runs[s], runs[s + 1]);
            if a == covered && b > a {
                if !checked[s] {
                    if loaded.is_none() {
                        let t = trailer()?;
                        if t.len() as u64 != trailer_len(runs.len()) {
                            return Err(format!(
                                "its trailer has {} bytes, not {}",
                                t.len(),
                                trailer_len(runs.len())
                            ));
                        }
                        loaded = Some(t);
                    }
                    let digests = loaded.as_deref().expect("loaded above");
                    let from = at + (a - first) as usize * RECORD;
                    let chunk = &bytes[from..from + (b - a) as usize * RECORD];
                    if run_digest(chunk) != digests[s * DIGEST..(s + 1) * DIGEST] {
                        return Err(format!("records {a}..{b} do not match their CRC-32"));
                    }
                    checked[s] = true;
                }
                covered = b;
            }
            s += 1;
        }
        if covered != end {
            return Err(format!("records {first}..{end} are not whole runs"));
        }
        at += (end - first) as usize * RECORD;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn records(n: usize) -> Vec<u8> {
        (0..n * RECORD).map(|i| (i * 7 % 251) as u8).collect()
    }

    /// `check_runs` with nothing checked before.
    fn check(
        bytes: &[u8],
        ranges: &[(u64, u64)],
        runs: &[u64],
        trailer: &[u8],
    ) -> Result<(), String> {
        let mut checked = vec![false; runs.len() - 1];
        check_runs(bytes, ranges, runs, &mut checked, &mut || {
            Ok(trailer.to_vec())
        })
    }

    #[test]
    fn whole_runs_pass_and_any_flipped_byte_fails() {
        let bytes = records(10);
        let runs = [0, 3, 3, 7, 10];
        let trailer = run_digests(&bytes, &runs);
        assert_eq!(trailer.len() as u64, trailer_len(runs.len()));
        let all = [(0, 10)];
        assert_eq!(check(&bytes, &all, &runs, &trailer), Ok(()));
        // Two ranges of whole runs, read one after the other.
        let ranges = [(0, 3), (7, 10)];
        let read: Vec<u8> = [&bytes[..3 * RECORD], &bytes[7 * RECORD..]].concat();
        assert_eq!(check(&read, &ranges, &runs, &trailer), Ok(()));
        for i in (0..bytes.len()).step_by(13) {
            let mut bad = bytes.clone();
            bad[i] ^= 1;
            assert!(check(&bad, &all, &runs, &trailer).is_err(), "byte {i}");
        }
        // (Run 1 is empty: its digest is never compared; the manifest checks the trailer.)
        let mut bad_trailer = trailer.clone();
        bad_trailer[3 * DIGEST] ^= 1;
        assert!(check(&bytes, &all, &runs, &bad_trailer).is_err());
    }

    #[test]
    fn checked_runs_are_not_hashed_again_and_the_trailer_is_read_once_at_most() {
        let bytes = records(10);
        let runs = [0, 3, 3, 7, 10];
        let trailer = run_digests(&bytes, &runs);
        let mut checked = vec![false; 4];
        let reads = std::cell::Cell::new(0);
        let mut read = || {
            reads.set(reads.get() + 1);
            Ok(trailer.clone())
        };
        let first: Vec<u8> = bytes[..7 * RECORD].to_vec();
        check_runs(&first, &[(0, 7)], &runs, &mut checked, &mut read).unwrap();
        assert_eq!(checked, [true, false, true, false]);
        // Runs 0 and 2, checked, are trusted now: damaged bytes there go unseen, and with
        // nothing left to check the trailer is not read.
        let mut damaged = first.clone();
        damaged[0] ^= 1;
        check_runs(&damaged, &[(0, 7)], &runs, &mut checked, &mut read).unwrap();
        assert_eq!(reads.get(), 1);
        let mut last = bytes[7 * RECORD..].to_vec();
        last[0] ^= 1;
        assert!(check_runs(&last, &[(7, 10)], &runs, &mut checked, &mut read).is_err());
        assert_eq!(reads.get(), 2);
    }

    #[test]
    fn a_run_streamed_in_pieces_has_the_digest_of_its_bytes_at_once() {
        // Oracle: the CRC-32 of the check value (IEEE 802.3: "123456789" -> 0xCBF43926).
        assert_eq!(run_digest(b"123456789"), 0xCBF4_3926u32.to_le_bytes());
        let bytes = records(7);
        for piece in [1, 5, RECORD, 3 * RECORD + 1] {
            let mut d = RunDigest::default();
            bytes.chunks(piece).for_each(|c| d.update(c));
            assert_eq!(d.finish(), run_digest(&bytes), "pieces of {piece}");
        }
    }

    #[test]
    fn a_range_that_splits_a_run_is_refused() {
        let bytes = records(10);
        let runs = [0, 3, 3, 7, 10];
        let trailer = run_digests(&bytes, &runs);
        let read = &bytes[2 * RECORD..7 * RECORD];
        let err = check(read, &[(2, 7)], &runs, &trailer).unwrap_err();
        assert!(err.contains("not whole runs"), "{err}");
        let read = &bytes[3 * RECORD..5 * RECORD];
        assert!(check(read, &[(3, 5)], &runs, &trailer).is_err());
    }
}
