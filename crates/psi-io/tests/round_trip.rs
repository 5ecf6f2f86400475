//! Round trips: what the writers write, the readers (and a third-party reader) read back.

use glam::DVec3;
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Property};
use psi_io::{
    Format, MeshSampling, ReadOptions, TriangleMesh, read_mesh, read_points, write_mesh_ply,
    write_points_ply,
};
use psi_shapes::{AnalyticShape, assert_near, tolerance::EXACT};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

fn sphere_points() -> (Vec<DVec3>, Vec<DVec3>) {
    let pts = AnalyticShape::Sphere { radius: 1.5 }.sample(500, 3);
    (
        pts.iter().map(|p| p.p).collect(),
        pts.iter().map(|p| p.n).collect(),
    )
}

#[test]
fn points_round_trip_exactly() {
    let (positions, normals) = sphere_points();
    let depth: Vec<f64> = (0..positions.len()).map(|i| i as f64 * 0.25).collect();
    let sigma: Vec<f64> = (0..positions.len())
        .map(|i| 1.0 / (i as f64 + 1.0))
        .collect();
    let mut bytes = Vec::new();
    write_points_ply(
        &mut bytes,
        &positions,
        &normals,
        &[("depth", &depth), ("sigma", &sigma)],
    )
    .unwrap();
    assert_eq!(Format::sniff(&bytes), Format::Ply);

    let file = read_points(&bytes, Format::Ply, &ReadOptions::paper()).unwrap();
    assert_eq!(file.vertices, positions.len());
    assert_eq!(
        (file.faces, file.degenerate_faces, file.dropped_points),
        (0, 0, 0)
    );
    assert!(file.mesh.is_none());
    assert_eq!(file.points.len(), positions.len());
    for ((q, p), n) in file.points.iter().zip(&positions).zip(&normals) {
        assert_eq!(q.p, *p, "positions are written and read bit-exactly");
        assert_near!((q.n - *n).length(), 0.0, EXACT);
        assert_near!(q.n.length(), 1.0, EXACT);
    }

    // A generic PLY reader sees the layout and the scalar channels.
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut bytes.as_slice())
        .unwrap();
    let vertex = &ply.header.elements["vertex"];
    let names: Vec<&str> = vertex.properties.keys().map(String::as_str).collect();
    assert_eq!(names, ["x", "y", "z", "nx", "ny", "nz", "depth", "sigma"]);
    for (i, v) in ply.payload["vertex"].iter().enumerate() {
        assert_eq!(v["depth"], Property::Double(depth[i]));
        assert_eq!(v["sigma"], Property::Double(sigma[i]));
        assert_eq!(v["nx"], Property::Double(normals[i].x));
    }
}

#[test]
fn points_with_random_values_round_trip() {
    let mut rng = Pcg64Mcg::seed_from_u64(11);
    let n = 2000;
    let positions: Vec<DVec3> = (0..n)
        .map(|_| {
            DVec3::new(
                rng.random_range(-1e6..1e6),
                rng.random(),
                rng.random_range(-1e-6..1e-6),
            )
        })
        .collect();
    let normals: Vec<DVec3> = (0..n)
        .map(|_| {
            DVec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                1.0,
            )
        })
        .collect();
    let mut bytes = Vec::new();
    write_points_ply(&mut bytes, &positions, &normals, &[]).unwrap();
    let file = read_points(&bytes, Format::Ply, &ReadOptions::paper()).unwrap();
    assert_eq!(file.points.len(), positions.len());
    for ((q, p), n) in file.points.iter().zip(&positions).zip(&normals) {
        assert_eq!(q.p, *p);
        assert_near!((q.n - n.normalize()).length(), 0.0, EXACT);
    }
}

#[test]
fn empty_point_set_writes_a_valid_header() {
    let mut bytes = Vec::new();
    write_points_ply(&mut bytes, &[], &[], &[]).unwrap();
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut bytes.as_slice())
        .unwrap();
    assert_eq!(ply.header.elements["vertex"].count, 0);
    // ... which psi refuses to use: there are no points.
    assert!(read_points(&bytes, Format::Ply, &ReadOptions::paper()).is_err());
}

#[test]
fn mesh_round_trips_through_f32() {
    let mut rng = Pcg64Mcg::seed_from_u64(5);
    // Values exactly representable in f32, so the round trip is exact.
    let vertices: Vec<DVec3> = (0..300)
        .map(|_| {
            DVec3::new(
                f64::from(rng.random::<f32>()),
                f64::from(rng.random::<f32>()),
                f64::from(rng.random::<f32>() * 8.0 - 4.0),
            )
        })
        .collect();
    let faces: Vec<[u32; 3]> = (0..500)
        .map(|_| {
            [
                rng.random_range(0..300),
                rng.random_range(0..300),
                rng.random_range(0..300),
            ]
        })
        .collect();
    let mesh = TriangleMesh { vertices, faces };
    let mut bytes = Vec::new();
    write_mesh_ply(&mut bytes, &mesh).unwrap();
    let header_end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap();
    let header = std::str::from_utf8(&bytes[..header_end]).unwrap();
    assert!(header.contains("property float x\n"));
    assert!(header.contains("property list uchar int vertex_indices\n"));

    let back = read_mesh(&bytes, Format::Ply).unwrap();
    assert_eq!(back, mesh);

    // read_points returns the same mesh alongside the points.
    let file = read_points(&bytes, Format::Ply, &ReadOptions::paper()).unwrap();
    assert_eq!(file.mesh.as_ref(), Some(&mesh));
    assert_eq!(file.faces, 500);
    assert_eq!(file.points.len() + file.degenerate_faces, 500);
}

#[test]
fn mesh_positions_round_to_f32() {
    let mesh = TriangleMesh {
        vertices: vec![DVec3::new(0.1, 0.2, 0.3), DVec3::X, DVec3::Y],
        faces: vec![[0, 1, 2]],
    };
    let mut bytes = Vec::new();
    write_mesh_ply(&mut bytes, &mesh).unwrap();
    let back = read_mesh(&bytes, Format::Ply).unwrap();
    assert_eq!(
        back.vertices[0],
        DVec3::new(0.1f32 as f64, 0.2f32 as f64, 0.3f32 as f64)
    );
    assert_eq!(back.faces, mesh.faces);
}

#[test]
fn mesh_written_then_sampled_per_vertex() {
    let mesh = TriangleMesh {
        vertices: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, DVec3::splat(9.0)],
        faces: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
    };
    let mut bytes = Vec::new();
    write_mesh_ply(&mut bytes, &mesh).unwrap();
    let opts = ReadOptions {
        sampling: MeshSampling::VertexNormals,
    };
    let file = read_points(&bytes, Format::Ply, &opts).unwrap();
    // Vertex 4 is unreferenced and skipped.
    assert_eq!(file.points.len(), 4);
    assert_eq!(file.vertices, 5);
}
