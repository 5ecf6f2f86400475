//! Errors of reading (malformed, truncated or unusable input) and writing (I/O, bad arguments).

use thiserror::Error;

/// Why a byte slice could not be turned into oriented points or a triangle mesh.
///
/// Element indices (`index`, `face`) are 0-based record numbers in file order; `line` numbers
/// are 1-based. The facade crate adds the file name.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum ReadError {
    /// The input has no bytes, or only whitespace.
    ///
    /// ```
    /// use psi_io::{read_points, Format, ReadError, ReadOptions};
    /// let err = read_points(b"  \n", Format::Xyz, &ReadOptions::paper()).unwrap_err();
    /// assert_eq!(err, ReadError::Empty);
    /// ```
    #[error("the input is empty")]
    Empty,

    /// The PLY header is malformed or lacks what psi needs (a `vertex` element with scalar
    /// `x y z`; a `face` element, when present, with an integer list `vertex_indices`).
    ///
    /// ```
    /// use psi_io::{read_points, Format, ReadError, ReadOptions};
    /// let err = read_points(b"ply\nformat ascii 1.0\nend_header\n", Format::Ply, &ReadOptions::paper())
    ///     .unwrap_err();
    /// assert!(matches!(err, ReadError::Header { .. }));
    /// ```
    #[error("invalid PLY header: {reason}")]
    Header {
        /// What is wrong.
        reason: String,
    },

    /// A PLY record (one element: a vertex, a face, ...) could not be decoded.
    ///
    /// ```
    /// use psi_io::{read_points, Format, ReadError, ReadOptions};
    /// let ply = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
    ///             property float z\nend_header\n0 zero 0\n";
    /// let err = read_points(ply, Format::Ply, &ReadOptions::paper()).unwrap_err();
    /// assert!(matches!(err, ReadError::Record { index: 0, .. }));
    /// ```
    #[error("{element} {index}: {reason}")]
    Record {
        /// The PLY element name, e.g. `vertex` or `face`.
        element: String,
        /// 0-based record index within the element.
        index: usize,
        /// What is wrong.
        reason: String,
    },

    /// A line of a text format (OBJ, XYZ) could not be parsed.
    ///
    /// ```
    /// use psi_io::{read_points, Format, ReadError, ReadOptions};
    /// let err = read_points(b"0 0 0 0 0 1\n0 0 x 0 0 1\n", Format::Xyz, &ReadOptions::paper())
    ///     .unwrap_err();
    /// assert!(matches!(err, ReadError::Line { line: 2, .. }));
    /// ```
    #[error("line {line}: {reason}")]
    Line {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        reason: String,
    },

    /// The data ends before all records the PLY header announces were read.
    ///
    /// ```
    /// use psi_io::{read_points, Format, ReadError, ReadOptions};
    /// let ply = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
    ///             property float z\nend_header\n0 0 0\n";
    /// let err = read_points(ply, Format::Ply, &ReadOptions::paper()).unwrap_err();
    /// assert!(matches!(err, ReadError::Truncated { index: 1, count: 3, .. }));
    /// ```
    #[error(
        "the data ends inside {element} {index}, but the header announces {count} {element} records"
    )]
    Truncated {
        /// The PLY element being read.
        element: String,
        /// 0-based index of the first record that is missing or incomplete.
        index: usize,
        /// How many records the header announces.
        count: usize,
    },

    /// A position or normal has a NaN or infinite component.
    ///
    /// ```
    /// use psi_io::{read_points, Format, ReadError, ReadOptions};
    /// let err = read_points(b"0 0 0 0 0 1\nnan 0 0 0 0 1\n", Format::Xyz, &ReadOptions::paper())
    ///     .unwrap_err();
    /// assert!(matches!(err, ReadError::NonFinite { index: 1, what: "position", .. }));
    /// ```
    #[error("{element} {index} has a NaN or infinite {what}{}", at_line(*line))]
    NonFinite {
        /// `vertex` (PLY, OBJ) or `point` (XYZ, PCD, LAS, E57).
        element: &'static str,
        /// 0-based index of the vertex or point.
        index: usize,
        /// `position` or `normal`.
        what: &'static str,
        /// 1-based line number, for text formats.
        line: Option<usize>,
    },

    /// A face refers to a vertex that does not exist.
    ///
    /// ```
    /// use psi_io::{read_mesh, Format, ReadError};
    /// let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n";
    /// let err = read_mesh(obj, Format::Obj).unwrap_err();
    /// assert_eq!(err, ReadError::IndexOutOfRange { face: 0, vertex: 4, vertices: 3 });
    /// ```
    #[error(
        "face {face} refers to vertex {vertex}, but the file has {vertices} vertices \
         (index as written in the file)"
    )]
    IndexOutOfRange {
        /// 0-based index of the face record (polygon) in the file.
        face: usize,
        /// The index as written in the file (0-based for PLY, 1-based or negative for OBJ).
        vertex: i64,
        /// Number of vertices in the file (for a relative OBJ index: defined before the face).
        vertices: usize,
    },

    /// A particle file's `vertex` element without `nx ny nz` (particles carry their normals).
    ///
    /// ```
    /// let ply = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n";
    /// let columns = psi_io::read_point_scalars(ply, &["x", "y", "z", "nx", "ny", "nz"]).unwrap();
    /// assert!(columns[3].is_none()); // the caller reports psi_io::ReadError::NoNormals
    /// ```
    #[error("the file has points but no normals (nx ny nz)")]
    NoNormals,

    /// An OBJ file without faces whose `vn` count differs from its `v` count, so normals cannot
    /// be paired with positions by index.
    ///
    /// ```
    /// use psi_io::{read_points, Format, ReadError, ReadOptions};
    /// let obj = b"v 0 0 0\nv 1 0 0\nvn 0 0 1\n";
    /// let err = read_points(obj, Format::Obj, &ReadOptions::paper()).unwrap_err();
    /// assert_eq!(err, ReadError::NormalCountMismatch { vertices: 2, normals: 1 });
    /// ```
    #[error(
        "the file has {vertices} vertices (v) but {normals} normals (vn) and no faces; \
         give one normal per vertex or a triangle mesh"
    )]
    NormalCountMismatch {
        /// Number of `v` lines.
        vertices: usize,
        /// Number of `vn` lines.
        normals: usize,
    },

    /// A triangle mesh was asked for ([`crate::read_mesh`]) but the file has no faces.
    ///
    /// ```
    /// use psi_io::{read_mesh, Format, ReadError};
    /// let err = read_mesh(b"0 0 0 0 0 1\n", Format::Xyz).unwrap_err();
    /// assert_eq!(err, ReadError::NoFaces);
    /// ```
    #[error("the file has no faces; a triangle mesh is required")]
    NoFaces,

    /// Parsing succeeded but no usable oriented point remains (no vertices, only zero normals,
    /// or only degenerate triangles).
    ///
    /// ```
    /// use psi_io::{read_points, Format, ReadError, ReadOptions};
    /// let err = read_points(b"0 0 0 0 0 0\n", Format::Xyz, &ReadOptions::paper()).unwrap_err();
    /// assert!(matches!(err, ReadError::NoPoints { dropped_points: 1, .. }));
    /// ```
    #[error(
        "no usable oriented points: {vertices} vertices, {faces} faces, \
         {degenerate_faces} degenerate faces, {dropped_points} points with zero normal"
    )]
    NoPoints {
        /// Vertex records in the file.
        vertices: usize,
        /// Triangles in the file.
        faces: usize,
        /// Degenerate triangles skipped.
        degenerate_faces: usize,
        /// Points skipped for a zero normal.
        dropped_points: usize,
    },

    /// The input could not be read (an I/O error of the stream the facade opened), as text.
    #[error("cannot read the input: {reason}")]
    Io {
        /// The operating system's reason.
        reason: String,
    },

    /// The format cannot be told: a binary file whose extension (or lack of one) names no
    /// format psi reads, and whose first bytes match none either.
    ///
    /// ```
    /// use psi_io::ReadError;
    /// let err = ReadError::UnknownFormat { extension: Some("bin".into()) };
    /// assert!(err.to_string().contains("unknown file extension `.bin`"));
    /// ```
    #[error(
        "{}: binary content in no format psi reads (ply, obj, xyz, las, laz, e57, pcd); \
         name the format with --format",
        extension_text(extension.as_deref())
    )]
    UnknownFormat {
        /// The file's extension, without the dot, when it has one.
        extension: Option<String>,
    },

    /// A LAS or LAZ file whose header, records or structure are malformed or unsupported
    /// (ASPRS LAS 1.4 R15; LAZ as written by LASzip).
    ///
    /// ```
    /// use psi_io::{read_points, Format, ReadError, ReadOptions};
    /// let err = read_points(b"LASF", Format::Las, &ReadOptions::paper()).unwrap_err();
    /// assert!(matches!(err, ReadError::Las { .. }));
    /// ```
    #[error("invalid LAS/LAZ file: {reason}")]
    Las {
        /// What is wrong.
        reason: String,
    },

    /// A LAS point data record format psi cannot read (LAS 1.4 R15 defines 0 to 10).
    #[error(
        "unsupported LAS point data record format {format} (LAS 1.4 R15 defines formats 0 to 10)"
    )]
    UnsupportedPointFormat {
        /// The format number as written in the header (compression bits removed).
        format: u8,
    },

    /// The point data ends before all the points a LAS, PCD or E57 header announces.
    #[error("the data ends after {read} points, but the header announces {announced}")]
    TruncatedPoints {
        /// Points the header announces.
        announced: u64,
        /// Points actually present (complete records).
        read: u64,
    },

    /// A LAZ chunk is truncated or corrupt: decoding the points from `first_point` on failed.
    #[error(
        "LAZ data is truncated or corrupt in the chunk holding points {first_point}..{end}: {reason}"
    )]
    LazChunk {
        /// 0-based index of the first point of the batch being decoded.
        first_point: u64,
        /// One past the last point of that batch.
        end: u64,
        /// The decoder's reason.
        reason: String,
    },

    /// An E57 file (ASTM E2807) that is malformed or cannot be read.
    #[error("invalid E57 file: {reason}")]
    E57 {
        /// What is wrong.
        reason: String,
    },

    /// An E57 scan (a `data3D` entry) without the fields of a position: neither
    /// `cartesianX/Y/Z` nor `sphericalRange/Azimuth/Elevation` (ASTM E2807 §8.4.4).
    #[error(
        "E57 scan {scan} has neither cartesian (cartesianX/Y/Z) nor spherical \
         (sphericalRange/Azimuth/Elevation) coordinate fields"
    )]
    E57NoCoordinates {
        /// 0-based index of the scan in the file's `data3D` list.
        scan: usize,
    },

    /// A PCD header (PCL's PCD v0.7 format) line that is malformed or contradicts another.
    ///
    /// ```
    /// use psi_io::{read_points, Format, ReadError, ReadOptions};
    /// let err = read_points(b"VERSION 0.7\nFIELDS x y\n", Format::Pcd, &ReadOptions::paper())
    ///     .unwrap_err();
    /// assert!(matches!(err, ReadError::PcdHeader { .. }));
    /// ```
    #[error("invalid PCD header (line {line}): {reason}")]
    PcdHeader {
        /// 1-based line number (the line after the header when something is missing).
        line: usize,
        /// What is wrong.
        reason: String,
    },

    /// PCD point data that disagrees with its header, or cannot be decoded.
    #[error("PCD point {point}: {reason}")]
    PcdData {
        /// 0-based index of the point record.
        point: u64,
        /// What is wrong.
        reason: String,
    },
}

fn extension_text(extension: Option<&str>) -> String {
    match extension {
        Some(e) => format!("unknown file extension `.{e}`"),
        None => "no file extension".to_owned(),
    }
}

fn at_line(line: Option<usize>) -> String {
    line.map(|l| format!(" (line {l})")).unwrap_or_default()
}

/// Why a PLY, LAS or LAZ file could not be written.
#[derive(Debug, Error)]
pub enum WriteError {
    /// The output rejected a write.
    ///
    /// ```
    /// use std::io;
    /// use glam::DVec3;
    /// use psi_io::{write_points_ply, WriteError};
    /// struct Full;
    /// impl io::Write for Full {
    ///     fn write(&mut self, _: &[u8]) -> io::Result<usize> {
    ///         Err(io::Error::new(io::ErrorKind::StorageFull, "disk full"))
    ///     }
    ///     fn flush(&mut self) -> io::Result<()> { Ok(()) }
    /// }
    /// let err = write_points_ply(&mut Full, &[DVec3::ZERO], &[DVec3::Z], &[]).unwrap_err();
    /// assert!(matches!(err, WriteError::Io(_)));
    /// ```
    #[error(transparent)]
    Io(#[from] std::io::Error),

    /// A per-point array does not have one entry per position.
    ///
    /// ```
    /// use glam::DVec3;
    /// use psi_io::{write_points_ply, WriteError};
    /// let mut out = Vec::new();
    /// let err = write_points_ply(&mut out, &[DVec3::ZERO; 2], &[DVec3::Z], &[]).unwrap_err();
    /// assert!(matches!(err, WriteError::LengthMismatch { expected: 2, got: 1, .. }));
    /// ```
    #[error("{what} has {got} entries, but there are {expected} positions")]
    LengthMismatch {
        /// Which array (`normals` or the scalar channel's name).
        what: String,
        /// Number of positions.
        expected: usize,
        /// Length of the offending array.
        got: usize,
    },

    /// A scalar channel name is not a valid, unique PLY property name.
    ///
    /// ```
    /// use glam::DVec3;
    /// use psi_io::{write_points_ply, WriteError};
    /// let mut out = Vec::new();
    /// let err = write_points_ply(&mut out, &[DVec3::ZERO], &[DVec3::Z], &[("my depth", &[1.0])])
    ///     .unwrap_err();
    /// assert!(matches!(err, WriteError::InvalidName { .. }));
    /// ```
    #[error("invalid PLY property name {name:?}: {reason}")]
    InvalidName {
        /// The rejected name.
        name: String,
        /// Why it is rejected.
        reason: &'static str,
    },

    /// A face refers to a vertex that does not exist, or to an index a PLY `int` cannot hold
    /// (above `i32::MAX`).
    ///
    /// ```
    /// use glam::DVec3;
    /// use psi_io::{write_mesh_ply, TriangleMesh, WriteError};
    /// let mesh = TriangleMesh { vertices: vec![DVec3::ZERO; 3], faces: vec![[0, 1, 3]] };
    /// let err = write_mesh_ply(&mut Vec::new(), &mesh).unwrap_err();
    /// assert!(matches!(err, WriteError::IndexOutOfRange { face: 0, vertex: 3, vertices: 3 }));
    /// ```
    #[error("face {face} refers to vertex {vertex}, but the mesh has {vertices} vertices")]
    IndexOutOfRange {
        /// 0-based face index.
        face: usize,
        /// The offending vertex index.
        vertex: u32,
        /// Number of vertices in the mesh.
        vertices: usize,
    },

    /// A position has a NaN or infinite coordinate, which LAS cannot store.
    ///
    /// ```
    /// use std::io::Cursor;
    /// use glam::DVec3;
    /// use psi_io::{write_las, PointAttributes, WriteError};
    /// let points = [DVec3::ZERO, DVec3::new(0.0, f64::NAN, 0.0)];
    /// let err = write_las(Cursor::new(Vec::new()), &points, &PointAttributes::default(), false)
    ///     .unwrap_err();
    /// assert!(matches!(err, WriteError::NonFinite { index: 1 }));
    /// assert_eq!(err.to_string(), "point 1 has a NaN or infinite position");
    /// ```
    #[error("point {index} has a NaN or infinite position")]
    NonFinite {
        /// 0-based index of the first such point.
        index: usize,
    },

    /// The `las` crate refused the LAS/LAZ header or a point record (not expected for
    /// finite positions: the writer chooses a scale that fits them).
    #[error("cannot write the LAS/LAZ file: {reason}")]
    Las {
        /// The `las` crate's reason.
        reason: String,
    },
}
