//! PCD files written by hand in each encoding (PCL's PCD v0.7: ascii, binary,
//! binary_compressed) read back exactly: positions, normals, packed colours, intensities;
//! organised clouds' NaN points skipped and counted; every disagreement between header and
//! data is an error naming the point or header line.

mod common;

use std::io::Cursor;
use std::ops::ControlFlow;

use common::scans::{lzf_literals, packed_rgb, pcd_file};
use glam::DVec3;
use psi_io::{
    Format, NormalSource, PointCloudFile, PointStream, ReadError, ReadOptions, read_points,
};

const ENCODINGS: [&str; 3] = ["ascii", "binary", "binary_compressed"];

fn read(bytes: &[u8]) -> Result<PointCloudFile, ReadError> {
    read_points(bytes, Format::Pcd, &ReadOptions::paper())
}

/// Rows `x y z nx ny nz rgb intensity` with values that are exact in f32.
fn rows(n: usize) -> Vec<[f32; 8]> {
    (0..n)
        .map(|i| {
            let t = i as f32;
            let rgb = packed_rgb([(i * 37 % 256) as u8, (i * 11 % 256) as u8, 255 - i as u8]);
            [
                t * 0.25,
                -t * 0.5,
                1.0 + t * 0.125,
                0.0,
                0.0,
                if i % 2 == 0 { 1.0 } else { -2.0 },
                rgb,
                t * 3.5,
            ]
        })
        .collect()
}

#[test]
fn every_encoding_reads_back_exactly() {
    let rows = rows(40);
    for encoding in ENCODINGS {
        let file = read(&pcd_file(encoding, &rows, 8, 5)).unwrap();
        assert_eq!(file.points.len(), 40, "{encoding}");
        assert_eq!(file.normals, NormalSource::File);
        for (p, r) in file.points.iter().zip(&rows) {
            let want = DVec3::new(f64::from(r[0]), f64::from(r[1]), f64::from(r[2]));
            assert_eq!(p.p, want, "{encoding}");
            assert_eq!(p.n, DVec3::new(0.0, 0.0, r[5].signum() as f64));
        }
        let colors: Vec<[u8; 3]> = rows
            .iter()
            .map(|r| {
                let [_, r, g, b] = r[6].to_bits().to_be_bytes();
                [r, g, b]
            })
            .collect();
        assert_eq!(file.attributes.colors, Some(colors), "{encoding}");
        let intensity: Vec<f32> = rows.iter().map(|r| r[7]).collect();
        assert_eq!(file.attributes.intensity, Some(intensity));
        assert_eq!(file.attributes.classification, None);
        let detail = file.source.detail.unwrap();
        assert_eq!(detail, format!("PCD 0.7, {encoding}, 8 x 5"));
    }
}

#[test]
fn organised_clouds_skip_nan_points_and_nan_normals_are_dropped() {
    let mut rows = rows(6);
    rows[1][0] = f32::NAN; // an invalid return of an organised cloud
    rows[4][1] = f32::INFINITY;
    rows[2][3] = f32::NAN; // a failed normal estimate
    for encoding in ENCODINGS {
        let file = read(&pcd_file(encoding, &rows, 3, 2)).unwrap();
        assert_eq!(file.source.invalid_points, 2, "{encoding}");
        assert_eq!(
            (file.vertices, file.dropped_points, file.points.len()),
            (4, 1, 3)
        );
        let xs: Vec<f64> = file.points.iter().map(|p| p.p.x).collect();
        assert_eq!(xs, vec![0.0, 0.75, 1.25]);
        assert_eq!(file.attributes.intensity, Some(vec![0.0, 10.5, 17.5]));
    }
}

#[test]
fn positions_only_integer_types_and_rgba() {
    let pcd = b"VERSION .7\nFIELDS x y z rgba _ intensity\nSIZE 2 4 8 4 1 1\nTYPE I U F U U U\n\
                COUNT 1 1 1 1 3 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n\
                -3 7 0.5 4294901760 1 2 3 200\n\n4 0 -1e3 16777215 0 0 0 0\n";
    let file = read(pcd).unwrap();
    assert_eq!(file.normals, NormalSource::Missing);
    let ps: Vec<DVec3> = file.points.iter().map(|p| p.p).collect();
    assert_eq!(
        ps,
        vec![DVec3::new(-3.0, 7.0, 0.5), DVec3::new(4.0, 0.0, -1000.0)]
    );
    assert_eq!(
        file.attributes.colors,
        Some(vec![[255, 0, 0], [255, 255, 255]])
    );
    assert_eq!(file.attributes.intensity, Some(vec![200.0, 0.0]));
    // The same in binary: i16, u32, f64, u32, 3 × u8, u8 little-endian.
    let mut bin =
        b"VERSION .7\nFIELDS x y z rgba _ intensity\nSIZE 2 4 8 4 1 1\nTYPE I U F U U U\n\
                    COUNT 1 1 1 1 3 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA binary\n"
            .to_vec();
    for (x, y, z, c, i) in [
        (-3i16, 7u32, 0.5f64, 4294901760u32, 200u8),
        (4, 0, -1e3, 16777215, 0),
    ] {
        bin.extend_from_slice(&x.to_le_bytes());
        bin.extend_from_slice(&y.to_le_bytes());
        bin.extend_from_slice(&z.to_le_bytes());
        bin.extend_from_slice(&c.to_le_bytes());
        bin.extend_from_slice(&[1, 2, 3, i]);
    }
    let binary = read(&bin).unwrap();
    assert_eq!(
        (binary.points, binary.attributes),
        (file.points, file.attributes)
    );
}

#[test]
fn compressed_data_with_back_references_decodes() {
    // Four identical points: the columns repeat, so one literal and back-references do.
    let row = [1.5f32, 2.5, -3.5];
    let mut columns = Vec::new();
    for v in row {
        for _ in 0..4 {
            columns.extend_from_slice(&v.to_le_bytes());
        }
    }
    let mut packed = Vec::new();
    for k in 0..3 {
        // A literal of column k's first value, then 12 bytes copied from 4 back: the long
        // form, length 7 + 3 + 2, distance 3 + 1.
        packed.push(3);
        packed.extend_from_slice(&columns[16 * k..16 * k + 4]);
        packed.extend_from_slice(&[0xe0, 3, 3]);
    }
    let mut pcd = b"VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 4\n\
                    HEIGHT 1\nPOINTS 4\nDATA binary_compressed\n"
        .to_vec();
    pcd.extend_from_slice(&(packed.len() as u32).to_le_bytes());
    pcd.extend_from_slice(&48u32.to_le_bytes());
    pcd.extend_from_slice(&packed);
    let file = read(&pcd).unwrap();
    assert_eq!(file.points.len(), 4);
    assert!(
        file.points
            .iter()
            .all(|p| p.p == DVec3::new(1.5, 2.5, -3.5))
    );
    assert_eq!(lzf_literals(&[7; 33]).len(), 35);
}

#[test]
fn streams_in_bounded_chunks() {
    let rows = rows(250);
    for encoding in ENCODINGS {
        let bytes = pcd_file(encoding, &rows, 250, 1);
        let stream = PointStream::open(Cursor::new(bytes), Format::Pcd).unwrap();
        let mut sizes = Vec::new();
        stream
            .for_each_chunk(64, |c| {
                sizes.push(c.len());
                ControlFlow::Continue(())
            })
            .unwrap();
        assert_eq!(sizes, vec![64, 64, 64, 58], "{encoding}");
    }
}

fn header_error(pcd: &str) -> String {
    let err = read(pcd.as_bytes()).unwrap_err();
    assert!(matches!(err, ReadError::PcdHeader { .. }), "{err}");
    err.to_string()
}

#[test]
fn header_mistakes_are_named() {
    let ok = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\n\
              POINTS 2\nDATA ascii\n0 0 0\n1 1 1\n";
    assert!(read(ok.as_bytes()).is_ok());
    let cases = [
        (
            "POINTS 2",
            "POINTS 3",
            "POINTS 3 but WIDTH × HEIGHT = 2 × 1",
        ),
        ("SIZE 4 4 4", "SIZE 4 4", "SIZE gives 2 values for 3 FIELDS"),
        ("TYPE F F F", "TYPE F F X", "TYPE \"X\" with SIZE 4"),
        ("SIZE 4 4 4", "SIZE 4 4 2", "TYPE \"F\" with SIZE 2"),
        ("FIELDS x y z", "FIELDS x y w", "FIELDS has no x y z"),
        ("DATA ascii", "DATA zip", "DATA Some(\"zip\")"),
        ("WIDTH 2", "WIDTH two", "WIDTH value \"two\""),
        ("COUNT 1 1 1", "COUNT 1 2 1", "field y must have COUNT 1"),
        (
            "VERSION 0.7",
            "VERSION 0.7\nCOLOR red",
            "unknown header entry \"COLOR\"",
        ),
    ];
    for (from, to, message) in cases {
        let text = header_error(&ok.replace(from, to));
        assert!(text.contains(message), "{to}: {text}");
    }
    assert!(header_error("VERSION 0.7\nFIELDS x y z\n").contains("ends before the DATA line"));
}

#[test]
fn data_that_disagrees_with_the_header_is_an_error() {
    let rows = rows(6);
    for encoding in ENCODINGS {
        let full = pcd_file(encoding, &rows, 6, 1);
        let data_start = full.windows(5).position(|w| w == b"DATA ").unwrap();
        for cut in data_start + 5..full.len() {
            let text = full[..cut].to_vec();
            match read(&text) {
                Err(_) => {}
                // An ASCII cut inside the last number still parses.
                Ok(file) => assert!(
                    encoding == "ascii" && file.points.len() == 6,
                    "{encoding} {cut}"
                ),
            }
        }
    }
    let ascii = pcd_file("ascii", &rows, 6, 1);
    let text = String::from_utf8(ascii).unwrap();
    let short = text.replacen(" 0.0 0.0 1.0 ", " 0.0 1.0 ", 1);
    let err = read(short.as_bytes()).unwrap_err().to_string();
    assert!(
        err.contains("has 7 values, the header's FIELDS and COUNT announce 8"),
        "{err}"
    );
    let extra = format!("{text}1 2 3 4 5 6 7 8\n");
    let err = read(extra.as_bytes()).unwrap_err().to_string();
    assert!(err.contains("data follows the 6 points"), "{err}");
    let missing = text
        .rsplit_once('\n')
        .unwrap()
        .0
        .rsplit_once('\n')
        .unwrap()
        .0;
    let err = read(missing.as_bytes()).unwrap_err();
    assert_eq!(
        err,
        ReadError::TruncatedPoints {
            announced: 6,
            read: 5
        }
    );
    let mut binary = pcd_file("binary", &rows, 6, 1);
    binary.extend_from_slice(&[0; 32]);
    let err = read(&binary).unwrap_err().to_string();
    assert!(
        err.contains("32 bytes follow the 6 points of 32 bytes"),
        "{err}"
    );
    let mut compressed = pcd_file("binary_compressed", &rows, 6, 1);
    let at = compressed.len() - lzf_literals(&[0; 6 * 32]).len() - 4;
    compressed[at..at + 4].copy_from_slice(&100u32.to_le_bytes());
    let err = read(&compressed).unwrap_err().to_string();
    assert!(
        err.contains("need 192 bytes, the compressed block decodes to 100"),
        "{err}"
    );
}
