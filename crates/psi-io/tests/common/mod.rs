//! Test helpers: a small PLY builder writing the same data in ASCII, binary little-endian or
//! binary big-endian with any property types, and shared fixtures.

#![allow(dead_code, unreachable_pub)]

use proptest::test_runner::{Config, RngSeed};

/// The three PLY encodings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Enc {
    Ascii,
    Le,
    Be,
}

pub const ALL_ENCODINGS: [Enc; 3] = [Enc::Ascii, Enc::Le, Enc::Be];

impl Enc {
    fn header_name(self) -> &'static str {
        match self {
            Enc::Ascii => "ascii",
            Enc::Le => "binary_little_endian",
            Enc::Be => "binary_big_endian",
        }
    }
}

/// Appends `value` encoded as PLY scalar type `ty`.
pub fn push_value(out: &mut Vec<u8>, enc: Enc, ty: &str, value: f64) {
    macro_rules! bin {
        ($t:ty) => {{
            let v = value as $t;
            match enc {
                Enc::Ascii => out.extend_from_slice(v.to_string().as_bytes()),
                Enc::Le => out.extend_from_slice(&v.to_le_bytes()),
                Enc::Be => out.extend_from_slice(&v.to_be_bytes()),
            }
        }};
    }
    match ty {
        "char" | "int8" => bin!(i8),
        "uchar" | "uint8" => bin!(u8),
        "short" | "int16" => bin!(i16),
        "ushort" | "uint16" => bin!(u16),
        "int" | "int32" => bin!(i32),
        "uint" | "uint32" => bin!(u32),
        "float" | "float32" => bin!(f32),
        "double" | "float64" => bin!(f64),
        other => panic!("unknown PLY type {other}"),
    }
}

/// A PLY face list declaration: (count type, index type, property name).
pub type FaceList<'a> = (&'a str, &'a str, &'a str);

/// Builds a PLY file: `element vertex` with `vertex_props` (type, name) and one row per vertex,
/// then (when `face` is given) `element face` with that list and one index list per face.
pub fn ply(
    enc: Enc,
    vertex_props: &[(&str, &str)],
    vertices: &[Vec<f64>],
    face: Option<FaceList<'_>>,
    faces: &[Vec<i64>],
) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat {} 1.0\ncomment psi-io test\nelement vertex {}\n",
        enc.header_name(),
        vertices.len()
    );
    for (ty, name) in vertex_props {
        out.push_str(&format!("property {ty} {name}\n"));
    }
    if let Some((count_ty, index_ty, name)) = face {
        out.push_str(&format!(
            "element face {}\nproperty list {count_ty} {index_ty} {name}\n",
            faces.len()
        ));
    }
    out.push_str("end_header\n");
    let mut out = out.into_bytes();
    for row in vertices {
        for (k, ((ty, _), &v)) in vertex_props.iter().zip(row).enumerate() {
            if enc == Enc::Ascii && k > 0 {
                out.push(b' ');
            }
            push_value(&mut out, enc, ty, v);
        }
        if enc == Enc::Ascii {
            out.push(b'\n');
        }
    }
    if let Some((count_ty, index_ty, _)) = face {
        for f in faces {
            push_value(&mut out, enc, count_ty, f.len() as f64);
            for &i in f {
                if enc == Enc::Ascii {
                    out.push(b' ');
                }
                push_value(&mut out, enc, index_ty, i as f64);
            }
            if enc == Enc::Ascii {
                out.push(b'\n');
            }
        }
    }
    out
}

pub const XYZ_FLOAT: [(&str, &str); 3] = [("float", "x"), ("float", "y"), ("float", "z")];
pub const XYZN_DOUBLE: [(&str, &str); 6] = [
    ("double", "x"),
    ("double", "y"),
    ("double", "z"),
    ("double", "nx"),
    ("double", "ny"),
    ("double", "nz"),
];
pub const UCHAR_INT: FaceList<'static> = ("uchar", "int", "vertex_indices");

/// A closed, outward-oriented tetrahedron: vertices and counter-clockwise faces.
pub fn tetrahedron() -> (Vec<Vec<f64>>, Vec<Vec<i64>>) {
    let v = vec![
        vec![0.0, 0.0, 0.0],
        vec![1.0, 0.0, 0.0],
        vec![0.0, 1.0, 0.0],
        vec![0.0, 0.0, 1.0],
    ];
    let f = vec![vec![0, 2, 1], vec![0, 1, 3], vec![0, 3, 2], vec![1, 2, 3]];
    (v, f)
}

/// A tetrahedron mesh as a binary or ASCII PLY.
pub fn tetrahedron_ply(enc: Enc) -> Vec<u8> {
    let (v, f) = tetrahedron();
    ply(enc, &XYZ_FLOAT, &v, Some(UCHAR_INT), &f)
}

/// An oriented point cloud (six points on the unit sphere's axes) as PLY.
pub fn cloud_ply(enc: Enc) -> Vec<u8> {
    let rows: Vec<Vec<f64>> = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ]
    .iter()
    .map(|p| vec![p[0], p[1], p[2], 2.0 * p[0], 2.0 * p[1], 2.0 * p[2]])
    .collect();
    ply(enc, &XYZN_DOUBLE, &rows, None, &[])
}

pub const TETRA_OBJ: &str = "\
# tetrahedron
o tetra
v 0 0 0
v 1 0 0
v 0 1 0
v 0 0 1
vn 0 0 -1
vt 0 0
f 1 3 2
f 1/1 2/1 4/1
f 1/1/1 4/1/1 3/1/1
f 2//1 3//1 4//1
";

/// The seeded proptest configuration of this crate.
pub fn config() -> Config {
    Config {
        cases: 256,
        rng_seed: RngSeed::Fixed(0x9510_0001),
        failure_persistence: None,
        ..Config::default()
    }
}

pub mod mutation;
pub mod scans;
