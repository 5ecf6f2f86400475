//! The oriented points of a streamed chunk, by the rule a whole read applies: normals made
//! unit, a point whose normal is zero dropped (and counted), a non-finite normal an error.

use psi_octree::OrientedPoint;

use crate::error::ReadError;
use crate::mesh_to_points::unit;
use crate::point_chunk::PointChunk;

/// The oriented points of `chunk` and how many it dropped for a zero normal, exactly as
/// [`crate::read_points_from`] makes them; `None` when the chunk has no normals. `first` is
/// the index of the chunk's first point in the file, for error messages.
///
/// ```
/// use glam::DVec3;
/// use psi_io::{PointChunk, chunk_oriented_points};
/// let chunk = PointChunk {
///     positions: vec![DVec3::ZERO, DVec3::X],
///     normals: Some(vec![DVec3::new(0.0, 0.0, 2.0), DVec3::ZERO]),
///     ..Default::default()
/// };
/// let (points, dropped) = chunk_oriented_points(&chunk, 0).unwrap().unwrap();
/// assert_eq!((points.len(), dropped, points[0].n), (1, 1, DVec3::Z));
/// ```
pub fn chunk_oriented_points(
    chunk: &PointChunk,
    first: u64,
) -> Option<Result<(Vec<OrientedPoint>, usize), ReadError>> {
    let normals = chunk.normals.as_ref()?;
    let mut points = Vec::with_capacity(chunk.len());
    let mut dropped = 0;
    for (i, (&p, &n)) in chunk.positions.iter().zip(normals).enumerate() {
        if !n.is_finite() {
            return Some(Err(ReadError::NonFinite {
                element: "vertex",
                index: first as usize + i,
                what: "normal",
                line: None,
            }));
        }
        match unit(n) {
            Some(n) => points.push(OrientedPoint { p, n }),
            None => dropped += 1,
        }
    }
    Some(Ok((points, dropped)))
}
