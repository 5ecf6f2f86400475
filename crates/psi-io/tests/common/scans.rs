//! Scanner files for the tests, written by independent writers: LAS/LAZ by the `las` crate's
//! writer, E57 by the `e57` crate's writer, PCD by hand (the encodings of PCL's PCD v0.7
//! doc), with a literal-only LZF encoder for `binary_compressed`.

use std::io::Cursor;

use las::{Builder, Color, Point, Transform, Vector, Writer};

/// One scan point with its attributes, as the tests write it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScanPoint {
    pub p: [f64; 3],
    pub rgb: [u8; 3],
    pub intensity: u16,
    pub class: u8,
}

/// `n` deterministic points on a 10 m × 10 m × 2 m block around `origin`, colours and
/// intensities spanning their ranges, classes in 0..=11.
pub fn scan_points(n: usize, origin: [f64; 3]) -> Vec<ScanPoint> {
    (0..n)
        .map(|i| {
            let t = i as f64;
            ScanPoint {
                p: [
                    origin[0] + (t * 0.7548776662).fract() * 10.0,
                    origin[1] + (t * 0.5698402910).fract() * 10.0,
                    origin[2] + (t * 0.3141592653).fract() * 2.0,
                ],
                rgb: [
                    (i * 7 % 256) as u8,
                    (i * 13 % 256) as u8,
                    (255 - i % 256) as u8,
                ],
                intensity: (i * 977 % 65536) as u16,
                class: (i % 12) as u8,
            }
        })
        .collect()
}

/// A LAS file of `points` written by the `las` crate: version `(1, minor)`, point data
/// format `format`, LAZ when `compressed`, scale `scale` and offset `offset` on every axis.
/// Colours are stored × 256 (LAS 1.4 R15), classes as written.
pub fn las_file(
    points: &[ScanPoint],
    minor: u8,
    format: u8,
    compressed: bool,
    scale: f64,
    offset: [f64; 3],
) -> Vec<u8> {
    let mut builder = Builder::from((1, minor));
    builder.point_format = las::point::Format::new(format).unwrap();
    builder.point_format.is_compressed = compressed;
    builder.transforms = Vector {
        x: Transform {
            scale,
            offset: offset[0],
        },
        y: Transform {
            scale,
            offset: offset[1],
        },
        z: Transform {
            scale,
            offset: offset[2],
        },
    };
    let header = builder.into_header().unwrap();
    let has_color = header.point_format().has_color;
    let has_time = header.point_format().has_gps_time;
    let mut writer = Writer::new(Cursor::new(Vec::new()), header).unwrap();
    for q in points {
        let point = Point {
            x: q.p[0],
            y: q.p[1],
            z: q.p[2],
            intensity: q.intensity,
            classification: las::point::Classification::new(q.class).unwrap(),
            color: has_color.then(|| Color {
                red: u16::from(q.rgb[0]) * 256,
                green: u16::from(q.rgb[1]) * 256,
                blue: u16::from(q.rgb[2]) * 256,
            }),
            gps_time: has_time.then_some(0.0),
            ..Point::default()
        };
        writer.write_point(point).unwrap();
    }
    writer.into_inner().unwrap().into_inner()
}

/// A position as LAS stores it: quantised to `scale` around `offset`.
pub fn quantised(v: f64, scale: f64, offset: f64) -> f64 {
    ((v - offset) / scale).round() * scale + offset
}

/// A literal-only LZF stream of `data` (runs of at most 32 bytes, each after its length - 1):
/// valid LZF that any decoder must expand back to `data`.
pub fn lzf_literals(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    for run in data.chunks(32) {
        out.push((run.len() - 1) as u8);
        out.extend_from_slice(run);
    }
    out
}

/// A PCD file of `x y z normal_x normal_y normal_z rgb intensity` (all `F 4`) in `encoding`
/// (`ascii`, `binary`, `binary_compressed`), one record per row of `rows`, the `rgb` float
/// holding the packed colour bits. `width × height` must be `rows.len()`.
pub fn pcd_file(encoding: &str, rows: &[[f32; 8]], width: usize, height: usize) -> Vec<u8> {
    let mut out = format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n\
         FIELDS x y z normal_x normal_y normal_z rgb intensity\nSIZE 4 4 4 4 4 4 4 4\n\
         TYPE F F F F F F F F\nCOUNT 1 1 1 1 1 1 1 1\nWIDTH {width}\nHEIGHT {height}\n\
         VIEWPOINT 0 0 0 1 0 0 0\nPOINTS {}\nDATA {encoding}\n",
        rows.len()
    )
    .into_bytes();
    match encoding {
        "ascii" => {
            for row in rows {
                let mut line: Vec<String> = row.iter().map(|v| format!("{v:?}")).collect();
                // PCL >= 1.8 writes the packed colour as the integer of its bits.
                line[6] = row[6].to_bits().to_string();
                out.extend_from_slice(line.join(" ").as_bytes());
                out.push(b'\n');
            }
        }
        "binary" => {
            for v in rows.iter().flatten() {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        "binary_compressed" => {
            // Column-major: every point's x, then every point's y, ...
            let mut columns = Vec::new();
            for field in 0..8 {
                for row in rows {
                    columns.extend_from_slice(&row[field].to_le_bytes());
                }
            }
            let packed = lzf_literals(&columns);
            out.extend_from_slice(&(packed.len() as u32).to_le_bytes());
            out.extend_from_slice(&(columns.len() as u32).to_le_bytes());
            out.extend_from_slice(&packed);
        }
        other => panic!("unknown PCD encoding {other}"),
    }
    out
}

/// A packed PCD colour as the float whose bits hold `0x00RRGGBB`.
pub fn packed_rgb([r, g, b]: [u8; 3]) -> f32 {
    f32::from_bits(u32::from_be_bytes([0, r, g, b]))
}

/// A scan's pose in an E57 file: rotation quaternion (w, x, y, z) and translation.
pub type Pose = ([f64; 4], [f64; 3]);

/// An E57 file written by the `e57` crate with one scan per entry of `scans`: cartesian
/// (f64, with `cartesianInvalidState`) points, u8 colours and u16 intensity, under `pose`.
/// Points whose `valid` flag is false are written with invalid state 2.
pub fn e57_file(scans: &[(Pose, Vec<(ScanPoint, bool)>)]) -> Vec<u8> {
    use e57::{E57Writer, Quaternion, Record, RecordValue, Transform as E57Transform, Translation};
    let mut bytes = Cursor::new(Vec::new());
    {
        let mut writer = E57Writer::new(&mut bytes, "file-guid").unwrap();
        for (k, ((q, t), points)) in scans.iter().enumerate() {
            let prototype = vec![
                Record::CARTESIAN_X_F64,
                Record::CARTESIAN_Y_F64,
                Record::CARTESIAN_Z_F64,
                Record::CARTESIAN_INVALID_STATE,
                Record::COLOR_RED_U8,
                Record::COLOR_GREEN_U8,
                Record::COLOR_BLUE_U8,
                Record::INTENSITY_U16,
            ];
            let mut pc = writer
                .add_pointcloud(&format!("scan-{k}"), prototype)
                .unwrap();
            pc.set_transform(Some(E57Transform {
                rotation: Quaternion {
                    w: q[0],
                    x: q[1],
                    y: q[2],
                    z: q[3],
                },
                translation: Translation {
                    x: t[0],
                    y: t[1],
                    z: t[2],
                },
            }));
            for (p, valid) in points {
                pc.add_point(vec![
                    RecordValue::Double(p.p[0]),
                    RecordValue::Double(p.p[1]),
                    RecordValue::Double(p.p[2]),
                    RecordValue::Integer(if *valid { 0 } else { 2 }),
                    RecordValue::Integer(i64::from(p.rgb[0])),
                    RecordValue::Integer(i64::from(p.rgb[1])),
                    RecordValue::Integer(i64::from(p.rgb[2])),
                    RecordValue::Integer(i64::from(p.intensity)),
                ])
                .unwrap();
            }
            pc.finalize().unwrap();
        }
        writer.finalize().unwrap();
    }
    bytes.into_inner()
}

/// An E57 file with one scan in spherical coordinates (f64 range, azimuth, elevation), no
/// pose, no colour.
pub fn e57_spherical(points: &[[f64; 3]]) -> Vec<u8> {
    use e57::{E57Writer, Record, RecordValue};
    let mut bytes = Cursor::new(Vec::new());
    {
        let mut writer = E57Writer::new(&mut bytes, "file-guid").unwrap();
        let prototype = vec![
            Record::SPHERICAL_RANGE_F64,
            Record::SPHERICAL_AZIMUTH_F64,
            Record::SPHERICAL_ELEVATION_F64,
        ];
        let mut pc = writer.add_pointcloud("spherical", prototype).unwrap();
        for &[r, a, e] in points {
            pc.add_point(vec![
                RecordValue::Double(r),
                RecordValue::Double(a),
                RecordValue::Double(e),
            ])
            .unwrap();
        }
        pc.finalize().unwrap();
        writer.finalize().unwrap();
    }
    bytes.into_inner()
}
