//! `cargo xtask reproduce-tables`: the paper's Tables 1 and 2 side by side with ours, on the
//! shared models, timed with the release binary, checked against the reference meshes.

use crate::median::median;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result};
use serde_json::{Value, json};

use crate::paper::{LEVET, TABLE1, TABLE2};
use crate::reference::{
    METRO_SAMPLES, Reference, area, coverage, distance_stats, metro_stats, worst_gap,
};
use crate::release_binary::{build_release, run_psi, run_psi_report};
use crate::{Flags, host, models_dir, project_root};

/// Depth levels with fewer particles than this show their count beside their CV (a
/// coefficient of variation from a handful of distances is mostly noise).
const FEW_PARTICLES: u64 = 30;

/// Runs `psi sample` on one model; returns the report and the particle file.
pub(crate) fn sample(
    psi: &Path,
    model: &Path,
    iterations: usize,
    out_dir: &Path,
    tag: &str,
) -> Result<(Value, PathBuf)> {
    let ply = out_dir.join(format!("{tag}.ply"));
    let report = out_dir.join(format!("{tag}.json"));
    let value = run_psi_report(
        Command::new(psi)
            .arg("sample")
            .arg(model)
            .args([
                "--iterations",
                &iterations.to_string(),
                "--evaluation-floor",
                "-o",
            ])
            .arg(&ply)
            .arg("--json")
            .arg(&report),
        &report,
    )?;
    Ok((value, ply))
}

/// Runs of `psi sample` per model whose times Table 1 gives the median of: a single run on a
/// shared VM varies with the host's load (docs/results/*/SETUP.md); the particles are the same
/// in every run.
const TIMED_RUNS: usize = 5;

/// The seeding, simulation and MPU build seconds of `first` (a report of `psi sample` on
/// `model`) and of [`TIMED_RUNS`] − 1 further runs, each sorted ascending.
fn timed_runs(
    psi: &Path,
    model: &Path,
    iterations: usize,
    out_dir: &Path,
    tag: &str,
    first: &Value,
) -> Result<[Vec<f64>; 3]> {
    let times = |r: &Value| {
        [
            f(&r["particles"]["init_seconds"]),
            f(&r["particles"]["simulate_seconds"]),
            f(&r["mpu"]["build_seconds"]),
        ]
    };
    let mut runs = vec![times(first)];
    for k in 1..TIMED_RUNS {
        let (report, _) = sample(psi, model, iterations, out_dir, &format!("{tag}-timing{k}"))?;
        runs.push(times(&report));
    }
    Ok(std::array::from_fn(|c| {
        let mut v: Vec<f64> = runs.iter().map(|r| r[c]).collect();
        v.sort_by(f64::total_cmp);
        v
    }))
}

/// Distance and coverage checks of a particle file against its reference mesh.
pub(crate) fn check(model: &Path, particles: &Path, report: &Value) -> Result<Value> {
    let mesh = psi::load_mesh(model)?;
    let reference = Reference::new(mesh)?;
    let points: Vec<_> = psi::load_points(particles, &psi::ReadOptions::paper())?
        .points
        .iter()
        .map(|p| p.p)
        .collect();
    let diag = report["input"]["bbox_diagonal"]
        .as_f64()
        .context("report without bbox_diagonal")?;
    let d = reference.distances(&points);
    let spacing = report["particles"]["after"]["spacing"]["mean"]
        .as_f64()
        .unwrap_or(0.0);
    Ok(json!({
        "distance": distance_stats(&d, diag),
        "coverage_1.5_spacing": coverage(&reference, &points, 1.5 * spacing),
    }))
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

pub(crate) fn run(flags: &Flags) -> Result<()> {
    let dir = models_dir(flags)?;
    let psi = build_release()?;
    let out_dir = project_root().join("target/xtask");
    std::fs::create_dir_all(&out_dir)?;
    let wanted = |m: &str| flags.only.as_ref().is_none_or(|o| o.iter().any(|x| x == m));
    let mut rows = Vec::new();
    let mut md = String::new();
    md.push_str(&format!(
        "## Table 1: {} iterations, one particle per surface-containing octree leaf\n\nSeeding, simulation and MPU build seconds: medians of {TIMED_RUNS} runs of `psi sample` (each a new process); the simulation's fastest and slowest run in brackets; sim / floor is the first run's (the floor: one evaluation on one thread, the simulation on two).\n\n",
        flags.iterations
    ));
    md.push_str("| model | dataset points | particles (paper) | seeding s (paper) | simulation s (paper) | speed-up | sim / floor | MPU build s | leaves | depth | peak GiB | dist. mean / p99 / max (D) | within 2e-3 D | CV per level | coverage |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for row in TABLE1.iter().filter(|r| wanted(r.model)) {
        let path = dir.join(row.file);
        if !path.is_file() {
            eprintln!("skipping {}: {} not found", row.model, path.display());
            continue;
        }
        eprintln!("{} ...", row.model);
        let (report, ply) = sample(&psi, &path, flags.iterations, &out_dir, row.model)?;
        let quality = check(&path, &ply, &report)?;
        let p = &report["particles"];
        let levels: Vec<String> = p["after"]["levels"]
            .as_array()
            .map(|ls| {
                ls.iter()
                    .map(|l| {
                        // A level of a few particles gets its count: its CV says little.
                        let few = match l["spacing"]["count"].as_u64() {
                            Some(count) if count < FEW_PARTICLES => format!(" (n={count})"),
                            _ => String::new(),
                        };
                        format!("{}:{:.3}{few}", l["depth"], f(&l["spacing"]["cv"]))
                    })
                    .collect()
            })
            .unwrap_or_default();
        let [inits, sims, builds] =
            timed_runs(&psi, &path, flags.iterations, &out_dir, row.model, &report)?;
        let (init, sim, build) = (median(&inits), median(&sims), median(&builds));
        let sim_range = format!(
            "{:.3} [{:.3}–{:.3}]",
            sim,
            sims.first().copied().unwrap_or(0.0),
            sims.last().copied().unwrap_or(0.0)
        );
        let name = match row.stand_in {
            Some(s) => format!("{} (stand-in: {s})", row.model),
            None => row.model.to_owned(),
        };
        let dist = &quality["distance"];
        md.push_str(&format!(
            "| {name} | {} | {} ({}) | {:.3} ({}) | {sim_range} ({}) | {:.0}× / {:.0}× | {:.2} | {:.3} | {} | {} | {:.2} | {:.1e} / {:.1e} / {:.1e} | {:.2} % | {} | {:.2} % |\n",
            report["input"]["points"], p["count"], row.particles, init, row.init_seconds, row.simulate_seconds,
            row.init_seconds / init, row.simulate_seconds / sim, f(&p["evaluation_floor_ratio"]), build, report["mpu"]["leaves"],
            report["mpu"]["max_depth"], f(&report["peak_memory_bytes"]) / (1u64 << 30) as f64, f(&dist["mean"]), f(&dist["p99"]), f(&dist["max"]), 100.0 * f(&dist["within_2e-3"]),
            levels.join(" "), 100.0 * f(&quality["coverage_1.5_spacing"])
        ));
        rows.push(json!({
            "model": row.model,
            "file": row.file,
            "stand_in": row.stand_in,
            "sha256": host::sha256(&path)?,
            "dataset_points": report["input"]["points"],
            "particles": p["count"],
            "init_seconds": init,
            "simulate_seconds": sim,
            "simulate_seconds_runs": sims,
            "mpu_build_seconds": build,
            "leaves": report["mpu"]["leaves"],
            "max_depth": report["mpu"]["max_depth"],
            "peak_memory_bytes": report["peak_memory_bytes"],
            "quality": quality,
            "levels": p["after"]["levels"],
            "paper": { "dataset_points": row.dataset_points, "particles": row.particles, "init_seconds": row.init_seconds, "simulate_seconds": row.simulate_seconds },
            "report": report,
        }));
    }
    // The MPU surface itself: polygonized, against the reference mesh in both directions.
    md.push_str("\n## MPU surface against the reference mesh (polygonized at resolution 256)\n\n`paper`: `MpuParams::paper()` — the octree of world-unit solves as Ohtake's code, each leaf keeping the better of its world-unit and scale-invariant fits; `scale-invariant`: every fit solved in units of its cell's radius (`--scale-invariant`). Distances as Metro measures them: means and p99 over 200 000 area-uniform samples of the measured surface, maxima over those samples and all its (referenced) vertices.\n\n| model | closed? | fits | surface→reference mean / max (D) | reference→surface mean / p99 / max (D) |\n|---|---|---|---|---|\n");
    let mut surfaces = Vec::new();
    for row in TABLE1
        .iter()
        .filter(|r| wanted(r.model) && ["bunny", "horse", "igea"].contains(&r.model))
    {
        let path = dir.join(row.file);
        if !path.is_file() {
            continue;
        }
        let reference = Reference::new(psi::load_mesh(&path)?)?;
        let diag = psi::Aabb::from_points(reference.mesh.vertices.iter().copied())
            .map_or(1.0, |b| b.diagonal());
        let used: std::collections::BTreeSet<u32> =
            reference.mesh.faces.iter().flatten().copied().collect();
        let ref_points: Vec<_> = used
            .iter()
            .map(|&i| reference.mesh.vertices[i as usize])
            .collect();
        let (n, seed) = METRO_SAMPLES;
        let ref_samples = reference.surface_samples(n, seed);
        for (mode, extra) in [
            ("paper", None),
            ("scale-invariant", Some("--scale-invariant")),
        ] {
            let mesh_path = out_dir.join(format!("{}-{mode}-surface.ply", row.model));
            run_psi(
                Command::new(&psi)
                    .arg("mesh")
                    .arg(&path)
                    .arg("-o")
                    .arg(&mesh_path)
                    .args(extra),
            )?;
            let ours = Reference::new(psi::load_mesh(&mesh_path)?)?;
            let ours_samples = ours.surface_samples(n, seed);
            let to_reference = metro_stats(&ours_samples, &ours.mesh.vertices, &reference, diag);
            let from_reference = metro_stats(&ref_samples, &ref_points, &ours, diag);
            md.push_str(&format!(
                "| {} | {} | {mode} | {:.1e} / {:.1e} | {:.1e} / {:.1e} / {:.1e} |\n",
                row.model,
                if row.model == "bunny" {
                    "no (5 holes)"
                } else {
                    "yes"
                },
                f(&to_reference["mean"]),
                f(&to_reference["max"]),
                f(&from_reference["mean"]),
                f(&from_reference["p99"]),
                f(&from_reference["max"]),
            ));
            surfaces.push(json!({ "model": row.model, "fits": mode, "surface_to_reference": to_reference, "reference_to_surface": from_reference }));
        }
    }
    // Uniform (blue-noise) mode on the bunny, beside the best mesh samplers measured.
    let mut uniform = Vec::new();
    if wanted("bunny") && dir.join("bunny.ply").is_file() {
        let path = dir.join("bunny.ply");
        let ply = out_dir.join("bunny-uniform.ply");
        let json_path = out_dir.join("bunny-uniform.json");
        let report = run_psi_report(
            Command::new(&psi)
                .arg("sample")
                .arg(&path)
                .args(["--uniform", "--count", "10000", "-o"])
                .arg(&ply)
                .arg("--json")
                .arg(&json_path),
            &json_path,
        )?;
        let reference = Reference::new(psi::load_mesh(&path)?)?;
        let points: Vec<_> = psi::load_points(&ply, &psi::ReadOptions::paper())?
            .points
            .iter()
            .map(|p| p.p)
            .collect();
        let a = area(&reference);
        let n = points.len() as f64;
        let d_hex = (2.0 * a / (3f64.sqrt() * n)).sqrt();
        let spacing = &report["particles"]["after"]["spacing"];
        let rho = f(&spacing["min"]) / d_hex;
        let gap = worst_gap(&reference, &points) / f(&spacing["mean"]);
        md.push_str(&format!(
            "\n## Uniform mode on the bunny (`--uniform --count 10000`)\n\n| sampler | points | ρ = d_min / d_hex | nearest-neighbour CV | worst gap / mean spacing | seconds |\n|---|---|---|---|---|---|\n| psi | {} | {rho:.3} | {:.3} | {gap:.2} | {:.3} |\n| pymeshlab (exact count, as measured) | 9 954 | 0.768 | 0.054 | | 2.12 |\n| libigl blue_noise (as measured) | 10 002 | 0.752 | 0.061 | | 0.71 |\n",
            points.len(), f(&spacing["cv"]), f(&report["particles"]["init_seconds"]) + f(&report["particles"]["simulate_seconds"])
        ));
        uniform.push(json!({ "model": "bunny", "count": points.len(), "rho": rho, "cv": spacing["cv"], "worst_gap_over_mean_spacing": gap, "area": a, "report": report }));
    }
    // Local edits on the bunny (issue #5).
    let mut edits = Value::Null;
    if wanted("bunny") && dir.join("bunny.ply").is_file() {
        eprintln!("bunny edits ...");
        let (section, rows) = crate::edits::local_edits(&psi, &dir.join("bunny.ply"), &out_dir)?;
        md.push_str(&section);
        let (section, session) = crate::session::session(&psi, &dir.join("bunny.ply"), &out_dir)?;
        md.push_str(&section);
        edits = json!({ "brushes": rows, "session": session });
    }
    // Table 2: 10 iterations on the bunny and the David stand-in.
    let mut table2 = Vec::new();
    md.push_str("\n## Table 2: 10 iterations, beside the paper and Levet et al. as the paper quotes them\n\n| method | model | particles | seeding s | simulation s |\n|---|---|---|---|---|\n");
    for (model, particles, init, sim) in TABLE2.iter().filter(|r| wanted(r.0)) {
        let file = TABLE1
            .iter()
            .find(|r| r.model == *model)
            .map(|r| r.file)
            .unwrap_or_default();
        let path = dir.join(file);
        if !path.is_file() {
            continue;
        }
        let (report, _) = sample(&psi, &path, 10, &out_dir, &format!("{model}-10"))?;
        let p = &report["particles"];
        md.push_str(&format!("| psi | {model} | {} | {:.3} | {:.3} |\n| paper (MPU) | {model} | {particles} | {init} | {sim} |\n", p["count"], f(&p["init_seconds"]), f(&p["simulate_seconds"])));
        table2.push(json!({ "model": model, "particles": p["count"], "init_seconds": p["init_seconds"], "simulate_seconds": p["simulate_seconds"], "paper": { "particles": particles, "init_seconds": init, "simulate_seconds": sim } }));
    }
    for (model, implicit, particles, init, sim) in LEVET {
        let init = init.map_or("(total)".into(), |i| i.to_string());
        md.push_str(&format!(
            "| Levet et al. ({implicit}) | {model} | {particles} | {init} | {sim} |\n"
        ));
    }
    println!("{md}");
    let json = json!({
        "host": host::host(),
        "revision": host::revision(&project_root()),
        "models_dir": dir,
        "iterations": flags.iterations,
        "params": { "mpu": psi::MpuParams::paper(), "particles": psi::ParticleParams::paper() },
        "rows": rows,
        "table2": table2,
        "mpu_surfaces": surfaces,
        "uniform": uniform,
        "local_edits": edits,
        "markdown": md,
    });
    let path = flags
        .json
        .clone()
        .unwrap_or_else(|| out_dir.join("reproduce-tables.json"));
    psi::save_json(&path, &json)?;
    eprintln!("wrote {}", path.display());
    Ok(())
}
