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
    /// Points per LAZ chunk (fixed-size chunks; 0 otherwise): batches are decoded in whole
    /// chunks, many at once, so that the parallel decoder keeps every core busy.
    laz_chunk: u64,
}

/// LAZ chunks decoded per batch at least: enough that both cores get several whole chunks
/// (a batch cutting chunks, or a few chunks between two cores, leaves one idle).
const CHUNKS_PER_BATCH: u64 = 16;

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
    let laz_chunk = match reader.header().laz_vlr() {
        Ok(vlr) if checked.compressed && !vlr.uses_variable_size_chunks() => {
            u64::from(vlr.chunk_size())
        }
        _ => 0,
    };
    let stream = LasStream {
        reader,
        points: checked.points,
        compressed: checked.compressed,
        laz_chunk,
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
        // Decoded in whole LAZ chunks, at least CHUNKS_PER_BATCH of them; handed out in pieces
        // of at most `max` (so at most `decode` points are held at once).
        let max = max.max(1);
        let decode = match self.laz_chunk {
            0 => max as u64,
            c => (max as u64).max(CHUNKS_PER_BATCH * c).div_ceil(c) * c,
        };
        while index < self.points {
            let want = (self.points - index).min(decode);
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
            let (flow, handed) = hand_out(chunk, max, visit);
            index += handed as u64;
            if flow.is_break() {
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

/// Hands `all` to `visit` in pieces of at most `max` points, in order, until it breaks;
/// returns how it ended and the points handed out.
fn hand_out<F: FnMut(PointChunk) -> ControlFlow<()>>(
    mut all: PointChunk,
    max: usize,
    visit: &mut F,
) -> (ControlFlow<()>, usize) {
    if all.len() <= max {
        let n = all.len();
        return (visit(all), n);
    }
    // Cut from the end, so that each piece is copied once.
    let mut pieces = Vec::new();
    while all.len() > max {
        let start = (all.len() - 1) / max * max;
        pieces.push(all.split_off(start));
    }
    pieces.push(all);
    let mut handed = 0;
    for piece in pieces.into_iter().rev() {
        handed += piece.len();
        if visit(piece).is_break() {
            return (ControlFlow::Break(()), handed);
        }
    }
    (ControlFlow::Continue(()), handed)
}
