//! The `psi` binary on scan-like inputs (generated shapes, so the truth is analytic): positions
//! without normals, stray points, noise, a single view with its sensor; and the error paths
//! that came with them (each cause printed once, an output naming the input refused).

mod common;
use common::{assert_success, psi, scratch, write_xyz, xyz_text};

use psi::shapes::gaussian_vector;
use psi::{AnalyticShape, DVec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// Writes `positions` as an XYZ file of three columns.
fn write_positions(path: &std::path::Path, positions: &[DVec3]) {
    let text: String = positions
        .iter()
        .map(|p| format!("{} {} {}\n", p.x, p.y, p.z))
        .collect();
    std::fs::write(path, text).unwrap();
}

/// Runs `psi sample` on `input` with `extra` flags; returns the report and the particles.
fn sample(input: &std::path::Path, extra: &[&str]) -> (serde_json::Value, Vec<psi::OrientedPoint>) {
    let dir = input.parent().unwrap();
    let stem = input.file_stem().unwrap().to_string_lossy().into_owned();
    let out = dir.join(format!("{stem}-particles.ply"));
    let json = dir.join(format!("{stem}-report.json"));
    let mut args = vec![
        "sample",
        input.to_str().unwrap(),
        "--iterations",
        "5",
        "-o",
        out.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let run = psi(&args);
    assert_success(&run);
    let report = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let particles = psi::load_points(&out, &psi::ReadOptions::paper())
        .unwrap()
        .points;
    (report, particles)
}

#[test]
fn positions_alone_are_accepted_and_the_particles_face_outward() {
    let dir = scratch("scan-xyz");
    let sphere = AnalyticShape::Sphere { radius: 1.0 };
    let mut positions: Vec<DVec3> = sphere.sample(6000, 3).iter().map(|p| p.p).collect();
    // Shuffled, as a scanner's order carries no meaning.
    let mut rng = Pcg64Mcg::seed_from_u64(4);
    for i in (1..positions.len()).rev() {
        positions.swap(i, rng.random_range(0..=i));
    }
    let input = dir.join("sphere.xyz");
    write_positions(&input, &positions);
    let (report, particles) = sample(&input, &[]);
    assert_eq!(report["input"]["normals"]["source"], "estimated");
    assert_eq!(report["input"]["points"], 6000);
    assert!(!particles.is_empty());
    for p in &particles {
        assert!(sphere.signed_distance(p.p).abs() < 2e-3, "{:?}", p.p);
        assert!(
            p.n.dot(p.p.normalize()) > 0.95,
            "normal {:?} at {:?}",
            p.n,
            p.p
        );
    }
    // With estimation refused, the file is refused, naming it.
    let out = psi(&["info", input.to_str().unwrap(), "--no-normal-estimation"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("sphere.xyz"));
}

#[test]
fn a_single_view_with_its_sensor_keeps_to_the_data() {
    let dir = scratch("scan-view");
    let sphere = AnalyticShape::Sphere { radius: 1.0 };
    let sensor = DVec3::new(0.0, 0.0, 4.0);
    // What the sensor sees: the cap facing it.
    let seen: Vec<DVec3> = sphere
        .sample(12_000, 5)
        .iter()
        .filter(|p| p.n.dot(sensor - p.p) > 0.0)
        .map(|p| p.p)
        .collect();
    let input = dir.join("view.xyz");
    write_positions(&input, &seen);
    let (report, particles) = sample(&input, &["--viewpoint", "0,0,4"]);
    assert_eq!(
        report["input"]["normals"]["treatment"],
        "estimated_toward_viewpoint"
    );
    for p in &particles {
        assert!(sphere.signed_distance(p.p).abs() < 2e-3 * 2.0 * 3f64.sqrt());
        // On the seen cap (its rim is where the sphere turns away from the sensor, z ≈ 0.25),
        // facing the sensor.
        assert!(p.p.z > 0.2, "particle off the data at {:?}", p.p);
        // Outward, as the sphere's own normal (near the rim it grazes the sensor's ray, which
        // is where orientation by propagation takes over from the sensor's direction).
        assert!(
            p.n.dot(p.p.normalize()) > 0.9,
            "normal {:?} at {:?}",
            p.n,
            p.p
        );
    }
}

#[test]
fn stray_points_are_left_out_and_reported() {
    let dir = scratch("scan-outliers");
    let torus = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    };
    let mut points = torus.sample(20_000, 7);
    let mut rng = Pcg64Mcg::seed_from_u64(8);
    for _ in 0..200 {
        let p = DVec3::new(
            rng.random_range(-1.4..1.4),
            rng.random_range(-1.4..1.4),
            rng.random_range(-0.4..0.4),
        );
        let n = gaussian_vector(&mut rng).normalize();
        points.push(psi::OrientedPoint { p, n });
    }
    let input = dir.join("torus.xyz");
    write_xyz(&input, &points);
    // The criteria, in sample spacings (the bunny's 2e-3 and 1e-2 D are about 0.55
    // and 2.8 of its spacings): at most 1 % of the particles farther than 0.55 spacing from
    // the true surface, none farther than 2.8.
    let spacing = (torus.area() / 20_000.0).sqrt();
    let beyond = |particles: &[psi::OrientedPoint], spacings: f64| {
        particles
            .iter()
            .filter(|p| torus.signed_distance(p.p).abs() > spacings * spacing)
            .count()
    };
    let (report, particles) = sample(&input, &[]);
    let removed = report["input"]["outliers"]["removed"].as_u64().unwrap();
    assert!(removed >= 150, "removed {removed}");
    assert_eq!(beyond(&particles, 2.8), 0, "particles on stray points");
    assert!(100 * beyond(&particles, 0.55) <= particles.len());
    // Kept on request: then they are fitted, and particles sit on them.
    let (kept, particles) = sample(&input, &["--keep-outliers"]);
    assert!(kept["input"]["outliers"].is_null());
    assert!(
        beyond(&particles, 2.8) > 0,
        "the test's stray points do matter"
    );
}

#[test]
fn noise_raises_the_error_threshold_and_the_user_wins() {
    let dir = scratch("scan-noise");
    let sphere = AnalyticShape::Sphere { radius: 1.0 };
    let clean = sphere.sample(20_000, 9);
    let input = dir.join("clean.xyz");
    write_xyz(&input, &clean);
    let (report, _) = sample(&input, &[]);
    assert_eq!(report["mpu"]["error_threshold"]["source"], "paper");
    assert_eq!(report["mpu"]["error_threshold"]["relative"], 0.005);
    // Noise of 0.5 % of D on every coordinate.
    let d = 2.0 * 3f64.sqrt();
    let sigma = 0.005 * d;
    let mut rng = Pcg64Mcg::seed_from_u64(10);
    let noisy: Vec<psi::OrientedPoint> = clean
        .iter()
        .map(|p| psi::OrientedPoint {
            p: p.p + sigma * gaussian_vector(&mut rng),
            n: p.n,
        })
        .collect();
    let noisy_input = dir.join("noisy.xyz");
    write_xyz(&noisy_input, &noisy);
    let mean_distance = |particles: &[psi::OrientedPoint]| {
        particles
            .iter()
            .map(|p| sphere.signed_distance(p.p).abs())
            .sum::<f64>()
            / particles.len() as f64
    };
    // By default the noise is taken out of the points, and what is left sets the threshold.
    let (report, particles) = sample(&noisy_input, &[]);
    let estimate = report["input"]["noise_estimate"]["relative"]
        .as_f64()
        .unwrap();
    assert!(
        (estimate / 0.005 - 1.0).abs() < 0.15,
        "noise estimate {estimate}"
    );
    let left = report["input"]["noise_estimate"]["relative_after_denoising"]
        .as_f64()
        .unwrap();
    assert!(left < 0.3 * estimate, "noise left {left}");
    assert!(report["input"]["denoised"]["moved"].as_u64().unwrap() > 19_000);
    let mean = mean_distance(&particles);
    assert!(
        mean < 0.2 * sigma,
        "mean distance {mean} against noise {sigma}"
    );
    // Without denoising, the noise sets the threshold: 4σ.
    let (report, particles) = sample(&noisy_input, &["--no-denoise"]);
    assert_eq!(report["mpu"]["error_threshold"]["source"], "noise");
    let threshold = report["mpu"]["error_threshold"]["relative"]
        .as_f64()
        .unwrap();
    assert!(threshold > 0.015, "threshold {threshold}");
    assert!(report["input"]["denoised"].is_null());
    let mean = mean_distance(&particles);
    assert!(
        mean < 0.5 * sigma,
        "mean distance {mean} against noise {sigma}"
    );
    let (user, _) = sample(&noisy_input, &["--mpu-error", "0.008"]);
    assert_eq!(user["mpu"]["error_threshold"]["source"], "user");
    assert_eq!(user["mpu"]["error_threshold"]["relative"], 0.008);
}

#[test]
fn an_error_names_its_cause_once_and_outputs_never_replace_the_input() {
    let dir = scratch("scan-errors");
    let bad = dir.join("bad.xyz");
    std::fs::write(&bad, "0 0 0 0 0 1\n1 0 nan 0 0 1\n").unwrap();
    let out = psi(&["sample", bad.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2));
    let cause = "NaN or infinite position";
    assert_eq!(err.matches(cause).count(), 1, "{err}");
    assert_eq!(err.matches("bad.xyz").count(), 1, "{err}");

    let input = dir.join("sphere.xyz");
    let points = AnalyticShape::Sphere { radius: 1.0 }.sample(500, 1);
    let text = xyz_text(&points);
    std::fs::write(&input, &text).unwrap();
    // The same file by another name.
    let other = dir.join(".").join("sphere.xyz");
    for args in [
        vec![
            "sample",
            input.to_str().unwrap(),
            "-o",
            other.to_str().unwrap(),
        ],
        vec![
            "sample",
            input.to_str().unwrap(),
            "--json",
            input.to_str().unwrap(),
        ],
        vec![
            "mesh",
            input.to_str().unwrap(),
            "-o",
            input.to_str().unwrap(),
        ],
        vec![
            "render",
            input.to_str().unwrap(),
            "-o",
            input.to_str().unwrap(),
        ],
    ] {
        let out = psi(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains("names the input file"),
            "{args:?}"
        );
        assert_eq!(std::fs::read_to_string(&input).unwrap(), text, "{args:?}");
    }
}

/// A torus as a triangle mesh of `nu` × `nv` quads (two triangles each), written as ASCII PLY;
/// returns the vertices and faces.
fn torus_mesh(path: &std::path::Path, nu: usize, nv: usize) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let (major, minor) = (1.0, 0.4);
    let mut v = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            let (a, b) = (
                std::f64::consts::TAU * i as f64 / nu as f64,
                std::f64::consts::TAU * j as f64 / nv as f64,
            );
            let r = major + minor * b.cos();
            v.push(DVec3::new(r * a.cos(), r * a.sin(), minor * b.sin()));
        }
    }
    let id = |i: usize, j: usize| ((i % nu) * nv + (j % nv)) as u32;
    let mut f = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            f.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            f.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    let mut text = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        v.len(),
        f.len()
    );
    for p in &v {
        text.push_str(&format!("{} {} {}\n", p.x, p.y, p.z));
    }
    for t in &f {
        text.push_str(&format!("3 {} {} {}\n", t[0], t[1], t[2]));
    }
    std::fs::write(path, text).unwrap();
    (v, f)
}

#[test]
fn a_coarse_mesh_is_followed_and_a_fine_one_kept_as_it_is() {
    use parry3d_f64::query::PointQuery;
    let dir = scratch("scan-mesh");
    let coarse = dir.join("coarse.ply");
    let (v, f) = torus_mesh(&coarse, 24, 10);
    let (report, particles) = sample(&coarse, &[]);
    let added = report["input"]["mesh_points_added"].as_u64().unwrap();
    assert!(added > 2000, "added {added}");
    assert_eq!(report["input"]["points"], 480 + added);
    let mesh = parry3d_f64::shape::TriMesh::new(v, f).unwrap();
    let d = report["input"]["bbox_diagonal"].as_f64().unwrap();
    let near = particles
        .iter()
        .filter(|p| mesh.distance_to_local_point(p.p, false) <= 2e-3 * d)
        .count();
    assert!(
        near as f64 >= 0.995 * particles.len() as f64,
        "{near} of {} within 2e-3 D of the mesh",
        particles.len()
    );
    // Without the added points the implicit bulges between the coarse triangles' centroids
    // (seen without the ceiling on spacing, whose darts sit at the centroids themselves).
    let (_, plain) = sample(&coarse, &["--no-densify", "--max-spacing", "inf"]);
    let near = plain
        .iter()
        .filter(|p| mesh.distance_to_local_point(p.p, false) <= 2e-3 * d)
        .count();
    assert!(
        (near as f64) < 0.9 * plain.len() as f64,
        "{near} of {}",
        plain.len()
    );
    // A fine mesh of the same torus keeps one point per triangle.
    let fine = dir.join("fine.ply");
    torus_mesh(&fine, 240, 100);
    let out = psi(&["info", fine.to_str().unwrap(), "--json"]);
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(j["points"], 48_000);
    assert_eq!(j["mesh_points_added"], 0);
}
