//! OBJ (all face reference forms, relative indices, polygons, normals by index) and XYZ.

mod common;

use common::{Enc, TETRA_OBJ, tetrahedron_ply};
use glam::DVec3;
use psi_io::{Format, NormalSource, ReadError, ReadOptions, read_mesh, read_points};

fn read(bytes: &[u8], format: Format) -> Result<psi_io::PointCloudFile, ReadError> {
    read_points(bytes, format, &ReadOptions::paper())
}

#[test]
fn obj_reference_forms_give_the_same_mesh_as_ply() {
    let mut obj = read(TETRA_OBJ.as_bytes(), Format::Obj).unwrap();
    let ply = read(&tetrahedron_ply(Enc::Le), Format::Ply).unwrap();
    // Everything but the format read is the same.
    assert_eq!(
        (obj.source.format, ply.source.format),
        (Some(Format::Obj), Some(Format::Ply))
    );
    obj.source = ply.source.clone();
    assert_eq!(obj, ply);
    assert_eq!(Format::sniff(TETRA_OBJ.as_bytes()), Format::Obj);
}

#[test]
fn obj_negative_indices_are_relative() {
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 0 0 1\nf -4/1 -1/1 -2/1\nf 1 2 -1\n";
    let mesh = read_mesh(obj.as_bytes(), Format::Obj).unwrap();
    assert_eq!(mesh.faces, vec![[0, 1, 2], [0, 3, 2], [0, 1, 3]]);
}

#[test]
fn obj_polygons_are_fans_and_extras_are_ignored() {
    let obj = "mtllib x.mtl\r\ng quad\r\nusemtl red\r\ns off\r\n\
               v 0 0 0 1.0\r\nv 1 0 0 0.5 0.5 0.5\r\nv 1 1 0\r\nv 0 1 0\r\n\
               vt 0 0\r\nvp 0.1\r\nl 1 2\r\np 1\r\n  f 1 2 3 4 \r\n# end\r\n";
    let file = read(obj.as_bytes(), Format::Obj).unwrap();
    assert_eq!((file.vertices, file.faces, file.points.len()), (4, 2, 2));
    assert_eq!(file.mesh.unwrap().faces, vec![[0, 1, 2], [0, 2, 3]]);
    assert!(file.points.iter().all(|p| p.n == DVec3::Z));
}

#[test]
fn obj_point_cloud_with_normals_by_index() {
    let obj = "v 0 0 0\nv 1 0 0\nv 2 0 0\nvn 0 0 3\nvn 0 1 0\nvn 0 0 0\n";
    let file = read(obj.as_bytes(), Format::Obj).unwrap();
    assert_eq!((file.vertices, file.faces, file.dropped_points), (3, 0, 1));
    assert_eq!(file.points[0].n, DVec3::Z);
    assert_eq!(file.points[1].p, DVec3::X);
    assert_eq!(file.points[1].n, DVec3::Y);
    assert!(file.mesh.is_none());
}

/// Positions without normals or faces, in every format, are read as such: the points with
/// zero normals, marked [`NormalSource::Missing`] (normals are estimated later).
#[test]
fn positions_without_normals_are_read_with_missing_normals() {
    let expected = [DVec3::ZERO, DVec3::X, DVec3::new(0.0, 2.0, 0.5)];
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 2 0.5\n".to_vec();
    let xyz = b"# x y z\n0 0 0\n1 0 0\n\n0 2 0.5\n".to_vec();
    let ply = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\nend_header\n0 0 0\n1 0 0\n0 2 0.5\n".to_vec();
    for (bytes, format) in [(obj, Format::Obj), (xyz, Format::Xyz), (ply, Format::Ply)] {
        let file = read(&bytes, format).unwrap();
        assert_eq!(file.normals, NormalSource::Missing, "{format:?}");
        assert_eq!((file.vertices, file.faces, file.dropped_points), (3, 0, 0));
        let positions: Vec<DVec3> = file.points.iter().map(|p| p.p).collect();
        assert_eq!(positions, expected, "{format:?}");
        assert!(file.points.iter().all(|p| p.n == DVec3::ZERO));
    }
    // Files with normals or faces say where theirs came from.
    let with = read(b"0 0 0 0 0 1\n", Format::Xyz).unwrap();
    assert_eq!(with.normals, NormalSource::File);
    let mesh = read(TETRA_OBJ.as_bytes(), Format::Obj).unwrap();
    assert_eq!(mesh.normals, NormalSource::Faces);
}

#[test]
fn obj_normal_count_must_match_positions() {
    let err = read(b"v 0 0 0\nv 1 0 0\nvn 0 0 1\n", Format::Obj).unwrap_err();
    assert_eq!(
        err,
        ReadError::NormalCountMismatch {
            vertices: 2,
            normals: 1
        }
    );
}

#[test]
fn obj_errors_name_the_line_or_face() {
    let cases: [(&str, &str); 9] = [
        ("v 0 0\n", "line 1"),
        ("v 0 0 0\nv 0 zero 0\n", "line 2"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "line 4"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "line 4"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 x 2\n", "line 4"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf /1 2 3\n", "line 4"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n", "face 1"),
        ("v 0 0 0\nv 1 0 0\nf -3 1 2\n", "face 0"),
        ("v 0 0 0\nv 1 0 inf\n", "vertex 1"),
    ];
    for (obj, expected) in cases {
        let err = read(obj.as_bytes(), Format::Obj).unwrap_err();
        assert!(err.to_string().contains(expected), "{obj:?}: {err}");
    }
}

#[test]
fn xyz_reads_oriented_points() {
    let xyz =
        "# a comment\n\n1 2 3 0 0 5\n  4\t5 6   -1 0 0  \r\n\n1e-3 -2.5E2 +7 0 3 4\n0 0 0 0 0 0\n";
    let file = read(xyz.as_bytes(), Format::Xyz).unwrap();
    assert_eq!(Format::sniff(xyz.as_bytes()), Format::Xyz);
    assert_eq!((file.vertices, file.faces, file.dropped_points), (4, 0, 1));
    assert_eq!(file.points[0].p, DVec3::new(1.0, 2.0, 3.0));
    assert_eq!(file.points[0].n, DVec3::Z);
    assert_eq!(file.points[1].n, -DVec3::X);
    assert_eq!(file.points[2].p, DVec3::new(1e-3, -250.0, 7.0));
    assert_eq!(file.points[2].n, DVec3::new(0.0, 0.6, 0.8));
}

#[test]
fn xyz_errors() {
    let mixed = read(b"0 0 0\n1 1 1 0 0 1\n", Format::Xyz).unwrap_err();
    assert!(matches!(mixed, ReadError::Line { line: 2, .. }), "{mixed}");
    assert!(mixed.to_string().contains("3 numbers (x y z)"), "{mixed}");
    let err = read(b"0 0 0 0 0 1\n0 0 0 0 1\n", Format::Xyz).unwrap_err();
    assert!(matches!(err, ReadError::Line { line: 2, .. }), "{err}");
    let err = read(b"0 0 0 0 0 1\n# c\n0 0 0 0 1 1 1\n", Format::Xyz).unwrap_err();
    assert!(matches!(err, ReadError::Line { line: 3, .. }), "{err}");
    let err = read(b"0 0 0 0 0 1\n0 0 0 0 0 1,\n", Format::Xyz).unwrap_err();
    assert!(matches!(err, ReadError::Line { line: 2, .. }), "{err}");
    let err = read(b"0 0 0 0 0 1\n0 0 0 0 0 NaN\n", Format::Xyz).unwrap_err();
    assert!(
        matches!(
            err,
            ReadError::NonFinite {
                element: "point",
                index: 1,
                what: "normal",
                line: Some(2)
            }
        ),
        "{err}"
    );
    let err = read(b"# only comments\n", Format::Xyz).unwrap_err();
    assert!(
        matches!(err, ReadError::NoPoints { vertices: 0, .. }),
        "{err}"
    );
    assert_eq!(
        read_mesh(b"0 0 0 0 0 1\n", Format::Xyz).unwrap_err(),
        ReadError::NoFaces
    );
}

#[test]
fn extension_and_sniffing() {
    for (ext, format) in [
        ("ply", Some(Format::Ply)),
        (".PLY", Some(Format::Ply)),
        ("Obj", Some(Format::Obj)),
        ("xyz", Some(Format::Xyz)),
        ("PTS", Some(Format::Xyz)),
        ("txt", Some(Format::Xyz)),
        ("stl", None),
        ("", None),
    ] {
        assert_eq!(Format::from_extension(ext), format, "{ext}");
    }
    assert_eq!(Format::sniff(b"ply\r\nformat ascii 1.0\r\n"), Format::Ply);
    assert_eq!(Format::sniff(b"plyx\n"), Format::Xyz);
    assert_eq!(Format::sniff(b"# x\nf 1 2 3\n"), Format::Obj);
    assert_eq!(Format::sniff(b"vn 0 0 1\n"), Format::Xyz);
    assert_eq!(Format::sniff(b""), Format::Xyz);
}
