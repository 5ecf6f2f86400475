//! Tests of the vertex record decoders: the binary block decoders against `ply-rs-bw`'s
//! record parser reading the same records as text, the coordinates-only decoder against the
//! general one, non-finite positions named.

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

use crate::read_ply::read_ply;

/// One property of the test files: its PLY type and name.
const LAYOUTS: [&[(&str, &str)]; 5] = [
    &[("float", "x"), ("float", "y"), ("float", "z")],
    &[
        ("double", "x"),
        ("uchar", "quality"),
        ("double", "y"),
        ("double", "z"),
        ("float", "nx"),
        ("float", "ny"),
        ("float", "nz"),
    ],
    &[
        ("double", "x"),
        ("double", "y"),
        ("double", "z"),
        ("float", "nx"),
        ("float", "ny"),
        ("float", "nz"),
        ("uchar", "red"),
        ("uchar", "green"),
        ("uchar", "blue"),
        ("float", "intensity"),
    ],
    &[
        ("int", "x"),
        ("short", "y"),
        ("uint", "z"),
        ("ushort", "red"),
        ("ushort", "green"),
        ("ushort", "blue"),
        ("char", "flag"),
        ("double", "scalar_intensity"),
    ],
    &[
        ("uchar", "quality"),
        ("float", "z"),
        ("float", "y"),
        ("float", "x"),
        ("float", "red"),
        ("float", "green"),
        ("float", "blue"),
        ("double", "nz"),
        ("double", "nx"),
        ("double", "ny"),
    ],
];

/// A value of PLY type `ty` from `r` (a pseudo-random integer), as text and as bytes.
fn value(ty: &str, r: u64, big: bool) -> (String, Vec<u8>) {
    let f = (r % 20_001) as f64 / 7.0 - 1400.0;
    macro_rules! out {
        ($v:expr) => {{
            let v = $v;
            let b = if big {
                v.to_be_bytes().to_vec()
            } else {
                v.to_le_bytes().to_vec()
            };
            (format!("{v}"), b)
        }};
    }
    match ty {
        "char" => out!((r % 256) as u8 as i8),
        "uchar" => out!((r % 256) as u8),
        "short" => out!((r % 65_536) as u16 as i16),
        "ushort" => out!((r % 65_536) as u16),
        "int" => out!((r % 2_000_001) as i32 - 1_000_000),
        "uint" => out!((r % 2_000_001) as u32),
        "float" => out!(f as f32),
        _ => out!(f),
    }
}

/// The coordinates-only decoder gives the general one's records (its brute-force twin), in
/// both byte orders; a layout with a colour or an integer coordinate takes the general one.
#[test]
fn coordinates_only_records_decode_as_the_general_decoder() {
    use super::*;
    let f = |slot, ty, at| (slot, ty, at);
    let fields = vec![
        f(Slot::Coordinate(0), ScalarType::Double, 0),
        f(Slot::Coordinate(1), ScalarType::Double, 9),
        f(Slot::Coordinate(2), ScalarType::Double, 17),
        f(Slot::Coordinate(5), ScalarType::Float, 25),
        f(Slot::Coordinate(3), ScalarType::Float, 29),
    ];
    let coordinates = float_coordinates(&fields).expect("coordinates only");
    let mut rng = Pcg64Mcg::seed_from_u64(5);
    for big_endian in [false, true] {
        for _ in 0..1000 {
            let r: Vec<u8> = (0..33).map(|_| rng.random::<u8>()).collect();
            let general = read_record(&r, &fields, big_endian);
            let fast = read_coordinates(&r, &coordinates, big_endian);
            let bits = |v: [f64; 6]| v.map(f64::to_bits);
            assert_eq!(bits(fast.v), bits(general.v));
            assert_eq!((fast.rgb, fast.intensity), (general.rgb, general.intensity));
        }
    }
    let mut coloured = fields.clone();
    coloured.push(f(Slot::Color(0), ScalarType::UChar, 8));
    assert!(float_coordinates(&coloured).is_none());
    let integer = vec![f(Slot::Coordinate(0), ScalarType::Int, 0)];
    assert!(float_coordinates(&integer).is_none());
}

/// The same records as ASCII, binary little- and big-endian PLY read through the PLY
/// reader: the binary files take the parallel block decoder, the ASCII one the record-at-a-
/// time parser of `ply-rs-bw`; all three give the same points and attributes.
#[test]
fn binary_blocks_decode_as_the_record_parser_reads_text() {
    let mut rng = Pcg64Mcg::seed_from_u64(99);
    let mut rnd = move || rng.random::<u64>();
    for layout in LAYOUTS {
        for count in [1usize, 7, 70_000] {
            let rows: Vec<Vec<u64>> = (0..count)
                .map(|_| layout.iter().map(|_| rnd()).collect())
                .collect();
            let file = |encoding: &str| -> Vec<u8> {
                let mut out = format!("ply\nformat {encoding} 1.0\nelement vertex {count}\n");
                for (ty, name) in layout {
                    out += &format!("property {ty} {name}\n");
                }
                out += "end_header\n";
                let mut bytes = out.into_bytes();
                for row in &rows {
                    let mut line = Vec::new();
                    for ((ty, _), &r) in layout.iter().zip(row) {
                        let (text, b) = value(ty, r, encoding == "binary_big_endian");
                        if encoding == "ascii" {
                            line.push(text);
                        } else {
                            bytes.extend(b);
                        }
                    }
                    if encoding == "ascii" {
                        bytes.extend(line.join(" ").into_bytes());
                        bytes.push(b'\n');
                    }
                }
                bytes
            };
            let text = read_ply(&file("ascii")).unwrap();
            for encoding in ["binary_little_endian", "binary_big_endian"] {
                let bin = read_ply(&file(encoding)).unwrap();
                assert_eq!(bin.vertices, text.vertices, "{encoding} {layout:?}");
                assert_eq!(bin.normals, text.normals, "{encoding} {layout:?}");
                assert_eq!(bin.attributes, text.attributes, "{encoding} {layout:?}");
            }
        }
    }
}

/// A non-finite position is refused with the index of the first one, whatever chunk it is in.
#[test]
fn the_first_non_finite_position_is_named() {
    let count = 200_000;
    let mut bytes = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {count}\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
    )
    .into_bytes();
    for i in 0..count {
        let x = if i == 150_001 || i == 190_000 {
            f32::NAN
        } else {
            i as f32
        };
        for v in [x, 0.0, 1.0] {
            bytes.extend(v.to_le_bytes());
        }
    }
    let err = read_ply(&bytes).unwrap_err();
    assert!(err.to_string().contains("150001"), "{err}");
}

/// A binary PLY without faces read for its points (decoded straight into oriented points)
/// gives the points, attributes and counts that the mesh reader's vertices and normals give
/// (zero normals left out with their attributes, the first non-finite normal named).
#[test]
fn points_decoded_for_themselves_are_the_vertex_readers() {
    use crate::mesh_to_points::to_point_cloud;
    use crate::options::ReadOptions;
    use crate::read_ply::read_ply_for_points;
    let mut rng = Pcg64Mcg::seed_from_u64(7);
    for (count, zeros, nan) in [
        (10usize, vec![3usize], None),
        (70_000, vec![], None),
        (200_000, vec![0, 70_000, 199_999], None),
        (200_000, vec![5], Some(150_001usize)),
    ] {
        let mut bytes = format!(
            "ply\nformat binary_little_endian 1.0\nelement vertex {count}\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
        )
        .into_bytes();
        for i in 0..count {
            let mut v: Vec<f32> = (0..6).map(|_| rng.random_range(-2.0..2.0)).collect();
            if zeros.contains(&i) {
                v[3..].fill(0.0);
            }
            if nan == Some(i) {
                v[4] = f32::NAN;
            }
            for x in v {
                bytes.extend(x.to_le_bytes());
            }
            bytes.extend([(i % 251) as u8, (i % 7) as u8, 9]);
        }
        let opts = ReadOptions::paper();
        let direct = read_ply_for_points(&bytes).unwrap();
        assert!(direct.oriented.is_some() && direct.vertices.is_empty());
        let got = to_point_cloud(direct, &opts);
        let want = to_point_cloud(read_ply(&bytes).unwrap(), &opts);
        match (got, want) {
            (Ok(a), Ok(b)) => {
                assert_eq!(a, b, "{count} points");
                assert_eq!(a.dropped_points, zeros.len());
                assert_eq!(
                    a.attributes.colors.as_ref().map(Vec::len),
                    Some(a.points.len())
                );
            }
            (Err(a), Err(b)) => {
                assert_eq!(a.to_string(), b.to_string());
                assert!(
                    nan.is_some_and(|k| a.to_string().contains(&k.to_string())),
                    "{a}"
                );
            }
            (a, b) => panic!("{count} points: {a:?} against {b:?}"),
        }
    }
}
