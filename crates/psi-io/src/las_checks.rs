//! Checks of a LAS/LAZ file's structure before the `las` and `laz` crates read it, so that a
//! hostile or truncated header gives a [`ReadError`] rather than an overflow, a huge
//! allocation or a decoder panic: the header's counts, scales and offsets against the file's
//! length (ASPRS LAS 1.4 R15 §2.4–2.6), the extended VLRs, and for LAZ the LASzip VLR and
//! chunk table (LASzip's format: an i64 offset to the chunk table at the start of the point
//! data, the table a version, a chunk count and arithmetic-coded chunk sizes).

use std::io::{Read, Seek, SeekFrom};

use las::raw;

use crate::error::ReadError;
use crate::point_chunk::io_error;

/// The largest decoded LAZ chunk accepted, in bytes (LASzip writes 50 000 points a chunk).
const MAX_CHUNK_BYTES: u64 = 256 << 20;

/// What the checks learn from the raw header.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Checked {
    /// Point records the header announces.
    pub(crate) points: u64,
    /// Whether the point data is LAZ-compressed.
    pub(crate) compressed: bool,
    /// The point data record format, 0–10.
    pub(crate) point_format: u8,
    /// LAS version (major, minor).
    pub(crate) version: (u8, u8),
}

pub(crate) fn las_error(reason: impl std::fmt::Display) -> ReadError {
    ReadError::Las {
        reason: reason.to_string(),
    }
}

fn read_u64_at<R: Read + Seek>(input: &mut R, at: u64) -> Result<u64, ReadError> {
    let mut b = [0u8; 8];
    input.seek(SeekFrom::Start(at)).map_err(io_error)?;
    input.read_exact(&mut b).map_err(io_error)?;
    Ok(u64::from_le_bytes(b))
}

/// Checks the public header block and the EVLR start of a LAS or LAZ file of `len` bytes;
/// leaves `input` anywhere.
pub(crate) fn check_header<R: Read + Seek>(input: &mut R, len: u64) -> Result<Checked, ReadError> {
    input.seek(SeekFrom::Start(0)).map_err(io_error)?;
    let raw = raw::Header::read_from(&mut *input).map_err(|e| match e {
        las::Error::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            las_error(format!("the file ends inside the header ({len} bytes)"))
        }
        other => las_error(other),
    })?;
    let id = raw.point_data_record_format;
    let compressed = id & 0x80 != 0;
    let point_format = if compressed { id & 0x3f } else { id };
    if point_format > 10 {
        return Err(ReadError::UnsupportedPointFormat {
            format: point_format,
        });
    }
    let (major, minor) = (raw.version.major, raw.version.minor);
    if major != 1 || minor > 4 {
        return Err(las_error(format!(
            "version {major}.{minor}; psi reads LAS 1.0 to 1.4"
        )));
    }
    let scales = [raw.x_scale_factor, raw.y_scale_factor, raw.z_scale_factor];
    let offsets = [raw.x_offset, raw.y_offset, raw.z_offset];
    if scales.iter().any(|s| !s.is_finite() || *s == 0.0) || offsets.iter().any(|o| !o.is_finite())
    {
        return Err(las_error(format!(
            "the scale factors {scales:?} must be finite and non-zero, the offsets {offsets:?} finite"
        )));
    }
    let points = if raw.number_of_point_records > 0 {
        u64::from(raw.number_of_point_records)
    } else {
        raw.large_file.map_or(0, |l| l.number_of_point_records)
    };
    let record = u64::from(raw.point_data_record_length);
    let start = u64::from(raw.offset_to_point_data);
    let end = points
        .checked_mul(record)
        .and_then(|bytes| bytes.checked_add(start))
        .ok_or_else(|| {
            las_error(format!(
                "the header announces {points} points of {record} bytes, more than a file holds"
            ))
        })?;
    if start > len {
        return Err(las_error(format!(
            "the point data starts at byte {start}, past the end of the file ({len} bytes)"
        )));
    }
    if !compressed && end > len {
        return Err(ReadError::TruncatedPoints {
            announced: points,
            read: (len - start) / record.max(1),
        });
    }
    if let Some(evlr) = raw.evlr.filter(|e| e.number_of_evlrs > 0) {
        // An EVLR header is 60 bytes; its record length, a u64, is at byte 20.
        let at = evlr.start_of_first_evlr;
        let fits = at.checked_add(60).is_some_and(|e| e <= len);
        let length = if fits {
            read_u64_at(input, at + 20)?
        } else {
            u64::MAX
        };
        if !fits || length > len - at - 60 {
            return Err(las_error(format!(
                "the extended VLR at byte {at} does not fit in the file ({len} bytes)"
            )));
        }
    }
    Ok(Checked {
        points,
        compressed,
        point_format,
        version: (major, minor),
    })
}

/// Checks the LASzip VLR and the chunk table of a LAZ file whose (already read) header is
/// `header`: item sizes against the record length, the chunk table's offset, count and sizes
/// against the file, and that its chunks hold every announced point.
pub(crate) fn check_laz<R: Read + Seek>(
    input: &mut R,
    len: u64,
    header: &las::Header,
    points: u64,
) -> Result<(), ReadError> {
    let vlr = header.laz_vlr().map_err(las_error)?;
    let record = u64::from(header.point_format().len());
    if vlr.items_size() != record {
        return Err(las_error(format!(
            "the LASzip VLR's items take {} bytes, the point records {record}",
            vlr.items_size()
        )));
    }
    let fixed = !vlr.uses_variable_size_chunks();
    if fixed && (vlr.chunk_size() == 0 || u64::from(vlr.chunk_size()) * record > MAX_CHUNK_BYTES) {
        return Err(las_error(format!(
            "a LAZ chunk size of {} points is not supported",
            vlr.chunk_size()
        )));
    }
    // The offset to the chunk table: at the start of the point data, or (when the writer could
    // not go back to write it) in the last 8 bytes of the file.
    let data_start = header_offset(input)?;
    let mut table = read_u64_at(input, data_start)? as i64;
    if table <= data_start as i64 && len >= 8 {
        table = read_u64_at(input, len - 8)? as i64;
    }
    if table <= data_start as i64 {
        return Err(las_error("the LAZ chunk table is missing"));
    }
    let table = table as u64;
    if table.checked_add(8).is_none_or(|e| e > len) {
        return Err(ReadError::LazChunk {
            first_point: 0,
            end: points,
            reason: format!(
                "the chunk table at byte {table} lies past the end of the file ({len} bytes): the file is truncated"
            ),
        });
    }
    let count = read_u64_at(input, table)? >> 32;
    let data_bytes = table.saturating_sub(data_start + 8);
    if count > data_bytes {
        return Err(las_error(format!(
            "the chunk table lists {count} chunks in {data_bytes} bytes of point data"
        )));
    }
    input.seek(SeekFrom::Start(data_start)).map_err(io_error)?;
    let chunks = laz::laszip::ChunkTable::read_from(&mut *input, &vlr)
        .map_err(|e| las_error(format!("cannot read the LAZ chunk table: {e}")))?;
    let (mut held, mut bytes) = (0u64, 0u64);
    for (i, entry) in chunks.as_ref().iter().enumerate() {
        let decoded = entry.point_count.checked_mul(record);
        if decoded.is_none_or(|d| d > MAX_CHUNK_BYTES) {
            return Err(las_error(format!(
                "LAZ chunk {i} announces {} points, more than psi accepts in one chunk",
                entry.point_count
            )));
        }
        held = held.saturating_add(entry.point_count);
        bytes = bytes.saturating_add(entry.byte_count);
    }
    if bytes > data_bytes {
        return Err(ReadError::LazChunk {
            first_point: 0,
            end: points,
            reason: format!(
                "the chunk table's chunks take {bytes} bytes, the file holds {data_bytes}: the file is truncated"
            ),
        });
    }
    if held < points {
        return Err(ReadError::TruncatedPoints {
            announced: points,
            read: held,
        });
    }
    Ok(())
}

/// The offset to the point data, from the raw header.
fn header_offset<R: Read + Seek>(input: &mut R) -> Result<u64, ReadError> {
    input.seek(SeekFrom::Start(0)).map_err(io_error)?;
    let raw = raw::Header::read_from(&mut *input).map_err(las_error)?;
    Ok(u64::from(raw.offset_to_point_data))
}
