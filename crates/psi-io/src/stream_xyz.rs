//! XYZ read in blocks of whole lines (a text file larger than memory): the same points, the
//! same errors with the file's line numbers, as [`crate::read_points`] on the whole file.

use std::io::Read;
use std::ops::ControlFlow;

use crate::error::ReadError;
use crate::format::Format;
use crate::point_chunk::{PointChunk, StreamEnd, StreamHeader, emit_if_full, emit_rest, io_error};
use crate::read_xyz::{BLOCK_BYTES, XyzState, read_xyz_lines};
use crate::text::is_blank;

/// Bytes read at a time.
const BLOCK: usize = 8 << 20;

/// An XYZ file being read: the bytes read but not parsed yet (a partial last line) and the
/// parser's state.
pub(crate) struct XyzStream<R: Read> {
    input: R,
    /// Bytes read at a time ([`BLOCK`]; tests use a few).
    block: usize,
    pending: Vec<u8>,
    eof: bool,
    state: XyzState,
}

impl<R: Read> XyzStream<R> {
    /// Reads another block after the pending bytes; false at the end of the input.
    fn fill(&mut self) -> Result<bool, ReadError> {
        if self.eof {
            return Ok(false);
        }
        let start = self.pending.len();
        self.pending.resize(start + self.block, 0);
        let mut filled = start;
        while filled < self.pending.len() {
            let n = self
                .input
                .read(&mut self.pending[filled..])
                .map_err(io_error)?;
            if n == 0 {
                self.eof = true;
                break;
            }
            filled += n;
        }
        self.pending.truncate(filled);
        Ok(filled > start)
    }

    /// The next whole lines to parse (up to the last newline; everything at the end).
    fn take_lines(&mut self) -> Vec<u8> {
        let cut = if self.eof {
            self.pending.len()
        } else {
            self.pending
                .iter()
                .rposition(|&b| b == b'\n')
                .map_or(0, |i| i + 1)
        };
        let rest = self.pending.split_off(cut);
        std::mem::replace(&mut self.pending, rest)
    }

    /// Every point in file order, in chunks of at most `max` points.
    pub(crate) fn for_each_chunk<F: FnMut(PointChunk) -> ControlFlow<()>>(
        mut self,
        header: &StreamHeader,
        max: usize,
        visit: &mut F,
    ) -> Result<StreamEnd, ReadError> {
        let mut end = StreamEnd::default();
        let mut chunk = PointChunk::fresh(header, max);
        loop {
            let more = self.fill()?;
            let lines = self.take_lines();
            if !lines.is_empty() {
                let (positions, normals) = read_xyz_lines(&lines, &mut self.state, BLOCK_BYTES)?;
                for (p, n) in positions.into_iter().zip(normals) {
                    chunk.positions.push(p);
                    if let Some(ns) = chunk.normals.as_mut() {
                        ns.push(n);
                    }
                    if emit_if_full(&mut chunk, header, max, &mut end, visit) {
                        return Ok(end);
                    }
                }
            }
            if !more && self.pending.is_empty() {
                break;
            }
        }
        Ok(emit_rest(chunk, end, visit))
    }
}

/// Opens an XYZ input: reads until its first point line, which says whether the points have
/// normals (6 numbers) or not (3).
pub(crate) fn open<R: Read>(input: R) -> Result<(StreamHeader, XyzStream<R>), ReadError> {
    open_with_block(input, BLOCK)
}

/// [`open`] reading `block` bytes at a time.
fn open_with_block<R: Read>(
    input: R,
    block: usize,
) -> Result<(StreamHeader, XyzStream<R>), ReadError> {
    let mut stream = XyzStream {
        input,
        block: block.max(1),
        pending: Vec::new(),
        eof: false,
        state: XyzState::default(),
    };
    let columns = loop {
        let more = stream.fill()?;
        // Whole lines only (all of them at the end of the input).
        let whole = if more {
            stream
                .pending
                .iter()
                .rposition(|&b| b == b'\n')
                .map_or(&[][..], |i| &stream.pending[..i])
        } else {
            &stream.pending[..]
        };
        let first = whole
            .split(|&b| b == b'\n')
            .map(|l| String::from_utf8_lossy(l).trim().to_owned())
            .find(|l| !l.is_empty() && !l.starts_with('#'));
        match first {
            Some(l) => break l.split_ascii_whitespace().count(),
            // No point line at all: nothing to hand out (comments only), or nothing.
            None if !more => {
                if is_blank(&stream.pending) {
                    return Err(ReadError::Empty);
                }
                break 0;
            }
            None => {}
        }
    };
    let header = StreamHeader {
        format: Format::Xyz,
        detail: format!("XYZ, {columns} columns"),
        announced_points: 0,
        scans: None,
        normals: columns == 6,
        attributes: Default::default(),
    };
    Ok((header, stream))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::read_xyz::read_xyz;

    /// Streams `text` in blocks of `block` bytes and chunks of `max` points.
    fn streamed(text: &str, block: usize, max: usize) -> Result<(Vec<[f64; 6]>, bool), ReadError> {
        let (header, stream) = open_with_block(text.as_bytes(), block)?;
        let mut out = Vec::new();
        stream.for_each_chunk(&header, max, &mut |c: PointChunk| {
            assert!(!c.is_empty() && c.len() <= max);
            for i in 0..c.len() {
                let p = c.positions[i];
                let n = c.normals.as_ref().map_or(glam::DVec3::ZERO, |n| n[i]);
                out.push([p.x, p.y, p.z, n.x, n.y, n.z]);
            }
            ControlFlow::Continue(())
        })?;
        Ok((out, header.normals))
    }

    /// The whole-file parse of `text`, in the same shape.
    fn whole(text: &str) -> Result<(Vec<[f64; 6]>, bool), ReadError> {
        let parsed = read_xyz(text.as_bytes())?;
        let normals = parsed.normals.clone();
        let rows = parsed
            .vertices
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let n = normals.as_ref().map_or(glam::DVec3::ZERO, |n| n[i]);
                [p.x, p.y, p.z, n.x, n.y, n.z]
            })
            .collect();
        Ok((rows, normals.is_some()))
    }

    #[test]
    fn blocks_of_any_size_read_what_the_whole_file_reads_errors_included() {
        let mut good = String::from("# a comment\n\n");
        for i in 0..300 {
            let v = i as f64 * 0.37 - 11.0;
            good += &format!("{v} {} {} 0 0 {}\r\n", v * 2.0, 1e-3 * v, 1.0 + v.abs());
        }
        let positions_only: String = (0..50).map(|i| format!("{i} {} 1\n", i * 2)).collect();
        let mut bad_deep = good.clone();
        bad_deep += "1 2 3 4 5\n";
        let mut nan_deep = good.clone();
        nan_deep += "1 2 3 nan 0 1\n";
        let no_final_newline = good.trim_end().to_owned();
        for text in [
            &good,
            &positions_only,
            &bad_deep,
            &nan_deep,
            &no_final_newline,
        ] {
            for block in [1, 7, 64, 1000, 1 << 20] {
                for max in [1, 5, 1000] {
                    let a = streamed(text, block, max);
                    let b = whole(text);
                    match (&a, &b) {
                        (Ok(a), Ok(b)) => assert_eq!(a, b, "block {block}, max {max}"),
                        (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
                        _ => panic!("block {block}, max {max}: {a:?} against {b:?}"),
                    }
                }
            }
        }
        assert!(
            whole(&bad_deep)
                .unwrap_err()
                .to_string()
                .contains("line 303")
        );
    }

    #[test]
    fn an_empty_input_is_refused() {
        assert!(matches!(
            open_with_block(&b"  \n"[..], 4),
            Err(ReadError::Empty)
        ));
    }

    #[test]
    fn no_damaged_byte_makes_the_stream_panic() {
        let base = b"# c\n0 0 0 0 0 1\n1 0 0 0 0 1\n2 1 0 0 1 0\n";
        for i in 0..base.len() {
            for v in [0u8, b' ', b'\n', b'x', b'#', 0xff] {
                let mut b = base.to_vec();
                b[i] = v;
                for block in [1, 5, 64] {
                    let _ = streamed(std::str::from_utf8(&b).unwrap_or("0 0 0"), block, 2);
                }
            }
        }
    }
}
