//! E57 reader (ASTM E2807, "3D Imaging Data Exchange") on the `e57` crate: every scan of the
//! file's `data3D` list in order, each with its pose (`pose`: rotation quaternion then
//! translation, §8.4.3) applied, so all scans share the file's coordinate system. A scan
//! gives positions from `cartesianX/Y/Z` or, where those are missing or invalid, from
//! `sphericalRange/Azimuth/Elevation` (§8.4.4); returns flagged invalid
//! (`cartesianInvalidState` / `sphericalInvalidState` not 0) or direction-only are skipped and
//! counted. Colour is scaled from the scan's `colorLimits` to 0–255; intensity is the raw
//! value (0 where `isIntensityInvalid`).

use std::io::{Read, Seek, SeekFrom};
use std::ops::ControlFlow;

use e57::{CartesianCoordinate, E57Reader, PointCloud};
use glam::DVec3;

use crate::attributes::{AttributeKinds, channel_from_unit};
use crate::error::ReadError;
use crate::format::Format;
use crate::point_chunk::{PointChunk, StreamEnd, StreamHeader, emit_if_full, emit_rest, io_error};

/// An opened E57 file: the reader and its scans' descriptions.
pub(crate) struct E57Stream<R: Read + Seek> {
    reader: E57Reader<R>,
    scans: Vec<PointCloud>,
}

fn e57_error(reason: impl std::fmt::Display) -> ReadError {
    ReadError::E57 {
        reason: reason.to_string(),
    }
}

/// Checks the file header's XML section against the file's length (ASTM E2807 §9.3: the
/// 48-byte header holds the XML section's physical offset and logical length), so that the
/// crate never allocates for a section the file cannot hold.
fn check_header<R: Read + Seek>(input: &mut R, len: u64) -> Result<(), ReadError> {
    let mut head = [0u8; 48];
    input.seek(SeekFrom::Start(0)).map_err(io_error)?;
    input.read_exact(&mut head).map_err(|_| {
        e57_error(format!(
            "the file ends inside its 48-byte header ({len} bytes)"
        ))
    })?;
    if &head[..8] != b"ASTM-E57" {
        return Err(e57_error(
            "the file does not start with the signature ASTM-E57",
        ));
    }
    let word = |at: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&head[at..at + 8]);
        u64::from_le_bytes(b)
    };
    let (offset, length) = (word(24), word(32));
    if offset >= len || length > len {
        return Err(e57_error(format!(
            "the XML section ({length} bytes at byte {offset}) does not fit in the file ({len} bytes)"
        )));
    }
    Ok(())
}

/// Checks and reads the header and XML section of an E57 file of `len` bytes.
pub(crate) fn open<R: Read + Seek>(
    mut input: R,
    len: u64,
) -> Result<(StreamHeader, E57Stream<R>), ReadError> {
    check_header(&mut input, len)?;
    input.seek(SeekFrom::Start(0)).map_err(io_error)?;
    let reader = E57Reader::new(input).map_err(e57_error)?;
    let scans = reader.pointclouds();
    if let Some(scan) = scans
        .iter()
        .position(|s| !s.has_cartesian() && !s.has_spherical())
    {
        return Err(ReadError::E57NoCoordinates { scan });
    }
    let announced = scans
        .iter()
        .fold(0u64, |sum, s| sum.saturating_add(s.records));
    let e57_header = reader.header();
    let header = StreamHeader {
        format: Format::E57,
        detail: format!(
            "E57 {}.{}, {} scan{}",
            e57_header.major,
            e57_header.minor,
            scans.len(),
            if scans.len() == 1 { "" } else { "s" }
        ),
        announced_points: announced,
        scans: Some(scans.len()),
        normals: false,
        attributes: AttributeKinds {
            colors: scans.iter().any(PointCloud::has_color),
            intensity: scans.iter().any(PointCloud::has_intensity),
            classification: false,
        },
    };
    Ok((header, E57Stream { reader, scans }))
}

impl<R: Read + Seek> E57Stream<R> {
    /// Reads the scans' points in batches of at most `max` (see
    /// [`crate::PointStream::for_each_chunk`]). A scan without colour (intensity) in a file
    /// where another has it gives black (0), as does a point flagged invalid for it.
    pub(crate) fn for_each_chunk<F: FnMut(PointChunk) -> ControlFlow<()>>(
        mut self,
        header: &StreamHeader,
        max: usize,
        visit: &mut F,
    ) -> Result<StreamEnd, ReadError> {
        let mut end = StreamEnd::default();
        let mut chunk = PointChunk::fresh(header, max);
        for (index, scan) in self.scans.iter().enumerate() {
            let scan_error =
                |point: u64, e: e57::Error| e57_error(format!("scan {index}, point {point}: {e}"));
            let mut points = self
                .reader
                .pointcloud_simple(scan)
                .map_err(|e| scan_error(0, e))?;
            points.apply_pose(true);
            points.spherical_to_cartesian(true);
            points.intensity_to_color(false);
            points.normalize_intensity(false);
            points.normalize_color(true);
            for (i, point) in points.enumerate() {
                let point = point.map_err(|e| scan_error(i as u64, e))?;
                let p = match point.cartesian {
                    CartesianCoordinate::Valid { x, y, z } => DVec3::new(x, y, z),
                    _ => DVec3::NAN,
                };
                if !p.is_finite() {
                    end.invalid_points += 1;
                    continue;
                }
                chunk.positions.push(p);
                let attributes = &mut chunk.attributes;
                if let Some(colors) = attributes.colors.as_mut() {
                    colors.push(point.color.map_or([0; 3], |c| {
                        [c.red, c.green, c.blue].map(|v| channel_from_unit(f64::from(v)))
                    }));
                }
                if let Some(values) = attributes.intensity.as_mut() {
                    values.push(point.intensity.filter(|v| v.is_finite()).unwrap_or(0.0));
                }
                if emit_if_full(&mut chunk, header, max, &mut end, visit) {
                    return Ok(end);
                }
            }
        }
        Ok(emit_rest(chunk, end, visit))
    }
}
