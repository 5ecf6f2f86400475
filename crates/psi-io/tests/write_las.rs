//! `write_las`: LAS and LAZ files that psi-io's reader and the `las` crate's reader read back
//! as written (positions within the documented 0.51 × scale, colours, intensities and classes
//! exactly), at the origin and georeferenced, with and without attributes; the scale rule;
//! the records as the `las` crate decodes them; bad input refused before anything is written;
//! a failing output an error, never a panic; any cloud, any f64 bits (proptests).

mod common;

use std::io::{Cursor, Seek, SeekFrom, Write};
use std::ops::ControlFlow;

use glam::DVec3;
use proptest::prelude::*;
use psi_io::{
    Format, PointAttributes, PointCloudFile, PointStream, ReadError, ReadOptions, WriteError,
    read_points_from, write_las,
};

/// The documented bound on a coordinate's error, in units of the scale.
const BOUND: f64 = 0.51;

/// `n` deterministic points in the box `origin + [0, size]` (a low-discrepancy sequence), with
/// every colour, class and a spread of integer intensities.
fn scan(n: usize, origin: DVec3, size: DVec3) -> (Vec<DVec3>, PointAttributes) {
    let positions = (0..n)
        .map(|i| {
            let t = i as f64 + 0.5;
            origin
                + size
                    * DVec3::new(
                        (t * 0.754_877_666_2).fract(),
                        (t * 0.569_840_291_0).fract(),
                        (t * 0.314_159_265_3).fract(),
                    )
        })
        .collect();
    let attributes = PointAttributes {
        colors: Some(
            (0..n)
                .map(|i| {
                    [
                        (i % 256) as u8,
                        (i * 7 % 256) as u8,
                        (255 - i * 13 % 256) as u8,
                    ]
                })
                .collect(),
        ),
        intensity: Some((0..n).map(|i| (i * 977 % 65536) as f32).collect()),
        classification: Some((0..n).map(|i| (i * 31 % 256) as u8).collect()),
    };
    (positions, attributes)
}

fn write(positions: &[DVec3], attributes: &PointAttributes, compressed: bool) -> Vec<u8> {
    let mut out = Cursor::new(Vec::new());
    write_las(&mut out, positions, attributes, compressed).unwrap();
    out.into_inner()
}

fn read(bytes: Vec<u8>) -> PointCloudFile {
    read_points_from(Cursor::new(bytes), Format::Las, &ReadOptions::paper()).unwrap()
}

/// The header's scale (the same on every axis) and offsets, as the `las` crate reads them.
fn grid(bytes: &[u8]) -> (f64, [f64; 3]) {
    let reader = las::Reader::new(Cursor::new(bytes.to_vec())).unwrap();
    let t = reader.header().transforms();
    assert_eq!((t.x.scale, t.y.scale), (t.z.scale, t.z.scale));
    (t.x.scale, [t.x.offset, t.y.offset, t.z.offset])
}

/// The bounding box of `positions`.
fn bounds(positions: &[DVec3]) -> (DVec3, DVec3) {
    positions
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        })
}

/// The largest coordinate error of `file` against `positions`, in units of `scale`.
fn worst_error(file: &PointCloudFile, positions: &[DVec3], scale: f64) -> f64 {
    assert_eq!(file.points.len(), positions.len());
    file.points
        .iter()
        .zip(positions)
        .map(|(got, want)| (got.p - *want).abs().max_element() / scale)
        .fold(0.0, f64::max)
}

#[test]
fn las_and_laz_read_back_what_was_written() {
    // More than one batch of 400 000 points, so batches and LAZ chunks join up.
    let n = 410_000;
    let (positions, attributes) = scan(n, DVec3::splat(-1.0), DVec3::splat(2.0));
    for compressed in [false, true] {
        let bytes = write(&positions, &attributes, compressed);
        // Half-extent 1 (to f64 rounding): the smallest power of ten s with 1 / s ≤ 2^30.
        let (scale, offset) = grid(&bytes);
        assert_eq!(scale, 1e-9, "compressed: {compressed}");
        let (lo, hi) = bounds(&positions);
        for k in 0..3 {
            assert!(
                (offset[k] - (lo[k] + hi[k]) / 2.0).abs() <= scale,
                "{offset:?}"
            );
        }
        let file = read(bytes);
        let expected = if compressed { Format::Laz } else { Format::Las };
        assert_eq!(file.source.format, Some(expected));
        let detail = file.source.detail.clone().unwrap();
        assert!(detail.starts_with("LAS 1.4, point format 7"), "{detail}");
        let worst = worst_error(&file, &positions, scale);
        assert!(worst <= BOUND, "worst error {worst} × scale");
        assert_eq!(file.attributes, attributes);
    }
}

#[test]
fn georeferenced_tiles_keep_their_precision() {
    let origin = DVec3::new(5e5, 5e6, 100.0);
    // (size, expected scale): a 300 m tile (extent rule: 150 / 2^30 = 1.4e-7 → 1e-6) and a
    // 100 m tile (f64 rule: 5e6 × 2^-46 = 7.1e-8 → 1e-7; extent rule 4.7e-8).
    for (size, expected) in [
        (DVec3::new(300.0, 300.0, 50.0), 1e-6),
        (DVec3::splat(100.0), 1e-7),
    ] {
        let (positions, attributes) = scan(20_000, origin, size);
        for compressed in [false, true] {
            let bytes = write(&positions, &attributes, compressed);
            let (scale, offset) = grid(&bytes);
            assert_eq!(scale, expected, "{size}");
            // The bound of the doc comment (s < 10 E / 2^31 when the extent sets s, and
            // s < 10 M 2^-46 when f64 does), and the s ≤ 1e-6 E.
            let extent = size.max_element();
            let magnitude = (origin + size).max_element();
            assert!(scale < 10.0 * (extent / 2f64.powi(31)).max(magnitude * 2f64.powi(-46)));
            assert!(scale <= 1e-6 * extent);
            // Offsets: the box's centre on the grid of multiples of the scale.
            let (lo, hi) = bounds(&positions);
            for k in 0..3 {
                let centre = (lo[k] + hi[k]) / 2.0;
                assert!((offset[k] - centre).abs() <= scale, "{offset:?}");
                let steps = offset[k] / scale;
                assert!((steps - steps.round()).abs() < 1e-3, "{offset:?}");
            }
            let file = read(bytes);
            let worst = worst_error(&file, &positions, scale);
            assert!(worst <= BOUND, "worst error {worst} × scale");
            assert_eq!(file.attributes, attributes);
        }
    }
}

#[test]
fn points_without_attributes_read_back_black_unclassified_and_zero() {
    let (positions, _) = scan(1000, DVec3::new(-3.0, 2.0, 0.5), DVec3::new(4.0, 1.0, 0.25));
    for compressed in [false, true] {
        let bytes = write(&positions, &PointAttributes::default(), compressed);
        let (scale, _) = grid(&bytes);
        // Half-extent 2: 2 / 2^30 = 1.9e-9 → 1e-8.
        assert_eq!(scale, 1e-8);
        let file = read(bytes);
        assert!(worst_error(&file, &positions, scale) <= BOUND);
        // Point format 7 always has the columns; absent ones are written as zeros.
        let a = &file.attributes;
        assert_eq!(a.colors, Some(vec![[0; 3]; 1000]));
        assert_eq!(a.intensity, Some(vec![0.0; 1000]));
        assert_eq!(a.classification, Some(vec![0; 1000]));
    }
}

#[test]
fn some_attributes_without_the_others() {
    let (positions, all) = scan(500, DVec3::ZERO, DVec3::ONE);
    let only_colors = PointAttributes {
        colors: all.colors.clone(),
        ..PointAttributes::default()
    };
    let file = read(write(&positions, &only_colors, true));
    assert_eq!(file.attributes.colors, all.colors);
    assert_eq!(file.attributes.intensity, Some(vec![0.0; 500]));
    let only_classes = PointAttributes {
        classification: all.classification.clone(),
        ..PointAttributes::default()
    };
    let file = read(write(&positions, &only_classes, false));
    assert_eq!(file.attributes.classification, all.classification);
    assert_eq!(file.attributes.colors, Some(vec![[0; 3]; 500]));
}

#[test]
fn intensities_are_rounded_and_clamped() {
    let positions = vec![DVec3::ZERO; 7];
    let attributes = PointAttributes {
        intensity: Some(vec![
            12.4,
            12.6,
            -5.0,
            1e6,
            f32::NAN,
            f32::INFINITY,
            65535.0,
        ]),
        ..PointAttributes::default()
    };
    let file = read(write(&positions, &attributes, false));
    assert_eq!(
        file.attributes.intensity,
        Some(vec![12.0, 13.0, 0.0, 65535.0, 0.0, 65535.0, 65535.0])
    );
}

#[test]
fn the_las_crate_reads_the_records_as_written() {
    let origin = DVec3::new(5e5, 5e6, 100.0);
    let (positions, attributes) = scan(60_000, origin, DVec3::new(250.0, 120.0, 30.0));
    for compressed in [false, true] {
        let bytes = write(&positions, &attributes, compressed);
        let mut reader = las::Reader::new(Cursor::new(bytes.clone())).unwrap();
        let header = reader.header().clone();
        assert_eq!(header.version(), las::Version::new(1, 4));
        assert_eq!(header.point_format().to_u8().unwrap(), 7);
        assert_eq!(header.point_format().is_compressed, compressed);
        assert_eq!(header.number_of_points(), 60_000);
        assert!(header.date().is_none());
        let data = reader.read_all().unwrap();
        assert_eq!(data.len(), 60_000);
        // Half-extent 125: 125 / 2^30 = 1.16e-7 → 1e-6.
        let t = *header.transforms();
        assert_eq!(t.x.scale, 1e-6);
        // The integers are the positions rounded to the grid around the offsets.
        let expected = |k: usize, tr: las::Transform| -> Vec<i32> {
            positions
                .iter()
                .map(|p| ((p[k] - tr.offset) / tr.scale).round() as i32)
                .collect()
        };
        assert_eq!(data.x_raw().collect::<Vec<_>>(), expected(0, t.x));
        assert_eq!(data.y_raw().collect::<Vec<_>>(), expected(1, t.y));
        assert_eq!(data.z_raw().collect::<Vec<_>>(), expected(2, t.z));
        let colors = attributes.colors.as_ref().unwrap();
        let rgb: Vec<(u16, u16, u16)> = colors
            .iter()
            .map(|c| {
                let w = |v: u8| u16::from(v) * 257;
                (w(c[0]), w(c[1]), w(c[2]))
            })
            .collect();
        assert_eq!(data.rgb().unwrap().collect::<Vec<_>>(), rgb);
        let intensity: Vec<u16> = attributes
            .intensity
            .as_ref()
            .unwrap()
            .iter()
            .map(|&v| v as u16)
            .collect();
        assert_eq!(data.intensity().collect::<Vec<_>>(), intensity);
        assert_eq!(
            data.classification().collect::<Vec<_>>(),
            *attributes.classification.as_ref().unwrap()
        );
        assert!(data.return_number().all(|r| r == 1));
        assert!(data.number_of_returns().all(|r| r == 1));
        assert!(data.gps_time().unwrap().all(|t| t == 0.0));
        // The header's bounds are those of the stored points.
        let bounds = header.bounds();
        let xs: Vec<f64> = data.x().collect();
        let min = xs.iter().copied().fold(f64::INFINITY, f64::min);
        let max = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        assert!((bounds.min.x - min).abs() <= 1e-6 && (bounds.max.x - max).abs() <= 1e-6);
        // And the records decode, through the Point API too.
        let first = data.points().next().unwrap().unwrap();
        assert_eq!(
            first.classification,
            las::point::Classification::new(0).unwrap()
        );
        assert!((first.x - positions[0].x).abs() <= BOUND * 1e-6);
    }
}

#[test]
fn the_same_points_give_the_same_bytes() {
    let (positions, attributes) = scan(3000, DVec3::ZERO, DVec3::splat(10.0));
    for compressed in [false, true] {
        assert_eq!(
            write(&positions, &attributes, compressed),
            write(&positions, &attributes, compressed)
        );
    }
}

#[test]
fn a_file_written_after_other_bytes_starts_there_and_ends_the_stream() {
    let (positions, attributes) = scan(2000, DVec3::ZERO, DVec3::ONE);
    for compressed in [false, true] {
        let alone = write(&positions, &attributes, compressed);
        let mut out = Cursor::new(b"prefix".to_vec());
        out.seek(SeekFrom::End(0)).unwrap();
        write_las(&mut out, &positions, &attributes, compressed).unwrap();
        assert_eq!(out.position(), out.get_ref().len() as u64);
        let bytes = out.into_inner();
        assert_eq!(&bytes[..6], b"prefix");
        assert_eq!(bytes[6..], alone[..]);
    }
}

#[test]
fn no_points_make_a_readable_empty_file() {
    for compressed in [false, true] {
        let bytes = write(&[], &PointAttributes::default(), compressed);
        let reader = las::Reader::new(Cursor::new(bytes.clone())).unwrap();
        assert_eq!(reader.header().number_of_points(), 0);
        let stream = PointStream::open(Cursor::new(bytes.clone()), Format::Las).unwrap();
        let end = stream
            .for_each_chunk(100, |_| ControlFlow::Continue(()))
            .unwrap();
        assert_eq!(end.points, 0);
        // Reading it whole: no points, said so.
        let err = read_points_from(Cursor::new(bytes), Format::Las, &ReadOptions::paper());
        assert!(matches!(err, Err(ReadError::NoPoints { vertices: 0, .. })));
    }
}

#[test]
fn a_non_finite_position_is_refused_by_index_before_writing() {
    let mut positions = vec![DVec3::ONE; 10];
    positions[7].z = f64::INFINITY;
    positions[9].x = f64::NAN;
    let mut out = Cursor::new(Vec::new());
    let err = write_las(&mut out, &positions, &PointAttributes::default(), true).unwrap_err();
    assert!(matches!(err, WriteError::NonFinite { index: 7 }), "{err:?}");
    assert_eq!(err.to_string(), "point 7 has a NaN or infinite position");
    assert!(out.get_ref().is_empty());
}

#[test]
fn attribute_columns_of_the_wrong_length_are_refused() {
    let positions = vec![DVec3::ZERO; 3];
    let attributes = PointAttributes {
        intensity: Some(vec![1.0; 2]),
        ..PointAttributes::default()
    };
    let mut out = Cursor::new(Vec::new());
    let err = write_las(&mut out, &positions, &attributes, false).unwrap_err();
    assert!(
        matches!(&err, WriteError::LengthMismatch { what, expected: 3, got: 2 } if what == "intensity"),
        "{err:?}"
    );
    assert!(out.get_ref().is_empty());
}

/// A stream that takes `room` bytes and then fails every write (or every seek).
struct Failing {
    inner: Cursor<Vec<u8>>,
    room: usize,
    seeks_fail: bool,
}

impl Write for Failing {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.inner.get_ref().len() + buf.len() > self.room {
            return Err(std::io::Error::new(
                std::io::ErrorKind::StorageFull,
                "disk full",
            ));
        }
        self.inner.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Seek for Failing {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        if self.seeks_fail && pos != SeekFrom::Current(0) {
            return Err(std::io::Error::other("not seekable"));
        }
        self.inner.seek(pos)
    }
}

#[test]
fn a_failing_output_is_an_io_error_not_a_panic() {
    let (positions, attributes) = scan(450_000, DVec3::ZERO, DVec3::ONE);
    for compressed in [false, true] {
        for (room, seeks_fail) in [
            (0, false),
            (100, false),
            (1 << 20, false),
            (usize::MAX, true),
        ] {
            let out = Failing {
                inner: Cursor::new(Vec::new()),
                room,
                seeks_fail,
            };
            let err = write_las(out, &positions, &attributes, compressed).unwrap_err();
            assert!(
                matches!(err, WriteError::Io(_)),
                "{room} {seeks_fail}: {err:?}"
            );
        }
    }
}

/// Points around a centre of any magnitude (±1e-10 to ±1e12), over an extent of any size
/// (1e-12 to 1e8).
fn clouds() -> impl Strategy<Value = Vec<DVec3>> {
    let magnitude = (-10.0f64..12.0, prop::bool::ANY).prop_map(|(e, neg)| {
        let m = 10f64.powf(e);
        if neg { -m } else { m }
    });
    let centre = (magnitude.clone(), magnitude.clone(), magnitude);
    let extent = -12.0f64..8.0;
    let offsets = prop::collection::vec((-0.5f64..0.5, -0.5f64..0.5, -0.5f64..0.5), 1..40);
    (centre, extent, offsets).prop_map(|((x, y, z), e, offsets)| {
        let size = 10f64.powf(e);
        offsets
            .into_iter()
            .map(|(a, b, c)| DVec3::new(x, y, z) + size * DVec3::new(a, b, c))
            .collect()
    })
}

proptest! {
    #![proptest_config(common::config())]

    /// The scale is the least power of ten of the documented rule, and every position reads
    /// back within 0.51 × scale.
    #[test]
    fn any_cloud_reads_back_within_the_bound(positions in clouds(), compressed in any::<bool>()) {
        let bytes = write(&positions, &PointAttributes::default(), compressed);
        let (scale, _) = grid(&bytes);
        let (lo, hi) = bounds(&positions);
        let half = (hi * 0.5 - lo * 0.5).max_element();
        let magnitude = lo.abs().max(hi.abs()).max_element();
        let least = (half * 2f64.powi(-30)).max(magnitude * 2f64.powi(-46));
        prop_assert!(scale >= least && scale / 10.0 < least * (1.0 + 1e-12), "{scale} {least}");
        let file = read(bytes);
        let worst = worst_error(&file, &positions, scale);
        prop_assert!(worst <= BOUND, "worst error {} × scale {}", worst, scale);
    }

    /// Any f64 bits: refused by index when not finite, otherwise written and read back
    /// within the bound (or, for coordinates within a scale of ±f64::MAX, refused); never a
    /// panic.
    #[test]
    fn any_bits_are_written_or_refused(
        bits in prop::collection::vec(any::<u64>(), 3..30),
        compressed in any::<bool>(),
    ) {
        let positions: Vec<DVec3> = bits
            .chunks_exact(3)
            .map(|c| DVec3::new(f64::from_bits(c[0]), f64::from_bits(c[1]), f64::from_bits(c[2])))
            .collect();
        let mut out = Cursor::new(Vec::new());
        match write_las(&mut out, &positions, &PointAttributes::default(), compressed) {
            Ok(()) => {
                let bytes = out.into_inner();
                let (scale, _) = grid(&bytes);
                let file = read(bytes);
                prop_assert!(worst_error(&file, &positions, scale) <= BOUND);
            }
            Err(WriteError::NonFinite { index }) => {
                prop_assert!(!positions[index].is_finite());
                prop_assert!(positions[..index].iter().all(|p| p.is_finite()));
            }
            Err(WriteError::Las { .. }) => {
                prop_assert!(positions.iter().any(|p| p.abs().max_element() > 1e307));
            }
            Err(e) => prop_assert!(false, "{e}"),
        }
    }
}
