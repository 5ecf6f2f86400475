//! The `psi` binary end to end: real data, malformed input, exit codes, atomic outputs.

mod common;
use common::{assert_rejected, assert_success, models, psi, scratch, write_xyz};

#[test]
fn info_reports_the_bunny_dataset_count() {
    let Some(models) = models() else { return };
    let out = psi(&["info", models.join("bunny.ply").to_str().unwrap(), "--json"]);
    assert_success(&out);
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(j["points"], 69451);
    assert_eq!(j["faces"], 69451);
    assert_eq!(j["vertices"], 35947);
    let d = j["bbox_diagonal"].as_f64().unwrap();
    assert!((d - 0.24997).abs() < 1e-4, "{d}");
}

#[test]
fn info_on_the_builtin_model() {
    let out = psi(&["info", "--json"]);
    assert!(out.status.success());
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(j["points"], psi::shapes::BUILTIN_MODEL_POINTS);
}

#[test]
fn malformed_inputs_fail_with_exit_code_2_and_name_the_file() {
    let dir = scratch("bad");
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("empty.ply", vec![]),
        ("header_only.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n".to_vec()),
        ("garbage.xyz", b"1 2 three 4 5 6\n".to_vec()),
        ("no_normals.xyz", b"0 0 0\n1 0 0\n0 1 0\n".to_vec()),
        ("nan.xyz", b"nan 0 0 0 0 1\n".to_vec()),
        ("random.ply", (0..4000u32).map(|i| (i.wrapping_mul(2654435761) >> 13) as u8).collect()),
        ("few.xyz", b"0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n".to_vec()),
        ("same.xyz", "0 0 0 0 0 1\n".repeat(50).into_bytes()),
    ];
    let existing = dir.join("keep.ply");
    std::fs::write(&existing, b"precious").unwrap();
    for (name, bytes) in cases {
        let path = dir.join(name);
        std::fs::write(&path, &bytes).unwrap();
        let out = psi(&[
            "sample",
            path.to_str().unwrap(),
            "-o",
            existing.to_str().unwrap(),
            "--iterations",
            "1",
        ]);
        assert_rejected(&out, name, &existing, name);
    }
    for missing in [dir.join("missing.ply"), dir.clone()] {
        let out = psi(&["info", missing.to_str().unwrap()]);
        assert_eq!(out.status.code(), Some(2));
    }
    // Usage errors are exit code 2 too.
    assert_eq!(
        psi(&["sample", "--iterations", "many"]).status.code(),
        Some(2)
    );
    assert_eq!(psi(&["sample", "--count", "0"]).status.code(), Some(2));
}

#[test]
fn sample_writes_a_readable_particle_file_and_report() {
    let dir = scratch("ok");
    // A small sphere as XYZ.
    let pts = psi::AnalyticShape::Sphere { radius: 2.0 }.sample(3000, 4);
    let input = dir.join("sphere.xyz");
    write_xyz(&input, &pts);
    let out_ply = dir.join("p.ply");
    let report = dir.join("r.json");
    let out = psi(&[
        "sample",
        input.to_str().unwrap(),
        "-o",
        out_ply.to_str().unwrap(),
        "--json",
        report.to_str().unwrap(),
    ]);
    assert_success(&out);
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    for key in [
        "input.points",
        "input.bbox_diagonal",
        "mpu.build_seconds",
        "mpu.leaves",
        "mpu.max_depth",
        "particles.count",
        "particles.init_seconds",
        "particles.simulate_seconds",
        "particles.iterations",
    ] {
        let (a, b) = key.split_once('.').unwrap();
        assert!(!j[a][b].is_null(), "report lacks {key}");
    }
    // The evaluation floor is a benchmark: measured only when asked.
    assert!(j["particles"]["value_and_gradient_seconds"].is_null());
    let floor_report = dir.join("floor.json");
    let out = psi(&[
        "sample",
        input.to_str().unwrap(),
        "--iterations",
        "2",
        "--evaluation-floor",
        "--json",
        floor_report.to_str().unwrap(),
    ]);
    assert_success(&out);
    let f: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&floor_report).unwrap()).unwrap();
    assert!(
        f["particles"]["value_and_gradient_seconds"]
            .as_f64()
            .unwrap()
            > 0.0
    );
    assert!(f["particles"]["evaluation_floor_ratio"].as_f64().unwrap() > 0.0);
    let n = j["particles"]["count"].as_u64().unwrap() as usize;
    let back = psi::load_points(&out_ply, &psi::ReadOptions::paper()).unwrap();
    assert_eq!(back.points.len(), n);
    for p in &back.points {
        assert!((p.p.length() - 2.0).abs() < 1e-3 * 4.0 * 3f64.sqrt());
    }
    let mesh = dir.join("m.ply");
    let out = psi(&[
        "mesh",
        input.to_str().unwrap(),
        "-o",
        mesh.to_str().unwrap(),
        "--resolution",
        "64",
    ]);
    assert!(out.status.success());
    let m = psi::load_mesh(&mesh).unwrap();
    assert!(m.faces.len() > 500);
}

#[test]
fn the_ceiling_on_spacing_covers_a_flat_sheet_and_is_reported() {
    let dir = scratch("ceiling");
    // A flat square of 2 × 2 (x y z only, normals estimated): one octree cell.
    let pts: Vec<psi::OrientedPoint> = (0..10_000u64)
        .map(|i| {
            let h =
                |k: u64| ((i.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ k) % 10_007) as f64 / 10_007.0;
            psi::OrientedPoint {
                p: psi::DVec3::new(2.0 * h(1), 2.0 * ((i % 100) as f64 + h(2)) / 100.0, 0.0),
                n: psi::DVec3::Z,
            }
        })
        .collect();
    let input = dir.join("sheet.xyz");
    write_xyz(&input, &pts);
    let run = |extra: &[&str], name: &str| {
        let json = dir.join(format!("{name}.json"));
        let mut args = vec![
            "sample",
            input.to_str().unwrap(),
            "-q",
            "--json",
            json.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        assert_success(&psi(&args));
        serde_json::from_slice::<serde_json::Value>(&std::fs::read(&json).unwrap()).unwrap()
    };
    let default = run(&[], "default");
    let d = default["input"]["bbox_diagonal"].as_f64().unwrap();
    let ceiling = default["particles"]["max_spacing"].as_f64().unwrap();
    assert!((ceiling - 0.025 * d).abs() <= 1e-12 * d);
    let count = default["particles"]["count"].as_u64().unwrap() as f64;
    // About one particle per ceiling-sized hexagon of the 4 m² sheet: 4 / (0.87 · s²).
    let hexagons = 4.0 / (0.866 * ceiling * ceiling);
    assert!(
        count > 0.6 * hexagons && count < 1.6 * hexagons,
        "{count} for {hexagons}"
    );
    let given = run(&["--max-spacing", "0.2"], "given");
    assert_eq!(given["particles"]["max_spacing"].as_f64(), Some(0.2));
    let none = run(&["--max-spacing", "inf"], "none");
    assert!(none["particles"]["max_spacing"].is_null());
    assert!(none["particles"]["count"].as_u64().unwrap() < 10);
    for bad in [
        ["--max-spacing", "0"],
        ["--max-spacing", "-1"],
        ["--max-spacing", "nan"],
    ] {
        assert_eq!(
            psi(&["sample", "--iterations", "1", bad[0], bad[1]])
                .status
                .code(),
            Some(2)
        );
    }
    let conflict = psi(&["sample", "--count", "10", "--max-spacing", "1"]);
    assert_eq!(conflict.status.code(), Some(2));
}
