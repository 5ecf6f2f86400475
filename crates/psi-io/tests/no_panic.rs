//! Property tests (seeded, 256 cases each): random bytes, and random mutations and
//! truncations of valid PLY (ASCII and binary) and OBJ files, never panic any reader
//! (`read_points`, `read_mesh`, `read_point_scalars`); whatever is accepted satisfies the
//! output invariants.

mod common;

use common::mutation::{apply, text_mutation};
use common::{
    ALL_ENCODINGS, Enc, TETRA_OBJ, UCHAR_INT, XYZ_FLOAT, cloud_ply, config, ply, tetrahedron_ply,
};
use proptest::prelude::*;
use psi_io::{
    Format, MeshSampling, NormalSource, PointCloudFile, ReadOptions, TriangleMesh, read_mesh,
    read_point_scalars, read_points,
};

fn check_mesh(mesh: &TriangleMesh) {
    assert!(mesh.vertices.iter().all(|v| v.is_finite()));
    assert!(
        mesh.faces
            .iter()
            .flatten()
            .all(|&i| (i as usize) < mesh.vertices.len())
    );
}

fn check_points(file: &PointCloudFile) {
    assert!(!file.points.is_empty());
    for p in &file.points {
        assert!(p.p.is_finite());
        if file.normals == NormalSource::Missing {
            assert_eq!(p.n, glam::DVec3::ZERO);
        } else {
            assert!((p.n.length() - 1.0).abs() < 1e-12, "{:?}", p.n);
        }
    }
    if let Some(mesh) = &file.mesh {
        check_mesh(mesh);
        assert_eq!(mesh.faces.len(), file.faces);
        assert_eq!(mesh.vertices.len(), file.vertices);
    }
}

/// Runs every reader in every mode on `bytes`; panics only if an invariant is broken (or a
/// reader panics).
fn read_everything(bytes: &[u8]) {
    for format in [Format::Ply, Format::Obj, Format::Xyz, Format::sniff(bytes)] {
        for sampling in [MeshSampling::FaceCentroids, MeshSampling::VertexNormals] {
            if let Ok(file) = read_points(bytes, format, &ReadOptions { sampling }) {
                check_points(&file);
            }
        }
        if let Ok(mesh) = read_mesh(bytes, format) {
            assert!(!mesh.faces.is_empty());
            check_mesh(&mesh);
        }
    }
    if let Ok(columns) = read_point_scalars(bytes, &["x", "nz", "depth", "x"]) {
        assert_eq!(columns.len(), 4);
        assert_eq!(columns[0], columns[3]);
        let lengths: Vec<usize> = columns.iter().flatten().map(Vec::len).collect();
        assert!(lengths.windows(2).all(|w| w[0] == w[1]), "{lengths:?}");
        assert!(columns.iter().flatten().flatten().all(|v| v.is_finite()));
    }
}

/// Valid files to mutate: meshes and clouds in the three PLY encodings, a PLY with skipped
/// elements and wider types, and OBJ.
fn seeds() -> Vec<Vec<u8>> {
    let mut seeds = Vec::new();
    for enc in ALL_ENCODINGS {
        seeds.push(tetrahedron_ply(enc));
        seeds.push(cloud_ply(enc));
        let quad = vec![
            vec![0.0, 0.0, 0.0],
            vec![1.0, 0.0, 0.0],
            vec![1.0, 1.0, 0.0],
            vec![0.0, 1.0, 0.0],
        ];
        seeds.push(ply(
            enc,
            &[("double", "x"), ("short", "y"), ("uint", "z")],
            &quad,
            Some(("uint", "ushort", "vertex_index")),
            &[vec![0, 1, 2, 3]],
        ));
        seeds.push(ply(
            enc,
            &XYZ_FLOAT,
            &quad,
            Some(UCHAR_INT),
            &[vec![0, 1, 2], vec![0, 2, 3]],
        ));
    }
    seeds.push(
        b"ply\nformat ascii 1.0\nelement junk 1\nproperty list uchar float a\nelement vertex 3\n\
          property float x\nproperty float y\nproperty float z\nelement face 1\n\
          property list uchar int vertex_indices\nend_header\n2 0.5 1\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
            .to_vec(),
    );
    seeds.push(TETRA_OBJ.as_bytes().to_vec());
    seeds.push(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 1\nvn 0 0 1\n".to_vec());
    seeds.push(b"0 0 0 0 0 1\n1 0 0 0 1 0\n".to_vec());
    seeds
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        read_everything(&bytes);
    }

    #[test]
    fn random_text_never_panics(text in "[ -~\n\t\r]{0,400}") {
        read_everything(text.as_bytes());
        let mut with_magic = b"ply\n".to_vec();
        with_magic.extend_from_slice(text.as_bytes());
        read_everything(&with_magic);
    }

    #[test]
    fn random_payloads_after_valid_headers_never_panic(
        seed in 0usize..1000,
        payload in prop::collection::vec(any::<u8>(), 0..400),
    ) {
        let seeds = seeds();
        let base = &seeds[seed % seeds.len()];
        let cut = base
            .windows(11)
            .position(|w| w == b"end_header\n")
            .map_or(0, |p| p + 11);
        let mut bytes = base[..cut].to_vec();
        bytes.extend_from_slice(&payload);
        read_everything(&bytes);
    }

    #[test]
    fn mutated_valid_files_never_panic(
        seed in 0usize..1000,
        mutations in prop::collection::vec(text_mutation(), 1..8),
    ) {
        let seeds = seeds();
        let mut bytes = seeds[seed % seeds.len()].clone();
        for m in &mutations {
            apply(&mut bytes, m);
        }
        read_everything(&bytes);
    }

    #[test]
    fn every_truncation_of_valid_files_is_handled(seed in 0usize..1000, keep in 0.0f64..1.0) {
        let seeds = seeds();
        let base = &seeds[seed % seeds.len()];
        let len = (keep * base.len() as f64) as usize;
        read_everything(&base[..len]);
    }
}

#[test]
fn seeds_are_valid() {
    for (i, seed) in seeds().iter().enumerate() {
        let file = read_points(seed, Format::sniff(seed), &ReadOptions::paper());
        assert!(file.is_ok(), "seed {i}: {file:?}");
    }
}

#[test]
fn all_truncations_of_binary_meshes_are_errors() {
    for enc in [Enc::Le, Enc::Be] {
        let full = tetrahedron_ply(enc);
        for len in 0..full.len() {
            assert!(
                read_points(&full[..len], Format::Ply, &ReadOptions::paper()).is_err(),
                "{enc:?} {len}"
            );
        }
    }
}
