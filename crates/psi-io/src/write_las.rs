//! LAS 1.4 and LAZ writer (ASPRS LAS Specification 1.4 R15) on the `las` crate's writer, LAZ
//! compressed by the `laz` crate in parallel. One point data record format, 7 (positions, the
//! extended flags, GPS time and RGB): the smallest LAS 1.4 format that holds colour with the
//! full-byte classification, and one layout whatever attributes are present, so every reader
//! gets the same columns.
//!
//! The `las` writer wants a `'static + Send + Sync` stream and rewrites its header when it is
//! closed or dropped, panicking if that fails. It is therefore given a [`Spool`] instead of the
//! caller's writer: a log of positioned writes that never fails, applied to the caller's writer
//! after every batch of points. An I/O error of the caller's writer is returned as such; the
//! `las` writer never sees it, so it never panics.

use std::io::{Seek, SeekFrom, Write};
use std::sync::{Arc, Mutex, PoisonError};

use glam::DVec3;
use las::raw::point::{Flags, ScanAngle};
use las::{Builder, Color, PointDataBuilder, Transform, Vector, Version};

use crate::attributes::PointAttributes;
use crate::error::WriteError;
use crate::write_ply::check_attribute_lengths;

/// The point data record format written (ASPRS LAS 1.4 R15 Table 14 with RGB: 36 bytes).
const POINT_FORMAT: u8 = 7;

/// Points encoded and handed to the `las` writer at a time: eight LAZ chunks of the `las`
/// crate's default 50 000 points, so the parallel compressor has whole chunks to share out.
const BATCH: usize = 8 * 50_000;

/// The LAS scale used when every position is exactly the origin (or there is none): the `las`
/// crate's and most tools' default, 1 mm for metres.
const DEFAULT_SCALE: f64 = 1e-3;

/// Writes points with their attributes as a LAS 1.4 file, LAZ-compressed when `compressed`.
///
/// * `w`: where the file goes, from its current position; left positioned after the file's
///   last byte.
/// * `positions`: N points (shape: N), world units, f64, all finite.
/// * `attributes`: colour, intensity, classification, each column with N entries or absent.
/// * `compressed`: LAZ (LASzip, `laz` crate, parallel) instead of plain LAS.
///
/// **Layout.** LAS 1.4, point data record format 7 (with or without attributes: absent
/// columns are written as zeros; the header's version and format, and a LASzip VLR for LAZ,
/// tell the readers). Each record: the quantised position; intensity rounded and clamped to
/// 0–65535 (NaN as 0, the readers' value for an undefined intensity); return 1 of 1;
/// classification the byte as given (format 7 stores the whole byte, so every `u8` is a valid
/// class: ASPRS 1.4 R15 Table 17, 0–63 defined or reserved, 64–255 user definable); colour
/// 16 bits a channel as `v × 257`, so that an 8-bit reader's high byte (`>> 8`, what
/// [`crate::read_points_from`] keeps) gives `v` back exactly and 255 maps to 65535; GPS time,
/// scan angle, user data and point source 0. The header has no creation date, so the same
/// points give the same bytes.
///
/// **Scale and offset.** LAS stores each coordinate as an i32 `X` with `x = X × s + o`. With
/// `lo`, `hi` the data's bounding box, `H` the largest half-extent `(hi − lo) / 2` over the
/// three axes and `M` the largest coordinate magnitude, the scale `s` (one for all three axes)
/// is the smallest power of ten with
///
/// * `H / s ≤ 2^30`, i.e. extent / s ≤ 2^31: the data spans at most half of i32's range around
///   the offset, the other half a margin for the rounding below; and
/// * `s ≥ M × 2^-46`: no finer than 64 ulps of the coordinates' f64 magnitude, below which
///   quantising would only fit f64 rounding (this binds only when the extent is below 2^-15
///   of the distance from the origin: under 152 m at 5e6 m, where it gives 1e-7 m);
///
/// or 0.001 when all positions are the origin. The offset is the bounding box's centre `c`
/// rounded to a multiple of `s` (the decimal `round(c / s) × s`), so the stored positions lie
/// on the global grid of multiples of `s`, the same for every tile written at that scale, and
/// `|X| ≤ 2^30 + 1`.
///
/// **Precision.** Each coordinate reads back within `s / 2` of the written one (the rounding
/// to the grid), plus the f64 rounding of `(x − o) / s` and `X × s + o`, below `s / 100` by
/// the second rule: `|x' − x| ≤ 0.51 s`. Relative to the extent E (largest axis),
/// `s < 10 × E / 2^31 < 4.7e-9 E` when the first rule sets `s`, and `s < 10 × M × 2^-46
/// < 1.5e-13 M` when the second does. A unit-sized model at the origin gets `s` = 1e-9; a
/// survey tile at (5e5, 5e6, 100) m gets 1e-7 m up to 214 m across, 1e-6 m up to 2.1 km.
///
/// Nothing is written when an argument is invalid.
///
/// # Errors
///
/// * [`WriteError::LengthMismatch`] when an attribute column does not have N entries;
/// * [`WriteError::NonFinite`] naming the first point with a NaN or infinite coordinate;
/// * [`WriteError::Io`] when `w` fails (the file is then incomplete);
/// * [`WriteError::Las`] when the `las` crate refuses the header or points (not expected).
///
/// ```
/// use std::io::Cursor;
/// use glam::DVec3;
/// use psi_io::{read_points_from, write_las, Format, PointAttributes, ReadOptions};
///
/// let positions = [DVec3::new(5e5, 5e6, 100.0), DVec3::new(5e5 + 20.0, 5e6 + 10.0, 101.0)];
/// let attributes = PointAttributes {
///     colors: Some(vec![[255, 0, 7], [1, 2, 3]]),
///     intensity: Some(vec![12.0, 65535.0]),
///     classification: Some(vec![2, 6]),
/// };
/// let mut file = Cursor::new(Vec::new());
/// write_las(&mut file, &positions, &attributes, true).unwrap();
/// let back = read_points_from(file, Format::Laz, &ReadOptions::paper()).unwrap();
/// // 20 m across at 5e6 m: s = 1e-7 m (the second rule: 5e6 × 2^-46 ≈ 7.1e-8).
/// assert!((back.points[1].p - positions[1]).abs().max_element() <= 0.51e-7);
/// assert_eq!(back.attributes, attributes);
/// ```
pub fn write_las<W: Write + Seek>(
    mut w: W,
    positions: &[DVec3],
    attributes: &PointAttributes,
    compressed: bool,
) -> Result<(), WriteError> {
    let n = positions.len();
    check_attribute_lengths(attributes, n)?;
    if let Some(index) = positions.iter().position(|p| !p.is_finite()) {
        return Err(WriteError::NonFinite { index });
    }
    let grid = Grid::of(positions);

    let mut builder = Builder::from(Version::new(1, 4));
    builder.point_format = las::point::Format::new(POINT_FORMAT).map_err(las_error)?;
    builder.point_format.is_compressed = compressed;
    builder.transforms = Vector {
        x: grid.transform(0),
        y: grid.transform(1),
        z: grid.transform(2),
    };
    builder.generating_software = format!("psi-io {}", env!("CARGO_PKG_VERSION"));
    builder.system_identifier = "psi".to_owned();
    let header = builder.into_header().map_err(las_error)?;

    let base = w.stream_position()?;
    let spool = Spool::default();
    let mut out = Applied { w, base, at: base };
    let mut writer = las::Writer::new(spool.clone(), header).map_err(las_error)?;
    let written = write_batches(&mut writer, &spool, &mut out, positions, attributes, &grid);
    let closed = writer.close();
    if closed.is_err() {
        // The header could not be rewritten; dropping the writer would try again and panic.
        std::mem::forget(writer);
    } else {
        drop(writer);
    }
    written?;
    closed.map_err(las_error)?;
    out.apply(&spool)?;
    let end = base + spool.end();
    if out.at != end {
        out.w.seek(SeekFrom::Start(end))?;
    }
    out.w.flush()?;
    Ok(())
}

/// Encodes the points in batches, hands each to the `las` writer and applies what it wrote.
fn write_batches<W: Write + Seek>(
    writer: &mut las::Writer<Spool>,
    spool: &Spool,
    out: &mut Applied<W>,
    positions: &[DVec3],
    attributes: &PointAttributes,
    grid: &Grid,
) -> Result<(), WriteError> {
    let format = *writer.header().point_format();
    let record = usize::from(format.len());
    let mut data = PointDataBuilder::new().for_header(writer.header()).build();
    for first in (0..positions.len()).step_by(BATCH) {
        let end = (first + BATCH).min(positions.len());
        let bytes = data.resize_for(end - first);
        for (i, slot) in (first..end).zip(bytes.chunks_exact_mut(record)) {
            let point = raw_point(i, positions[i], attributes, grid)?;
            point.write_to(slot, &format).map_err(las_error)?;
        }
        writer.write_points(&data).map_err(las_error)?;
        out.apply(spool)?;
    }
    Ok(())
}

/// The format-7 record of point `i`.
fn raw_point(
    i: usize,
    p: DVec3,
    attributes: &PointAttributes,
    grid: &Grid,
) -> Result<las::raw::Point, WriteError> {
    let [x, y, z] = grid.quantise(i, p)?;
    let intensity = attributes
        .intensity
        .as_ref()
        .map_or(0, |v| intensity_u16(v[i]));
    let class = attributes.classification.as_ref().map_or(0, |v| v[i]);
    let color = attributes.colors.as_ref().map_or(Color::default(), |c| {
        let [r, g, b] = c[i];
        Color::new(channel_u16(r), channel_u16(g), channel_u16(b))
    });
    Ok(las::raw::Point {
        x,
        y,
        z,
        intensity,
        // Return 1 of 1 (low and high nibbles); no classification flags, scanner channel 0;
        // the classification byte.
        flags: Flags::ThreeByte(0x11, 0, class),
        scan_angle: ScanAngle::Scaled(0),
        gps_time: Some(0.0),
        color: Some(color),
        ..las::raw::Point::default()
    })
}

/// An 8-bit colour channel as LAS's 16 bits: `v × 257` (0 → 0, 255 → 65535), whose high byte
/// is `v`.
fn channel_u16(v: u8) -> u16 {
    u16::from(v) * 257
}

/// An intensity as LAS's u16: rounded, clamped to 0–65535, NaN as 0.
fn intensity_u16(v: f32) -> u16 {
    // `as` saturates and maps NaN to 0.
    v.round() as u16
}

fn las_error(e: impl std::fmt::Display) -> WriteError {
    WriteError::Las {
        reason: e.to_string(),
    }
}

/// The quantisation: one scale for the three axes, an offset per axis.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Grid {
    scale: f64,
    offset: [f64; 3],
}

impl Grid {
    /// The scale and offsets of `positions` (all finite), by the rule of [`write_las`].
    fn of(positions: &[DVec3]) -> Self {
        let (lo, hi) = positions
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
                (lo.min(p), hi.max(p))
            });
        if positions.is_empty() {
            return Grid {
                scale: DEFAULT_SCALE,
                offset: [0.0; 3],
            };
        }
        // Halved before subtracting or adding, so that no finite input overflows.
        let half = hi * 0.5 - lo * 0.5;
        let centre = lo * 0.5 + hi * 0.5;
        let magnitude = lo.abs().max(hi.abs()).max_element();
        let least = (half.max_element() * 2f64.powi(-30)).max(magnitude * 2f64.powi(-46));
        if least == 0.0 {
            return Grid {
                scale: DEFAULT_SCALE,
                offset: [0.0; 3],
            };
        }
        let k = power_of_ten_exponent(least);
        let scale = pow10(k);
        // |c / s| ≤ M / s ≤ 2^46: an exact integer; the offset is the decimal `K × 10^k`.
        let offset = centre
            .to_array()
            .map(|c| format!("{}e{k}", (c / scale).round()).parse().unwrap_or(c));
        Grid { scale, offset }
    }

    fn transform(&self, axis: usize) -> Transform {
        Transform {
            scale: self.scale,
            offset: self.offset[axis],
        }
    }

    /// The stored integers of point `index` at `p`.
    fn quantise(&self, index: usize, p: DVec3) -> Result<[i32; 3], WriteError> {
        let mut out = [0; 3];
        for (k, v) in p.to_array().into_iter().enumerate() {
            let q = ((v - self.offset[k]) / self.scale).round();
            // |q| ≤ 2^30 + 1 by the choice of scale and offset; checked all the same.
            if !(f64::from(i32::MIN)..=f64::from(i32::MAX)).contains(&q) {
                return Err(WriteError::Las {
                    reason: format!(
                        "point {index}: coordinate {v} does not fit the scale {} and offset {}",
                        self.scale, self.offset[k]
                    ),
                });
            }
            // Only coordinates within a scale of ±f64::MAX can round to a grid point beyond it.
            if !(q * self.scale + self.offset[k]).is_finite() {
                return Err(WriteError::Las {
                    reason: format!(
                        "point {index}: coordinate {v} rounds to a grid point beyond f64's range"
                    ),
                });
            }
            out[k] = q as i32;
        }
        Ok(out)
    }
}

/// `10^k` as the nearest f64 (which prints as `1e{k}`).
fn pow10(k: i32) -> f64 {
    format!("1e{k}").parse().unwrap_or(f64::MAX)
}

/// The least `k` in −300..=300 with `10^k ≥ v` (`v` positive and finite, at most 10^300).
fn power_of_ten_exponent(v: f64) -> i32 {
    let mut k = (v.log10().ceil() as i32).clamp(-300, 300);
    while k < 300 && pow10(k) < v {
        k += 1;
    }
    while k > -300 && pow10(k - 1) >= v {
        k -= 1;
    }
    k
}

/// What the `las` writer writes: positioned byte runs, kept until [`Applied::apply`] writes
/// them to the caller's stream. Writing and seeking never fail (a seek before the start is
/// clamped to it), so the `las` writer never fails on I/O.
#[derive(Clone, Default)]
struct Spool(Arc<Mutex<SpoolState>>);

#[derive(Default)]
struct SpoolState {
    /// The position of the next write, from the start of the file.
    at: u64,
    /// One past the last byte written.
    end: u64,
    /// Runs not yet applied: (position, bytes), in the order written.
    runs: Vec<(u64, Vec<u8>)>,
}

impl Spool {
    fn with<T>(&self, f: impl FnOnce(&mut SpoolState) -> T) -> T {
        f(&mut self.0.lock().unwrap_or_else(PoisonError::into_inner))
    }

    fn end(&self) -> u64 {
        self.with(|s| s.end)
    }
}

impl Write for Spool {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.with(|s| {
            let at = s.at;
            match s.runs.last_mut() {
                Some((start, run)) if *start + run.len() as u64 == at => {
                    run.extend_from_slice(buf);
                }
                _ => s.runs.push((at, buf.to_vec())),
            }
            s.at += buf.len() as u64;
            s.end = s.end.max(s.at);
        });
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Seek for Spool {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        Ok(self.with(|s| {
            s.at = match pos {
                SeekFrom::Start(p) => p,
                SeekFrom::Current(d) => s.at.saturating_add_signed(d),
                SeekFrom::End(d) => s.end.saturating_add_signed(d),
            };
            s.at
        }))
    }
}

/// The caller's stream, with where the file starts in it and where it stands.
struct Applied<W> {
    w: W,
    base: u64,
    at: u64,
}

impl<W: Write + Seek> Applied<W> {
    /// Writes the spool's runs to the stream, in order, and forgets them.
    fn apply(&mut self, spool: &Spool) -> std::io::Result<()> {
        let runs = spool.with(|s| std::mem::take(&mut s.runs));
        for (start, bytes) in runs {
            let start = self.base + start;
            if start != self.at {
                self.w.seek(SeekFrom::Start(start))?;
            }
            self.w.write_all(&bytes)?;
            self.at = start + bytes.len() as u64;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scales_follow_the_rule() {
        let grid = |a: DVec3, b: DVec3| Grid::of(&[a, b]);
        // Unit model at the origin: H = 1, s = 1e-9 (1 / 1e-9 = 1e9 ≤ 2^30 < 1 / 1e-10).
        let g = grid(DVec3::splat(-1.0), DVec3::splat(1.0));
        assert_eq!((g.scale, g.offset), (1e-9, [0.0; 3]));
        // A 100 m tile at (5e5, 5e6, 100): H = 50, s = 1e-7.
        let o = DVec3::new(5e5, 5e6, 100.0);
        let g = grid(o, o + DVec3::splat(100.0));
        assert_eq!(g.scale, 1e-7);
        assert_eq!(g.offset, [5e5 + 50.0, 5e6 + 50.0, 150.0]);
        // A millimetre at 5e6: the f64 rule (M × 2^-46 ≈ 7.1e-8) sets s = 1e-7.
        let g = grid(DVec3::splat(5e6), DVec3::splat(5e6 + 1e-3));
        assert_eq!(g.scale, 1e-7);
        // One point at the origin, and no point: 0.001.
        assert_eq!(grid(DVec3::ZERO, DVec3::ZERO).scale, 1e-3);
        assert_eq!(Grid::of(&[]).scale, 1e-3);
        // Extremes stay finite.
        let g = grid(DVec3::splat(-f64::MAX), DVec3::splat(f64::MAX));
        assert!(g.scale.is_finite() && g.offset.iter().all(|o| o.is_finite()));
        assert!(g.quantise(0, DVec3::splat(-f64::MAX)).is_ok());
        assert!(g.quantise(0, DVec3::splat(1e308)).is_ok());
        // Below 1e-300 the exponent is clamped; subnormal extents vanish when halved.
        assert_eq!(grid(DVec3::ZERO, DVec3::splat(1e-305)).scale, 1e-300);
        let tiny = f64::from_bits(1);
        assert_eq!(grid(DVec3::ZERO, DVec3::splat(tiny)).scale, 1e-3);
    }

    #[test]
    fn powers_of_ten_are_exact_and_least() {
        let least = |v| pow10(power_of_ten_exponent(v));
        assert_eq!(least(1.0), 1.0);
        assert_eq!(least(1.0000001), 10.0);
        assert_eq!(least(9.3e-10), 1e-9);
        assert_eq!(least(1e-9), 1e-9);
        assert_eq!(least(1.01e-9), 1e-8);
        assert_eq!(least(1e299), 1e299);
        assert_eq!(least(f64::from_bits(1)), 1e-300);
    }

    #[test]
    fn attribute_values_convert_as_documented() {
        assert_eq!(channel_u16(255), 65535);
        assert!((0..=255u8).all(|v| (channel_u16(v) >> 8) as u8 == v));
        assert_eq!(intensity_u16(-3.0), 0);
        assert_eq!(intensity_u16(12.5), 13);
        assert_eq!(intensity_u16(1e9), 65535);
        assert_eq!(intensity_u16(f32::NAN), 0);
        assert_eq!(intensity_u16(f32::INFINITY), 65535);
    }
}
