//! An editing session on the bunny (issue "Interactive editing sessions"): a drag of 20 brush
//! strokes of radius 0.012 across its back, each moving the points 0.8 mm along their normal,
//! through `psi edit --strokes --frame-iterations` in several fresh processes (each stroke a
//! frame, settled before the next); the time of every frame and the CPU time of every stroke,
//! and the session's locality and accuracy against a from-scratch build of the edited points.
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

/// Runs the session on `model` (the bunny) with the release binary `psi`, scratch files in
/// `out_dir`. Returns the Markdown section and its JSON.
pub(crate) fn session(psi: &Path, model: &Path, out_dir: &Path) -> Result<(String, Value)> {
    let points = psi::load_points(model, &psi::ReadOptions::paper())?.points;
    let drag = drag(&points)?;
    let strokes = out_dir.join("drag.json");
    std::fs::write(
        &strokes,
        serde_json::to_string_pretty(&strokes_json(&drag))?,
    )?;
    let (before, after, points_after, report) = (
        out_dir.join("drag-before.ply"),
        out_dir.join("drag-after.ply"),
        out_dir.join("drag-points.ply"),
        out_dir.join("drag.json.report"),
    );
    let mut per_edit: Vec<Vec<f64>> = vec![Vec::new(); STROKES];
    let mut cpu_per_edit: Vec<Vec<f64>> = vec![Vec::new(); STROKES];
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
        let times = last["local"]["frame_seconds_per_edit"]
            .as_array()
            .context("report without frame_seconds_per_edit")?;
        for (k, t) in times.iter().enumerate() {
            per_edit[k].push(t.as_f64().unwrap_or(f64::NAN));
        }
        let cpu = last["local"]["cpu_seconds_per_edit"]
            .as_array()
            .context("report without cpu_seconds_per_edit")?;
        for (k, t) in cpu.iter().enumerate() {
            cpu_per_edit[k].push(t.as_f64().unwrap_or(f64::NAN));
        }
    }
    // Each edit's median over the runs; the session's median and worst of those.
    let edit_medians: Vec<f64> = per_edit.iter().map(|v| median(v)).collect();
    let session_median = median(&edit_medians);
    let worst = edit_medians.iter().copied().fold(0.0, f64::max);
    let first = edit_medians[0];
    let cpu_median = median(&cpu_per_edit.iter().map(|v| median(v)).collect::<Vec<_>>());
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
    let marked = last["local"]["marked_cells_per_edit"].clone();
    let regenerated = last["local"]["particles_regenerated_per_edit"].clone();
    let md = format!(
        "\n## An editing session on the bunny (`psi edit --strokes --frame-iterations {FRAME_ITERATIONS}`: {STROKES} brush strokes of radius {RADIUS} across the back, each moving the points {} mm, each a frame of {FRAME_ITERATIONS} relaxation iterations settled before the next; {RUNS} sessions, each a fresh process; more drags: `cargo xtask bench edit`)\n\n| median frame ms | worst frame ms | first frame ms | CPU per stroke ms (median, frame and settle) | particles > 4 radii from every stroke unchanged | particles within 2e-3 D of a from-scratch build | marked cells per edit (median) | particles regenerated per edit (median) |\n|---|---|---|---|---|---|---|---|\n| {:.1} | {:.1} | {:.1} | {:.1} | {unchanged} of {} | {:.2} % | {} | {} |\n",
        1e3 * DEPTH,
        1e3 * session_median,
        1e3 * worst,
        1e3 * first,
        1e3 * cpu_median,
        far_old.len(),
        100.0 * within as f64 / new.len().max(1) as f64,
        median(
            &marked
                .as_array()
                .map(|a| a.iter().filter_map(Value::as_f64).collect::<Vec<_>>())
                .unwrap_or_default()
        ),
        median(
            &regenerated
                .as_array()
                .map(|a| a.iter().filter_map(Value::as_f64).collect::<Vec<_>>())
                .unwrap_or_default()
        ),
    );
    let value = json!({
        "strokes": strokes_json(&drag),
        "runs": RUNS,
        "frame_iterations": FRAME_ITERATIONS,
        "frame_medians_seconds": edit_medians,
        "cpu_per_stroke_median_seconds": cpu_median,
        "median_seconds": session_median,
        "worst_seconds": worst,
        "far_particles": far_old.len(),
        "far_particles_unchanged": unchanged,
        "within_2e-3_of_scratch": within as f64 / new.len().max(1) as f64,
        "last_report": last,
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
