//! Every kind of malformed input the readers must refuse: each case asserts an `Err` of the
//! expected kind, and none may panic.

mod common;

use common::{
    ALL_ENCODINGS, Enc, UCHAR_INT, XYZ_FLOAT, XYZN_DOUBLE, ply, tetrahedron, tetrahedron_ply,
};
use psi_io::{Format, ReadError, ReadOptions, read_mesh, read_points};

/// What a case must produce.
#[derive(Debug)]
enum Expect {
    Empty,
    Header,
    Record,
    Line,
    Truncated,
    NonFinite,
    IndexOutOfRange,
    NoPoints,
}

fn matches(err: &ReadError, expect: &Expect) -> bool {
    matches!(
        (err, expect),
        (ReadError::Empty, Expect::Empty)
            | (ReadError::Header { .. }, Expect::Header)
            | (ReadError::Record { .. }, Expect::Record)
            | (ReadError::Line { .. }, Expect::Line)
            | (ReadError::Truncated { .. }, Expect::Truncated)
            | (ReadError::NonFinite { .. }, Expect::NonFinite)
            | (ReadError::IndexOutOfRange { .. }, Expect::IndexOutOfRange)
            | (ReadError::NoPoints { .. }, Expect::NoPoints)
    )
}

fn cases() -> Vec<(String, Format, Vec<u8>, Expect)> {
    let mut cases: Vec<(String, Format, Vec<u8>, Expect)> = Vec::new();
    let mut add = |name: &str, format, bytes: Vec<u8>, expect| {
        cases.push((name.to_owned(), format, bytes, expect));
    };
    let (tv, _) = tetrahedron();

    // Empty input, for every format.
    for format in [Format::Ply, Format::Obj, Format::Xyz] {
        add("empty", format, Vec::new(), Expect::Empty);
        add("whitespace", format, b" \n\t\r\n".to_vec(), Expect::Empty);
    }

    // Garbage.
    add(
        "garbage text as PLY",
        Format::Ply,
        b"hello world\n".to_vec(),
        Expect::Header,
    );
    add(
        "binary garbage as PLY",
        Format::Ply,
        (0..=255u8).rev().collect(),
        Expect::Header,
    );
    add(
        "garbage as XYZ",
        Format::Xyz,
        b"hello world\n".to_vec(),
        Expect::Line,
    );
    add(
        "binary garbage as XYZ",
        Format::Xyz,
        (0..=255u8).collect(),
        Expect::Line,
    );
    add(
        "garbage as OBJ",
        Format::Obj,
        b"v hello world\n".to_vec(),
        Expect::Line,
    );
    add(
        "binary garbage as OBJ",
        Format::Obj,
        b"v \xff\xfe 0 0\n".to_vec(),
        Expect::Line,
    );
    add(
        "OBJ without vertices",
        Format::Obj,
        b"# nothing\ng x\n".to_vec(),
        Expect::NoPoints,
    );

    // PLY headers.
    add("magic only", Format::Ply, b"ply\n".to_vec(), Expect::Header);
    add(
        "no format line",
        Format::Ply,
        b"ply\nelement vertex 0\nend_header\n".to_vec(),
        Expect::Header,
    );
    add(
        "header only, no elements",
        Format::Ply,
        b"ply\nformat ascii 1.0\nend_header\n".to_vec(),
        Expect::Header,
    );
    add(
        "missing end_header",
        Format::Ply,
        b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n".to_vec(),
        Expect::Header,
    );
    add(
        "unknown encoding",
        Format::Ply,
        b"ply\nformat binary_middle_endian 1.0\nend_header\n".to_vec(),
        Expect::Header,
    );
    add(
        "unknown type",
        Format::Ply,
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n".to_vec(),
        Expect::Header,
    );
    add(
        "property before element",
        Format::Ply,
        b"ply\nformat ascii 1.0\nproperty float x\nend_header\n".to_vec(),
        Expect::Header,
    );
    add(
        "vertex without z",
        Format::Ply,
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n".to_vec(),
        Expect::Header,
    );
    add(
        "x is a list",
        Format::Ply,
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\nproperty float y\nproperty float z\nend_header\n1 0 0 0\n".to_vec(),
        Expect::Header,
    );
    add(
        "partial normals",
        Format::Ply,
        ply(
            Enc::Ascii,
            &[XYZ_FLOAT[0], XYZ_FLOAT[1], XYZ_FLOAT[2], ("float", "nx")],
            &[vec![0.0, 0.0, 0.0, 1.0]],
            None,
            &[],
        ),
        Expect::Header,
    );
    add(
        "duplicate element",
        Format::Ply,
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement vertex 1\nend_header\n0 0 0\n".to_vec(),
        Expect::Header,
    );
    add(
        "duplicate property",
        Format::Ply,
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0 0\n".to_vec(),
        Expect::Header,
    );
    add(
        "face without index list",
        Format::Ply,
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty int a\nend_header\n0 0 0\n1 0 0\n0 1 0\n7\n".to_vec(),
        Expect::Header,
    );
    add(
        "face with both index lists",
        Format::Ply,
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_index\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 3 0 1 2\n".to_vec(),
        Expect::Header,
    );
    add(
        "header-only cloud (0 vertices)",
        Format::Ply,
        ply(Enc::Le, &XYZN_DOUBLE, &[], None, &[]),
        Expect::NoPoints,
    );

    for enc in ALL_ENCODINGS {
        let tag = |what: &str| format!("{what} ({enc:?})");
        // Counts that lie / truncation.
        let full = tetrahedron_ply(enc);
        let header_len = full.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        add(
            &tag("header only, data missing"),
            Format::Ply,
            full[..header_len].to_vec(),
            Expect::Truncated,
        );
        let cut = if enc == Enc::Ascii {
            full.len() - 8
        } else {
            full.len() - 3
        };
        add(
            &tag("truncated inside the faces"),
            Format::Ply,
            full[..cut].to_vec(),
            Expect::Truncated,
        );
        add(
            &tag("truncated inside the vertices"),
            Format::Ply,
            full[..header_len + 10].to_vec(),
            Expect::Truncated,
        );
        // The same body under a header whose count says `to` instead of `from`.
        let lie = |from: &str, to: &str| {
            let mut bytes = String::from_utf8_lossy(&full[..header_len])
                .replace(from, to)
                .into_bytes();
            bytes.extend_from_slice(&full[header_len..]);
            bytes
        };
        add(
            &tag("face count lies"),
            Format::Ply,
            lie("element face 4", "element face 5"),
            Expect::Truncated,
        );
        add(
            &tag("vertex count lies hugely"),
            Format::Ply,
            lie("element vertex 4", "element vertex 4000000000"),
            Expect::Truncated,
        );

        // Values.
        let nan_rows = vec![
            vec![0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
            vec![f64::NAN, 0.0, 0.0, 0.0, 0.0, 1.0],
        ];
        let inf_normal = vec![vec![0.0, 0.0, 0.0, 0.0, f64::INFINITY, 1.0]];
        let zero_normals = vec![vec![0.0, 0.0, 0.0, 0.0, 0.0, 0.0]; 3];
        if enc == Enc::Ascii {
            // ASCII PLY has no spelling for NaN: the number grammar rejects it.
            add(
                &tag("NaN position"),
                Format::Ply,
                ply(enc, &XYZN_DOUBLE, &nan_rows, None, &[]),
                Expect::Record,
            );
            let text = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nproperty double y\nproperty double z\nproperty double nx\nproperty double ny\nproperty double nz\nend_header\n1e400 0 0 0 0 1\n";
            add(
                &tag("1e400 overflows to inf"),
                Format::Ply,
                text.to_vec(),
                Expect::NonFinite,
            );
        } else {
            add(
                &tag("NaN position"),
                Format::Ply,
                ply(enc, &XYZN_DOUBLE, &nan_rows, None, &[]),
                Expect::NonFinite,
            );
            add(
                &tag("infinite normal"),
                Format::Ply,
                ply(enc, &XYZN_DOUBLE, &inf_normal, None, &[]),
                Expect::NonFinite,
            );
        }
        add(
            &tag("only zero normals"),
            Format::Ply,
            ply(enc, &XYZN_DOUBLE, &zero_normals, None, &[]),
            Expect::NoPoints,
        );

        // Faces.
        let int_list = ("uchar", "int", "vertex_indices");
        add(
            &tag("face index out of range"),
            Format::Ply,
            ply(enc, &XYZ_FLOAT, &tv, Some(int_list), &[vec![0, 1, 4]]),
            Expect::IndexOutOfRange,
        );
        add(
            &tag("negative face index"),
            Format::Ply,
            ply(enc, &XYZ_FLOAT, &tv, Some(int_list), &[vec![0, -1, 2]]),
            Expect::IndexOutOfRange,
        );
        add(
            &tag("face with two indices"),
            Format::Ply,
            ply(enc, &XYZ_FLOAT, &tv, Some(UCHAR_INT), &[vec![0, 1]]),
            Expect::Record,
        );
        add(
            &tag("only degenerate faces"),
            Format::Ply,
            ply(
                enc,
                &XYZ_FLOAT,
                &tv,
                Some(UCHAR_INT),
                &[vec![0, 0, 1], vec![2, 2, 2]],
            ),
            Expect::NoPoints,
        );
    }

    // ASCII record syntax.
    let text = |data: &str| {
        format!("ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nend_header\n{data}")
            .into_bytes()
    };
    add(
        "ASCII word in record",
        Format::Ply,
        text("0 0 0 0 0 1\n0 0 zero 0 0 1\n"),
        Expect::Record,
    );
    add(
        "ASCII short record",
        Format::Ply,
        text("0 0 0 0 0 1\n0 0 0\n"),
        Expect::Record,
    );
    add(
        "ASCII blank record",
        Format::Ply,
        text("0 0 0 0 0 1\n\n0 0 0 0 0 1\n"),
        Expect::Record,
    );
    add(
        "ASCII non-UTF-8 record",
        Format::Ply,
        text("0 0 0 0 0 1\n0 0 \u{0}\u{1} 0 0 1\n"),
        Expect::Record,
    );
    let mut bad_utf8 = text("0 0 0 0 0 1\n");
    bad_utf8.extend_from_slice(b"\xff\xfe\n");
    add(
        "ASCII invalid UTF-8 record",
        Format::Ply,
        bad_utf8,
        Expect::Record,
    );
    add("ASCII float for int index", Format::Ply,
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n".to_vec(),
        Expect::Record);
    add("ASCII negative list count", Format::Ply,
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n-3 0 1 2\n".to_vec(),
        Expect::Record);

    // OBJ.
    add(
        "OBJ v with 2 numbers",
        Format::Obj,
        b"v 0 0\n".to_vec(),
        Expect::Line,
    );
    add(
        "OBJ NaN vertex",
        Format::Obj,
        b"v 0 0 NaN\n".to_vec(),
        Expect::NonFinite,
    );
    add(
        "OBJ infinite normal in a cloud",
        Format::Obj,
        b"v 0 0 0\nvn 0 0 inf\n".to_vec(),
        Expect::NonFinite,
    );
    add(
        "OBJ index 0",
        Format::Obj,
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n".to_vec(),
        Expect::Line,
    );
    add(
        "OBJ index out of range",
        Format::Obj,
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999\n".to_vec(),
        Expect::IndexOutOfRange,
    );
    add(
        "OBJ relative index before the start",
        Format::Obj,
        b"v 0 0 0\nf -1 -2 -3\n".to_vec(),
        Expect::IndexOutOfRange,
    );
    add(
        "OBJ index overflowing i64",
        Format::Obj,
        b"v 0 0 0\nf 1 2 99999999999999999999999\n".to_vec(),
        Expect::Line,
    );
    add(
        "OBJ face with one vertex",
        Format::Obj,
        b"v 0 0 0\nf 1\n".to_vec(),
        Expect::Line,
    );
    add(
        "OBJ only zero normals",
        Format::Obj,
        b"v 0 0 0\nvn 0 0 0\n".to_vec(),
        Expect::NoPoints,
    );

    // XYZ.
    add(
        "XYZ three numbers, then six",
        Format::Xyz,
        b"0 0 0\n0 0 0 0 0 1\n".to_vec(),
        Expect::Line,
    );
    add(
        "XYZ six numbers, then three",
        Format::Xyz,
        b"0 0 0 0 0 1\n0 0 0\n".to_vec(),
        Expect::Line,
    );
    add(
        "XYZ five numbers",
        Format::Xyz,
        b"0 0 0 0 1\n".to_vec(),
        Expect::Line,
    );
    add(
        "XYZ seven numbers",
        Format::Xyz,
        b"0 0 0 0 1 0 0\n".to_vec(),
        Expect::Line,
    );
    add(
        "XYZ word",
        Format::Xyz,
        b"0 0 0 0 one 0\n".to_vec(),
        Expect::Line,
    );
    add(
        "XYZ infinite position",
        Format::Xyz,
        b"0 0 -inf 0 1 0\n".to_vec(),
        Expect::NonFinite,
    );
    add(
        "XYZ only zero normals",
        Format::Xyz,
        b"0 0 0 0 0 0\n".to_vec(),
        Expect::NoPoints,
    );
    add(
        "XYZ only comments",
        Format::Xyz,
        b"# a\n# b\n".to_vec(),
        Expect::NoPoints,
    );
    cases
}

#[test]
fn every_malformed_input_is_an_error() {
    let mut failures = Vec::new();
    for (name, format, bytes, expect) in cases() {
        match read_points(&bytes, format, &ReadOptions::paper()) {
            Ok(file) => failures.push(format!("{name}: read {} points", file.points.len())),
            Err(err) => {
                if !matches(&err, &expect) {
                    failures.push(format!("{name}: expected {expect:?}, got {err:?}"));
                }
                // Messages are one line and not empty.
                let message = err.to_string();
                assert!(
                    !message.is_empty() && !message.contains('\n'),
                    "{name}: {message:?}"
                );
            }
        }
        // read_mesh must fail on every one of these too (none is a valid mesh).
        assert!(
            read_mesh(&bytes, format).is_err() || matches!(expect, Expect::NoPoints),
            "{name}"
        );
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn errors_name_element_index_and_reason() {
    let (tv, _) = tetrahedron();
    let bytes = ply(
        Enc::Le,
        &XYZ_FLOAT,
        &tv,
        Some(("uchar", "int", "vertex_indices")),
        &[vec![0, 1, 2], vec![0, 1, 7]],
    );
    let err = read_points(&bytes, Format::Ply, &ReadOptions::paper()).unwrap_err();
    assert_eq!(
        err,
        ReadError::IndexOutOfRange {
            face: 1,
            vertex: 7,
            vertices: 4
        }
    );
    assert_eq!(
        err.to_string(),
        "face 1 refers to vertex 7, but the file has 4 vertices (index as written in the file)"
    );

    let mut bytes = tetrahedron_ply(Enc::Be);
    bytes.truncate(bytes.len() - 1);
    let err = read_points(&bytes, Format::Ply, &ReadOptions::paper()).unwrap_err();
    assert_eq!(
        err,
        ReadError::Truncated {
            element: "face".to_owned(),
            index: 3,
            count: 4
        }
    );

    let rows = vec![
        vec![0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
        vec![0.0, f64::NEG_INFINITY, 0.0, 0.0, 0.0, 1.0],
    ];
    let err = read_points(
        &ply(Enc::Le, &XYZN_DOUBLE, &rows, None, &[]),
        Format::Ply,
        &ReadOptions::paper(),
    )
    .unwrap_err();
    assert_eq!(
        err,
        ReadError::NonFinite {
            element: "vertex",
            index: 1,
            what: "position",
            line: None
        }
    );

    let text = "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\nproperty double z\nend_header\n0 0 0\n0 1e999 0\n";
    let err = read_points(text.as_bytes(), Format::Ply, &ReadOptions::paper()).unwrap_err();
    assert_eq!(
        err,
        ReadError::NonFinite {
            element: "vertex",
            index: 1,
            what: "position",
            line: Some(9)
        }
    );
    assert_eq!(
        err.to_string(),
        "vertex 1 has a NaN or infinite position (line 9)"
    );

    let rows = vec![
        vec![0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
        vec![0.0, 0.0, 0.0, f64::NAN, 0.0, 1.0],
    ];
    let err = read_points(
        &ply(Enc::Be, &XYZN_DOUBLE, &rows, None, &[]),
        Format::Ply,
        &ReadOptions::paper(),
    )
    .unwrap_err();
    assert_eq!(
        err,
        ReadError::NonFinite {
            element: "vertex",
            index: 1,
            what: "normal",
            line: None
        }
    );
}

#[test]
fn long_garbage_gives_a_short_message() {
    let mut bytes = b"ply\nformat ascii 1.0\n".to_vec();
    bytes.extend(std::iter::repeat_n(b'a', 100_000));
    let err = read_points(&bytes, Format::Ply, &ReadOptions::paper()).unwrap_err();
    assert!(err.to_string().len() < 400, "{}", err.to_string().len());
}
