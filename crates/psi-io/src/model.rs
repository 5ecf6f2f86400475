//! What the readers return: a triangle mesh, and oriented points with the counts behind them.

use glam::DVec3;
use psi_octree::{Aabb, OrientedPoint};

use crate::attributes::{AttributeKinds, PointAttributes};
use crate::format::Format;

/// An indexed triangle mesh in the file's units.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions (shape: V), world units, all finite.
    pub vertices: Vec<DVec3>,
    /// Triangles (shape: F) as indices into `vertices`, all `< vertices.len()`. Polygons of the
    /// file are split into fans `(v0, v_i, v_i+1)`. Degenerate triangles are kept here.
    pub faces: Vec<[u32; 3]>,
}

/// Where the normals of a [`PointCloudFile`]'s points came from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum NormalSource {
    /// The file's own per-point normals (PLY `nx ny nz`, OBJ `vn`, XYZ columns 4–6).
    #[default]
    File,
    /// Face normals of the file's triangles ([`crate::MeshSampling::FaceCentroids`]).
    Faces,
    /// Area-weighted vertex normals of the file's triangles
    /// ([`crate::MeshSampling::VertexNormals`]).
    Vertices,
    /// None: a point cloud of positions only. Every point's `n` is zero until normals are
    /// estimated (`psi_preprocess::estimate_normals`).
    Missing,
}

/// Oriented points read from a file, with the counts that explain where they came from.
#[derive(Clone, Debug, PartialEq)]
pub struct PointCloudFile {
    /// The points to use (shape: N): positions in the file's units, unit normals — or zero
    /// normals when [`PointCloudFile::normals`] is [`NormalSource::Missing`].
    pub points: Vec<OrientedPoint>,
    /// Where the normals came from.
    pub normals: NormalSource,
    /// Vertex records in the file (PLY `vertex` elements, OBJ `v` lines, XYZ point lines).
    pub vertices: usize,
    /// Triangles in the file after splitting polygons into fans; 0 for a point cloud.
    pub faces: usize,
    /// Triangles with a repeated index or zero (or non-finite) area, which give no point
    /// ([`crate::MeshSampling::FaceCentroids`]) and no normal contribution
    /// ([`crate::MeshSampling::VertexNormals`]).
    pub degenerate_faces: usize,
    /// Points skipped because their normal was zero (a bare point with normal `0 0 0`, or a
    /// mesh vertex whose area-weighted normal sums to zero).
    pub dropped_points: usize,
    /// The triangle mesh, when the file had faces.
    pub mesh: Option<TriangleMesh>,
    /// Colour, intensity and classification of the points, each column aligned with
    /// `points` when present (see [`PointAttributes`] for units).
    pub attributes: PointAttributes,
    /// What the file was: its format, scans and the records skipped as invalid.
    pub source: SourceInfo,
}

/// Where a [`PointCloudFile`] came from, beyond its points.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SourceInfo {
    /// The format read; `None` for points given in memory.
    pub format: Option<Format>,
    /// A one-line description of the file's layout, e.g. `LAS 1.4, point format 7, LAZ` or
    /// `PCD 0.7, binary_compressed, 640 x 480`; `None` for PLY, OBJ and XYZ.
    pub detail: Option<String>,
    /// The number of scans (E57 `data3D` entries); `None` for formats without scans.
    pub scans: Option<usize>,
    /// Records skipped because the file marks them invalid or their position is not finite:
    /// E57 returns flagged invalid or direction-only, PCD NaN points (PCL's marker in
    /// organised clouds). Not counted in `vertices`.
    pub invalid_points: u64,
}

/// What `psi info` says about a file as read, before any preprocessing.
#[derive(Clone, Debug, PartialEq)]
pub struct FileSummary {
    /// See [`SourceInfo`].
    pub source: SourceInfo,
    /// Points read (`points.len()`).
    pub points: usize,
    /// Whether the file gave normals.
    pub normals: NormalSource,
    /// The attribute columns present.
    pub attributes: AttributeKinds,
    /// Componentwise minimum and maximum of the positions; `None` without points.
    pub bounds: Option<(DVec3, DVec3)>,
}

impl PointCloudFile {
    /// The componentwise minimum and maximum of the points' positions; `None` when there
    /// are none.
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        // (In parallel, the same box for any thread count.)
        Aabb::from_positions_at(self.points.len(), &|i| self.points[i].p).map(|b| (b.min, b.max))
    }

    /// The format, scans, counts, attributes and coordinate ranges of this file.
    pub fn summary(&self) -> FileSummary {
        FileSummary {
            source: self.source.clone(),
            points: self.points.len(),
            normals: self.normals,
            attributes: AttributeKinds::of(&self.attributes),
            bounds: self.bounds(),
        }
    }
}

/// What a reader extracts before points are made: positions, optional per-vertex normals,
/// and triangles with validated indices.
#[derive(Debug, Default)]
pub(crate) struct Parsed {
    /// Vertex positions, all finite.
    pub(crate) vertices: Vec<DVec3>,
    /// Per-vertex normals (same length as `vertices`) when the file has them; not validated.
    pub(crate) normals: Option<Vec<DVec3>>,
    /// Triangles, indices `< vertices.len()`.
    pub(crate) faces: Vec<[u32; 3]>,
    /// The vertices with their normals as read (any length), when the reader made the points
    /// directly (a PLY without faces read for its points): `vertices` and `normals` are then
    /// empty.
    pub(crate) oriented: Option<Vec<OrientedPoint>>,
    /// Per-vertex attributes, each present column as long as `vertices` (or `oriented`).
    pub(crate) attributes: PointAttributes,
    /// What the file was (the format is set by the caller of the reader).
    pub(crate) source: SourceInfo,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bounds of a file of several chunks, found in parallel, are the serial fold's.
    #[test]
    fn bounds_in_chunks_are_the_serial_folds() {
        let n = 3 * (1 << 16) + 5;
        let at = |i: usize, k: usize| ((i * (2 * k + 1)) as f64 * 0.618_033_988_7).fract() - 0.5;
        let positions: Vec<DVec3> = (0..n)
            .map(|i| DVec3::new(at(i, 1), at(i, 2), at(i, 3)) * (1.0 + i as f64))
            .collect();
        // Signed zeros whose ties the serial fold settles by order.
        let mut positions = positions;
        positions[0] = DVec3::ZERO;
        positions[7] = DVec3::splat(-0.0);
        let first = positions[0];
        let serial = positions
            .iter()
            .fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        let file = crate::points_from_columns(positions, None, PointAttributes::default())
            .expect("finite positions");
        assert_eq!(file.bounds(), Some(serial));
        assert_eq!(file.summary().bounds, Some(serial));
    }
}
