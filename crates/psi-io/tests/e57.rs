//! E57 files written by the `e57` crate read back: every scan, each under its pose, invalid
//! returns skipped and counted, colours and intensities as written; spherical coordinates
//! converted; files without coordinates or malformed are errors naming what is wrong.

mod common;

use std::io::Cursor;
use std::ops::ControlFlow;

use common::scans::{Pose, ScanPoint, e57_file, e57_spherical, scan_points};
use glam::{DQuat, DVec3};
use psi_io::{Format, PointCloudFile, PointStream, ReadError, ReadOptions, read_points};

fn read(bytes: &[u8]) -> Result<PointCloudFile, ReadError> {
    read_points(bytes, Format::E57, &ReadOptions::paper())
}

/// Two scans: the first rotated 90° about z and moved, every fifth point flagged invalid;
/// the second under the identity.
fn two_scans() -> Vec<(Pose, Vec<(ScanPoint, bool)>)> {
    let half = std::f64::consts::FRAC_1_SQRT_2;
    let a = scan_points(100, [0.0; 3]).into_iter().enumerate();
    let b = scan_points(50, [1.0, 2.0, 3.0]).into_iter();
    vec![
        (
            ([half, 0.0, 0.0, half], [10.0, -5.0, 2.0]),
            a.map(|(i, p)| (p, i % 5 != 0)).collect(),
        ),
        (
            ([1.0, 0.0, 0.0, 0.0], [0.0; 3]),
            b.map(|p| (p, true)).collect(),
        ),
    ]
}

#[test]
fn every_scan_is_read_under_its_pose() {
    let scans = two_scans();
    let file = read(&e57_file(&scans)).unwrap();
    assert_eq!(file.source.scans, Some(2));
    assert_eq!(file.source.invalid_points, 20);
    assert_eq!(file.points.len(), 80 + 50);
    let mut expected = Vec::new();
    for ((q, t), points) in &scans {
        let rotation = DQuat::from_xyzw(q[1], q[2], q[3], q[0]);
        for (p, valid) in points {
            if *valid {
                expected.push((
                    rotation * DVec3::from_array(p.p) + DVec3::from_array(*t),
                    *p,
                ));
            }
        }
    }
    for (got, (want, p)) in file.points.iter().zip(&expected) {
        assert!((got.p - *want).length() < 1e-12, "{} vs {want}", got.p);
        let _ = p;
    }
    let colors: Vec<[u8; 3]> = expected.iter().map(|(_, p)| p.rgb).collect();
    assert_eq!(file.attributes.colors, Some(colors));
    let intensity: Vec<f32> = expected
        .iter()
        .map(|(_, p)| f32::from(p.intensity))
        .collect();
    assert_eq!(file.attributes.intensity, Some(intensity));
    assert_eq!(file.source.detail.as_deref(), Some("E57 1.0, 2 scans"));
}

#[test]
fn spherical_coordinates_become_cartesian() {
    let (r, az, el) = (2.0, 0.5f64, 0.25f64);
    let file = read(&e57_spherical(&[[r, az, el], [1.0, 0.0, 0.0]])).unwrap();
    let want = DVec3::new(
        r * el.cos() * az.cos(),
        r * el.cos() * az.sin(),
        r * el.sin(),
    );
    assert!((file.points[0].p - want).length() < 1e-12);
    assert!((file.points[1].p - DVec3::X).length() < 1e-12);
    assert!(file.attributes.is_empty());
}

#[test]
fn streams_in_bounded_chunks_across_scans() {
    let bytes = e57_file(&two_scans());
    let stream = PointStream::open(Cursor::new(bytes), Format::E57).unwrap();
    assert_eq!(
        (stream.header().announced_points, stream.header().scans),
        (150, Some(2))
    );
    let mut sizes = Vec::new();
    let end = stream
        .for_each_chunk(32, |c| {
            sizes.push(c.len());
            ControlFlow::Continue(())
        })
        .unwrap();
    assert_eq!(sizes, vec![32, 32, 32, 32, 2]);
    assert_eq!((end.points, end.invalid_points), (130, 20));
}

#[test]
fn malformed_files_are_errors() {
    let bytes = e57_file(&two_scans());
    for cut in (0..bytes.len()).step_by(211) {
        let err = read(&bytes[..cut]).unwrap_err();
        assert!(
            matches!(
                err,
                ReadError::Empty | ReadError::E57 { .. } | ReadError::TruncatedPoints { .. }
            ),
            "{cut}: {err}"
        );
    }
    let err = read(b"ASTM-E57 but nothing else").unwrap_err();
    assert!(err.to_string().contains("48-byte header"), "{err}");
    let mut no_xml = bytes.clone();
    no_xml[32..40].copy_from_slice(&u64::MAX.to_le_bytes());
    let err = read(&no_xml).unwrap_err();
    assert!(
        err.to_string().contains("does not fit in the file"),
        "{err}"
    );
}

#[test]
fn scans_without_coordinates_are_named() {
    use e57::{E57Writer, Record, RecordValue};
    // The writer refuses such a scan, so its XML is edited: the cartesian fields renamed to
    // index fields (the binary section is unchanged and its pages' checksums stay valid).
    let mut bytes = Cursor::new(Vec::new());
    {
        let mut writer = E57Writer::new(&mut bytes, "guid").unwrap();
        let prototype = vec![
            Record::CARTESIAN_X_F64,
            Record::CARTESIAN_Y_F64,
            Record::CARTESIAN_Z_F64,
        ];
        let mut pc = writer.add_pointcloud("no-coordinates", prototype).unwrap();
        pc.add_point(vec![RecordValue::Double(1.0); 3]).unwrap();
        pc.finalize().unwrap();
        writer
            .finalize_customized_xml(|xml| {
                Ok(xml
                    .replace("cartesianX", "rowIndex")
                    .replace("cartesianY", "columnIndex")
                    .replace("cartesianZ", "returnIndex"))
            })
            .unwrap();
    }
    let err = read(&bytes.into_inner()).unwrap_err();
    assert_eq!(err, ReadError::E57NoCoordinates { scan: 0 }, "{err}");
    assert!(err.to_string().contains("neither cartesian"));
}
