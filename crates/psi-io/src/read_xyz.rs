//! XYZ reader: one oriented point `x y z nx ny nz` per line.

use glam::DVec3;

use crate::error::ReadError;
use crate::model::Parsed;
use crate::text::{is_blank, line_str, numbered_lines, parse_number};

/// Parses whitespace-separated `x y z nx ny nz` lines; blank lines and lines starting with `#`
/// are skipped. A line of three numbers means the file has no normals.
pub(crate) fn read_xyz(bytes: &[u8]) -> Result<Parsed, ReadError> {
    if is_blank(bytes) {
        return Err(ReadError::Empty);
    }
    let mut vertices = Vec::new();
    let mut normals = Vec::new();
    for (number, raw) in numbered_lines(bytes) {
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
        match count {
            6 => {}
            3 => return Err(ReadError::NoNormals),
            _ => {
                return Err(ReadError::Line {
                    line: number,
                    reason: format!("expected 6 numbers (x y z nx ny nz), found {count} tokens"),
                });
            }
        }
        let index = vertices.len();
        let p = DVec3::new(values[0], values[1], values[2]);
        let n = DVec3::new(values[3], values[4], values[5]);
        for (what, v) in [("position", p), ("normal", n)] {
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
    Ok(Parsed {
        vertices,
        normals: Some(normals),
        faces: Vec::new(),
    })
}
