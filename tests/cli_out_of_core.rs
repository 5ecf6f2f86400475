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
            // (The point formats' noise would set the threshold the mesh's does not.)
            "--no-noise-estimate",
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

/// A torus with what a scan's outlier step leaves out: 150 points scattered through its box,
/// 40 lifted 3 to 10 spacings off, 25 repeats of earlier points (random normals on the
/// scattered ones), a stray clump of 30 points.
fn torus_with_strays() -> Vec<psi::OrientedPoint> {
    use psi::shapes::AnalyticShape;
    use rand::{RngExt, SeedableRng};
    let torus = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    };
    let mut points = torus.sample(20_000, 7);
    let spacing = (torus.area() / 20_000.0).sqrt();
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
    let mut within = |half: psi::DVec3| {
        half * psi::DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        )
    };
    let mut scattered = Vec::new();
    for _ in 0..150 {
        let p = within(psi::DVec3::new(1.4, 1.4, 0.5));
        let n = within(psi::DVec3::ONE).normalize_or(psi::DVec3::Z);
        scattered.push(psi::OrientedPoint { p, n });
    }
    for k in 0..40 {
        let q = points[k * 487];
        let lift = (3.0 + 0.17 * k as f64) * spacing;
        scattered.push(psi::OrientedPoint {
            p: q.p + lift * q.n,
            n: q.n,
        });
    }
    for k in 0..25 {
        scattered.push(points[k * 701]);
    }
    // A stray clump: 30 points within 0.01 of each other, hovering 0.33 above the top of the
    // torus (farther than 3 link distances from it).
    for _ in 0..30 {
        let p = psi::DVec3::new(1.0, 0.0, 0.68) + 0.01 * within(psi::DVec3::ONE);
        scattered.push(psi::OrientedPoint {
            p,
            n: psi::DVec3::Z,
        });
    }
    points.extend(scattered);
    points
}

/// The outlier step (its clump search too) and missing normals out of core: a torus with strays
/// and a clump (positions alone, and with normals), a box (positions alone: many ties among its neighbours) and a dense noisy
/// sphere (positions alone, planes among a coarser level of its points), tile by tile, give
/// the in-core run's particles byte for byte (the noisy sphere denoised; the noise's
/// threshold, the inward check and the ceiling on spacing in both, its darts on the box's
/// faces) and
/// leave out what it leaves out; a second run resumes from the final tiles, and only they and
/// the verdicts are left in the scratch directory.
#[test]
fn out_of_core_leaves_out_strays_and_estimates_normals_bitwise_as_in_core() {
    use psi::shapes::AnalyticShape;
    let dir = common::scratch("out-of-core-normals");
    let torus = torus_with_strays();
    let boxed = AnalyticShape::Box {
        half: psi::DVec3::new(0.5, 0.4, 0.3),
    }
    .sample(20_000, 8);
    let positions =
        |points: &[psi::OrientedPoint]| -> Vec<psi::DVec3> { points.iter().map(|p| p.p).collect() };
    // A dense noisy sphere: its planes are fitted among one point in 16 (level 2).
    let mut rng = <rand_pcg::Pcg64Mcg as rand::SeedableRng>::seed_from_u64(3);
    let noisy: Vec<psi::OrientedPoint> = AnalyticShape::Sphere { radius: 1.0 }
        .sample(20_000, 2)
        .iter()
        .map(|p| psi::OrientedPoint {
            p: p.p + 0.03 * psi::shapes::gaussian_vector(&mut rng),
            n: psi::DVec3::ZERO,
        })
        .collect();
    let cases = [
        ("torus", torus.clone(), false, 0),
        ("torus-normals", torus, true, -1),
        ("box", boxed, false, 0),
        ("noisy-sphere", noisy, false, 2),
    ];
    for (name, points, with_normals, level) in cases {
        let input = if with_normals {
            let ply = dir.join(format!("{name}.ply"));
            psi::save_points(&ply, &points).unwrap();
            ply
        } else {
            let xyz = dir.join(format!("{name}.xyz"));
            write_positions(&xyz, &positions(&points));
            xyz
        };
        let x = input.to_str().unwrap();
        let (core, core_json) = (
            dir.join(format!("{name}-core.ply")),
            dir.join(format!("{name}-core.json")),
        );
        let out = common::psi(&[
            "sample",
            x,
            "-q",
            "-o",
            core.to_str().unwrap(),
            "--json",
            core_json.to_str().unwrap(),
        ]);
        common::assert_success(&out);
        let core_report = json(&core_json);
        let outliers = &core_report["input"]["outliers"];
        let clumps = outliers["clumps"].as_u64().unwrap();
        assert_eq!(
            clumps >= 30,
            name.starts_with("torus"),
            "{name}: {outliers}"
        );
        let removed = outliers["removed"].as_u64().unwrap()
            + core_report["input"]["repeated_points"].as_u64().unwrap();
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
        assert_eq!(
            report["particles"]["added_by_ceiling"], core_report["particles"]["added_by_ceiling"],
            "{name}"
        );
        if name == "box" {
            assert!(report["particles"]["added_by_ceiling"].as_u64() > Some(50));
        }
        let pre = &report["tiles"]["preprocessing"];
        let normals = if with_normals {
            "given"
        } else {
            "estimated and oriented tile by tile"
        };
        assert_eq!(pre["normals"], normals);
        assert_eq!(pre["normals_level"].as_i64().unwrap_or(-1), level, "{name}");
        assert_eq!(pre["outliers"]["removed"].as_u64(), Some(removed), "{name}");
        assert_eq!(pre["outliers"]["clumps"].as_u64(), Some(clumps), "{name}");
        if name.starts_with("torus") {
            assert_eq!(pre["outliers"]["repeated"], 25);
            assert!(removed >= 25 + 150, "{name}: {removed} left out");
        }
        let mut left: Vec<String> = std::fs::read_dir(&scratch)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        // (The noisy sphere is denoised: its moved points' store too.)
        let noisy = name == "noisy-sphere";
        let mut kept = vec!["checks.json", "strays.bin", "strays.source", "tiles"];
        if noisy {
            kept.insert(1, "denoised");
            let moved = &core_report["input"]["denoised"];
            assert!(moved["moved"].as_u64() > Some(19_000), "{moved}");
            assert_eq!(pre["denoised"], *moved, "{name}");
        }
        assert_eq!(left, kept, "{name}");
        // The noise's threshold as in core (the noisy sphere's above the paper's).
        assert_eq!(
            report["mpu"]["error_threshold"],
            core_report["mpu"]["error_threshold"]["source"]
                .as_str()
                .map(|source| serde_json::json!({
                    "relative": core_report["mpu"]["error_threshold"]["relative"],
                    "source": source,
                }))
                .unwrap(),
            "{name}"
        );
        // (The noisy sphere's noise left after denoising is below the paper's threshold.)
        let after = &pre["noise_rel_after"];
        assert_eq!(after.is_number(), noisy, "{name}: {pre}");
        assert_eq!(
            *after, core_report["input"]["noise_estimate"]["relative_after_denoising"],
            "{name}"
        );
        let (again, report) = tiled("b");
        assert_eq!(report["tiles"]["resumed"], true);
        assert_eq!(
            report["tiles"]["preprocessing"]["outliers"],
            pre["outliers"]
        );
        assert!(again == first, "{name}: the resumed run differs");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The checks before the MPU out of core: a noisy torus whose given normals point inward, read
/// from a PLY file, tile by tile gives the in-core run's particles byte for byte (its normals
/// flipped outward, ε0 set from the noise, the points denoised); again with the same scratch
/// and `--no-denoise`, `--keep-inward-normals` (the store read as written), a given
/// threshold, and with the defaults once more (flipped again).
#[test]
fn out_of_core_flips_inward_normals_denoises_and_sets_the_noise_threshold_as_in_core() {
    use psi::shapes::AnalyticShape;
    let dir = common::scratch("out-of-core-checks");
    let mut rng = <rand_pcg::Pcg64Mcg as rand::SeedableRng>::seed_from_u64(5);
    let points: Vec<psi::OrientedPoint> = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    }
    .sample(20_000, 9)
    .iter()
    .map(|p| psi::OrientedPoint {
        p: p.p + 0.008 * psi::shapes::gaussian_vector(&mut rng),
        n: -p.n,
    })
    .collect();
    let ply = dir.join("inward.ply");
    psi::save_points(&ply, &points).unwrap();
    let x = ply.to_str().unwrap();
    let scratch = dir.join("scratch");
    let run = |tag: &str, flags: &[&str], tiled: bool| {
        let (o, j) = (
            dir.join(format!("{tag}.ply")),
            dir.join(format!("{tag}.json")),
        );
        // (Quiet but for the first tiled run, whose notices are read.)
        let mut args = vec!["sample", x, "-o", o.to_str().unwrap()];
        if tag != "tiled" {
            args.push("-q");
        }
        args.extend(["--json", j.to_str().unwrap()]);
        if tiled {
            args.extend([
                "--max-memory",
                "64MiB",
                "--scratch",
                scratch.to_str().unwrap(),
            ]);
        }
        args.extend(flags);
        let out = common::psi(&args);
        common::assert_success(&out);
        (std::fs::read(o).unwrap(), json(&j), out)
    };
    let (core, core_report, _) = run("core", &[], false);
    let input = &core_report["input"];
    assert_eq!(input["inward_normals_flipped"], true, "{core_report}");
    assert!(
        input["denoised"]["moved"].as_u64().unwrap() > 19_000,
        "{input}"
    );
    let (tiled, report, out) = run("tiled", &[], true);
    assert!(tiled == core, "particles differ from in core");
    let pre = &report["tiles"]["preprocessing"];
    assert_eq!(pre["inward_normals_flipped"], true, "{pre}");
    assert_eq!(pre["noise"]["sigma"], input["noise_estimate"]["sigma"]);
    // Denoised as in core, the noise left and the normals' consistency as in core.
    assert_eq!(pre["denoised"], input["denoised"], "{pre}");
    assert_eq!(
        pre["noise_rel_after"],
        input["noise_estimate"]["relative_after_denoising"]
    );
    assert_eq!(
        pre["normal_consistency"]["pairs_checked"],
        input["normals"]["pairs_checked"]
    );
    assert!(report["tiles"]["count"].as_u64().unwrap() >= 8);
    assert_eq!(
        report["mpu"]["error_rel"],
        core_report["mpu"]["error_threshold"]["relative"]
    );
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(said.contains("flipped them outward"), "{said}");
    // The store's own manifest says its normals are read flipped (a cluster's tasks open it),
    // also after the checks were made again for other flags.
    let negated = || {
        let m = json(&scratch.join("tiles").join("manifest.json"));
        m["normals_negated"].as_bool() == Some(true)
    };
    assert!(negated());
    // Without denoising, ε0 is set from the noise, as in core.
    let (core_nd, core_nd_report, _) = run("core-nd", &["--no-denoise"], false);
    let (tiled_nd, report_nd, _) = run("tiled-nd", &["--no-denoise"], true);
    assert!(
        tiled_nd == core_nd,
        "--no-denoise out of core: particles differ"
    );
    assert_eq!(core_nd_report["mpu"]["error_threshold"]["source"], "noise");
    assert_eq!(
        report_nd["mpu"]["error_rel"],
        core_nd_report["mpu"]["error_threshold"]["relative"]
    );
    assert_ne!(core_nd, core, "denoising changed nothing");
    assert!(report_nd["tiles"]["preprocessing"]["denoised"].is_null());
    assert!(
        !scratch.join("denoised").exists(),
        "the denoised store left once the checks were made again without denoising"
    );
    assert!(
        negated(),
        "the flag on disk after the checks were made again"
    );
    // The store read as written, and the checks made again (the points denoised with the
    // normals inward).
    let kept = ["--keep-inward-normals"];
    let (core_kept, ..) = run("core-kept", &kept, false);
    let (tiled_kept, report_kept, _) = run("tiled-kept", &kept, true);
    assert!(
        tiled_kept == core_kept,
        "--keep-inward-normals: particles differ"
    );
    assert_ne!(core_kept, core);
    assert_eq!(report_kept["tiles"]["resumed"], true);
    assert_eq!(
        report_kept["tiles"]["preprocessing"]["inward_normals_flipped"],
        false
    );
    // A given threshold is the run's (denoising still as the noise asks; ε0 = 3e-3 D would
    // split into 21 000 cells, more than 64 MiB holds beside the relaxation).
    let given = ["--mpu-error", "0.004"];
    let (core_given, ..) = run("core-given", &given, false);
    let (tiled_given, report_given, _) = run("tiled-given", &given, true);
    assert!(tiled_given == core_given, "--mpu-error: particles differ");
    assert_eq!(report_given["mpu"]["error_threshold"]["source"], "user");
    // The defaults again: flipped again, the denoised store found, the first run's particles.
    let (again, ..) = run("again", &[], true);
    assert!(again == core, "the defaults again: particles differ");
    // Checks an older psi made (no version, no denoising recorded) and a stopped run's moves
    // file: made again (denoised as in core), the stale file gone.
    let checks_path = scratch.join("checks.json");
    let mut old = json(&checks_path);
    assert_eq!(old["version"], psi::CHECKS_VERSION);
    let fields = old.as_object_mut().unwrap();
    for key in ["version", "consistency", "denoised", "denoised_store"] {
        fields.remove(key).unwrap();
    }
    fields.remove("noise_rel_after_bits").unwrap();
    std::fs::write(&checks_path, serde_json::to_vec(&old).unwrap()).unwrap();
    std::fs::remove_dir_all(scratch.join("denoised")).unwrap();
    std::fs::write(scratch.join("denoised.bin"), b"stale").unwrap();
    let (older, older_report, _) = run("older", &[], true);
    assert!(older == core, "checks of an older psi: particles differ");
    assert_eq!(
        older_report["tiles"]["preprocessing"]["denoised"],
        input["denoised"]
    );
    assert_eq!(json(&checks_path)["version"], psi::CHECKS_VERSION);
    assert!(
        !scratch.join("denoised.bin").exists(),
        "the stale moves' file"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Given normals that point every way (a noisy torus, every third normal flipped): the
/// consistency check out of core counts the in-core pairs, warns, and leaves the points
/// undenoised as in core (the particles byte for byte); without the noise estimate too.
#[test]
fn out_of_core_checks_the_consistency_of_given_normals_as_in_core() {
    use psi::shapes::AnalyticShape;
    let dir = common::scratch("out-of-core-consistency");
    let mut rng = <rand_pcg::Pcg64Mcg as rand::SeedableRng>::seed_from_u64(11);
    let points: Vec<psi::OrientedPoint> = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.4,
    }
    .sample(12_000, 3)
    .iter()
    .enumerate()
    .map(|(i, p)| psi::OrientedPoint {
        p: p.p + 0.008 * psi::shapes::gaussian_vector(&mut rng),
        n: if i % 3 == 0 { -p.n } else { p.n },
    })
    .collect();
    let ply = dir.join("every-way.ply");
    psi::save_points(&ply, &points).unwrap();
    let x = ply.to_str().unwrap();
    let run = |tag: &str, flags: &[&str], tiled: bool| {
        let (o, j) = (
            dir.join(format!("{tag}.ply")),
            dir.join(format!("{tag}.json")),
        );
        let scratch = dir.join(format!("scratch-{tag}"));
        let mut args = vec!["sample", x, "-o", o.to_str().unwrap()];
        args.extend(["--json", j.to_str().unwrap()]);
        if tiled {
            // (Without the noise estimate the noisy torus's cells need more than 64 MiB.)
            let budget = if flags.is_empty() { "64MiB" } else { "256MiB" };
            args.extend([
                "--max-memory",
                budget,
                "--scratch",
                scratch.to_str().unwrap(),
            ]);
        }
        args.extend(flags);
        let out = common::psi(&args);
        common::assert_success(&out);
        let said = String::from_utf8_lossy(&out.stderr).into_owned();
        (std::fs::read(o).unwrap(), json(&j), said)
    };
    for flags in [&[][..], &["--no-noise-estimate"][..]] {
        let (core, core_report, core_said) = run("core", flags, false);
        let (tiled, report, said) = run("tiled", flags, true);
        let normals = &core_report["input"]["normals"];
        let opposed = normals["opposed_fraction"].as_f64().unwrap();
        assert!(opposed > 0.05, "{flags:?}: {normals}");
        let warning = "of neighbouring normals point to opposite sides";
        assert!(core_said.contains(warning), "{flags:?}: {core_said}");
        assert!(said.contains(warning), "{flags:?}: {said}");
        let pre = &report["tiles"]["preprocessing"];
        assert_eq!(
            pre["normal_consistency"]["pairs_checked"], normals["pairs_checked"],
            "{flags:?}"
        );
        assert_eq!(
            pre["normal_consistency"]["opposed_fraction"],
            normals["opposed_fraction"]
        );
        assert!(core_report["input"]["denoised"].is_null(), "{flags:?}");
        assert!(pre["denoised"].is_null(), "{flags:?}");
        assert!(report["tiles"]["count"].as_u64().unwrap() >= 8, "{flags:?}");
        assert!(tiled == core, "{flags:?}: particles differ from in core");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Refused without touching the output: four points (too few for an MPU, their normals
/// estimated first), sizes that are no sizes; normal estimation cannot be turned off, nor steps
/// not done out of core asked for.
#[test]
fn out_of_core_refuses_too_few_points_and_bad_sizes() {
    let dir = common::scratch("out-of-core-bad");
    let xyz = dir.join("plain.xyz");
    std::fs::write(&xyz, "0 0 0\n1 0 0\n0 1 0\n0 0 1\n").unwrap();
    let kept = dir.join("kept.ply");
    std::fs::write(&kept, "precious").unwrap();
    // Estimating normals out of core cannot be turned off (the in-core flag would refuse
    // positions alone): the parser says so.
    let out = common::psi(&[
        "sample",
        xyz.to_str().unwrap(),
        "--max-memory",
        "64MiB",
        "--no-normal-estimation",
        "-o",
        kept.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot be used with"));
    let out = common::psi(&[
        "sample",
        xyz.to_str().unwrap(),
        "--max-memory",
        "64MiB",
        "-o",
        kept.to_str().unwrap(),
    ]);
    common::assert_rejected(&out, "plain.xyz", &kept, "too few");
    assert!(String::from_utf8_lossy(&out.stderr).contains("too few"));
    // Steps not done out of core are refused by the parser, not skipped: reorienting given
    // normals, a viewpoint.
    for flag in ["--orient-normals", "--viewpoint=0,0,5"] {
        let out = common::psi(&[
            "sample",
            xyz.to_str().unwrap(),
            "--max-memory",
            "64MiB",
            flag,
        ]);
        assert_eq!(out.status.code(), Some(2), "{flag}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("cannot be used with"));
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

/// An MPU with more cells than the budget holds is refused by name, the output untouched: a
/// noisy torus without its noise estimate (ε0 the paper's, far below the noise, splits cells
/// down to a few points each); with the noise estimate the same budget suffices.
#[test]
fn out_of_core_refuses_more_cells_than_the_budget_holds() {
    use psi::shapes::AnalyticShape;
    let dir = common::scratch("out-of-core-cells");
    let mut rng = <rand_pcg::Pcg64Mcg as rand::SeedableRng>::seed_from_u64(21);
    let points: Vec<psi::OrientedPoint> = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    }
    .sample(30_000, 2)
    .iter()
    .map(|p| psi::OrientedPoint {
        p: p.p + 0.02 * psi::shapes::gaussian_vector(&mut rng),
        n: p.n,
    })
    .collect();
    let ply = dir.join("noisy.ply");
    psi::save_points(&ply, &points).unwrap();
    let kept = dir.join("kept.ply");
    std::fs::write(&kept, "precious").unwrap();
    let scratch = dir.join("scratch");
    let run = |flags: &[&str]| {
        let mut args = vec![
            "sample",
            ply.to_str().unwrap(),
            "-o",
            kept.to_str().unwrap(),
            "--max-memory",
            "64MiB",
            "--scratch",
            scratch.to_str().unwrap(),
        ];
        args.extend(flags);
        common::psi(&args)
    };
    let out = run(&["--no-noise-estimate"]);
    common::assert_rejected(&out, "noisy.ply", &kept, "cells");
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(said.contains("more than --max-memory 64 MiB"), "{said}");
    assert!(said.contains("--mpu-error"), "{said}");
    let out = run(&[]);
    common::assert_success(&out);
    assert_ne!(std::fs::read(&kept).unwrap(), b"precious");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The budget is the whole process's peak: the bunny out of core within 96 MiB peaks below it
/// (the process's own baseline included, `VmHWM` in the report), and 64 MiB, which cannot
/// hold its MPU's 29 000 cells beside the baseline, is refused by name, the output untouched.
#[test]
fn the_budget_holds_the_whole_run_or_the_run_is_refused() {
    let Some(bunny) = common::model("bunny.ply") else {
        return;
    };
    let dir = common::scratch("out-of-core-budget");
    let kept = dir.join("kept.ply");
    std::fs::write(&kept, "precious").unwrap();
    let report = dir.join("r.json");
    let run = |budget: &str, out: &Path| {
        common::psi(&[
            "sample",
            bunny.to_str().unwrap(),
            "--max-memory",
            budget,
            "-o",
            out.to_str().unwrap(),
            "--json",
            report.to_str().unwrap(),
            "--scratch",
            dir.join(budget).to_str().unwrap(),
            "-q",
        ])
    };
    let out = run("64MiB", &kept);
    common::assert_rejected(&out, "bunny.ply", &kept, "cells");
    assert!(String::from_utf8_lossy(&out.stderr).contains("more than --max-memory 64 MiB"));
    let out = run("96MiB", &dir.join("b.ply"));
    common::assert_success(&out);
    let r = json(&report);
    let peak = r["peak_memory_bytes"].as_u64().unwrap();
    assert!(peak <= 96 << 20, "peak {peak} bytes above 96 MiB");
    assert!(r["particles"]["count"].as_u64().unwrap() > 7000, "{r}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The budget holds a run whose relaxation is thinned and whose cells take most of it: 600 000
/// torus points at 96 MiB with ε0 = 2e-3 D (more than 20 000 cells, asserted below, at 1.7 kB
/// each) peak below the budget, through the stores' write buffers (which grow by doubling) and
/// the relaxation (whose points share what the cells leave).
#[test]
fn a_thinned_relaxation_beside_many_cells_stays_within_the_budget() {
    use psi::shapes::AnalyticShape;
    let dir = common::scratch("out-of-core-thinned-budget");
    let points = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    }
    .sample(600_000, 3);
    let ply = dir.join("torus.ply");
    psi::save_points(&ply, &points).unwrap();
    let report = dir.join("r.json");
    let out = common::psi(&[
        "sample",
        ply.to_str().unwrap(),
        "--max-memory",
        "96MiB",
        "--mpu-error",
        "0.002",
        "-o",
        dir.join("p.ply").to_str().unwrap(),
        "--json",
        report.to_str().unwrap(),
        "--scratch",
        dir.join("s").to_str().unwrap(),
        "-q",
    ]);
    common::assert_success(&out);
    let r = json(&report);
    let cells = r["tiles"]["cells"].as_u64().unwrap();
    let relaxed = r["tiles"]["sampling"]["relax_points"].as_u64().unwrap();
    assert!(cells > 20_000, "{cells} cells");
    assert!(relaxed < 300_000, "{relaxed} points relaxed: not thinned");
    let peak = r["peak_memory_bytes"].as_u64().unwrap();
    assert!(peak <= 96 << 20, "peak {peak} bytes above 96 MiB");
    std::fs::remove_dir_all(&dir).unwrap();
}
