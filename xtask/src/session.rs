//! Editing sessions on the bunny (issues "Interactive editing sessions", "Edits at any size"):
//! drags of 20 brush strokes of radius 0.012, each moving the points 0.8 mm along their normal,
//! one across its back and several from seeds in other places and directions, through
//! `psi edit --strokes --frame-iterations` in several fresh processes (each stroke a frame,
//! settled before the next); the time of every frame and the CPU time of every stroke, and each
//! drag's locality and accuracy against a from-scratch build of the edited points.
//! `cargo xtask session` runs it alone; `reproduce-tables` includes it.

use crate::median::median;
use psi::regen::FRAME_ITERATIONS;
use std::path::Path;
use std::process::Command;

use anyhow::{Context, Result, bail};
use psi::{DVec3, Mpu, MpuParams, OrientedPoint};
use serde_json::{Value, json};

use crate::release_binary::{build_release, run_psi_report};
use crate::{Flags, models_dir, project_root};

/// Strokes in the drag.
const STROKES: usize = 20;
/// Brush radius, world units (the bunny's).
const RADIUS: f64 = 0.012;
/// How far a stroke moves the points at its centre, world units.
const DEPTH: f64 = 0.0008;
/// Sessions run (each a fresh process).
const RUNS: usize = 5;

/// The drag: stroke centres on the bunny's back, along x at z ≈ 0 from x = −0.015 to 0.035
/// (the highest input point in a thin slab around each x), each pushing the points out by
/// [`DEPTH`] along the normal there.
pub(crate) fn drag(points: &[OrientedPoint]) -> Result<Vec<(DVec3, DVec3)>> {
    (0..STROKES)
        .map(|k| {
            let x = -0.015 + 0.05 * k as f64 / (STROKES - 1) as f64;
            let top = points
                .iter()
                .filter(|p| (p.p.x - x).abs() < 0.002 && p.p.z.abs() < 0.004)
                .max_by(|a, b| a.p.y.total_cmp(&b.p.y))
                .with_context(|| format!("no point of the back near x = {x}"))?;
            Ok((top.p, DEPTH * top.n))
        })
        .collect()
}

/// The strokes file of `drag`: each stroke a frame (`--frame-iterations`), settled before the
/// next, as an editor settles between frames.
fn strokes_json(drag: &[(DVec3, DVec3)]) -> Value {
    Value::Array(
        drag.iter()
            .flat_map(|(c, d)| {
                [
                    json!({"brush": {"centre": c.to_array(), "radius": RADIUS, "displacement": d.to_array()}}),
                    json!({"settle": {"iterations": 20}}),
                ]
            })
            .collect(),
    )
}

/// Seeds of the generated drags (`bench edit`'s: a random start and direction on the surface,
/// strokes a quarter radius apart), beside the drag across the back.
const SEEDS: std::ops::RangeInclusive<u64> = 1..=4;

/// One drag's figures over its runs.
struct DragFigures {
    /// Each stroke's median frame time over the runs (s).
    frames: Vec<f64>,
    /// Each stroke's median CPU time over the runs (s).
    cpu: Vec<f64>,
    /// Particles farther than 4 radii from every stroke, and how many are bitwise unchanged.
    far: (usize, usize),
    /// Share of the particles within 2e-3 D of a from-scratch build of the edited points.
    within: f64,
    /// The last run's report.
    last: Value,
}

/// Runs `drag` (stroke centres and displacements, world units) through `psi edit --strokes` in
/// [`RUNS`] fresh processes, scratch files in `out_dir`.
fn run_drag(
    psi: &Path,
    model: &Path,
    drag: &[(DVec3, DVec3)],
    out_dir: &Path,
) -> Result<DragFigures> {
    let strokes = out_dir.join("drag.json");
    std::fs::write(&strokes, serde_json::to_string_pretty(&strokes_json(drag))?)?;
    let (before, after, points_after, report) = (
        out_dir.join("drag-before.ply"),
        out_dir.join("drag-after.ply"),
        out_dir.join("drag-points.ply"),
        out_dir.join("drag.json.report"),
    );
    let mut per_edit: Vec<Vec<f64>> = vec![Vec::new(); drag.len()];
    let mut cpu_per_edit: Vec<Vec<f64>> = vec![Vec::new(); drag.len()];
    let mut last = Value::Null;
    for _ in 0..RUNS {
        last = run_psi_report(
            Command::new(psi)
                .arg("edit")
                .arg(model)
                .arg("--strokes")
                .arg(&strokes)
                .arg("--frame-iterations")
                .arg(FRAME_ITERATIONS.to_string())
                .arg("--before")
                .arg(&before)
                .arg("-o")
                .arg(&after)
                .arg("--points-after")
                .arg(&points_after)
                .arg("--json")
                .arg(&report)
                .arg("-q"),
            &report,
        )?;
        for (key, into) in [
            ("frame_seconds_per_edit", &mut per_edit),
            ("cpu_seconds_per_edit", &mut cpu_per_edit),
        ] {
            let times = last["local"][key]
                .as_array()
                .with_context(|| format!("report without {key}"))?;
            for (k, t) in times.iter().enumerate().take(drag.len()) {
                into[k].push(t.as_f64().unwrap_or(f64::NAN));
            }
        }
    }
    // Locality: particles farther than 4 radii from every stroke are bitwise unchanged.
    let read = |p: &Path| -> Result<Vec<OrientedPoint>> {
        Ok(psi::load_points(p, &psi::ReadOptions::paper())?.points)
    };
    let (old, new) = (read(&before)?, read(&after)?);
    let far = |p: &DVec3| drag.iter().all(|(c, _)| (*p - *c).length() > 4.0 * RADIUS);
    let new_set: std::collections::HashSet<[u64; 3]> = new
        .iter()
        .map(|p| p.p.to_array().map(f64::to_bits))
        .collect();
    let far_old: Vec<&OrientedPoint> = old.iter().filter(|p| far(&p.p)).collect();
    let unchanged = far_old
        .iter()
        .filter(|p| new_set.contains(&p.p.to_array().map(f64::to_bits)))
        .count();
    // Accuracy: the particles against a from-scratch build of the edited points.
    let edited = read(&points_after)?;
    let mpu = Mpu::build(&edited, &MpuParams::paper())?;
    let d = mpu.diagonal();
    let within = new
        .iter()
        .filter(|p| {
            let (f, g) = mpu.value_and_gradient(p.p);
            f.abs() / g.length().max(f64::MIN_POSITIVE) <= 2e-3 * d
        })
        .count();
    Ok(DragFigures {
        frames: per_edit.iter().map(|v| median(v)).collect(),
        cpu: cpu_per_edit.iter().map(|v| median(v)).collect(),
        far: (far_old.len(), unchanged),
        within: within as f64 / new.len().max(1) as f64,
        last,
    })
}

/// The median of a report's per-edit list `key`.
fn per_edit_median(report: &Value, key: &str) -> f64 {
    median(
        &report["local"][key]
            .as_array()
            .map(|a| a.iter().filter_map(Value::as_f64).collect::<Vec<_>>())
            .unwrap_or_default(),
    )
}

/// Runs the session on `model` (the bunny) with the release binary `psi`, scratch files in
/// `out_dir`: the drag across the back and the generated drags of [`SEEDS`]. Returns the
/// Markdown section and its JSON. Frame figures are over the warm strokes (each drag's first
/// stroke is reported apart).
pub(crate) fn session(psi: &Path, model: &Path, out_dir: &Path) -> Result<(String, Value)> {
    let points = psi::load_points(model, &psi::ReadOptions::paper())?.points;
    let index = psi::octree::PointIndex::new(&points.iter().map(|p| p.p).collect::<Vec<_>>());
    let mut drags = vec![("across the back".to_owned(), drag(&points)?)];
    for seed in SEEDS {
        let strokes = crate::bench::edit::drag(&points, &index, RADIUS, seed, STROKES)
            .into_iter()
            .filter_map(|e| match e {
                psi::regen::Edit::Brush {
                    center,
                    displacement,
                    ..
                } => Some((center, displacement.normalize_or_zero() * DEPTH)),
                _ => None,
            })
            .collect();
        drags.push((format!("seed {seed}"), strokes));
    }
    let mut md = format!(
        "\n## Editing sessions on the bunny (`psi edit --strokes --frame-iterations {FRAME_ITERATIONS}`: drags of {STROKES} brush strokes of radius {RADIUS}, each moving the points {} mm along the normal, each a frame of {FRAME_ITERATIONS} relaxation iterations settled before the next; one drag across the back and drags from seeds {}–{} (a random start and direction, strokes a quarter radius apart); {RUNS} sessions per drag, each a fresh process; frame figures over the warm strokes, each stroke's median over the sessions; more models: `cargo xtask bench edit`)\n\n| drag | median frame ms | worst frame ms | first frame ms | CPU per stroke ms (median, frame and settle) | particles > 4 radii from every stroke unchanged | particles within 2e-3 D of a from-scratch build | marked cells per edit (median) | particles regenerated per edit (median) |\n|---|---|---|---|---|---|---|---|---|\n",
        1e3 * DEPTH,
        SEEDS.start(),
        SEEDS.end(),
    );
    let (mut all_warm, mut all_cpu) = (Vec::new(), Vec::new());
    let mut rows = Vec::new();
    for (name, drag) in &drags {
        let f = run_drag(psi, model, drag, out_dir)?;
        let warm = &f.frames[1.min(f.frames.len())..];
        let (frame_median, worst) = (median(warm), warm.iter().copied().fold(0.0, f64::max));
        let cpu_median = median(&f.cpu);
        all_warm.extend_from_slice(warm);
        all_cpu.extend_from_slice(&f.cpu);
        md.push_str(&format!(
            "| {name} | {:.1} | {:.1} | {:.1} | {:.1} | {} of {} | {:.2} % | {} | {} |\n",
            1e3 * frame_median,
            1e3 * worst,
            1e3 * f.frames.first().copied().unwrap_or(f64::NAN),
            1e3 * cpu_median,
            f.far.1,
            f.far.0,
            100.0 * f.within,
            per_edit_median(&f.last, "marked_cells_per_edit"),
            per_edit_median(&f.last, "particles_regenerated_per_edit"),
        ));
        rows.push(json!({
            "drag": name,
            "strokes": strokes_json(drag),
            "frame_medians_seconds": f.frames,
            "cpu_medians_seconds": f.cpu,
            "median_seconds": frame_median,
            "worst_seconds": worst,
            "cpu_per_stroke_median_seconds": cpu_median,
            "far_particles": f.far.0,
            "far_particles_unchanged": f.far.1,
            "within_2e-3_of_scratch": f.within,
            "last_report": f.last,
        }));
    }
    let (median_all, worst_all) = (
        median(&all_warm),
        all_warm.iter().copied().fold(0.0, f64::max),
    );
    md.push_str(&format!(
        "| all drags | {:.1} | {:.1} | | {:.1} | | | | |\n",
        1e3 * median_all,
        1e3 * worst_all,
        1e3 * median(&all_cpu),
    ));
    let value = json!({
        "runs": RUNS,
        "frame_iterations": FRAME_ITERATIONS,
        "median_seconds": median_all,
        "worst_seconds": worst_all,
        "drags": rows,
    });
    Ok((md, value))
}

/// `cargo xtask session`: the session alone.
pub(crate) fn run(flags: &Flags) -> Result<()> {
    let dir = models_dir(flags)?;
    let model = dir.join("bunny.ply");
    if !model.is_file() {
        bail!("{} not found", model.display());
    }
    let psi = build_release()?;
    let out_dir = project_root().join("target/xtask");
    std::fs::create_dir_all(&out_dir)?;
    let (md, value) = session(&psi, &model, &out_dir)?;
    print!("{md}");
    if let Some(path) = &flags.json {
        psi::save_json(path, &value).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}
