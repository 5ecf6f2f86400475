//! Fuzzes psi-io's readers: any byte sequence, read as each format and as a mesh, must give a
//! value or an error, never a panic; accepted points must be finite with unit normals.
#![no_main]

use libfuzzer_sys::fuzz_target;
use psi_io::{Format, MeshSampling, ReadOptions, read_mesh, read_points};

fuzz_target!(|data: &[u8]| {
    for format in [Format::Ply, Format::Obj, Format::Xyz, Format::sniff(data)] {
        for sampling in [MeshSampling::FaceCentroids, MeshSampling::VertexNormals] {
            if let Ok(file) = read_points(data, format, &ReadOptions { sampling }) {
                for p in &file.points {
                    assert!(p.p.is_finite() && p.n.is_finite());
                    assert!((p.n.length() - 1.0).abs() < 1e-9);
                }
            }
        }
        if let Ok(mesh) = read_mesh(data, format) {
            for f in &mesh.faces {
                assert!(f.iter().all(|&i| (i as usize) < mesh.vertices.len()));
            }
        }
    }
});
