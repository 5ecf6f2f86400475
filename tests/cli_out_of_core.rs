//! `psi sample --max-memory`: out of core on the bunny, from a PLY mesh (read whole) and from
//! a PCD, a PLY point cloud and an XYZ file (streamed), against the in-core run of the same points (the oracle: the same count,
//! the same MPU); resuming from the scratch files; damaged files decided again; bad input
//! refused without touching the output.

mod common;

use std::path::Path;

use serde_json::Value;

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// `points` as an ASCII PCD with normals.
fn write_pcd(path: &Path, points: &[psi::OrientedPoint]) {
    let mut s = format!(
        "VERSION 0.7\nFIELDS x y z normal_x normal_y normal_z\nSIZE 8 8 8 8 8 8\nTYPE F F F F F F\n\
         COUNT 1 1 1 1 1 1\nWIDTH {n}\nHEIGHT 1\nPOINTS {n}\nDATA ascii\n",
        n = points.len()
    );
    for p in points {
        s += &format!(
            "{:?} {:?} {:?} {:?} {:?} {:?}\n",
            p.p.x, p.p.y, p.p.z, p.n.x, p.n.y, p.n.z
        );
    }
    std::fs::write(path, s).unwrap();
}

#[test]
fn the_bunny_out_of_core_has_the_in_core_count_and_resumes_from_its_tiles() {
    let Some(bunny) = common::model("bunny.ply") else {
        return;
    };
    let dir = common::scratch("out-of-core");
    let b = bunny.to_str().unwrap();
    let run = |input: &str, out: &str, report: &str| {
        let out = common::psi(&[
            "sample",
            input,
            "--max-memory",
            "256MiB",
            "-o",
            out,
            "--json",
            report,
            "-q",
        ]);
        common::assert_success(&out);
    };
    let (o1, j1) = (dir.join("a.ply"), dir.join("a.json"));
    run(b, o1.to_str().unwrap(), j1.to_str().unwrap());
    let a = json(&j1);
    assert!(a["tiles"]["count"].as_u64().unwrap() >= 8, "{a}");
    assert_eq!(a["tiles"]["resumed"], false);
    // The in-core run of the same points (nothing removed or added).
    let jc = dir.join("core.json");
    let out = common::psi(&[
        "sample",
        b,
        "--keep-outliers",
        "--no-noise-estimate",
        "--keep-inward-normals",
        "--no-densify",
        "--json",
        jc.to_str().unwrap(),
        "-q",
    ]);
    common::assert_success(&out);
    let core = json(&jc);
    assert_eq!(a["particles"]["count"], core["particles"]["count"]);
    assert_eq!(a["tiles"]["cells"], core["mpu"]["report"]["cells"]);

    // Again: the tile and decision files are found and used; the particles are the same.
    let (o2, j2) = (dir.join("b.ply"), dir.join("b.json"));
    let scratch = dir.join("a.ply.psi-scratch");
    let out = common::psi(&[
        "sample",
        b,
        "--max-memory",
        "256MiB",
        "-o",
        o2.to_str().unwrap(),
        "--json",
        j2.to_str().unwrap(),
        "--scratch",
        scratch.to_str().unwrap(),
        "-q",
    ]);
    common::assert_success(&out);
    assert_eq!(json(&j2)["tiles"]["resumed"], true);
    assert_eq!(std::fs::read(&o1).unwrap(), std::fs::read(&o2).unwrap());

    // A damaged decisions file is decided again, to the same particles.
    let tiles = scratch.join("tiles");
    let victim = std::fs::read_dir(&tiles)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("cells-0")
        })
        .unwrap();
    let mut bytes = std::fs::read(&victim).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x10;
    std::fs::write(&victim, &bytes).unwrap();
    let o3 = dir.join("c.ply");
    let out = common::psi(&[
        "sample",
        b,
        "--max-memory",
        "256MiB",
        "-o",
        o3.to_str().unwrap(),
        "--scratch",
        scratch.to_str().unwrap(),
        "-q",
    ]);
    common::assert_success(&out);
    assert_eq!(std::fs::read(&o1).unwrap(), std::fs::read(&o3).unwrap());

    // The same points streamed from a PCD: the same count.
    let points = psi::load_points(&bunny, &psi::ReadOptions::paper())
        .unwrap()
        .points;
    let pcd = dir.join("bunny.pcd");
    write_pcd(&pcd, &points);
    let j4 = dir.join("d.json");
    run(
        pcd.to_str().unwrap(),
        dir.join("d.ply").to_str().unwrap(),
        j4.to_str().unwrap(),
    );
    assert_eq!(json(&j4)["particles"]["count"], core["particles"]["count"]);
    // And from a binary PLY point cloud (streamed) and an XYZ file (streamed): the same bytes.
    let ply = dir.join("bunny-points.ply");
    psi::save_points(&ply, &points).unwrap();
    let (o5, o6) = (dir.join("e.ply"), dir.join("f.ply"));
    run(
        ply.to_str().unwrap(),
        o5.to_str().unwrap(),
        dir.join("e.json").to_str().unwrap(),
    );
    let xyz = dir.join("bunny.xyz");
    common::write_xyz(&xyz, &points);
    run(
        xyz.to_str().unwrap(),
        o6.to_str().unwrap(),
        dir.join("f.json").to_str().unwrap(),
    );
    let d = std::fs::read(dir.join("d.ply")).unwrap();
    assert_eq!(std::fs::read(&o5).unwrap(), d);
    assert_eq!(std::fs::read(&o6).unwrap(), d);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `points`' positions alone as XYZ text, each number written so that it reads back exactly.
fn write_positions(path: &Path, points: &[psi::DVec3]) {
    let text: String = points
        .iter()
        .map(|p| format!("{:?} {:?} {:?}\n", p.x, p.y, p.z))
        .collect();
    std::fs::write(path, text).unwrap();
}

/// Positions alone (a torus and a box, x y z): the normals estimated and oriented tile by tile
/// give the in-core run's particles byte for byte (its other preprocessing off, as out of core);
/// a second run resumes from the final tiles, and only they are left in the scratch directory.
#[test]
fn out_of_core_estimates_missing_normals_bitwise_as_in_core() {
    use psi::shapes::AnalyticShape;
    let dir = common::scratch("out-of-core-normals");
    let shapes = [
        (
            "torus",
            AnalyticShape::Torus {
                major: 1.0,
                minor: 0.35,
            }
            .sample(20_000, 7),
        ),
        (
            "box",
            AnalyticShape::Box {
                half: psi::DVec3::new(0.5, 0.4, 0.3),
            }
            .sample(20_000, 8),
        ),
    ];
    for (name, points) in shapes {
        let xyz = dir.join(format!("{name}.xyz"));
        let positions: Vec<psi::DVec3> = points.iter().map(|p| p.p).collect();
        write_positions(&xyz, &positions);
        let x = xyz.to_str().unwrap();
        let core = dir.join(format!("{name}-core.ply"));
        let out = common::psi(&[
            "sample",
            x,
            "--keep-outliers",
            "--no-noise-estimate",
            "--no-denoise",
            "--max-spacing",
            "inf",
            "-q",
            "-o",
            core.to_str().unwrap(),
        ]);
        common::assert_success(&out);
        let scratch = dir.join(format!("{name}-scratch"));
        let tiled = |tag: &str| {
            let (o, j) = (
                dir.join(format!("{name}-{tag}.ply")),
                dir.join(format!("{name}-{tag}.json")),
            );
            let out = common::psi(&[
                "sample",
                x,
                "--max-memory",
                "64MiB",
                "--scratch",
                scratch.to_str().unwrap(),
                "-q",
                "-o",
                o.to_str().unwrap(),
                "--json",
                j.to_str().unwrap(),
            ]);
            common::assert_success(&out);
            (std::fs::read(o).unwrap(), json(&j))
        };
        let (first, report) = tiled("a");
        assert!(
            first == std::fs::read(&core).unwrap(),
            "{name}: particles differ from in core"
        );
        assert!(report["tiles"]["count"].as_u64().unwrap() >= 8, "{report}");
        assert!(
            report["tiles"]["preprocessing"]
                .as_str()
                .unwrap()
                .starts_with("normals estimated")
        );
        let left: Vec<String> = std::fs::read_dir(&scratch)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(left, ["tiles"], "{name}");
        let (again, report) = tiled("b");
        assert_eq!(report["tiles"]["resumed"], true);
        assert!(again == first, "{name}: the resumed run differs");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Refused without touching the output: four points (too few for an MPU, their normals
/// estimated first), a dense noisy cloud (its normals are fitted among a coarser subset of its
/// points in core: not done out of core yet, and said so), sizes that are no sizes.
#[test]
fn out_of_core_refuses_too_few_points_dense_noisy_positions_and_bad_sizes() {
    use psi::shapes::{AnalyticShape, gaussian_vector};
    use rand::SeedableRng;
    let dir = common::scratch("out-of-core-bad");
    let xyz = dir.join("plain.xyz");
    std::fs::write(&xyz, "0 0 0\n1 0 0\n0 1 0\n0 0 1\n").unwrap();
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
    let noisy: Vec<psi::DVec3> = AnalyticShape::Sphere { radius: 1.0 }
        .sample(20_000, 2)
        .iter()
        .map(|p| p.p + 0.03 * gaussian_vector(&mut rng))
        .collect();
    let noisy_xyz = dir.join("noisy.xyz");
    write_positions(&noisy_xyz, &noisy);
    let kept = dir.join("kept.ply");
    std::fs::write(&kept, "precious").unwrap();
    // Estimating normals out of core cannot be turned off (the in-core flag would refuse
    // positions alone): the parser says so.
    let out = common::psi(&[
        "sample",
        noisy_xyz.to_str().unwrap(),
        "--max-memory",
        "64MiB",
        "--no-normal-estimation",
        "-o",
        kept.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot be used with"));
    for (input, name, why) in [
        (&xyz, "plain.xyz", "too few"),
        (&noisy_xyz, "noisy.xyz", "does not do yet"),
    ] {
        let out = common::psi(&[
            "sample",
            input.to_str().unwrap(),
            "--max-memory",
            "64MiB",
            "-o",
            kept.to_str().unwrap(),
        ]);
        common::assert_rejected(&out, name, &kept, why);
        assert!(String::from_utf8_lossy(&out.stderr).contains(why), "{name}");
    }
    for size in ["12XB", "lots", "1MiB"] {
        let out = common::psi(&[
            "sample",
            xyz.to_str().unwrap(),
            "--max-memory",
            size,
            "-o",
            kept.to_str().unwrap(),
        ]);
        assert_eq!(out.status.code(), Some(2), "{size}");
        assert_eq!(std::fs::read(&kept).unwrap(), b"precious");
    }
    let out = common::psi(&["sample", xyz.to_str().unwrap(), "--max-memory", "1GiB"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--scratch"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_input_that_would_not_fit_in_memory_is_refused_before_it_is_read() {
    let dir = common::scratch("would-not-fit");
    let pcd = dir.join("cloud.pcd");
    let points = psi::AnalyticShape::Sphere { radius: 1.0 }.sample(20_000, 3);
    write_pcd(&pcd, &points);
    let kept = dir.join("kept.ply");
    std::fs::write(&kept, "precious").unwrap();
    let args = [
        "sample",
        pcd.to_str().unwrap(),
        "-o",
        kept.to_str().unwrap(),
    ];
    // 20 000 points take about 45 MiB in core: with 30 MiB available the run is refused.
    let out = common::psi_env(&args, &[("PSI_AVAILABLE_MEMORY", "31457280")]);
    common::assert_rejected(&out, "cloud.pcd", &kept, "would not fit");
    assert!(String::from_utf8_lossy(&out.stderr).contains("--max-memory"));
    // With 60 MiB it runs.
    let out = common::psi_env(&args, &[("PSI_AVAILABLE_MEMORY", "62914560")]);
    common::assert_success(&out);
    let est = psi::estimate_in_core_bytes(20_000, true);
    assert!((40 << 20..50 << 20).contains(&est), "{est}");
    assert_eq!(
        psi::estimate_points(&pcd, None).unwrap(),
        (20_000, Some(true))
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
