//! # psi-io
//!
//! Reading oriented points, scans and triangle meshes, and writing PLY and LAS/LAZ, for psi.
//! This crate does no filesystem access: readers parse a byte slice or any `Read + Seek`
//! stream, writers write to any [`std::io::Write`] (LAS/LAZ: `Write + Seek`, as the header is
//! completed last). The facade crate opens files, adds file names to errors and writes through
//! a temporary file.
//!
//! * Formats ([`Format`]): PLY (ASCII, binary little- and big-endian), Wavefront OBJ, XYZ
//!   text (`x y z nx ny nz` per line), LAS 1.0–1.4 and LAZ (ASPRS LAS 1.4 R15; the `las`
//!   crate, parallel LAZ decoding), E57 (ASTM E2807; the `e57` crate: every scan under its
//!   pose) and PCD (PCL's PCD v0.7: ascii, binary, binary_compressed; read here).
//!   [`Format::from_extension`], [`Format::detect`] (signatures) and [`Format::sniff`] pick
//!   one.
//! * [`read_points`] gives the oriented points psi works on ([`PointCloudFile`]): from a mesh
//!   one point per triangle at its centroid with the face normal (the paper's counts, the
//!   default), or per vertex with area-weighted normals ([`MeshSampling`]); from a point cloud
//!   the points with their (normalised) normals. [`read_mesh`] gives the [`TriangleMesh`].
//! * Attributes: colour, intensity and LAS classification ride along in
//!   [`PointCloudFile::attributes`] ([`PointAttributes`], one entry per kept point; PLY
//!   `red green blue` and `intensity`/`scalar_intensity` too), and what the file was in
//!   [`PointCloudFile::source`] ([`SourceInfo`]: format, E57 scans, invalid records).
//! * Streaming: [`PointStream`] reads LAS/LAZ, E57 and PCD in bounded chunks
//!   ([`PointChunk`]), for files larger than memory; [`read_points_from`] collects them.
//! * [`free_aside`] drops a large buffer on a thread of its own (a read's bytes, say).
//! * [`read_point_scalars`] gives named scalar columns of a PLY `vertex` element (a particle
//!   file's `depth` and `sigma`, say), aligned record by record, nothing dropped.
//! * [`write_points_ply`] writes points, normals and named scalar channels (f64);
//!   [`write_points_ply_with_attributes`] adds the attribute columns (`red green blue`
//!   uchar, `intensity` float, `classification` uchar); [`write_mesh_ply`] writes a mesh
//!   (f32 positions, int indices).
//! * [`write_las`] writes points with their attributes as LAS 1.4 or LAZ (point format 7,
//!   colour × 257, a power-of-ten scale from the data's extent, offsets at its centre: no
//!   precision lost beyond half the scale).
//! * Every malformed input is a [`ReadError`] naming the element and index (or line) and the
//!   reason; no byte sequence panics.
//!
//! ```
//! use glam::DVec3;
//! use psi_io::{read_points, Format, ReadOptions};
//!
//! let ply = b"ply
//! format ascii 1.0
//! element vertex 3
//! property float x
//! property float y
//! property float z
//! element face 1
//! property list uchar int vertex_indices
//! end_header
//! 0 0 0
//! 3 0 0
//! 0 3 0
//! 3 0 1 2
//! ";
//! assert_eq!(Format::sniff(ply), Format::Ply);
//! let file = read_points(ply, Format::Ply, &ReadOptions::paper()).unwrap();
//! assert_eq!((file.vertices, file.faces, file.points.len()), (3, 1, 1));
//! // One point at the triangle's centroid, normal along (b - a) x (c - a).
//! assert_eq!(file.points[0].p, DVec3::new(1.0, 1.0, 0.0));
//! assert_eq!(file.points[0].n, DVec3::Z);
//! assert!(file.mesh.is_some());
//! ```

mod attributes;
mod chunk_points;
mod error;
mod format;
mod free_aside;
mod las_checks;
mod lzf;
mod mesh_to_points;
mod model;
mod options;
mod pcd_header;
mod point_chunk;
mod read_e57;
mod read_las;
mod read_obj;
mod read_pcd;
mod read_ply;
mod read_scalars;
mod read_xyz;
mod stream;
mod stream_ply;
mod stream_xyz;
mod text;
mod vertex_record;
mod write_las;
mod write_ply;

pub use attributes::{AttributeKinds, PointAttributes};
pub use chunk_points::chunk_oriented_points;
pub use error::{ReadError, WriteError};
pub use format::Format;
pub use free_aside::free_aside;
pub use model::{FileSummary, NormalSource, PointCloudFile, SourceInfo, TriangleMesh};
pub use options::{MeshSampling, ReadOptions};
pub use point_chunk::{PointChunk, StreamEnd, StreamHeader};
pub use read_scalars::read_point_scalars;
pub use stream::{PointStream, read_points_from};
pub use write_las::write_las;
pub use write_ply::{write_mesh_ply, write_points_ply, write_points_ply_with_attributes};

use model::Parsed;

/// Parses a text or PLY file (the formats read whole); the streamed formats go through
/// [`read_points_from`].
fn parse(bytes: &[u8], format: Format) -> Result<Parsed, ReadError> {
    parse_as(bytes, format, false)
}

/// [`parse`]; `for_points`: only the points are wanted, not a mesh (a PLY without faces may
/// then come back as `Parsed::oriented`).
fn parse_as(bytes: &[u8], format: Format, for_points: bool) -> Result<Parsed, ReadError> {
    let mut parsed = match format {
        Format::Ply if for_points => read_ply::read_ply_for_points(bytes),
        Format::Ply => read_ply::read_ply(bytes),
        Format::Obj => read_obj::read_obj(bytes),
        Format::Xyz => read_xyz::read_xyz(bytes),
        Format::Las | Format::Laz | Format::E57 | Format::Pcd => Err(ReadError::Header {
            reason: format!("{} files are read as streams", format.name()),
        }),
    }?;
    parsed.source.format = Some(format);
    Ok(parsed)
}

/// Reads the oriented points of a file's content.
///
/// * `bytes`: the whole file. (LAS/LAZ, E57 and PCD are read through [`read_points_from`] on
///   a copy; the facade streams them from the file instead.)
/// * `format`: how to parse it (see [`Format::sniff`] / [`Format::from_extension`]).
/// * `opts`: how a mesh becomes points ([`ReadOptions::paper`]: one point per triangle).
///
/// When the file has faces, the points come from the mesh per `opts.sampling`, degenerate
/// triangles are skipped and counted, and the mesh is returned too. Without faces, the points
/// are the vertices with their normals (PLY `nx ny nz`, OBJ one `vn` per `v`, XYZ six columns;
/// non-unit normals are normalised, zero normals are skipped and counted), or, when the file
/// has none, with zero normals and [`NormalSource::Missing`]. Positions are in the file's
/// units.
///
/// # Errors
///
/// A [`ReadError`] for empty, malformed or truncated input, NaN or infinite values, face
/// indices out of range, and when no usable point remains.
///
/// ```
/// use psi_io::{read_points, Format, ReadOptions};
/// let xyz = b"# x y z nx ny nz\n0 0 0 0 0 2\n1 0 0 0 0 0\n";
/// let file = read_points(xyz, Format::Xyz, &ReadOptions::paper()).unwrap();
/// assert_eq!((file.points.len(), file.dropped_points), (1, 1));
/// assert_eq!(file.points[0].n.z, 1.0);
/// ```
pub fn read_points(
    bytes: &[u8],
    format: Format,
    opts: &ReadOptions,
) -> Result<PointCloudFile, ReadError> {
    if format.is_streamed() {
        return read_points_from(std::io::Cursor::new(bytes.to_vec()), format, opts);
    }
    mesh_to_points::to_point_cloud(parse_as(bytes, format, true)?, opts)
}

/// The oriented points of columns given in memory (a caller's arrays, not a file), read as an
/// XYZ file of them would be: `positions` (shape: N, world units) with `normals` (shape: N,
/// normalised here, zero ones skipped and counted) or without ([`NormalSource::Missing`]), and
/// their `attributes` (aligned, or empty), which follow the points kept.
///
/// # Errors
///
/// [`ReadError::NonFinite`] for the first point (`point i`) with a NaN or infinite position or
/// normal, [`ReadError::Record`] when the columns differ in length, [`ReadError::NoPoints`] when
/// no usable point remains.
///
/// ```
/// use glam::DVec3;
/// let none = psi_io::PointAttributes::default();
/// let file = psi_io::points_from_columns(vec![DVec3::ZERO, DVec3::X], Some(vec![DVec3::Z * 2.0, DVec3::ZERO]), none.clone()).unwrap();
/// assert_eq!((file.points.len(), file.dropped_points, file.points[0].n), (1, 1, DVec3::Z));
/// let err = psi_io::points_from_columns(vec![DVec3::NAN], None, none).unwrap_err();
/// assert_eq!(err.to_string(), "point 0 has a NaN or infinite position");
/// ```
pub fn points_from_columns(
    positions: Vec<glam::DVec3>,
    normals: Option<Vec<glam::DVec3>>,
    attributes: PointAttributes,
) -> Result<PointCloudFile, ReadError> {
    if !attributes.fits(positions.len()) {
        return Err(ReadError::Record {
            element: "point".to_owned(),
            index: 0,
            reason: format!(
                "{} positions but attributes for {}",
                positions.len(),
                attributes.len().unwrap_or(0)
            ),
        });
    }
    if let Some(n) = &normals
        && n.len() != positions.len()
    {
        return Err(ReadError::Record {
            element: "point".to_owned(),
            index: n.len().min(positions.len()),
            reason: format!("{} positions but {} normals", positions.len(), n.len()),
        });
    }
    for (index, p) in positions.iter().enumerate() {
        let normal = normals.as_ref().map(|n| n[index]);
        for (what, v) in [("position", Some(*p)), ("normal", normal)] {
            if v.is_some_and(|v| !v.is_finite()) {
                return Err(ReadError::NonFinite {
                    element: "point",
                    index,
                    what,
                    line: None,
                });
            }
        }
    }
    let parsed = Parsed {
        vertices: positions,
        normals,
        attributes,
        ..Parsed::default()
    };
    mesh_to_points::to_point_cloud(parsed, &ReadOptions::paper())
}

/// Reads the triangle mesh of a file's content: all vertices (shape: V, world units) and all
/// triangles (shape: F, polygons split into fans, degenerate triangles kept).
///
/// # Errors
///
/// [`ReadError::NoFaces`] when the file has no faces (always for LAS/LAZ, E57 and PCD, which
/// hold points only; their content is not read), and the parse errors of [`read_points`].
///
/// ```
/// use psi_io::{read_mesh, Format};
/// let obj = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
/// let mesh = read_mesh(obj, Format::Obj).unwrap();
/// assert_eq!(mesh.faces, vec![[0, 1, 2], [0, 2, 3]]);
/// ```
pub fn read_mesh(bytes: &[u8], format: Format) -> Result<TriangleMesh, ReadError> {
    if format.is_streamed() {
        return Err(ReadError::NoFaces);
    }
    mesh_to_points::to_mesh(parse(bytes, format)?)
}
