//! `read_point_scalars`: named vertex columns in every encoding, aligned with nothing dropped,
//! and its errors.

mod common;

use common::{ALL_ENCODINGS, Enc, UCHAR_INT, XYZ_FLOAT, ply, tetrahedron_ply};
use glam::DVec3;
use psi_io::{ReadError, read_point_scalars, write_points_ply};

/// A particle-like file: x y z as float, a uchar label, depth as int, sigma as double.
fn particles(enc: Enc) -> Vec<u8> {
    let props = [
        ("float", "x"),
        ("float", "y"),
        ("float", "z"),
        ("uchar", "label"),
        ("int", "depth"),
        ("double", "sigma"),
    ];
    let rows = vec![
        vec![0.5, 1.0, -2.0, 7.0, 5.0, 0.125],
        vec![1.5, 0.0, 2.0, 200.0, 9.0, 0.0625],
        // A zero "normal" would drop this row in read_points; here nothing is dropped.
        vec![0.0, 0.0, 0.0, 0.0, 6.0, 1e-3],
    ];
    ply(enc, &props, &rows, None, &[])
}

#[test]
fn columns_are_read_in_every_encoding_in_the_order_asked() {
    for enc in ALL_ENCODINGS {
        let bytes = particles(enc);
        let c = read_point_scalars(&bytes, &["sigma", "x", "nx", "depth", "label"]).unwrap();
        assert_eq!(c[0], Some(vec![0.125, 0.0625, 1e-3]), "{enc:?}");
        assert_eq!(c[1], Some(vec![0.5, 1.5, 0.0]), "{enc:?}");
        assert_eq!(c[2], None, "{enc:?}");
        assert_eq!(c[3], Some(vec![5.0, 9.0, 6.0]), "{enc:?}");
        assert_eq!(c[4], Some(vec![7.0, 200.0, 0.0]), "{enc:?}");
    }
}

#[test]
fn round_trip_with_the_particle_writer_is_bit_exact() {
    let positions: Vec<DVec3> = (0..100)
        .map(|i| DVec3::new(0.1 * i as f64, (i as f64).sin(), 1e6 + i as f64 / 3.0))
        .collect();
    // Zero and non-unit normals are written and read back as they are.
    let normals: Vec<DVec3> = (0..100).map(|i| DVec3::splat(i as f64 - 50.0)).collect();
    let depth: Vec<f64> = (0..100).map(|i| f64::from(i % 7)).collect();
    let sigma: Vec<f64> = (0..100).map(|i| 1.0 / (1.0 + i as f64)).collect();
    let mut bytes = Vec::new();
    write_points_ply(
        &mut bytes,
        &positions,
        &normals,
        &[("depth", &depth), ("sigma", &sigma)],
    )
    .unwrap();
    let names = ["x", "y", "z", "nx", "ny", "nz", "depth", "sigma"];
    let c: Vec<Vec<f64>> = read_point_scalars(&bytes, &names)
        .unwrap()
        .into_iter()
        .map(Option::unwrap)
        .collect();
    for i in 0..100 {
        assert_eq!(DVec3::new(c[0][i], c[1][i], c[2][i]), positions[i]);
        assert_eq!(DVec3::new(c[3][i], c[4][i], c[5][i]), normals[i]);
        assert_eq!(c[6][i], depth[i]);
        assert_eq!(c[7][i], sigma[i]);
    }
}

#[test]
fn elements_before_the_vertices_are_skipped_and_faces_after_are_ignored() {
    let mesh = tetrahedron_ply(Enc::Le);
    let c = read_point_scalars(&mesh, &["z"]).unwrap();
    assert_eq!(c[0], Some(vec![0.0, 0.0, 0.0, 1.0]));
    // Faces cut off after the vertices are not read, so not an error.
    let cut = mesh.len() - 5;
    assert!(read_point_scalars(&mesh[..cut], &["z"]).is_ok());

    let text = "ply\nformat ascii 1.0\nelement camera 2\nproperty float f\nelement vertex 2\n\
                property float x\nproperty list uchar int stuff\nproperty float y\nend_header\n\
                9\n8\n1 3 7 7 7 2\n3 0 4\n";
    let c = read_point_scalars(text.as_bytes(), &["y", "x"]).unwrap();
    assert_eq!(c, vec![Some(vec![2.0, 4.0]), Some(vec![1.0, 3.0])]);
}

#[test]
fn errors_name_the_problem() {
    assert_eq!(read_point_scalars(b"", &["x"]), Err(ReadError::Empty));
    let no_vertex = b"ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n";
    assert!(matches!(
        read_point_scalars(no_vertex, &["x"]),
        Err(ReadError::Header { reason }) if reason.contains("vertex")
    ));
    let list = ply(Enc::Ascii, &XYZ_FLOAT, &[], Some(UCHAR_INT), &[]);
    assert!(read_point_scalars(&list, &["x"]).is_ok());
    let text =
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\nend_header\n1 0\n";
    assert!(matches!(
        read_point_scalars(text.as_bytes(), &["x"]),
        Err(ReadError::Header { reason }) if reason.contains("list")
    ));
    for enc in ALL_ENCODINGS {
        let bytes = particles(enc);
        let cut = &bytes[..bytes.len() - 8];
        assert!(
            matches!(
                read_point_scalars(cut, &["x"]),
                Err(ReadError::Truncated {
                    index: 2,
                    count: 3,
                    ..
                })
            ),
            "{enc:?}"
        );
    }
    let nan = ply(
        Enc::Le,
        &[("double", "x"), ("double", "sigma")],
        &[vec![0.0, 1.0], vec![1.0, f64::NAN]],
        None,
        &[],
    );
    assert!(matches!(
        read_point_scalars(&nan, &["sigma"]),
        Err(ReadError::Record { index: 1, reason, .. }) if reason.contains("sigma")
    ));
    // A NaN in a column nobody asked for is not an error.
    assert!(read_point_scalars(&nan, &["x"]).is_ok());
}
