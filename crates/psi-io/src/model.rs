//! What the readers return: a triangle mesh, and oriented points with the counts behind them.

use glam::DVec3;
use psi_octree::OrientedPoint;

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
}
