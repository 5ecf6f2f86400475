//! How meshes become points: face centroids against hand-computed values, area-weighted
//! vertex normals, and degenerate triangles.

use glam::DVec3;
use psi_io::{Format, MeshSampling, ReadError, ReadOptions, read_points};
use psi_shapes::{assert_near, tolerance::EXACT};

fn vertex_normals() -> ReadOptions {
    ReadOptions {
        sampling: MeshSampling::VertexNormals,
    }
}

fn assert_vec_near(a: DVec3, b: DVec3) {
    assert_near!((a - b).length(), 0.0, EXACT, "{a} vs {b}");
}

#[test]
fn face_centroid_of_a_hand_computed_triangle() {
    // a = (1, 2, 3), b = (4, 2, 3), c = (1, 2, 9):
    // centroid = (2, 2, 5); (b - a) x (c - a) = (3, 0, 0) x (0, 0, 6) = (0, -18, 0) -> -y.
    let obj = b"v 1 2 3\nv 4 2 3\nv 1 2 9\nf 1 2 3\n";
    let file = read_points(obj, Format::Obj, &ReadOptions::paper()).unwrap();
    assert_eq!(file.points.len(), 1);
    assert_vec_near(file.points[0].p, DVec3::new(2.0, 2.0, 5.0));
    assert_eq!(file.points[0].n, DVec3::new(0.0, -1.0, 0.0));

    // A slanted one: a = 0, b = (2, 0, 0), c = (0, 2, 2): normal (0, -4, 4)/|.| .
    let obj = b"v 0 0 0\nv 2 0 0\nv 0 2 2\nf 1 2 3\n";
    let file = read_points(obj, Format::Obj, &ReadOptions::default()).unwrap();
    assert_vec_near(
        file.points[0].p,
        DVec3::new(2.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0),
    );
    let s = 0.5f64.sqrt();
    assert_vec_near(file.points[0].n, DVec3::new(0.0, -s, s));
}

#[test]
fn default_options_are_the_paper_options() {
    assert_eq!(ReadOptions::default(), ReadOptions::paper());
    assert_eq!(ReadOptions::paper().sampling, MeshSampling::FaceCentroids);
}

#[test]
fn tetrahedron_face_normals_point_outward() {
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
    let file = read_points(obj, Format::Obj, &ReadOptions::paper()).unwrap();
    let centre = DVec3::splat(0.25);
    assert_eq!(file.points.len(), 4);
    for p in &file.points {
        assert!(p.n.dot(p.p - centre) > 0.0, "{p:?}");
        assert_near!(p.n.length(), 1.0, EXACT);
    }
    let expected_normals = [-DVec3::Z, -DVec3::Y, -DVec3::X, DVec3::ONE.normalize()];
    for (p, n) in file.points.iter().zip(expected_normals) {
        assert_vec_near(p.n, n);
    }
}

#[test]
fn vertex_normals_are_area_weighted() {
    // Vertex 0 is shared by a big triangle in the z = 0 plane (normal +z, area 50) and a small
    // one in the x = 0 plane (normal +x, area 0.5): the area-weighted normal is (1, 0, 100)/|.|.
    let obj = b"v 0 0 0\nv 10 0 0\nv 0 10 0\nv 0 1 0\nv 0 0 1\nv 5 5 5\nf 1 2 3\nf 1 4 5\n";
    let file = read_points(obj, Format::Obj, &vertex_normals()).unwrap();
    assert_eq!((file.vertices, file.faces), (6, 2));
    // Vertex 6 (5 5 5) is unreferenced and skipped; the others each give a point, in order.
    assert_eq!(file.points.len(), 5);
    assert_eq!(file.points[0].p, DVec3::ZERO);
    assert_vec_near(file.points[0].n, DVec3::new(1.0, 0.0, 100.0).normalize());
    assert_eq!(file.points[1].n, DVec3::Z);
    assert_eq!(file.points[3].p, DVec3::Y);
    assert_eq!(file.points[3].n, DVec3::X);
    assert_eq!(file.dropped_points, 0);
}

#[test]
fn vertex_normals_that_cancel_are_dropped() {
    // Two copies of a triangle with opposite windings: normals cancel at every vertex.
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 3 2\n";
    let err = read_points(obj, Format::Obj, &vertex_normals()).unwrap_err();
    assert_eq!(
        err,
        ReadError::NoPoints {
            vertices: 3,
            faces: 2,
            degenerate_faces: 0,
            dropped_points: 3
        }
    );
    // Face centroids still give two (opposite) points.
    let file = read_points(obj, Format::Obj, &ReadOptions::paper()).unwrap();
    assert_eq!(file.points.len(), 2);
    assert_eq!(file.points[0].n, -file.points[1].n);
}

#[test]
fn degenerate_triangles_are_skipped_and_counted() {
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\n\
                f 1 2 3\nf 1 1 2\nf 1 2 4\nf 3 3 3\n";
    for sampling in [MeshSampling::FaceCentroids, MeshSampling::VertexNormals] {
        let file = read_points(obj, Format::Obj, &ReadOptions { sampling }).unwrap();
        assert_eq!((file.faces, file.degenerate_faces), (4, 3), "{sampling:?}");
        // The mesh keeps every triangle.
        assert_eq!(file.mesh.as_ref().unwrap().faces.len(), 4);
    }
    let file = read_points(obj, Format::Obj, &ReadOptions::paper()).unwrap();
    assert_eq!(file.points.len(), 1);
    // Vertex 3 (2 0 0) only lies on the collinear triangle: its normal is zero, dropped.
    let file = read_points(obj, Format::Obj, &vertex_normals()).unwrap();
    assert_eq!((file.points.len(), file.dropped_points), (3, 1));

    let only_degenerate = b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n";
    let err = read_points(only_degenerate, Format::Obj, &ReadOptions::paper()).unwrap_err();
    assert!(
        matches!(
            err,
            ReadError::NoPoints {
                degenerate_faces: 1,
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn overflowing_cross_products_count_as_degenerate() {
    let obj =
        b"v -1e300 0 0\nv 1e300 0 0\nv 0 1e300 0\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 4 5 6\n";
    let file = read_points(obj, Format::Obj, &ReadOptions::paper()).unwrap();
    assert_eq!((file.points.len(), file.degenerate_faces), (1, 1));
    assert!(
        file.points
            .iter()
            .all(|p| p.p.is_finite() && p.n.is_finite())
    );
}

#[test]
fn tiny_triangles_follow_the_exact_zero_rule() {
    // Edges of 1e-100: the cross product (1e-200) is non-zero though its squared length
    // underflows; the normal is still a unit vector.
    let obj = b"v 0 0 0\nv 1e-100 0 0\nv 0 1e-100 0\nf 1 2 3\n";
    let file = read_points(obj, Format::Obj, &ReadOptions::paper()).unwrap();
    assert_eq!(file.points[0].n, DVec3::Z);
    // Edges of 1e-170: the cross product itself underflows to zero, so the triangle has zero
    // area in f64 and is degenerate.
    let obj = b"v 0 0 0\nv 1e-170 0 0\nv 0 1e-170 0\nf 1 2 3\n";
    let err = read_points(obj, Format::Obj, &ReadOptions::paper()).unwrap_err();
    assert!(
        matches!(
            err,
            ReadError::NoPoints {
                degenerate_faces: 1,
                ..
            }
        ),
        "{err}"
    );
}
