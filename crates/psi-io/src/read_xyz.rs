//! XYZ reader: one point per line, `x y z nx ny nz` or positions only, `x y z`.

use glam::DVec3;
use rayon::prelude::*;

use crate::error::ReadError;
use crate::model::Parsed;
use crate::text::{is_blank, line_str, numbered_lines, parse_number};

/// Bytes per block of lines parsed as one task (cut after a line break).
pub(crate) const BLOCK_BYTES: usize = 1 << 20;

/// Parses whitespace-separated `x y z nx ny nz` or `x y z` lines (the first point line sets
/// which, for the whole file); blank lines and lines starting with `#` are skipped.
/// Blocks of lines are parsed in parallel ([`read_xyz_lines`]).
pub(crate) fn read_xyz(bytes: &[u8]) -> Result<Parsed, ReadError> {
    read_xyz_in_blocks(bytes, BLOCK_BYTES)
}

/// [`read_xyz`] with blocks of about `block_bytes`.
fn read_xyz_in_blocks(bytes: &[u8], block_bytes: usize) -> Result<Parsed, ReadError> {
    if is_blank(bytes) {
        return Err(ReadError::Empty);
    }
    let mut state = XyzState::default();
    let (vertices, normals) = read_xyz_lines(bytes, &mut state, block_bytes)?;
    Ok(Parsed {
        vertices,
        normals: (state.columns != Some(3)).then_some(normals),
        faces: Vec::new(),
        ..Parsed::default()
    })
}

/// [`read_xyz_block`] in parallel: blocks of about `block_bytes` of `bytes` (whole lines of
/// an XYZ file after `state`), each parsed as if it began the file; when every block parses
/// and they agree on the columns with each other and with `state`, their points are joined in
/// order and `state` advanced. Otherwise `bytes` are parsed again in one pass, which finds the
/// first problem and names its line and point as the serial reader does.
pub(crate) fn read_xyz_lines(
    bytes: &[u8],
    state: &mut XyzState,
    block_bytes: usize,
) -> Result<(Vec<DVec3>, Vec<DVec3>), ReadError> {
    match parse_blocks(bytes, block_bytes) {
        Some((vertices, normals, columns))
            if state.columns.is_none() || columns.is_none() || columns == state.columns =>
        {
            state.columns = state.columns.or(columns);
            let breaks = bytes.iter().filter(|&&b| b == b'\n').count();
            // As `read_xyz_block` counts: the empty piece after a final break is no line.
            state.lines += if bytes.last() == Some(&b'\n') {
                breaks
            } else {
                breaks + 1
            };
            state.points += vertices.len();
            Ok((vertices, normals))
        }
        _ => read_xyz_block(bytes, state),
    }
}

/// `bytes` cut into pieces of about `block_bytes` (at least 1), each but the last ending with
/// `\n`.
fn line_blocks(bytes: &[u8], block_bytes: usize) -> Vec<&[u8]> {
    let block_bytes = block_bytes.max(1);
    let mut blocks = Vec::new();
    let mut rest = bytes;
    while rest.len() > block_bytes {
        let cut = match rest[block_bytes..].iter().position(|&b| b == b'\n') {
            Some(k) => block_bytes + k + 1,
            None => rest.len(),
        };
        let (block, tail) = rest.split_at(cut);
        blocks.push(block);
        rest = tail;
    }
    if !rest.is_empty() {
        blocks.push(rest);
    }
    blocks
}

/// The positions, normals and columns of `bytes` parsed block by block in parallel, or `None`
/// when a block fails or two blocks' point lines have different columns (the caller then
/// parses serially for the exact error).
#[allow(clippy::type_complexity)]
fn parse_blocks(
    bytes: &[u8],
    block_bytes: usize,
) -> Option<(Vec<DVec3>, Vec<DVec3>, Option<usize>)> {
    let parts: Vec<Option<(Vec<DVec3>, Vec<DVec3>, Option<usize>)>> =
        line_blocks(bytes, block_bytes)
            .into_par_iter()
            .map(|block| {
                let mut state = XyzState::default();
                let (v, n) = read_xyz_block(block, &mut state).ok()?;
                Some((v, n, state.columns))
            })
            .collect();
    let mut columns = None;
    let mut total = 0;
    for part in &parts {
        let (v, _, c) = part.as_ref()?;
        match (columns, c) {
            (Some(a), Some(b)) if a != *b => return None,
            (None, Some(_)) => columns = *c,
            _ => {}
        }
        total += v.len();
    }
    let mut vertices = Vec::with_capacity(total);
    let mut normals = Vec::with_capacity(total);
    for (v, n, _) in parts.into_iter().flatten() {
        vertices.extend(v);
        normals.extend(n);
    }
    Some((vertices, normals, columns))
}

/// What parsing carries from one block of lines to the next (a file read in blocks).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct XyzState {
    /// Columns per point line, set by the first one (6, or 3 for positions only).
    pub(crate) columns: Option<usize>,
    /// Lines before the block.
    pub(crate) lines: usize,
    /// Points before the block.
    pub(crate) points: usize,
}

/// Parses `bytes`, whole lines of an XYZ file after `state.lines` lines and `state.points`
/// points (line numbers and point indices in errors are the file's), into positions and
/// normals (zero without normal columns); advances `state`.
pub(crate) fn read_xyz_block(
    bytes: &[u8],
    state: &mut XyzState,
) -> Result<(Vec<DVec3>, Vec<DVec3>), ReadError> {
    let mut vertices = Vec::new();
    let mut normals = Vec::new();
    let mut last = 0;
    for (local, raw) in numbered_lines(bytes) {
        let number = state.lines + local;
        last = local;
        let text = line_str(raw, number)?.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        let mut values = [0.0; 6];
        let mut count = 0;
        for token in text.split_ascii_whitespace() {
            if count < 6 {
                values[count] = parse_number(token, number)?;
            }
            count += 1;
        }
        let expected = match state.columns {
            Some(c) => c,
            None if count == 3 || count == 6 => *state.columns.insert(count),
            None => 0,
        };
        if count != expected {
            let what = match expected {
                6 => "6 numbers (x y z nx ny nz) as on the first point line",
                3 => "3 numbers (x y z) as on the first point line",
                _ => "6 numbers (x y z nx ny nz) or 3 (x y z)",
            };
            return Err(ReadError::Line {
                line: number,
                reason: format!("expected {what}, found {count} tokens"),
            });
        }
        let index = state.points + vertices.len();
        let p = DVec3::new(values[0], values[1], values[2]);
        let n = DVec3::new(values[3], values[4], values[5]);
        let checked: &[(&str, DVec3)] = if expected == 6 {
            &[("position", p), ("normal", n)]
        } else {
            &[("position", p)]
        };
        for &(what, v) in checked {
            if !v.is_finite() {
                return Err(ReadError::NonFinite {
                    element: "point",
                    index,
                    what,
                    line: Some(number),
                });
            }
        }
        vertices.push(p);
        normals.push(n);
    }
    // A block ends with its newline: the empty piece after it is no line of the file.
    state.lines += if bytes.last() == Some(&b'\n') {
        last - 1
    } else {
        last
    };
    state.points += vertices.len();
    Ok((vertices, normals))
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    use super::*;

    /// A seeded XYZ text of `lines` lines: points of `columns` numbers, with comments, blank
    /// lines and CRLF breaks mixed in, and, when `fault`, one bad line somewhere.
    fn text(seed: u64, lines: usize, columns: usize, fault: bool) -> String {
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let bad_at = rng.random_range(0..lines);
        let mut s = String::new();
        for i in 0..lines {
            let line = if fault && i == bad_at {
                match rng.random_range(0..5) {
                    0 => "1 2 3 4".to_owned(),
                    1 => "1 2 x".to_owned(),
                    2 => "nan 0 0 0 0 1".to_owned(),
                    3 => "0 0 0 inf 0 1".to_owned(),
                    _ => "1 2 3".to_owned(),
                }
            } else {
                match rng.random_range(0..20) {
                    0 => "# comment".to_owned(),
                    1 => "   ".to_owned(),
                    _ => (0..columns)
                        .map(|_| format!("{:.6}", rng.random_range(-10.0..10.0)))
                        .collect::<Vec<_>>()
                        .join(" "),
                }
            };
            s.push_str(&line);
            s.push_str(if rng.random_range(0..4) == 0 {
                "\r\n"
            } else {
                "\n"
            });
        }
        s
    }

    /// The serial parse of the whole text: the oracle.
    fn serial(bytes: &[u8]) -> Result<Parsed, ReadError> {
        let mut state = XyzState::default();
        let (vertices, normals) = read_xyz_block(bytes, &mut state)?;
        Ok(Parsed {
            vertices,
            normals: (state.columns != Some(3)).then_some(normals),
            ..Parsed::default()
        })
    }

    #[test]
    fn blocks_in_parallel_give_the_serial_parse_and_its_errors() {
        let mut faults = 0;
        for seed in 0..40 {
            let columns = if seed % 2 == 0 { 6 } else { 3 };
            let fault = seed % 3 == 0;
            let s = text(seed, 400, columns, fault);
            let want = serial(s.as_bytes());
            faults += usize::from(want.is_err());
            for block in [1, 7, 100, 1000, 1 << 20] {
                let got = read_xyz_in_blocks(s.as_bytes(), block);
                match (&want, &got) {
                    (Ok(a), Ok(b)) => {
                        assert_eq!(a.vertices, b.vertices, "seed {seed} block {block}");
                        assert_eq!(a.normals, b.normals, "seed {seed} block {block}");
                    }
                    (Err(a), Err(b)) => {
                        assert_eq!(a.to_string(), b.to_string(), "seed {seed} block {block}")
                    }
                    _ => panic!("seed {seed} block {block}: {want:?} against {got:?}"),
                }
            }
        }
        assert!(faults >= 8, "only {faults} texts had a fault");
    }

    /// A file's tail parsed after its head (as the streamed reader does), in parallel blocks
    /// and serially: the same points, the same state after, the same errors.
    #[test]
    fn a_tail_after_a_head_parses_as_the_serial_reader_does() {
        for seed in 0..30 {
            let s = text(
                100 + seed,
                300,
                if seed % 2 == 0 { 6 } else { 3 },
                seed % 3 == 0,
            );
            let breaks: Vec<usize> = (0..s.len()).filter(|&i| s.as_bytes()[i] == b'\n').collect();
            let cut = breaks[(seed as usize * 7919) % breaks.len()] + 1;
            let (head, tail) = s.as_bytes().split_at(cut);
            let mut state = XyzState::default();
            if read_xyz_block(head, &mut state).is_err() {
                continue;
            }
            let mut serial_state = state;
            let want = read_xyz_block(tail, &mut serial_state);
            for block in [1, 50, 1 << 20] {
                let mut got_state = state;
                let got = read_xyz_lines(tail, &mut got_state, block);
                match (&want, &got) {
                    (Ok(a), Ok(b)) => {
                        assert_eq!(a, b, "seed {seed} block {block}");
                        assert_eq!(
                            (got_state.lines, got_state.points, got_state.columns),
                            (
                                serial_state.lines,
                                serial_state.points,
                                serial_state.columns
                            ),
                            "seed {seed} block {block}"
                        );
                    }
                    (Err(a), Err(b)) => {
                        assert_eq!(a.to_string(), b.to_string(), "seed {seed} block {block}")
                    }
                    _ => panic!("seed {seed} block {block}: {want:?} against {got:?}"),
                }
            }
        }
    }

    #[test]
    fn blocks_end_at_line_breaks_and_cover_the_text() {
        let s = text(3, 300, 6, false);
        for block in [1, 10, 333, 5000] {
            let blocks = line_blocks(s.as_bytes(), block);
            assert_eq!(blocks.concat(), s.as_bytes());
            for b in &blocks[..blocks.len() - 1] {
                assert_eq!(b.last(), Some(&b'\n'));
                assert!(b.len() > block.min(s.len()) - 1);
            }
        }
    }
}
