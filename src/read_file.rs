//! A whole file's bytes, a large file read in parallel ranges: positional reads into disjoint
//! slices of one buffer, so that the copy from the page cache and the first touch of the
//! buffer's fresh pages are shared by every core (issue 30: each stage's CPU time at least
//! 1.7× its wall time; a serial `fs::read` of a 30 M-point file was one core's work).

use std::fs::File;
use std::io::Read;
use std::path::Path;

/// Files from this size on are read in ranges.
const PARALLEL_FROM_BYTES: u64 = 32 << 20;

/// The size of one range (one positional read, one rayon task).
const RANGE_BYTES: usize = 4 << 20;

/// The bytes of the file at `path`, as [`std::fs::read`] gives them (a file that grew while it
/// was read is read to its end; one that shrank is an error).
///
/// # Errors
///
/// What opening or reading the file returns.
pub(crate) fn read_file(path: &Path) -> std::io::Result<Vec<u8>> {
    let file = File::open(path)?;
    let len = file.metadata()?.len();
    if len < PARALLEL_FROM_BYTES {
        return read_from(file, len);
    }
    read_in_ranges(file, len, RANGE_BYTES)
}

/// `file`'s first `len` bytes read in ranges of `range` bytes (the last one shorter), in
/// parallel, then whatever follows them to the end of the file.
fn read_in_ranges(file: File, len: u64, range: usize) -> std::io::Result<Vec<u8>> {
    #[cfg(unix)]
    {
        use rayon::prelude::*;
        use std::os::unix::fs::FileExt;
        let range = range.max(1);
        let size = usize::try_from(len).map_err(std::io::Error::other)?;
        // Zeroed: the pages come mapped on first touch, which the reads do in parallel.
        let mut bytes = vec![0u8; size];
        bytes
            .par_chunks_mut(range)
            .enumerate()
            .try_for_each(|(i, chunk)| file.read_exact_at(chunk, (i * range) as u64))?;
        let mut rest = file;
        std::io::Seek::seek(&mut rest, std::io::SeekFrom::Start(len))?;
        rest.read_to_end(&mut bytes)?;
        Ok(bytes)
    }
    #[cfg(not(unix))]
    {
        let _ = range;
        read_from(file, len)
    }
}

/// `file` read serially from its current position to its end, with room for `hint` bytes.
fn read_from(mut file: File, hint: u64) -> std::io::Result<Vec<u8>> {
    let mut bytes = Vec::with_capacity(usize::try_from(hint).unwrap_or(0));
    file.read_to_end(&mut bytes)?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch_file(name: &str, bytes: &[u8]) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("psi-read-file-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    /// Reading in ranges gives `fs::read`'s bytes (the brute-force twin) for files shorter
    /// than a range, an exact number of ranges, and a shorter last range; an empty file too.
    #[test]
    fn ranges_read_the_same_bytes_as_one_read() {
        let bytes: Vec<u8> = (0..100_003u32)
            .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
            .collect();
        for (len, range) in [
            (0, 7),
            (5, 4096),
            (4096 * 3, 4096),
            (100_003, 4096),
            (100_003, 1),
        ] {
            let path = scratch_file(&format!("r{len}-{range}"), &bytes[..len]);
            let file = File::open(&path).unwrap();
            let read = read_in_ranges(file, len as u64, range).unwrap();
            assert_eq!(
                read,
                std::fs::read(&path).unwrap(),
                "{len} bytes, ranges of {range}"
            );
            assert_eq!(read_file(&path).unwrap(), &bytes[..len]);
            std::fs::remove_file(&path).unwrap();
        }
    }

    /// A file longer than the length its reader was given (it grew) is read to its end; one
    /// shorter (it shrank) is an error, not a buffer of zeros.
    #[test]
    fn a_file_that_changed_size_is_read_to_its_end_or_refused() {
        let bytes = vec![7u8; 10_000];
        let path = scratch_file("changed", &bytes);
        let grown = read_in_ranges(File::open(&path).unwrap(), 6_000, 1024).unwrap();
        assert_eq!(grown, bytes);
        let shrunk = read_in_ranges(File::open(&path).unwrap(), 12_000, 1024);
        if cfg!(unix) {
            assert_eq!(
                shrunk.unwrap_err().kind(),
                std::io::ErrorKind::UnexpectedEof
            );
        }
        std::fs::remove_file(&path).unwrap();
    }
}
