//! Wavefront OBJ reader: `v`, `vn` and `f` lines; every other statement is ignored.

use glam::DVec3;

use crate::error::ReadError;
use crate::model::Parsed;
use crate::text::{is_blank, line_str, numbered_lines, parse_number, quoted};

/// Polygons as flat, resolved 0-based vertex indices with their end offsets.
#[derive(Default)]
struct Polygons {
    corners: Vec<u64>,
    ends: Vec<usize>,
}

/// Parses an OBJ file. Faces accept `i`, `i/j`, `i/j/k` and `i//k` references with 1-based or
/// negative (relative) vertex indices; polygons are split into fans. Without faces, `vn` lines
/// pair with `v` lines by index when the counts agree.
pub(crate) fn read_obj(bytes: &[u8]) -> Result<Parsed, ReadError> {
    if is_blank(bytes) {
        return Err(ReadError::Empty);
    }
    let mut vertices: Vec<DVec3> = Vec::new();
    let mut normals: Vec<DVec3> = Vec::new();
    let mut polygons = Polygons::default();
    for (number, raw) in numbered_lines(bytes) {
        let raw = raw.trim_ascii_start();
        let keyword_len = raw
            .iter()
            .position(u8::is_ascii_whitespace)
            .unwrap_or(raw.len());
        match &raw[..keyword_len] {
            b"v" => {
                let p = read_vector(raw, number, "vertex")?;
                if !p.is_finite() {
                    return Err(ReadError::NonFinite {
                        element: "vertex",
                        index: vertices.len(),
                        what: "position",
                        line: Some(number),
                    });
                }
                vertices.push(p);
            }
            b"vn" => normals.push(read_vector(raw, number, "normal")?),
            b"f" => read_face(raw, number, vertices.len(), &mut polygons)?,
            _ => {}
        }
    }
    let faces = triangulate(&polygons, vertices.len())?;
    // Without faces and without `vn`: positions only.
    let normals = if !faces.is_empty() || normals.is_empty() {
        None
    } else if normals.len() == vertices.len() {
        Some(normals)
    } else {
        return Err(ReadError::NormalCountMismatch {
            vertices: vertices.len(),
            normals: normals.len(),
        });
    };
    Ok(Parsed {
        vertices,
        normals,
        faces,
        ..Parsed::default()
    })
}

/// The first three numbers after the keyword (`v` may carry more: `w` or a colour).
fn read_vector(raw: &[u8], number: usize, what: &str) -> Result<DVec3, ReadError> {
    let text = line_str(raw, number)?;
    let mut tokens = text.split_ascii_whitespace().skip(1);
    let mut xyz = [0.0; 3];
    for value in &mut xyz {
        let token = tokens.next().ok_or_else(|| ReadError::Line {
            line: number,
            reason: format!("a {what} needs 3 coordinates"),
        })?;
        *value = parse_number(token, number)?;
    }
    Ok(DVec3::from_array(xyz))
}

/// Parses one `f` line into `polygons`, resolving negative indices against the `seen`
/// vertices so far (positive indices are range-checked once all vertices are known).
fn read_face(
    raw: &[u8],
    number: usize,
    seen: usize,
    polygons: &mut Polygons,
) -> Result<(), ReadError> {
    let text = line_str(raw, number)?;
    let face = polygons.ends.len();
    let start = polygons.corners.len();
    for token in text.split_ascii_whitespace().skip(1) {
        let index_text = token.split('/').next().unwrap_or_default();
        let bad = |reason: String| ReadError::Line {
            line: number,
            reason,
        };
        let index: i64 = index_text.parse().map_err(|_| {
            bad(format!(
                "face reference {} does not start with a vertex index",
                quoted(token)
            ))
        })?;
        let resolved = if index > 0 {
            index.unsigned_abs() - 1
        } else if index < 0 && index.unsigned_abs() <= seen as u64 {
            seen as u64 - index.unsigned_abs()
        } else if index == 0 {
            return Err(bad("face index 0: OBJ indices start at 1".to_owned()));
        } else {
            return Err(ReadError::IndexOutOfRange {
                face,
                vertex: index,
                vertices: seen,
            });
        };
        polygons.corners.push(resolved);
    }
    let corners = polygons.corners.len() - start;
    if corners < 3 {
        return Err(ReadError::Line {
            line: number,
            reason: format!("a face needs at least 3 vertices, found {corners}"),
        });
    }
    polygons.ends.push(polygons.corners.len());
    Ok(())
}

/// Range-checks all polygon corners and splits each polygon into a fan of triangles.
fn triangulate(polygons: &Polygons, vertices: usize) -> Result<Vec<[u32; 3]>, ReadError> {
    // Every valid index must fit a u32; a file with more vertices cannot be indexed.
    let limit = vertices.min(u32::MAX as usize + 1) as u64;
    let mut faces = Vec::with_capacity(
        polygons
            .corners
            .len()
            .saturating_sub(2 * polygons.ends.len()),
    );
    let mut start = 0;
    for (face, &end) in polygons.ends.iter().enumerate() {
        let corners = &polygons.corners[start..end];
        start = end;
        if let Some(&bad) = corners.iter().find(|&&c| c >= limit) {
            return Err(ReadError::IndexOutOfRange {
                face,
                vertex: i64::try_from(bad).map_or(i64::MAX, |b| b.saturating_add(1)),
                vertices,
            });
        }
        for k in 1..corners.len() - 1 {
            faces.push([corners[0] as u32, corners[k] as u32, corners[k + 1] as u32]);
        }
    }
    Ok(faces)
}
