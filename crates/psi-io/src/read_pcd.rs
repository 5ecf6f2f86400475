//! PCD reader (PCL's "The PCD (Point Cloud Data) file format", v0.7), written here: no
//! maintained crate reads `binary_compressed` without panicking on a hostile header. The
//! header is parsed by `pcd_header`; the data is read in batches:
//!
//! * `ascii`: one point per line, the values of every field (each `COUNT` times) separated by
//!   spaces; a packed `rgb` typed `F` may be written as its float or, as PCL ≥ 1.8 writes it,
//!   as the integer of its bits;
//! * `binary`: little-endian records of the fields in order, packed;
//! * `binary_compressed`: two u32 (compressed and decompressed size), then LZF data that
//!   decodes to the fields as columns (every point's first field, then every point's second,
//!   ...), read whole and transposed batch by batch.
//!
//! Points with a NaN or infinite position (PCL's invalid points in organised clouds) are
//! skipped and counted; a NaN normal becomes zero (dropped later, like a zero normal).
//! `VIEWPOINT` (the sensor pose) is not applied, as PCL does not apply it when loading.

use std::io::{BufRead, BufReader, Read, Seek, SeekFrom};
use std::ops::ControlFlow;

use glam::DVec3;
use rayon::prelude::*;

use crate::attributes::{AttributeKinds, intensity_value};
use crate::error::ReadError;
use crate::format::Format;
use crate::lzf;
use crate::pcd_header::{Encoding, Kind, PcdHeader, Slot, read_header};
use crate::point_chunk::{PointChunk, StreamEnd, StreamHeader, emit_if_full, emit_rest, io_error};

/// The largest batch buffer of binary records, in bytes.
const MAX_BATCH_BYTES: usize = 64 << 20;
/// The longest ASCII data line, in bytes.
const MAX_LINE: u64 = 1 << 20;

/// An opened PCD file, positioned at its data.
pub(crate) struct PcdStream<R: Read> {
    input: BufReader<R>,
    header: PcdHeader,
    /// Bytes of the file after the header.
    data_bytes: u64,
}

fn data_error(point: u64, reason: impl Into<String>) -> ReadError {
    ReadError::PcdData {
        point,
        reason: reason.into(),
    }
}

/// Reads and checks the header of a PCD file of `len` bytes.
pub(crate) fn open<R: Read + Seek>(
    mut input: R,
    len: u64,
) -> Result<(StreamHeader, PcdStream<R>), ReadError> {
    input.seek(SeekFrom::Start(0)).map_err(io_error)?;
    let mut input = BufReader::new(input);
    let header = read_header(&mut input)?;
    let encoding = match header.encoding {
        Encoding::Ascii => "ascii",
        Encoding::Binary => "binary",
        Encoding::Compressed => "binary_compressed",
    };
    let stream_header = StreamHeader {
        format: Format::Pcd,
        detail: format!(
            "PCD {}, {encoding}, {} x {}",
            header.version, header.width, header.height
        ),
        announced_points: header.points,
        scans: None,
        normals: header.normal.is_some(),
        attributes: AttributeKinds {
            colors: header.rgb.is_some(),
            intensity: header.intensity.is_some(),
            classification: false,
        },
    };
    let data_bytes = len.saturating_sub(header.bytes);
    Ok((
        stream_header,
        PcdStream {
            input,
            header,
            data_bytes,
        },
    ))
}

/// One point's values, before they are pushed to a chunk.
struct Values {
    p: DVec3,
    n: DVec3,
    rgb: u32,
    intensity: f64,
}

impl<R: Read> PcdStream<R> {
    /// Reads the points in batches of at most `max` (see
    /// [`crate::PointStream::for_each_chunk`]).
    pub(crate) fn for_each_chunk<F: FnMut(PointChunk) -> ControlFlow<()>>(
        mut self,
        header: &StreamHeader,
        max: usize,
        visit: &mut F,
    ) -> Result<StreamEnd, ReadError> {
        match self.header.encoding {
            Encoding::Ascii => self.ascii(header, max, visit),
            Encoding::Binary => self.binary(header, max, visit),
            Encoding::Compressed => self.compressed(header, max, visit),
        }
    }

    /// Adds a point to `chunk`, or counts it invalid.
    fn push(&self, v: Values, chunk: &mut PointChunk, end: &mut StreamEnd) {
        if !v.p.is_finite() {
            end.invalid_points += 1;
            return;
        }
        chunk.positions.push(v.p);
        if let Some(normals) = chunk.normals.as_mut() {
            normals.push(if v.n.is_finite() { v.n } else { DVec3::ZERO });
        }
        let a = &mut chunk.attributes;
        if let Some(colors) = a.colors.as_mut() {
            let [_, r, g, b] = v.rgb.to_be_bytes();
            colors.push([r, g, b]);
        }
        if let Some(values) = a.intensity.as_mut() {
            values.push(intensity_value(v.intensity));
        }
    }

    fn ascii<F: FnMut(PointChunk) -> ControlFlow<()>>(
        &mut self,
        header: &StreamHeader,
        max: usize,
        visit: &mut F,
    ) -> Result<StreamEnd, ReadError> {
        let h = self.header.clone();
        let mut end = StreamEnd::default();
        let mut chunk = PointChunk::fresh(header, max);
        let mut raw = Vec::new();
        let mut line = h.lines;
        let mut point = 0u64;
        while point < h.points {
            raw.clear();
            let n = (&mut self.input)
                .take(MAX_LINE)
                .read_until(b'\n', &mut raw)
                .map_err(io_error)?;
            line += 1;
            if n == 0 {
                return Err(ReadError::TruncatedPoints {
                    announced: h.points,
                    read: point,
                });
            }
            if n as u64 == MAX_LINE && raw.last() != Some(&b'\n') {
                return Err(data_error(
                    point,
                    format!("line {line} is longer than 1 MiB"),
                ));
            }
            let text = std::str::from_utf8(&raw)
                .map_err(|_| data_error(point, format!("line {line} is not valid UTF-8 text")))?;
            let tokens: Vec<&str> = text.split_ascii_whitespace().collect();
            if tokens.is_empty() {
                continue;
            }
            if tokens.len() != h.tokens {
                return Err(data_error(
                    point,
                    format!(
                        "line {line} has {} values, the header's FIELDS and COUNT announce {}",
                        tokens.len(),
                        h.tokens
                    ),
                ));
            }
            let bad = |t: &str| data_error(point, format!("line {line}: {t:?} is not a number"));
            if let Some(t) = tokens.iter().find(|t| t.parse::<f64>().is_err()) {
                return Err(bad(t));
            }
            let at = |s: Slot| tokens[s.token].parse::<f64>().unwrap_or(f64::NAN);
            let [x, y, z] = h.position.map(at);
            let n = h.normal.map_or(DVec3::ZERO, |n| {
                let [a, b, c] = n.map(at);
                DVec3::new(a, b, c)
            });
            let rgb = match h.rgb {
                Some(s) => packed_colour(tokens[s.token], s.kind).ok_or_else(|| {
                    data_error(
                        point,
                        format!("line {line}: {:?} is not a packed colour", tokens[s.token]),
                    )
                })?,
                None => 0,
            };
            let v = Values {
                p: DVec3::new(x, y, z),
                n,
                rgb,
                intensity: h.intensity.map_or(0.0, at),
            };
            self.push(v, &mut chunk, &mut end);
            point += 1;
            if emit_if_full(&mut chunk, header, max, &mut end, visit) {
                return Ok(end);
            }
        }
        // Nothing but blank lines may follow the announced points.
        loop {
            raw.clear();
            let n = (&mut self.input)
                .take(MAX_LINE)
                .read_until(b'\n', &mut raw)
                .map_err(io_error)?;
            if n == 0 {
                break;
            }
            if !raw.iter().all(u8::is_ascii_whitespace) {
                return Err(data_error(
                    h.points,
                    format!("data follows the {} points the header announces", h.points),
                ));
            }
        }
        Ok(emit_rest(chunk, end, visit))
    }

    fn binary<F: FnMut(PointChunk) -> ControlFlow<()>>(
        &mut self,
        header: &StreamHeader,
        max: usize,
        visit: &mut F,
    ) -> Result<StreamEnd, ReadError> {
        let (points, record) = (self.header.points, self.header.record);
        let available = self.data_bytes / record as u64;
        if available < points {
            return Err(ReadError::TruncatedPoints {
                announced: points,
                read: available,
            });
        }
        if self.data_bytes - points * record as u64 >= record as u64 {
            return Err(data_error(
                points,
                format!(
                    "{} bytes follow the {points} points of {record} bytes the header announces",
                    self.data_bytes - points * record as u64
                ),
            ));
        }
        let batch = max.min((MAX_BATCH_BYTES / record).max(1));
        let mut buffer = Vec::new();
        let mut end = StreamEnd::default();
        let mut point = 0u64;
        while point < points {
            let n = (points - point).min(batch as u64) as usize;
            buffer.resize(n * record, 0);
            self.input.read_exact(&mut buffer).map_err(|e| {
                if e.kind() == std::io::ErrorKind::UnexpectedEof {
                    ReadError::TruncatedPoints {
                        announced: points,
                        read: point,
                    }
                } else {
                    io_error(e)
                }
            })?;
            // (Decoded in parallel, in order; pushed in order.)
            let values: Vec<Values> = buffer
                .par_chunks_exact(record)
                .map(|rec| record_values(&self.header, rec))
                .collect();
            let mut chunk = PointChunk::for_header(header, n);
            for v in values {
                self.push(v, &mut chunk, &mut end);
            }
            point += n as u64;
            end.points += chunk.len() as u64;
            if !chunk.is_empty() && visit(chunk).is_break() {
                break;
            }
        }
        Ok(end)
    }

    fn compressed<F: FnMut(PointChunk) -> ControlFlow<()>>(
        &mut self,
        header: &StreamHeader,
        max: usize,
        visit: &mut F,
    ) -> Result<StreamEnd, ReadError> {
        let (points, record) = (self.header.points, self.header.record);
        let mut sizes = [0u8; 8];
        if points == 0 && self.data_bytes < 8 {
            return Ok(StreamEnd::default());
        }
        self.input
            .read_exact(&mut sizes)
            .map_err(|_| data_error(0, "the file ends before the compressed block's sizes"))?;
        let word = |k: usize| {
            u64::from(u32::from_le_bytes([
                sizes[k],
                sizes[k + 1],
                sizes[k + 2],
                sizes[k + 3],
            ]))
        };
        let (packed, unpacked) = (word(0), word(4));
        let expected = points.checked_mul(record as u64);
        if expected != Some(unpacked) {
            return Err(data_error(
                0,
                format!(
                    "the header's {points} points of {record} bytes need {} bytes, the compressed block decodes to {unpacked}",
                    expected.map_or("more".to_owned(), |e| e.to_string())
                ),
            ));
        }
        let left = self.data_bytes - 8;
        if packed > left {
            return Err(data_error(
                0,
                format!(
                    "the compressed block announces {packed} bytes, the file holds {left}: the file is truncated"
                ),
            ));
        }
        if unpacked > packed.saturating_mul(lzf::MAX_EXPANSION) {
            return Err(data_error(
                0,
                format!("{packed} compressed bytes cannot decode to {unpacked}"),
            ));
        }
        let mut block = vec![0u8; packed as usize];
        self.input.read_exact(&mut block).map_err(io_error)?;
        let columns = lzf::decompress(&block, unpacked as usize)
            .map_err(|e| data_error(0, format!("LZF data: {e}")))?;
        drop(block);
        // Column f starts after the columns before it, each `field_bytes × points` long.
        let mut starts = Vec::with_capacity(self.header.field_bytes.len());
        let mut at = 0usize;
        for &b in &self.header.field_bytes {
            starts.push(at);
            at += b * points as usize;
        }
        let batch = max.min((MAX_BATCH_BYTES / record).max(1));
        let mut rows = Vec::new();
        let mut end = StreamEnd::default();
        let mut point = 0usize;
        while (point as u64) < points {
            let n = (points as usize - point).min(batch);
            rows.clear();
            for i in point..point + n {
                for (f, &b) in self.header.field_bytes.iter().enumerate() {
                    let from = starts[f] + i * b;
                    rows.extend_from_slice(&columns[from..from + b]);
                }
            }
            let mut chunk = PointChunk::for_header(header, n);
            for rec in rows.chunks_exact(record) {
                let v = record_values(&self.header, rec);
                self.push(v, &mut chunk, &mut end);
            }
            point += n;
            end.points += chunk.len() as u64;
            if !chunk.is_empty() && visit(chunk).is_break() {
                break;
            }
        }
        Ok(end)
    }
}

/// The values of one binary record `rec` of a file with header `h`.
fn record_values(h: &PcdHeader, rec: &[u8]) -> Values {
    let at = |s: Slot| number(&rec[s.offset..s.offset + s.size], s.kind);
    let [x, y, z] = h.position.map(at);
    let n = h.normal.map_or(DVec3::ZERO, |n| {
        let [a, b, c] = n.map(at);
        DVec3::new(a, b, c)
    });
    let rgb = h.rgb.map_or(0, |s| {
        let mut b = [0u8; 4];
        b.copy_from_slice(&rec[s.offset..s.offset + 4]);
        u32::from_le_bytes(b)
    });
    Values {
        p: DVec3::new(x, y, z),
        n,
        rgb,
        intensity: h.intensity.map_or(0.0, at),
    }
}

/// A little-endian value of `bytes.len()` bytes (1, 2, 4 or 8) and type `kind`, as f64.
fn number(bytes: &[u8], kind: Kind) -> f64 {
    let mut b = [0u8; 8];
    b[..bytes.len()].copy_from_slice(bytes);
    let wide = u64::from_le_bytes(b);
    match (kind, bytes.len()) {
        (Kind::F, 4) => f64::from(f32::from_bits(wide as u32)),
        (Kind::F, _) => f64::from_bits(wide),
        (Kind::U, _) => wide as f64,
        (Kind::I, n) => {
            // Sign-extend from n bytes.
            let shift = 64 - 8 * n as u32;
            (((wide << shift) as i64) >> shift) as f64
        }
    }
}

/// A packed colour written as text: the integer of its bits, or (for `F`) a float whose bits
/// are the colour.
fn packed_colour(token: &str, kind: Kind) -> Option<u32> {
    if let Ok(bits) = token.parse::<u32>() {
        return Some(bits);
    }
    match kind {
        Kind::F => token.parse::<f32>().ok().map(f32::to_bits),
        Kind::I => token.parse::<i32>().ok().map(|v| v as u32),
        Kind::U => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_decode_by_type() {
        assert_eq!(number(&(-3i16).to_le_bytes(), Kind::I), -3.0);
        assert_eq!(number(&[0xff], Kind::U), 255.0);
        assert_eq!(number(&[0xff], Kind::I), -1.0);
        assert_eq!(number(&1.5f32.to_le_bytes(), Kind::F), 1.5);
        assert_eq!(number(&(-2.25f64).to_le_bytes(), Kind::F), -2.25);
        assert_eq!(number(&u64::MAX.to_le_bytes(), Kind::U), u64::MAX as f64);
    }

    #[test]
    fn packed_colours_read_as_bits_or_floats() {
        let bits = 0x00ff_8001u32;
        assert_eq!(packed_colour(&bits.to_string(), Kind::F), Some(bits));
        let float = f32::from_bits(bits);
        assert_eq!(packed_colour(&format!("{float:e}"), Kind::F), Some(bits));
        assert_eq!(packed_colour("x", Kind::U), None);
    }
}
