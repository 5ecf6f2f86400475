//! LAS 1.0–1.4 and LAZ reader (ASPRS LAS Specification 1.4 R15) on the `las` crate, LAZ
//! decoded by the `laz` crate with its parallel chunk decoder. Positions are the records'
//! integers with the header's scale and offset applied (LAS 1.4 R15 §2.4: `X = Xrecord ×
//! scale + offset`), in f64; colour (point formats 2, 3, 5, 7, 8, 10) is kept as its high
//! byte (8-bit colour is stored × 256, §2.6 Table 8 note), intensity as its raw u16 value,
//! classification as the class code (the low 5 bits in formats 0–5, the whole byte in 6–10).
//! The structure is checked first (`las_checks`), so a hostile file is an error, not a panic.

use std::io::{Read, Seek, SeekFrom};
use std::ops::ControlFlow;

use glam::DVec3;
use las::PointDataBuilder;

use crate::attributes::{AttributeKinds, channel_from_u16};
use crate::error::ReadError;
use crate::format::Format;
use crate::las_checks::{check_header, check_laz, las_error};
use crate::point_chunk::{PointChunk, StreamEnd, StreamHeader, io_error};

/// An opened LAS/LAZ file: the `las` reader past the header.
pub(crate) struct LasStream {
    reader: las::Reader,
    points: u64,
    compressed: bool,
}

/// Checks and reads the header of a LAS or LAZ file of `len` bytes.
pub(crate) fn open<R: Read + Seek + Send + Sync + 'static>(
    mut input: R,
    len: u64,
) -> Result<(StreamHeader, LasStream), ReadError> {
    let checked = check_header(&mut input, len)?;
    if checked.compressed {
        input.seek(SeekFrom::Start(0)).map_err(io_error)?;
        let header = las::Header::new(&mut input).map_err(las_error)?;
        check_laz(&mut input, len, &header, checked.points)?;
    }
    input.seek(SeekFrom::Start(0)).map_err(io_error)?;
    let reader = las::Reader::new(input).map_err(las_error)?;
    let has_color = reader.header().point_format().has_color;
    let (major, minor) = checked.version;
    let header = StreamHeader {
        format: if checked.compressed {
            Format::Laz
        } else {
            Format::Las
        },
        detail: format!(
            "LAS {major}.{minor}, point format {}{}",
            checked.point_format,
            if checked.compressed { ", LAZ" } else { "" }
        ),
        announced_points: checked.points,
        scans: None,
        normals: false,
        attributes: AttributeKinds {
            colors: has_color,
            intensity: true,
            classification: true,
        },
    };
    let stream = LasStream {
        reader,
        points: checked.points,
        compressed: checked.compressed,
    };
    Ok((header, stream))
}

impl LasStream {
    /// Reads the points in batches of at most `max` (see
    /// [`crate::PointStream::for_each_chunk`]).
    pub(crate) fn for_each_chunk<F: FnMut(PointChunk) -> ControlFlow<()>>(
        mut self,
        header: &StreamHeader,
        max: usize,
        visit: &mut F,
    ) -> Result<StreamEnd, ReadError> {
        let mut data = PointDataBuilder::new()
            .for_header(self.reader.header())
            .build();
        let mut index = 0u64;
        while index < self.points {
            let want = (self.points - index).min(max as u64);
            let got = self
                .reader
                .fill_points(want, &mut data)
                .map_err(|e| self.error(e, index, want))?;
            if got == 0 {
                return Err(ReadError::TruncatedPoints {
                    announced: self.points,
                    read: index,
                });
            }
            let n = data.len();
            let mut chunk = PointChunk::for_header(header, n);
            chunk.positions.extend(
                data.x()
                    .zip(data.y())
                    .zip(data.z())
                    .map(|((x, y), z)| DVec3::new(x, y, z)),
            );
            if let Some(bad) = chunk.positions.iter().position(|p| !p.is_finite()) {
                return Err(ReadError::NonFinite {
                    element: "point",
                    index: usize::try_from(index)
                        .unwrap_or(usize::MAX)
                        .saturating_add(bad),
                    what: "position",
                    line: None,
                });
            }
            let attributes = &mut chunk.attributes;
            if let (Some(colors), Some(rgb)) = (attributes.colors.as_mut(), data.rgb()) {
                colors.extend(rgb.map(|(r, g, b)| {
                    [
                        channel_from_u16(r),
                        channel_from_u16(g),
                        channel_from_u16(b),
                    ]
                }));
            }
            if let Some(values) = attributes.intensity.as_mut() {
                values.extend(data.intensity().map(f32::from));
            }
            if let Some(classes) = attributes.classification.as_mut() {
                classes.extend(data.classification());
            }
            index += got;
            if visit(chunk).is_break() {
                break;
            }
        }
        Ok(StreamEnd {
            points: index,
            invalid_points: 0,
        })
    }

    /// The error of decoding the points `first..first + want`.
    fn error(&self, e: las::Error, first: u64, want: u64) -> ReadError {
        let eof =
            matches!(&e, las::Error::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof);
        if self.compressed {
            ReadError::LazChunk {
                first_point: first,
                end: first + want,
                reason: e.to_string(),
            }
        } else if eof {
            ReadError::TruncatedPoints {
                announced: self.points,
                read: first,
            }
        } else {
            las_error(e)
        }
    }
}
