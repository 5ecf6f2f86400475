//! The `flat` group of `cargo xtask scans` (issue 28): a sheet, a box and a street scene
//! (`flat_scenes.rs`) through `psi sample`, judged by how the particles cover the input points
//! and how evenly they are spaced where the points are labelled flat.

use anyhow::{Context, Result};
use psi::DVec3;
use serde_json::{Value, json};

use crate::checks::{Check, checks_json};
use crate::coverage::{
    coverage, level_cv, near_flat, nearest_neighbour_distances, spacing_ceiling, spacing_stats,
};
use crate::flat_scenes::{FlatScene, box_scene, sheet, street};
use crate::reference::Reference;
use crate::scan_case::{ScanRun, diagonal, distances_to, sample_once, write_positions_ply};

/// `x` as a number, NaN when it is not one.
fn num(x: &Value) -> f64 {
    x.as_f64().unwrap_or(f64::NAN)
}

/// Points per part as `name n` pairs.
fn parts_text(scene: &FlatScene) -> String {
    scene
        .parts
        .iter()
        .enumerate()
        .map(|(k, part)| {
            let n = scene.labels.iter().filter(|l| **l as usize == k).count();
            format!("{} {n}", part.name)
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The `flat` group on seeds (default 0 only): per scene, input points within 1.5 local
/// spacings of a particle at the 99th percentile and none beyond 2.5, the median
/// nearest-neighbour spacing of the particles near flat-labelled points at most 2.5 % D and
/// their nearest-neighbour CV at most 0.15.
pub(crate) fn flat(ctx: &ScanRun) -> Result<(String, Vec<Value>)> {
    let seeds = ctx.seeds_or(0..1);
    let mut md = String::from(
        "## Flat scenes (x y z only)\n\nCoverage: each input point's distance to the nearest particle over the local spacing there (the mean nearest-neighbour distance of the particles within 5 ceilings; ceiling = the report's `particles.max_spacing`, else 0.025 D). Spacing and CV over the particles whose nearest input point is labelled flat (all particles in brackets). Distances to the noiseless reference over its D.\n\n| case | points (by part) | D (m) | scan: mean / p99 / max (D) | particles (flat; added by ceiling) | particles: mean / p99 / max (D) | coverage p99 [≤ 1.5] | coverage max [≤ 2.5] | median spacing / D, flat [≤ 0.025] (all) | NN CV, flat [≤ 0.15] (all) | level CV (levels) | ceiling (source) | psi s |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut rows = Vec::new();
    for seed in seeds {
        for make in [sheet, box_scene, street] {
            let scene = make(seed)?;
            let name = format!("{}-{seed}", scene.name);
            eprintln!("{name} ...");
            let input = ctx.out.join(format!("{name}.ply"));
            write_positions_ply(&input, &scene.points)?;
            let run = sample_once(ctx, &input, &[], &name)?;
            let diag = diagonal(scene.reference.vertices.iter().copied())?;
            let reference =
                Reference::new(scene.reference.clone()).context("the scene's reference")?;
            let scan = distances_to(&reference, &scene.points, diag);
            let dist = distances_to(&reference, &run.particles, diag);
            let nn = nearest_neighbour_distances(&run.particles);
            let (ceiling, source) = spacing_ceiling(&run.report);
            let cover = coverage(&run.particles, &nn, &scene.points, ceiling);
            let flat_parts: Vec<bool> = scene.parts.iter().map(|p| p.flat).collect();
            let flat_mask = near_flat(&run.particles, &scene.points, &scene.labels, &flat_parts);
            let flat_spacing = spacing_stats(&nn, &flat_mask, diag);
            let all_spacing = spacing_stats(&nn, &vec![true; nn.len()], diag);
            let levels = level_cv(&run.report);
            let (p99, max) = (num(&cover["p99"]), num(&cover["max"]));
            let (median, cv) = (num(&flat_spacing["median"]), num(&flat_spacing["cv"]));
            let checks = [
                Check::at_most(
                    "coverage p99 ≤ 1.5 local spacings",
                    p99,
                    1.5,
                    format!("{p99:.2}"),
                ),
                Check::at_most(
                    "coverage max ≤ 2.5 local spacings",
                    max,
                    2.5,
                    format!("{max:.2}"),
                ),
                Check::at_most(
                    "median spacing ≤ 2.5 % D (flat)",
                    median,
                    0.025,
                    format!("{median:.4}"),
                ),
                Check::at_most("NN CV ≤ 0.15 (flat)", cv, 0.15, format!("{cv:.3}")),
            ];
            md.push_str(&format!(
                "| {name} | {} ({}) | {diag:.3} | {:.1e} / {:.1e} / {:.1e} | {} ({}; {}) | {:.1e} / {:.1e} / {:.1e} | {} | {} | {} ({:.4}) | {} ({:.3}) | {:.3} ({}) | {:.4} ({source}) | {:.1} |\n",
                scene.points.len(),
                parts_text(&scene),
                num(&scan["mean"]),
                num(&scan["p99"]),
                num(&scan["max"]),
                run.particles.len(),
                flat_mask.iter().filter(|f| **f).count(),
                run.report["particles"]["added_by_ceiling"],
                num(&dist["mean"]),
                num(&dist["p99"]),
                num(&dist["max"]),
                checks[0].cell(),
                checks[1].cell(),
                checks[2].cell(),
                num(&all_spacing["median"]),
                checks[3].cell(),
                num(&all_spacing["cv"]),
                levels.0,
                levels.1,
                ceiling,
                run.seconds,
            ));
            let counts: Vec<Value> = scene
                .parts
                .iter()
                .enumerate()
                .map(|(k, p)| json!({ "part": p.name, "flat": p.flat, "points": scene.labels.iter().filter(|l| **l as usize == k).count() }))
                .collect();
            let positions: &[DVec3] = &run.particles;
            rows.push(json!({
                "group": "flat",
                "case": name,
                "about": scene.about,
                "seed": seed,
                "diagonal": diag,
                "parts": counts,
                "input": run.report["input"],
                "particles": positions.len(),
                "particles_near_flat": flat_mask.iter().filter(|f| **f).count(),
                "max_spacing": run.report["particles"]["max_spacing"],
                "added_by_ceiling": run.report["particles"]["added_by_ceiling"],
                "ceiling": { "world": ceiling, "source": source },
                "scan_distance_to_reference": scan,
                "distance_to_reference": dist,
                "coverage": cover,
                "spacing_flat": flat_spacing,
                "spacing_all": all_spacing,
                "levels": run.report["particles"]["after"]["levels"],
                "largest_level_cv": levels.0,
                "psi_seconds": run.seconds,
                "checks": checks_json(&checks),
            }));
        }
    }
    Ok((md, rows))
}
