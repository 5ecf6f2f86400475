//! `psi edit`: build and sample, apply edits locally, write the particles before and after.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::Args;
use psi::regen::{Edit, Scene};
use psi::{DVec3, ParticleParams};
use serde_json::json;

use crate::input::load;
use crate::strokes::Step;
use crate::{Failure, InputArgs};

#[derive(Args)]
pub(crate) struct EditArgs {
    #[command(flatten)]
    input: InputArgs,
    #[command(flatten)]
    mpu: crate::MpuArgs,
    /// A session of edits applied in order: a JSON list of `{"brush": {"centre": [x,y,z],
    /// "radius": r, "displacement": [dx,dy,dz]}}`, `{"remove": {"centre": [x,y,z], "radius": r}}`,
    /// `{"insert": {"points": [[x,y,z],…], "normals": [[nx,ny,nz],…]}}` and
    /// `{"settle": {"iterations": n}}` (with --frame-iterations).
    #[arg(long, value_name = "FILE.json", conflicts_with_all = ["brush", "remove"])]
    strokes: Option<PathBuf>,
    /// A brush: centre, radius and displacement, `cx,cy,cz,r,dx,dy,dz` (repeatable, in order).
    #[arg(long, value_name = "CX,CY,CZ,R,DX,DY,DZ")]
    brush: Vec<String>,
    /// Remove the points in a ball: `cx,cy,cz,r` (repeatable; applied after the brushes).
    #[arg(long, value_name = "CX,CY,CZ,R")]
    remove: Vec<String>,
    /// Write the edited oriented points here (binary PLY: x y z nx ny nz).
    #[arg(long)]
    points_after: Option<PathBuf>,
    /// Write the particles before the edits here.
    #[arg(long)]
    before: Option<PathBuf>,
    /// Output particles after the edits (binary PLY).
    #[arg(short, long)]
    output: PathBuf,
    /// Relaxation iterations.
    #[arg(long, default_value_t = 20, value_parser = crate::iterations)]
    iterations: usize,
    /// Apply each stroke as an interactive frame: only N of its relaxation iterations, the
    /// rest settling at the strokes file's `settle` steps or before the next stroke (the
    /// particles are bitwise those of eager strokes; the report tells frame, settle and CPU
    /// time apart).
    #[arg(long, value_name = "N")]
    frame_iterations: Option<usize>,
    /// Write the report as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
}

fn numbers(text: &str, n: usize, what: &str) -> anyhow::Result<Vec<f64>> {
    crate::numbers(text, n).map_err(|e| anyhow::anyhow!("--{what} {e}"))
}

fn edits(args: &EditArgs) -> Result<Vec<Step>, Failure> {
    let usage = |e: anyhow::Error| Failure { error: e, code: 2 };
    if let Some(path) = &args.strokes {
        return crate::strokes::read_strokes(path).map_err(usage);
    }
    let mut out = Vec::new();
    for b in &args.brush {
        let v = numbers(b, 7, "brush").map_err(usage)?;
        out.push(Edit::Brush {
            center: DVec3::new(v[0], v[1], v[2]),
            radius: v[3],
            displacement: DVec3::new(v[4], v[5], v[6]),
        });
    }
    for r in &args.remove {
        let v = numbers(r, 4, "remove").map_err(usage)?;
        out.push(Edit::Remove {
            center: DVec3::new(v[0], v[1], v[2]),
            radius: v[3],
        });
    }
    if out.is_empty() {
        return Err(usage(anyhow::anyhow!(
            "give --strokes FILE.json, or at least one --brush or --remove"
        )));
    }
    for e in &out {
        e.validate().map_err(|e| usage(e.into()))?;
    }
    Ok(out.into_iter().map(Step::Edit).collect())
}

pub(crate) fn run(args: &EditArgs, ui: crate::ui::Ui) -> Result<(), Failure> {
    // Edits are checked before any work is done.
    let edits = edits(args)?;
    let loaded = load(&args.input, ui)?;
    loaded.check_output(&args.output, "-o")?;
    for (path, flag) in [
        (&args.before, "--before"),
        (&args.json, "--json"),
        (&args.points_after, "--points-after"),
    ] {
        if let Some(path) = path {
            loaded.check_output(path, flag)?;
        }
    }
    let params = ParticleParams {
        iterations: args.iterations,
        ..ParticleParams::paper()
    };
    let error_rel = loaded
        .input
        .report
        .error_threshold(args.mpu.mpu_error)
        .relative;
    let mpu_params = psi::MpuParams {
        error_rank: loaded.input.error_rank(error_rel),
        ..args.mpu.params(error_rel)
    };
    let (mut scene, _) = Scene::new_with(
        loaded.input.points.clone(),
        loaded.input.attributes.clone(),
        &mpu_params,
        &params,
        &psi::octree::Monitor::silent(),
    )
    .with_context(|| format!("{}: building the scene", loaded.input.name))?;
    let before = args.before.as_ref().map(|_| {
        (
            scene.particles().clone(),
            scene.particle_attributes().clone(),
        )
    });
    let mut reports = Vec::new();
    // Settles: after which stroke, and what they did.
    let mut settles: Vec<(usize, psi::regen::SettleReport)> = Vec::new();
    let none = psi::octree::PointAttributes::default();
    let silent = psi::octree::Monitor::silent();
    for (i, step) in edits.iter().enumerate() {
        let e = match step {
            Step::Edit(e) => e,
            Step::Settle(n) => {
                let s = scene.settle(*n);
                settles.push((reports.len().saturating_sub(1), s));
                continue;
            }
        };
        let frame = args.frame_iterations.unwrap_or(usize::MAX);
        let r = scene
            .apply_deferred(e, &none, frame, &silent)
            .map_err(|e| Failure {
                error: anyhow::Error::new(e).context(match &args.strokes {
                    Some(path) => format!("{}: applying edit {i}", path.display()),
                    None => format!("applying edit {i}"),
                }),
                code: 2,
            })?;
        if ui.verbose {
            eprintln!(
                "psi: edit {i}: {:.2} ms, {} cells marked, {} particles regenerated",
                1e3 * r.seconds,
                r.marked_cells,
                r.particles_regenerated
            );
        }
        reports.push(r);
    }
    // The last stroke settles before anything is written.
    let last = scene.settle(usize::MAX);
    if last.iterations > 0 {
        settles.push((reports.len().saturating_sub(1), last));
    }
    // Per stroke: its frame (without the previous stroke's settling), and the CPU time of its
    // frame and of every settle of its particles (those after it, and the start of the next
    // stroke).
    let frame_seconds: Vec<f64> = reports
        .iter()
        .map(|r| r.seconds - r.settle_seconds)
        .collect();
    let mut cpu_per_stroke: Vec<f64> = reports
        .iter()
        .map(|r| r.cpu_seconds - r.settle_cpu_seconds)
        .collect();
    for (k, r) in reports.iter().enumerate().skip(1) {
        cpu_per_stroke[k - 1] += r.settle_cpu_seconds;
    }
    for (k, s) in &settles {
        if let Some(c) = cpu_per_stroke.get_mut(*k) {
            *c += s.cpu_seconds;
        }
    }
    // Written only once every edit has succeeded.
    if let (Some(path), Some((before, attributes))) = (&args.before, &before) {
        psi::save_particles(path, before, attributes)?;
    }
    psi::save_particles(&args.output, scene.particles(), scene.particle_attributes())?;
    if let Some(path) = &args.points_after {
        psi::save_points(path, scene.points())?;
    }
    // The comparison: a full rebuild and sampling of the edited points.
    let t = Instant::now();
    let (full, _) =
        Scene::new(scene.points().to_vec(), &mpu_params, &params).context("full rebuild")?;
    let full_seconds = t.elapsed().as_secs_f64();
    let local_seconds: f64 = reports.iter().map(|r| r.seconds).sum();
    let report = json!({
        "input": &loaded.input.json,
        "full": { "seconds": full_seconds, "particles": full.particles().len() },
        "local": {
            "seconds": local_seconds,
            "seconds_per_edit": reports.iter().map(|r| r.seconds).collect::<Vec<_>>(),
            "frame_iterations": args.frame_iterations,
            "frame_seconds_per_edit": frame_seconds,
            "settle_seconds_per_edit": reports.iter().map(|r| r.settle_seconds).collect::<Vec<_>>(),
            "cpu_seconds_per_edit": cpu_per_stroke,
            "settles": settles.iter().map(|(k, s)| json!({"after_edit": k, "report": s})).collect::<Vec<_>>(),
            "marked_cells_per_edit": reports.iter().map(|r| r.marked_cells).collect::<Vec<_>>(),
            "particles_regenerated_per_edit": reports.iter().map(|r| r.particles_regenerated).collect::<Vec<_>>(),
            "marked_cells": reports.iter().map(|r| r.marked_cells).sum::<usize>(),
            "refit_cells": reports.iter().map(|r| r.refit_cells).sum::<usize>(),
            "particles_regenerated": reports.iter().map(|r| r.particles_regenerated).sum::<usize>(),
            "particles_removed": reports.iter().map(|r| r.particles_removed).sum::<usize>(),
            "edits": reports,
        },
        "particles": scene.particles().len(),
    });
    if let Some(path) = &args.json {
        psi::save_json(path, &report)?;
    }
    ui.timing("local regeneration", local_seconds);
    ui.timing("full rebuild and sampling", full_seconds);
    ui.summary(&format!(
        "{}: {} edit(s) regenerated {} particles in {:.4} s (full rebuild and sampling: {:.3} s); wrote {}",
        loaded.input.name,
        reports.len(),
        report["local"]["particles_regenerated"],
        local_seconds,
        full_seconds,
        args.output.display()
    ));
    Ok(())
}
