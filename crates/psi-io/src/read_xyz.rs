//! XYZ reader: one point per line, `x y z nx ny nz` or positions only, `x y z`.

use glam::DVec3;

use crate::error::ReadError;
use crate::model::Parsed;
use crate::text::{is_blank, line_str, numbered_lines, parse_number};

/// Parses whitespace-separated `x y z nx ny nz` or `x y z` lines (the first point line sets
/// which, for the whole file); blank lines and lines starting with `#` are skipped.
pub(crate) fn read_xyz(bytes: &[u8]) -> Result<Parsed, ReadError> {
    if is_blank(bytes) {
        return Err(ReadError::Empty);
    }
    let mut state = XyzState::default();
    let (vertices, normals) = read_xyz_block(bytes, &mut state)?;
    Ok(Parsed {
        vertices,
        normals: (state.columns != Some(3)).then_some(normals),
        faces: Vec::new(),
        ..Parsed::default()
    })
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
