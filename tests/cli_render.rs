//! `psi render` end to end: particle files (with and without depth and σ), meshes, and bad
//! input (exit code 2, one line naming the file, the existing output untouched).

mod common;
use common::{assert_rejected, assert_success, psi, scratch, write_xyz};

use psi::DVec3;

/// Width and height from a PNG's IHDR chunk.
fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
    let be = |at: usize| u32::from_be_bytes(bytes[at..at + 4].try_into().unwrap());
    (be(16), be(20))
}

/// A particle file like `psi sample` writes: a unit sphere with depth and σ.
fn particle_file(path: &std::path::Path) {
    let points = psi::AnalyticShape::Sphere { radius: 1.0 }.sample(1500, 3);
    let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
    let normals: Vec<DVec3> = points.iter().map(|p| p.n).collect();
    let depth: Vec<f64> = positions
        .iter()
        .map(|p| (5.0 + 2.0 * p.y.abs()).round())
        .collect();
    let sigma: Vec<f64> = depth.iter().map(|d| 0.2 / d).collect();
    let mut bytes = Vec::new();
    psi::io::write_points_ply(
        &mut bytes,
        &positions,
        &normals,
        &[("depth", &depth), ("sigma", &sigma)],
    )
    .unwrap();
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn render_draws_particles_in_every_colouring_and_view() {
    let dir = scratch("particles");
    let input = dir.join("p.ply");
    particle_file(&input);
    let png = dir.join("view.png");
    for (color, view) in [("depth", "front"), ("sigma", "iso"), ("normal", "top")] {
        let out = psi(&[
            "render",
            input.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--size",
            "160",
            "--color",
            color,
            "--view",
            view,
        ]);
        assert_success(&out);
        assert_eq!(png_size(&std::fs::read(&png).unwrap()), (160, 160));
        assert!(String::from_utf8_lossy(&out.stdout).contains("1500 particles"));
    }
    let disks = [
        "render",
        input.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--size",
        "100",
        "--style",
        "disks",
        "--no-legend",
    ];
    assert_success(&psi(&disks));
    // Same input, same picture.
    let first = std::fs::read(&png).unwrap();
    assert_success(&psi(&disks));
    assert_eq!(first, std::fs::read(&png).unwrap());
}

#[test]
fn render_draws_a_mesh_and_plain_points() {
    let dir = scratch("mesh");
    let mesh = psi::TriangleMesh {
        vertices: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
        faces: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
    };
    let mut bytes = Vec::new();
    psi::io::write_mesh_ply(&mut bytes, &mesh).unwrap();
    let input = dir.join("tetra.ply");
    std::fs::write(&input, bytes).unwrap();
    let png = dir.join("mesh.png");
    let out = psi(&[
        "render",
        input.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--size",
        "120",
        "--view",
        "iso",
    ]);
    assert_success(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("4 triangles"));
    assert_eq!(png_size(&std::fs::read(&png).unwrap()), (120, 120));

    // Oriented points without depth: colour by normal works, by depth is refused.
    let xyz = dir.join("points.xyz");
    write_xyz(
        &xyz,
        &psi::AnalyticShape::Sphere { radius: 1.0 }.sample(500, 1),
    );
    assert_success(&psi(&[
        "render",
        xyz.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--size",
        "64",
        "--color",
        "normal",
    ]));
    let out = psi(&["render", xyz.to_str().unwrap(), "-o", png.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("points.xyz") && err.contains("depth"), "{err}");
}

#[test]
fn bad_input_is_exit_code_2_naming_the_file_and_keeps_the_output() {
    let dir = scratch("bad");
    let existing = dir.join("keep.png");
    std::fs::write(&existing, b"precious").unwrap();
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("empty.ply", vec![]),
        ("garbage.ply", b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nend_header\n1\n".to_vec()),
        ("nan.ply", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nend_header\nnan 0 0 0 0 1\n".to_vec()),
        ("no_normals.ply", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n".to_vec()),
        ("random.xyz", (0..3000u32).map(|i| (i.wrapping_mul(2654435761) >> 11) as u8).collect()),
    ];
    for (name, bytes) in cases {
        let path = dir.join(name);
        std::fs::write(&path, &bytes).unwrap();
        let out = psi(&[
            "render",
            path.to_str().unwrap(),
            "-o",
            existing.to_str().unwrap(),
        ]);
        assert_rejected(&out, name, &existing, name);
    }
    let missing = dir.join("missing.ply");
    let out = psi(&[
        "render",
        missing.to_str().unwrap(),
        "-o",
        existing.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let input = dir.join("p.ply");
    particle_file(&input);
    for bad in [
        ["--size", "0"],
        ["--splat-scale", "-1"],
        ["--view", "sideways"],
    ] {
        let mut args = vec![
            "render",
            input.to_str().unwrap(),
            "-o",
            existing.to_str().unwrap(),
        ];
        args.extend(bad);
        assert_eq!(psi(&args).status.code(), Some(2), "{bad:?}");
    }
    assert_eq!(std::fs::read(&existing).unwrap(), b"precious");
}
