//! Every command on hostile or degenerate input: an error (exit 2, one line naming the file) or
//! a result, never a panic or a hang, and never a clobbered output. Plus determinism across
//! thread counts and precision far from the origin.

use std::time::{Duration, Instant};

mod common;
use common::{assert_rejected, assert_success, model, psi, psi_env, scratch, xyz_text};

fn binary_ply(
    big_endian: bool,
    count_claim: usize,
    vertices: &[[f32; 3]],
    faces: &[[i32; 3]],
) -> Vec<u8> {
    let fmt = if big_endian {
        "binary_big_endian"
    } else {
        "binary_little_endian"
    };
    let mut out = format!(
        "ply\nformat {fmt} 1.0\nelement vertex {count_claim}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        faces.len()
    )
    .into_bytes();
    for v in vertices {
        for c in v {
            out.extend(if big_endian {
                c.to_be_bytes()
            } else {
                c.to_le_bytes()
            });
        }
    }
    for f in faces {
        out.push(3);
        for i in f {
            out.extend(if big_endian {
                i.to_be_bytes()
            } else {
                i.to_le_bytes()
            });
        }
    }
    out
}

/// A tetrahedron as (vertices, faces), outward.
fn tetra() -> (Vec<[f32; 3]>, Vec<[i32; 3]>) {
    (
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
        vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
    )
}

#[test]
fn hostile_inputs_fail_cleanly_in_every_command() {
    let dir = scratch("hostile");
    let (v, f) = tetra();
    let mut truncated = binary_ply(false, 4, &v, &f);
    truncated.truncate(truncated.len() - 7);
    let line: Vec<psi::OrientedPoint> = (0..100)
        .map(|i| psi::OrientedPoint {
            p: psi::DVec3::new(i as f64, 0.0, 0.0),
            n: psi::DVec3::Z,
        })
        .collect();
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("empty.ply", vec![]),
        (
            "header_only.ply",
            binary_ply(false, 4, &[], &[])[..150].to_vec(),
        ),
        ("truncated.ply", truncated),
        ("lying_count.ply", binary_ply(false, 40, &v, &f)),
        ("bad_index.ply", binary_ply(true, 4, &v, &[[0, 1, 9]])),
        ("garbage.obj", b"v 1 2\nf 1 2 x\n".to_vec()),
        (
            "random.bin",
            (0..3000u32)
                .map(|i| (i.wrapping_mul(2246822519) >> 11) as u8)
                .collect(),
        ),
        ("inf.xyz", b"0 0 inf 0 0 1\n".to_vec()),
        ("zero_normals.xyz", "0 0 0 0 0 0\n".repeat(40).into_bytes()),
        ("identical.xyz", "1 1 1 0 0 1\n".repeat(40).into_bytes()),
        ("collinear.xyz", xyz_text(&line).into_bytes()),
    ];
    let keep = dir.join("keep.out");
    std::fs::write(&keep, b"precious").unwrap();
    for (name, bytes) in &cases {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        let p = path.to_str().unwrap();
        let k = keep.to_str().unwrap();
        for args in [
            vec!["info", p],
            vec!["mesh", p, "-o", k, "--resolution", "32"],
            vec!["sample", p, "-o", k, "--iterations", "2"],
            vec![
                "edit",
                p,
                "--remove",
                "0,0,0,0.1",
                "-o",
                k,
                "--iterations",
                "2",
            ],
        ] {
            let t = Instant::now();
            let out = psi(&args);
            assert!(
                t.elapsed() < Duration::from_secs(60),
                "{args:?} took too long"
            );
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
            // Degenerate but legal input: a collinear cloud with normals (a very thin open
            // strip) is sampled, and `info` reads coincident points without building anything.
            let may_succeed =
                *name == "collinear.xyz" || (args[0] == "info" && *name == "identical.xyz");
            if out.status.success() {
                assert!(may_succeed, "{args:?} accepted hostile input");
                continue;
            }
            assert_rejected(&out, name, &keep, &format!("{args:?}"));
        }
    }
}

#[test]
fn big_endian_and_ascii_meshes_give_the_same_points() {
    let dir = scratch("encodings");
    let (v, f) = tetra();
    let le = dir.join("le.ply");
    let be = dir.join("be.ply");
    std::fs::write(&le, binary_ply(false, 4, &v, &f)).unwrap();
    std::fs::write(&be, binary_ply(true, 4, &v, &f)).unwrap();
    let a = psi::load_points(&le, &psi::ReadOptions::paper()).unwrap();
    let b = psi::load_points(&be, &psi::ReadOptions::paper()).unwrap();
    assert_eq!(a.points, b.points);
    assert_eq!(a.points.len(), 4);
}

#[test]
fn outputs_are_identical_for_one_and_two_threads_and_across_runs() {
    let dir = scratch("threads");
    let input = dir.join("torus.xyz");
    std::fs::write(
        &input,
        xyz_text(
            &psi::AnalyticShape::Torus {
                major: 1.0,
                minor: 0.35,
            }
            .sample(15_000, 9),
        ),
    )
    .unwrap();
    let run = |threads: &str, name: &str| {
        let out = dir.join(name);
        let o = psi_env(
            &[
                "sample",
                input.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ],
            &[("RAYON_NUM_THREADS", threads)],
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        std::fs::read(out).unwrap()
    };
    let one = run("1", "one.ply");
    let two = run("2", "two.ply");
    let again = run("2", "again.ply");
    assert_eq!(one, two, "thread count changed the particles");
    assert_eq!(two, again, "two runs differ");
}

#[test]
fn coordinates_offset_by_a_million_are_as_good_as_at_the_origin() {
    let shape = psi::AnalyticShape::Sphere { radius: 1.0 };
    let points = shape.sample(8000, 5);
    let offset = psi::DVec3::splat(1e6);
    let moved: Vec<_> = points
        .iter()
        .map(|p| psi::OrientedPoint {
            p: p.p + offset,
            n: p.n,
        })
        .collect();
    let params = psi::ParticleParams {
        iterations: 5,
        ..psi::ParticleParams::paper()
    };
    let a = psi::sample(
        &psi::Mpu::build(&points, &psi::MpuParams::paper()).unwrap(),
        &params,
    );
    let b = psi::sample(
        &psi::Mpu::build(&moved, &psi::MpuParams::paper()).unwrap(),
        &params,
    );
    assert_eq!(a.particles.len(), b.particles.len());
    let d = 2.0 * 3f64.sqrt();
    for (p, q) in a.particles.positions.iter().zip(&b.particles.positions) {
        // The same particles, to the precision of coordinates near 1e6 (ulp ≈ 1.2e-10).
        assert!(
            (*q - offset - *p).length() <= 1e-6 * d,
            "{p} vs {}",
            *q - offset
        );
        assert!((shape.signed_distance(*q - offset)).abs() <= 1e-3 * d);
    }
}

#[test]
fn open_surfaces_get_particles_only_where_there_is_data() {
    // A hemisphere (z ≥ 0) of a unit sphere: no particle may fly off to the missing half.
    let points: Vec<_> = psi::AnalyticShape::Sphere { radius: 1.0 }
        .sample(20_000, 3)
        .into_iter()
        .filter(|p| p.p.z >= 0.0)
        .collect();
    let mpu = psi::Mpu::build(&points, &psi::MpuParams::paper()).unwrap();
    let run = psi::sample(&mpu, &psi::ParticleParams::paper());
    assert!(run.particles.len() > 50);
    let spacing = run.report.after.spacing.mean;
    for p in &run.particles.positions {
        assert!(p.z >= -spacing, "particle at {p} below the data");
        assert!(
            (p.length() - 1.0).abs() < 2e-3 * 2.0 * 3f64.sqrt(),
            "particle at {p} off the sphere"
        );
    }
}

#[test]
fn flipped_normals_are_reported_and_repaired_on_request() {
    let dir = scratch("flipped");
    let shape = psi::AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    };
    let mut points = shape.sample(12_000, 6);
    for p in points.iter_mut().skip(5).step_by(10) {
        p.n = -p.n;
    }
    let input = dir.join("flipped.xyz");
    std::fs::write(&input, xyz_text(&points)).unwrap();
    let out = psi(&["info", input.to_str().unwrap(), "--json"]);
    assert!(out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--orient-normals"),
        "no warning"
    );
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(j["normals"]["opposed_fraction"].as_f64().unwrap() > 0.1);
    let particles = dir.join("p.ply");
    let out = psi(&[
        "sample",
        input.to_str().unwrap(),
        "--orient-normals",
        "-o",
        particles.to_str().unwrap(),
    ]);
    assert_success(&out);
    let back = psi::load_points(&particles, &psi::ReadOptions::paper()).unwrap();
    let d = 2.0 * 3f64.sqrt() * 1.35;
    for p in &back.points {
        assert!(
            shape.signed_distance(p.p).abs() < 1e-3 * d,
            "particle off the torus at {}",
            p.p
        );
    }
}

#[test]
fn a_flat_patch_is_sampled_on_the_patch() {
    // An open square of a plane: oriented points on z = 0, normals +z.
    let n = 120;
    let mut points = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (x, y) = (
                2.0 * i as f64 / (n - 1) as f64 - 1.0,
                2.0 * j as f64 / (n - 1) as f64 - 1.0,
            );
            points.push(psi::OrientedPoint {
                p: psi::DVec3::new(x, y, 0.0),
                n: psi::DVec3::Z,
            });
        }
    }
    let mpu = psi::Mpu::build(&points, &psi::MpuParams::paper()).unwrap();
    // A plane is fitted exactly, so the octree stays shallow and the automatic count is small;
    // an exact count spreads particles over the patch.
    for params in [
        psi::ParticleParams::paper(),
        psi::ParticleParams {
            count: Some(200),
            ..psi::ParticleParams::paper()
        },
    ] {
        let run = psi::sample(&mpu, &params);
        assert!(!run.particles.is_empty());
        for p in &run.particles.positions {
            assert!(p.z.abs() < 1e-3, "off the plane: {p}");
            assert!(p.x.abs() <= 1.02 && p.y.abs() <= 1.02, "off the patch: {p}");
        }
        if params.count.is_some() {
            assert_eq!(run.particles.len(), 200);
            assert!(
                run.report.after.spacing.min > 0.02,
                "particles bunched: {}",
                run.report.after.spacing.min
            );
        }
    }
}

#[test]
fn a_bunny_with_a_quarter_removed_gets_no_particles_in_the_gap() {
    let Some(path) = model("bunny.ply") else {
        return;
    };
    let all = psi::load_points(&path, &psi::ReadOptions::paper())
        .unwrap()
        .points;
    let b = psi::Aabb::from_points(all.iter().map(|p| p.p)).unwrap();
    let c = b.center();
    let removed = |p: &psi::DVec3| p.x > c.x && p.y > c.y;
    let kept: Vec<_> = all.iter().copied().filter(|p| !removed(&p.p)).collect();
    let mpu = psi::Mpu::build(&kept, &psi::MpuParams::paper()).unwrap();
    let run = psi::sample(&mpu, &psi::ParticleParams::paper());
    let spacing = run.report.after.spacing.mean;
    let inside_gap = run
        .particles
        .positions
        .iter()
        .filter(|p| p.x > c.x + spacing && p.y > c.y + spacing)
        .count();
    assert_eq!(inside_gap, 0, "particles in the removed quarter");
    assert!(run.report.after.max_surface_distance <= 1e-4 + 1e-12);
}
