//! `psi edit --strokes` end to end: a session of edits from a file, its per-edit report, the
//! edited points written, and a malformed strokes file refused before any work.

mod common;
use common::{assert_rejected, assert_success, psi, scratch, write_xyz};

use psi::{AnalyticShape, DVec3};

#[test]
fn a_strokes_session_edits_in_order_and_reports_every_edit() {
    let dir = scratch("strokes");
    let points = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.4,
    }
    .sample(6000, 2);
    let input = dir.join("torus.xyz");
    write_xyz(&input, &points);
    let top = points
        .iter()
        .max_by(|a, b| a.p.z.total_cmp(&b.p.z))
        .unwrap();
    let strokes = serde_json::json!([
        {"brush": {"centre": top.p.to_array(), "radius": 0.3, "displacement": [0.0, 0.0, 0.05]}},
        {"brush": {"centre": (top.p + DVec3::X * 0.1).to_array(), "radius": 0.3, "displacement": [0.0, 0.0, 0.05]}},
        {"remove": {"centre": [-1.4, 0.0, 0.0], "radius": 0.1}},
        {"insert": {"points": [[1.0, 0.0, 0.45], [1.02, 0.0, 0.45]], "normals": [[0, 0, 1], [0, 0, 2]]}}
    ]);
    let strokes_path = dir.join("strokes.json");
    std::fs::write(&strokes_path, strokes.to_string()).unwrap();
    let (after, report, edited) = (
        dir.join("after.ply"),
        dir.join("r.json"),
        dir.join("points.ply"),
    );
    let out = psi(&[
        "edit",
        input.to_str().unwrap(),
        "--strokes",
        strokes_path.to_str().unwrap(),
        "--iterations",
        "3",
        "-o",
        after.to_str().unwrap(),
        "--points-after",
        edited.to_str().unwrap(),
        "--json",
        report.to_str().unwrap(),
    ]);
    assert_success(&out);
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    let local = &j["local"];
    let per_edit = local["seconds_per_edit"].as_array().unwrap();
    assert_eq!(per_edit.len(), 4);
    assert_eq!(local["marked_cells_per_edit"].as_array().unwrap().len(), 4);
    assert_eq!(
        local["particles_regenerated_per_edit"]
            .as_array()
            .unwrap()
            .len(),
        4
    );
    // Every edit changed points, so every one marked cells; the brushes moved particles.
    for (i, cells) in local["marked_cells_per_edit"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
    {
        assert!(cells.as_u64().unwrap() > 0, "edit {i} marked no cell");
    }
    for i in 0..2 {
        assert!(local["particles_regenerated_per_edit"][i].as_u64().unwrap() > 0);
    }
    // The edited points: the removed ball gone, the two inserted points there, the brush's
    // top raised.
    let edited = psi::load_points(&edited, &psi::ReadOptions::paper())
        .unwrap()
        .points;
    assert!(
        edited
            .iter()
            .all(|p| (p.p - DVec3::new(-1.4, 0.0, 0.0)).length() > 0.1)
    );
    assert!(
        edited
            .iter()
            .any(|p| (p.p - DVec3::new(1.02, 0.0, 0.45)).length() < 1e-12 && p.n == DVec3::Z)
    );
    let highest = edited.iter().map(|p| p.p.z).fold(f64::MIN, f64::max);
    assert!(highest > top.p.z + 0.04, "{highest} vs {}", top.p.z);
    let removed = points
        .iter()
        .filter(|p| (p.p - DVec3::new(-1.4, 0.0, 0.0)).length() <= 0.1)
        .count();
    assert_eq!(edited.len(), points.len() - removed + 2);
}

#[test]
fn a_malformed_strokes_file_is_refused_before_any_work() {
    let dir = scratch("strokes-bad");
    let keep = dir.join("keep.ply");
    std::fs::write(&keep, b"precious").unwrap();
    let cases = [
        ("not json", "not valid JSON", None),
        ("{\"brush\": {}}", "JSON array", None),
        (
            "[{\"brush\": {\"centre\": [0,0,0], \"radius\": 1, \"displacement\": [0,0,0]}}, {\"smudge\": {}}]",
            "unknown edit",
            Some(1),
        ),
        (
            "[{\"remove\": {\"centre\": [0,0,0], \"radius\": -2}}]",
            "negative",
            Some(0),
        ),
        (
            "[{\"brush\": {\"centre\": [0,0,1e999], \"radius\": 1, \"displacement\": [0,0,0]}}]",
            "not valid JSON",
            None,
        ),
        (
            "[{\"brush\": {\"centre\": [0,0,0], \"radius\": 1, \"displacement\": [0,0]}}]",
            "three numbers",
            Some(0),
        ),
        (
            "[{\"insert\": {\"points\": [[0,0,0],[1,0,0]], \"normals\": [[0,0,1]]}}]",
            "one normal per point",
            Some(0),
        ),
    ];
    for (k, (text, expected, index)) in cases.iter().enumerate() {
        let path = dir.join(format!("bad{k}.json"));
        std::fs::write(&path, text).unwrap();
        // A missing input file too: the strokes are checked first.
        let out = psi(&[
            "edit",
            dir.join("no-such-model.ply").to_str().unwrap(),
            "--strokes",
            path.to_str().unwrap(),
            "-o",
            keep.to_str().unwrap(),
        ]);
        assert_rejected(&out, &format!("bad{k}.json"), &keep, text);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(expected), "{text}: {err}");
        if let Some(i) = index {
            assert!(err.contains(&format!("edit {i}:")), "{text}: {err}");
        }
        assert!(
            !err.contains("no-such-model"),
            "the input was touched: {err}"
        );
    }
}

/// A strokes file that parses but whose second edit cannot be applied (a brush that folds the
/// surface over): the error names the strokes file and the edit, and no output is written.
#[test]
fn an_edit_failing_midway_names_the_strokes_file_and_writes_nothing() {
    let dir = scratch("strokes-fold");
    let input = dir.join("sphere.xyz");
    write_xyz(
        &input,
        &AnalyticShape::Sphere { radius: 1.0 }.sample(3000, 3),
    );
    let strokes = serde_json::json!([
        {"brush": {"centre": [0, 0, 1], "radius": 0.3, "displacement": [0, 0, 0.02]}},
        {"brush": {"centre": [0, 0, 1], "radius": 0.1, "displacement": [0, 0, 1.0]}}
    ]);
    let strokes_path = dir.join("fold.json");
    std::fs::write(&strokes_path, strokes.to_string()).unwrap();
    let keep = dir.join("keep.ply");
    std::fs::write(&keep, "precious").unwrap();
    let out = psi(&[
        "edit",
        input.to_str().unwrap(),
        "--strokes",
        strokes_path.to_str().unwrap(),
        "--iterations",
        "2",
        "-o",
        keep.to_str().unwrap(),
    ]);
    assert_rejected(&out, "fold.json", &keep, "folding brush");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("edit 1") && err.contains("folds"), "{err}");
}

/// `--frame-iterations` with `settle` steps: the particles written are byte for byte those of
/// the same strokes applied eagerly, and the report tells frame, settle and CPU time apart.
#[test]
fn deferred_strokes_write_the_eager_particles_and_report_their_settling() {
    let dir = scratch("strokes-deferred");
    let points = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.4,
    }
    .sample(6000, 3);
    let input = dir.join("torus.xyz");
    write_xyz(&input, &points);
    let brush = |x: f64| serde_json::json!({"brush": {"centre": [x, 0.0, 0.4], "radius": 0.3, "displacement": [0.0, 0.0, 0.03]}});
    let settle = |n: u64| serde_json::json!({"settle": {"iterations": n}});
    let eager = serde_json::json!([brush(0.9), brush(1.0), brush(1.1)]);
    let deferred = serde_json::json!([brush(0.9), settle(2), brush(1.0), brush(1.1), settle(1)]);
    let run = |name: &str, strokes: &serde_json::Value, extra: &[&str]| {
        let path = dir.join(format!("{name}.json"));
        std::fs::write(&path, strokes.to_string()).unwrap();
        let (out, report) = (
            dir.join(format!("{name}.ply")),
            dir.join(format!("{name}-report.json")),
        );
        let mut args = vec![
            "edit",
            input.to_str().unwrap(),
            "--strokes",
            path.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--json",
            report.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        assert_success(&psi(&args));
        let j: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
        (std::fs::read(&out).unwrap(), j)
    };
    let (eager_ply, eager_json) = run("eager", &eager, &[]);
    let (deferred_ply, j) = run("deferred", &deferred, &["--frame-iterations", "2"]);
    assert!(eager_ply == deferred_ply, "deferred particles differ");
    let local = &j["local"];
    assert_eq!(local["frame_iterations"], 2);
    let edits = local["edits"].as_array().unwrap();
    assert_eq!(edits.len(), 3);
    // 20 iterations: 2 in the frame, the rest pending.
    for e in edits {
        assert_eq!(e["pending_iterations"], 18);
    }
    // The first stroke settled 2 between strokes and its remaining 16 at the start of the
    // second; the third settled 1 and then the rest before writing.
    let settles = local["settles"].as_array().unwrap();
    let iterations: Vec<(u64, u64)> = settles
        .iter()
        .map(|s| {
            (
                s["after_edit"].as_u64().unwrap(),
                s["report"]["iterations"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(iterations, vec![(0, 2), (2, 1), (2, 17)]);
    assert!(edits[0]["settle_seconds"].as_f64().unwrap() == 0.0);
    assert!(edits[1]["settle_seconds"].as_f64().unwrap() > 0.0);
    assert_eq!(local["cpu_seconds_per_edit"].as_array().unwrap().len(), 3);
    assert_eq!(local["frame_seconds_per_edit"].as_array().unwrap().len(), 3);
    // Eager strokes leave nothing pending.
    for e in eager_json["local"]["edits"].as_array().unwrap() {
        assert_eq!(e["pending_iterations"], 0);
    }
}
