//! The `density` group of `cargo xtask scans` (issue 28; explicitly requested: 10 M points is
//! slow): the dragon mesh, then seeded area-weighted samplings of it at 1 M, 3 M and 10 M
//! points with Gaussian noise of σ = 2e-4 D, each with and without normals, all through
//! `psi sample`; the particle counts should agree within ±10 % (largest over smallest ≤ 1.1).

use anyhow::{Context, Result};
use psi::{DVec3, OrientedPoint};
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;
use serde_json::{Value, json};

use crate::checks::{Check, checks_json};
use crate::coverage::level_cv;
use crate::reference::Reference;
use crate::scan_case::{ScanRun, diagonal, distances_to, sample_once, write_positions_ply};
use crate::surface_samples::TriangleSampler;

/// The mesh sampled (in the models folder).
const MESH: &str = "stanford_dragon_vrip_raw.ply";

/// Sampling sizes, points.
const SIZES: [usize; 3] = [1_000_000, 3_000_000, 10_000_000];

/// Noise of the samplings' positions, in D.
const SIGMA: f64 = 2e-4;

/// `n` area-uniform samples of the mesh with their face normals, positions moved by isotropic
/// Gaussian noise of `sigma` (world units) per axis, from `seed`.
fn noisy_samples(sampler: &TriangleSampler, n: usize, sigma: f64, seed: u64) -> Vec<OrientedPoint> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let (p, _) = sampler.sample(&mut rng);
            OrientedPoint {
                p: p.p + sigma * psi::shapes::gaussian_vector(&mut rng),
                n: p.n,
            }
        })
        .collect()
}

/// The `density` group (seed: the first of `--seeds`, default 0).
pub(crate) fn density(ctx: &ScanRun) -> Result<(String, Vec<Value>)> {
    let path = ctx.models.join(MESH);
    if !path.is_file() {
        eprintln!("skipping density: {} not found", path.display());
        return Ok((String::new(), Vec::new()));
    }
    let seed = ctx.seeds_or(0..1).start;
    let mesh = psi::load_mesh(&path).with_context(|| format!("reading {}", path.display()))?;
    let diag = diagonal(mesh.vertices.iter().copied())?;
    let sampler = TriangleSampler::from_mesh(&mesh)?;
    let reference = Reference::new(mesh)?;
    let mut md = format!(
        "## Density: `{MESH}` and seeded samplings of it (σ = {SIGMA} D, seed {seed})\n\nCounts against the mesh's run (one point per triangle, face normals); distances of the particles to the mesh over its D (= {diag:.6}).\n\n| input | points | normals | scan: mean / p99 / max (D) | particles (× mesh) | particles: mean / p99 / max (D) | within 2e-3 D | largest level CV (levels) | psi s | peak GiB |\n|---|---|---|---|---|---|---|---|---|---|\n"
    );
    let mut rows = Vec::new();
    let mut counts = Vec::new();
    // One run: its name, input file, point count, normals' source, the input's distance to the
    // mesh (JSON of `distance_stats`) and the table to add to.
    let mut run_one = |name: &str,
                       input: &std::path::Path,
                       points: usize,
                       normals: &str,
                       scan: Value,
                       md: &mut String|
     -> Result<()> {
        eprintln!("{name} ...");
        let run = sample_once(ctx, input, &[], name)?;
        let d = distances_to(&reference, &run.particles, diag);
        let levels = level_cv(&run.report);
        let count = run.particles.len();
        counts.push(count);
        let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
        md.push_str(&format!(
            "| {name} | {points} | {normals} | {:.1e} / {:.1e} / {:.1e} | {count} ({:.3}×) | {:.1e} / {:.1e} / {:.1e} | {:.2} % | {:.3} ({}) | {:.1} | {:.2} |\n",
            f(&scan["mean"]),
            f(&scan["p99"]),
            f(&scan["max"]),
            count as f64 / counts[0] as f64,
            f(&d["mean"]),
            f(&d["p99"]),
            f(&d["max"]),
            100.0 * f(&d["within_2e-3"]),
            levels.0,
            levels.1,
            run.seconds,
            f(&run.report["peak_memory_bytes"]) / (1u64 << 30) as f64,
        ));
        rows.push(json!({
            "group": "density",
            "case": name,
            "points": points,
            "normals": normals,
            "input": run.report["input"],
            "particles": count,
            "count_ratio_to_mesh": count as f64 / counts[0] as f64,
            "scan_distance_to_reference": scan,
            "distance_to_reference": d,
            "levels": run.report["particles"]["after"]["levels"],
            "largest_level_cv": levels.0,
            "psi_seconds": run.seconds,
            "peak_memory_bytes": run.report["peak_memory_bytes"],
            "checks": [],
        }));
        Ok(())
    };
    run_one(
        "dragon-mesh",
        &path,
        reference.mesh.faces.len(),
        "faces",
        json!({ "mean": 0.0, "p99": 0.0, "max": 0.0 }),
        &mut md,
    )?;
    for (k, n) in SIZES.into_iter().enumerate() {
        eprintln!("sampling {n} points ...");
        let points = noisy_samples(
            &sampler,
            n,
            SIGMA * diag,
            seed.wrapping_mul(10).wrapping_add(k as u64),
        );
        let with = ctx
            .out
            .join(format!("dragon-{}M-normals.ply", n / 1_000_000));
        psi::save_points(&with, &points).with_context(|| format!("writing {}", with.display()))?;
        let without = ctx.out.join(format!("dragon-{}M-xyz.ply", n / 1_000_000));
        let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
        drop(points);
        write_positions_ply(&without, &positions)?;
        let scan = distances_to(&reference, &positions, diag);
        drop(positions);
        run_one(
            &format!("dragon-{}M-normals", n / 1_000_000),
            &with,
            n,
            "given",
            scan.clone(),
            &mut md,
        )?;
        run_one(
            &format!("dragon-{}M-xyz", n / 1_000_000),
            &without,
            n,
            "estimated",
            scan,
            &mut md,
        )?;
    }
    let (lo, hi) = (
        counts.iter().min().copied().unwrap_or(0),
        counts.iter().max().copied().unwrap_or(0),
    );
    let spread = hi as f64 / lo.max(1) as f64;
    let check = Check::at_most(
        "counts within ±10 % of each other (largest / smallest)",
        spread,
        1.1,
        format!("{spread:.3}"),
    );
    md.push_str(&format!(
        "\nLargest over smallest count: {} (target ≤ 1.1).\n",
        check.cell()
    ));
    rows.push(json!({ "group": "density", "case": "count-spread", "counts": counts, "checks": checks_json(&[check]) }));
    Ok((md, rows))
}
