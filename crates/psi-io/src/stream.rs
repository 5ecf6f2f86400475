//! Reading the scanner formats (LAS/LAZ, E57, PCD), XYZ and PLY point clouds in bounded chunks, so that a file
//! larger than memory can be processed batch by batch; [`read_points_from`] collects the
//! chunks.

use std::io::{Read, Seek, SeekFrom};
use std::ops::ControlFlow;

use crate::attributes;
use crate::error::ReadError;
use crate::format::Format;
use crate::mesh_to_points;
use crate::model::{Parsed, PointCloudFile, SourceInfo};
use crate::options::ReadOptions;
use crate::point_chunk::{PointChunk, StreamEnd, StreamHeader, io_error};
use crate::{read_e57, read_las, read_pcd, stream_ply, stream_xyz};

/// The batch size [`read_points_from`] reads with.
pub(crate) const COLLECT_CHUNK: usize = 1 << 18;

/// The shortest point record of an uncompressed format, bytes: an ASCII line `0 0 0`.
const SHORTEST_RECORD_BYTES: u64 = 6;

enum Inner<R: Read + Seek> {
    Las(read_las::LasStream),
    E57(Box<read_e57::E57Stream<R>>),
    Pcd(Box<read_pcd::PcdStream<R>>),
    Xyz(Box<stream_xyz::XyzStream<R>>),
    Ply(Box<stream_ply::PlyStream<R>>),
}

/// A LAS/LAZ, E57 or PCD file opened for reading in chunks: the header is read and checked
/// by [`PointStream::open`], the points by [`PointStream::for_each_chunk`].
///
/// ```
/// use std::io::Cursor;
/// use std::ops::ControlFlow;
/// use psi_io::{Format, PointStream};
///
/// let pcd = b"VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\n\
///             HEIGHT 1\nPOINTS 3\nDATA ascii\n0 0 0\n1 0 0\n0 1 0\n";
/// let stream = PointStream::open(Cursor::new(pcd.to_vec()), Format::Pcd).unwrap();
/// assert_eq!(stream.header().announced_points, 3);
/// let mut sizes = Vec::new();
/// let end = stream.for_each_chunk(2, |chunk| {
///     sizes.push(chunk.len());
///     ControlFlow::Continue(())
/// }).unwrap();
/// assert_eq!((sizes, end.points), (vec![2, 1], 3));
/// ```
pub struct PointStream<R: Read + Seek> {
    header: StreamHeader,
    inner: Inner<R>,
}

impl<R: Read + Seek> std::fmt::Debug for PointStream<R> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PointStream")
            .field("header", &self.header)
            .finish_non_exhaustive()
    }
}

impl<R: Read + Seek + Send + Sync + 'static> PointStream<R> {
    /// Opens `input` (positioned anywhere; read from its start) as `format`, one of
    /// [`Format::Las`], [`Format::Laz`] (the same reader: the header tells), [`Format::E57`],
    /// [`Format::Xyz`] (blocks of whole lines; the first point line says whether there are
    /// normals), [`Format::Ply`] (a point cloud only: a mesh is refused, to be read whole)
    /// or [`Format::Pcd`], and reads and checks its header.
    ///
    /// # Errors
    ///
    /// [`ReadError::Empty`] for an empty input; the format's header errors
    /// ([`ReadError::Las`], [`ReadError::UnsupportedPointFormat`], [`ReadError::E57`],
    /// [`ReadError::E57NoCoordinates`], [`ReadError::PcdHeader`], ...); a
    /// [`ReadError::Header`] for OBJ and PLY meshes, which are not read as streams.
    pub fn open(mut input: R, format: Format) -> Result<Self, ReadError> {
        let len = input.seek(SeekFrom::End(0)).map_err(io_error)?;
        input.seek(SeekFrom::Start(0)).map_err(io_error)?;
        if len == 0 {
            return Err(ReadError::Empty);
        }
        let (header, inner) = match format {
            Format::Las | Format::Laz => {
                let (h, s) = read_las::open(input, len)?;
                (h, Inner::Las(s))
            }
            Format::E57 => {
                let (h, s) = read_e57::open(input, len)?;
                (h, Inner::E57(Box::new(s)))
            }
            Format::Pcd => {
                let (h, s) = read_pcd::open(input, len)?;
                (h, Inner::Pcd(Box::new(s)))
            }
            Format::Xyz => {
                let (h, s) = stream_xyz::open(input)?;
                (h, Inner::Xyz(Box::new(s)))
            }
            Format::Ply => {
                let (h, s) = stream_ply::open(input)?;
                (h, Inner::Ply(Box::new(s)))
            }
            Format::Obj => {
                return Err(ReadError::Header {
                    reason: format!(
                        "{} files are read whole (read_points), not as a point stream",
                        format.name()
                    ),
                });
            }
        };
        Ok(Self { header, inner })
    }
}

impl<R: Read + Seek> PointStream<R> {
    /// What the header says.
    pub fn header(&self) -> &StreamHeader {
        &self.header
    }

    /// Reads every point record in file order (E57: scan by scan, each with its pose
    /// applied), handing them to `visit` in chunks, never empty, of at most `max_points`
    /// points (0 counts as 1); invalid records are skipped and counted. `visit` may stop
    /// the stream by returning [`ControlFlow::Break`]. Memory stays bounded by one chunk
    /// plus the decoder's own buffer (a LAZ chunk, an E57 data packet), except for PCD
    /// `binary_compressed`, whose column layout is decoded whole.
    ///
    /// # Errors
    ///
    /// The first malformed or truncated record ([`ReadError::TruncatedPoints`],
    /// [`ReadError::LazChunk`], [`ReadError::PcdData`], [`ReadError::E57`], ...); chunks
    /// before it have been visited.
    pub fn for_each_chunk(
        self,
        max_points: usize,
        mut visit: impl FnMut(PointChunk) -> ControlFlow<()>,
    ) -> Result<StreamEnd, ReadError> {
        let max_points = max_points.max(1);
        let header = self.header;
        match self.inner {
            Inner::Las(s) => s.for_each_chunk(&header, max_points, &mut visit),
            Inner::E57(s) => s.for_each_chunk(&header, max_points, &mut visit),
            Inner::Pcd(s) => s.for_each_chunk(&header, max_points, &mut visit),
            Inner::Xyz(s) => s.for_each_chunk(&header, max_points, &mut visit),
            Inner::Ply(s) => s.for_each_chunk(&header, max_points, &mut visit),
        }
    }
}

/// Reads the oriented points of a LAS/LAZ, E57 or PCD stream whole, through
/// [`PointStream`] in chunks of 2^18 points, and makes them a [`PointCloudFile`] as
/// [`crate::read_points`] does (normals normalised, zero ones dropped and counted; no
/// normals: [`crate::NormalSource::Missing`]). `opts` is unused (no faces) but kept for
/// symmetry with `read_points`.
///
/// # Errors
///
/// Those of [`PointStream::open`] and [`PointStream::for_each_chunk`];
/// [`ReadError::NoPoints`] when no valid point remains.
pub fn read_points_from<R: Read + Seek + Send + Sync + 'static>(
    input: R,
    format: Format,
    opts: &ReadOptions,
) -> Result<PointCloudFile, ReadError> {
    let mut input = input;
    // Room for the points the header announces, held once instead of grown by doubling (each
    // doubling copies what was read and faults in new pages), as far as the input's bytes can
    // hold them at the shortest record of an uncompressed format: a header that announces
    // more gets that much room and the reading ends in its error as before; a compressed
    // input (LAZ, E57, compressed PCD) may get less room than it needs, and grows.
    let room = remaining_bytes(&mut input).map_err(io_error)?;
    let stream = PointStream::open(input, format)?;
    let header = stream.header().clone();
    let capacity = header.announced_points.min(room / SHORTEST_RECORD_BYTES);
    let capacity = usize::try_from(capacity).unwrap_or(usize::MAX);
    let mut all = PointChunk::with_room(&header, capacity, COLLECT_CHUNK);
    let end = stream.for_each_chunk(COLLECT_CHUNK, |chunk| {
        append(&mut all, chunk);
        ControlFlow::Continue(())
    })?;
    let parsed = Parsed {
        vertices: all.positions,
        normals: all.normals,
        faces: Vec::new(),
        oriented: None,
        attributes: all.attributes,
        source: SourceInfo {
            format: Some(header.format),
            detail: Some(header.detail),
            scans: header.scans,
            invalid_points: end.invalid_points,
        },
    };
    mesh_to_points::to_point_cloud(parsed, opts)
}

/// The bytes from `input`'s position to its end (the position kept).
fn remaining_bytes(input: &mut (impl Seek + ?Sized)) -> std::io::Result<u64> {
    let at = input.stream_position()?;
    let end = input.seek(SeekFrom::End(0))?;
    input.seek(SeekFrom::Start(at))?;
    Ok(end.saturating_sub(at))
}

fn append(all: &mut PointChunk, mut chunk: PointChunk) {
    // (The first chunk is taken whole unless `all` has room for it already.)
    if all.positions.is_empty() && all.positions.capacity() < chunk.positions.len() {
        all.positions = std::mem::take(&mut chunk.positions);
    } else {
        all.positions.append(&mut chunk.positions);
    }
    if let (Some(to), Some(mut from)) = (all.normals.as_mut(), chunk.normals) {
        to.append(&mut from);
    }
    attributes::append(&mut all.attributes, chunk.attributes);
}
