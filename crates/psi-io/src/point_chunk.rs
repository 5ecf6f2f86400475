//! What the streaming readers hand out: a header read before any point, batches of points
//! with their normals and attributes, and the count at the end.

use glam::DVec3;

use crate::attributes::{self, AttributeKinds, PointAttributes};
use crate::error::ReadError;
use crate::format::Format;

/// A batch of points read from a stream: positions in the file's (georeferenced) units as
/// f64, with normals and attributes aligned with them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointChunk {
    /// Positions (shape: n ≤ the requested batch size), world units, all finite.
    pub positions: Vec<DVec3>,
    /// The file's normals, when it has them (PCD `normal_x normal_y normal_z`): not
    /// normalised; a normal the file leaves undefined (NaN) is zero.
    pub normals: Option<Vec<DVec3>>,
    /// Colour, intensity, classification: the columns [`StreamHeader::attributes`] names.
    pub attributes: PointAttributes,
}

/// A fresh chunk reserves room for at most this many points (a stream asked for large chunks
/// grows them as points come, instead of reserving memory a short file never uses).
const FRESH_CAPACITY: usize = 1 << 16;

impl PointChunk {
    /// An empty chunk with the columns of `header`, for a stream handing out chunks of at most
    /// `max` points.
    pub(crate) fn fresh(header: &StreamHeader, max: usize) -> Self {
        Self::for_header(header, max.min(FRESH_CAPACITY))
    }

    /// An empty chunk with the columns of `header` and room for `capacity` points when the
    /// allocator grants it, else room for at most `fallback` (a request it refuses costs
    /// the speed of growing, not the process).
    pub(crate) fn with_room(header: &StreamHeader, capacity: usize, fallback: usize) -> Self {
        let mut chunk = Self::for_header(header, 0);
        let a = &mut chunk.attributes;
        let granted = chunk.positions.try_reserve_exact(capacity).is_ok()
            && reserve_column(&mut chunk.normals, capacity)
            && reserve_column(&mut a.colors, capacity)
            && reserve_column(&mut a.intensity, capacity)
            && reserve_column(&mut a.classification, capacity);
        match granted {
            true => chunk,
            false => Self::for_header(header, capacity.min(fallback)),
        }
    }

    /// An empty chunk with the columns of `header`.
    pub(crate) fn for_header(header: &StreamHeader, capacity: usize) -> Self {
        Self {
            positions: Vec::with_capacity(capacity),
            normals: header.normals.then(|| Vec::with_capacity(capacity)),
            attributes: attributes::with_kinds(header.attributes, capacity),
        }
    }

    /// The number of points in the chunk.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether the chunk has no points.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// The points from `at` on, taken out of this chunk (which keeps the first `at`).
    pub(crate) fn split_off(&mut self, at: usize) -> PointChunk {
        fn tail<T>(column: &mut Option<Vec<T>>, at: usize) -> Option<Vec<T>> {
            column.as_mut().map(|c| c.split_off(at))
        }
        let a = &mut self.attributes;
        PointChunk {
            positions: self.positions.split_off(at),
            normals: tail(&mut self.normals, at),
            attributes: PointAttributes {
                colors: tail(&mut a.colors, at),
                intensity: tail(&mut a.intensity, at),
                classification: tail(&mut a.classification, at),
            },
        }
    }
}

/// What a stream knows from the file's header, before any point is read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StreamHeader {
    /// The format, as the content says ([`Format::Laz`] for a compressed LAS file whatever
    /// it was opened as).
    pub format: Format,
    /// A one-line description of the layout (version, point format, encoding, scans).
    pub detail: String,
    /// Point records the header announces (E57: the sum over the scans), invalid ones
    /// included.
    pub announced_points: u64,
    /// The number of scans (E57 `data3D` entries); `None` for the other formats.
    pub scans: Option<usize>,
    /// Whether chunks carry normals.
    pub normals: bool,
    /// The attribute columns chunks carry.
    pub attributes: AttributeKinds,
}

/// How a stream ended: every record visited (or the visitor stopped it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StreamEnd {
    /// Points handed to the visitor.
    pub points: u64,
    /// Records skipped as invalid (see [`crate::SourceInfo::invalid_points`]).
    pub invalid_points: u64,
}

/// Room for `n` more entries in `column` when it is there; false when the allocator refuses.
fn reserve_column<T>(column: &mut Option<Vec<T>>, n: usize) -> bool {
    column
        .as_mut()
        .is_none_or(|c| c.try_reserve_exact(n).is_ok())
}

/// A reader's I/O error as a [`ReadError::Io`].
pub(crate) fn io_error(e: std::io::Error) -> ReadError {
    ReadError::Io {
        reason: e.to_string(),
    }
}

/// Hands `chunk` to `visit` once it holds `max` points, a fresh chunk for `header` taking its
/// place, and counts its points in `end`; true when the visitor stopped the stream.
pub(crate) fn emit_if_full<F: FnMut(PointChunk) -> std::ops::ControlFlow<()>>(
    chunk: &mut PointChunk,
    header: &StreamHeader,
    max: usize,
    end: &mut StreamEnd,
    visit: &mut F,
) -> bool {
    if chunk.len() < max {
        return false;
    }
    end.points += chunk.len() as u64;
    let full = std::mem::replace(chunk, PointChunk::fresh(header, max));
    visit(full).is_break()
}

/// Hands the last, partly filled `chunk` to `visit` (none when empty) and returns `end`.
pub(crate) fn emit_rest<F: FnMut(PointChunk) -> std::ops::ControlFlow<()>>(
    chunk: PointChunk,
    mut end: StreamEnd,
    visit: &mut F,
) -> StreamEnd {
    if !chunk.is_empty() {
        end.points += chunk.len() as u64;
        let _ = visit(chunk);
    }
    end
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> StreamHeader {
        StreamHeader {
            format: Format::Ply,
            detail: String::new(),
            announced_points: 0,
            scans: None,
            normals: true,
            attributes: AttributeKinds {
                colors: true,
                intensity: false,
                classification: true,
            },
        }
    }

    /// Room the allocator grants is held in every column; room it refuses (more than the
    /// address space) falls back to the smaller room instead of ending the process.
    #[test]
    fn room_is_reserved_or_falls_back() {
        let h = header();
        let chunk = PointChunk::with_room(&h, 1000, 10);
        assert!(chunk.positions.capacity() >= 1000);
        assert!(chunk.normals.as_ref().unwrap().capacity() >= 1000);
        assert!(chunk.attributes.colors.as_ref().unwrap().capacity() >= 1000);
        assert!(chunk.attributes.intensity.is_none());
        let huge = PointChunk::with_room(&h, usize::MAX / 8, 10);
        assert_eq!(huge.positions.capacity(), 10);
        assert_eq!(huge.normals.as_ref().unwrap().capacity(), 10);
        assert_eq!(
            huge.attributes.classification.as_ref().unwrap().capacity(),
            10
        );
    }
}
