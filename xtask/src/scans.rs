//! `cargo xtask scans`: psi on what a scanner gives instead of a clean mesh, each case made
//! with a seeded generator (or read from `../shared/scans`), run through the release
//! `psi sample` and checked against a reference surface. Groups (`--only` names groups and/or
//! models; no group named: `variants`, `cow-coarse`, `dragon-scan`, `multiview` and `flat`;
//! only models named: `variants` and `multiview` on them; default models bunny, horse, igea):
//!
//! * `variants` (`--seed S`, default 1): per model, the clean run; Gaussian noise of 0.25 % and
//!   0.5 % of D on every coordinate with normals tilted by about 9°; 1 % of the points added
//!   uniformly in the bounding box with random normals; the positions alone, shuffled; the
//!   points a sensor sees from one side.
//! * `cow-coarse`: `cow_original_5804.ply`, a coarse mesh, against itself.
//! * `dragon-scan`, `multiview` (seeds 0–4), `outliers` (the 1 % outlier case over seeds 0–19):
//!   `scans_mesh.rs`; `flat` (a sheet, a box, a street scene): `scans_flat.rs`; `density` (the
//!   dragon at 1 M, 3 M, 10 M points): `scans_density.rs`. `--seeds a..b` (or `--seed S`) sets
//!   the seeds of these.
//!
//! The report: a markdown table per group with a ✓/✗ per issue 28 Done-when item, then a
//! summary per item; `--json FILE` writes every row.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result};
use parry3d_f64::shape::TriMesh;
use psi::octree::PointIndex;
use psi::shapes::gaussian_vector;
use psi::{DVec3, OrientedPoint};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use serde_json::{Value, json};

use crate::checks::summary;
use crate::outliers::with_uniform_outliers;
use crate::reference::{Reference, distance_stats};
use crate::release_binary::{build_release, run_psi_report};
use crate::scan_case::{ScanRun, distances_to, write_xyz};
use crate::scans_density::density;
use crate::scans_flat::flat;
use crate::scans_mesh::{dragon_scan, multiview, outlier_sweep};
use crate::visibility::visible;
use crate::{Flags, host, models_dir, project_root};

/// Models tried by default.
const MODELS: [&str; 3] = ["bunny", "horse", "igea"];

/// Runs of `psi sample` per case whose MPU build seconds the report gives the median of.
const TIMED_RUNS: usize = 3;

/// The standard deviation of the normal's tilt: n + s·g (g a standard normal 3-vector),
/// normalised, tilts it by s·√(π/2) rad on average for small s — 9° for s = 0.125.
const NORMAL_TILT: f64 = 0.125;

/// One variant of a model: how it was made and what psi is given.
struct Case {
    name: String,
    input: PathBuf,
    extra: Vec<String>,
    /// What the variant is, for the table.
    about: String,
}

/// The result of `psi sample` on a case: its first report, the particles, the points the
/// MPU was built from, and the median MPU build seconds.
struct Outcome {
    report: Value,
    particles: Vec<OrientedPoint>,
    points: Vec<OrientedPoint>,
    build_seconds: f64,
}

fn run_case(psi: &Path, case: &Case, out: &Path) -> Result<Outcome> {
    let mut builds = Vec::new();
    let mut first = None;
    for k in 0..TIMED_RUNS {
        let particles = out.join(format!("{}-particles.ply", case.name));
        let points = out.join(format!("{}-points.ply", case.name));
        let json = out.join(format!("{}-report.json", case.name));
        let report = run_psi_report(
            Command::new(psi)
                .arg("sample")
                .arg(&case.input)
                .args(&case.extra)
                .arg("-o")
                .arg(&particles)
                .arg("--points-out")
                .arg(&points)
                .arg("--json")
                .arg(&json)
                .arg("-q"),
            &json,
        )
        .with_context(|| format!("case {}", case.name))?;
        builds.push(report["mpu"]["build_seconds"].as_f64().unwrap_or(0.0));
        if k == 0 {
            let read = |p: &Path| -> Result<Vec<OrientedPoint>> {
                Ok(psi::load_points(p, &psi::ReadOptions::paper())?.points)
            };
            first = Some((report, read(&particles)?, read(&points)?));
        }
    }
    builds.sort_by(f64::total_cmp);
    let (report, particles, points) = first.context("no run")?;
    Ok(Outcome {
        report,
        particles,
        points,
        build_seconds: builds[builds.len() / 2],
    })
}

/// The variants of `model`'s clean points `clean` (face centroids with face normals) written
/// to `out`, seeded by `seed`.
fn cases(
    model: &str,
    path: &Path,
    clean: &[OrientedPoint],
    mesh: &TriMesh,
    diag: f64,
    seed: u64,
    out: &Path,
) -> Result<Vec<Case>> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut cases = vec![Case {
        name: format!("{model}-clean"),
        input: path.to_path_buf(),
        extra: Vec::new(),
        about: "the mesh, one point per triangle".into(),
    }];
    for percent in [0.25, 0.5] {
        let sigma = percent / 100.0 * diag;
        let noisy: Vec<OrientedPoint> = clean
            .iter()
            .map(|p| OrientedPoint {
                p: p.p + sigma * gaussian_vector(&mut rng),
                n: (p.n + NORMAL_TILT * gaussian_vector(&mut rng)).normalize(),
            })
            .collect();
        let name = format!("{model}-noise-{percent}");
        let input = out.join(format!("{name}.xyz"));
        write_xyz(&input, &noisy, true)?;
        cases.push(Case {
            name,
            input,
            extra: Vec::new(),
            about: format!("σ = {percent} % D on positions, normals tilted ~9°"),
        });
    }
    let bounds = psi::Aabb::from_points(clean.iter().map(|p| p.p)).context("empty model")?;
    let stray = with_uniform_outliers(clean, &mut rng)?;
    let name = format!("{model}-outliers-1");
    let input = out.join(format!("{name}.xyz"));
    write_xyz(&input, &stray, true)?;
    cases.push(Case {
        name,
        input,
        extra: Vec::new(),
        about: "+1 % uniform in the box, random normals".into(),
    });
    let mut shuffled = clean.to_vec();
    for i in (1..shuffled.len()).rev() {
        shuffled.swap(i, rng.random_range(0..=i));
    }
    let name = format!("{model}-xyz");
    let input = out.join(format!("{name}.xyz"));
    write_xyz(&input, &shuffled, false)?;
    cases.push(Case {
        name,
        input,
        extra: Vec::new(),
        about: "x y z only, shuffled".into(),
    });
    // One view, from the front (+z) at two diagonals from the centre, a little from above.
    let sensor = bounds.center() + 2.0 * diag * DVec3::new(0.3, 0.4, 1.0).normalize();
    let seen = visible(clean, mesh, sensor);
    let name = format!("{model}-view");
    let input = out.join(format!("{name}.xyz"));
    write_xyz(&input, &seen, false)?;
    cases.push(Case {
        name,
        input,
        extra: vec![
            "--viewpoint".into(),
            format!("{},{},{}", sensor.x, sensor.y, sensor.z),
        ],
        about: format!(
            "one view from the sensor, x y z only ({} of {} points)",
            seen.len(),
            clean.len()
        ),
    });
    Ok(cases)
}

/// Share of `estimated` normals within 30° of the truth: each estimated point is matched to
/// the clean point at the same position.
fn normals_within_30(estimated: &[OrientedPoint], clean: &[OrientedPoint]) -> f64 {
    let positions: Vec<DVec3> = clean.iter().map(|p| p.p).collect();
    let index = PointIndex::new(&positions);
    let good = estimated
        .par_iter()
        .filter(|p| {
            index
                .nearest_one(p.p)
                .is_some_and(|(k, _)| p.n.dot(clean[k as usize].n) >= 30f64.to_radians().cos())
        })
        .count();
    good as f64 / estimated.len().max(1) as f64
}

/// For a single view: the largest distance from a particle to the nearest point of the view, in
/// units of the view's local sample spacing there (d₈·√(π/8), d₈ the distance from that point to
/// its 8th neighbour: the spacing the footprint test uses).
fn farthest_from_view(particles: &[OrientedPoint], view: &[OrientedPoint]) -> f64 {
    let positions: Vec<DVec3> = view.iter().map(|p| p.p).collect();
    let index = PointIndex::new(&positions);
    particles
        .par_iter()
        .map(|p| {
            let Some((q, d2)) = index.nearest_one(p.p) else {
                return f64::INFINITY;
            };
            let d8 = index
                .nearest(positions[q as usize], 9)
                .last()
                .map_or(0.0, |n| n.1.sqrt());
            d2.sqrt() / (d8 * (std::f64::consts::PI / 8.0).sqrt()).max(f64::MIN_POSITIVE)
        })
        .reduce(|| 0.0, f64::max)
}

/// The seconds of all preprocessing steps in a report of `psi sample`.
fn preprocess_seconds(report: &Value) -> f64 {
    report["input"]["preprocess_seconds"]
        .as_object()
        .map_or(0.0, |steps| steps.values().filter_map(Value::as_f64).sum())
}

/// The table header of the scan variants (and of the coarse cow).
const VARIANTS_HEADER: &str = "| case | what psi is given | its mean / p99 / max distance (D) | points to MPU (their mean distance, D) | outliers removed | noise estimate (D) | ε0 (D) | leaves | preprocessing s | MPU build s (× clean) | particles (× clean) | mean / p99 / max distance (D) | within 2e-3 D | beyond 1e-2 D | other |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";

/// The `variants` group: per model, the clean mesh, noise, 1 % outliers, positions alone and
/// one view, seeded by `seed`, each timed over [`TIMED_RUNS`] runs.
fn variants(ctx: &ScanRun, seed: u64) -> Result<(String, Vec<Value>)> {
    let (psi, out) = (&ctx.psi, &ctx.out);
    let mut md = format!(
        "## Scans made from the shared models (seed {seed})\n\nEach case through `psi sample` with its defaults (20 iterations); distances of the particles to the clean reference mesh, over its D; MPU build seconds are medians of {TIMED_RUNS} runs; counts against the clean run's.\n\n{VARIANTS_HEADER}"
    );
    let mut rows = Vec::new();
    for (model, path) in ctx.present_models() {
        eprintln!("{model} ...");
        let mesh = psi::load_mesh(&path)?;
        let shape = TriMesh::new(mesh.vertices.clone(), mesh.faces.clone())
            .map_err(|e| anyhow::anyhow!("{model}: {e:?}"))?;
        let reference = Reference::new(mesh)?;
        let clean = psi::load_points(&path, &psi::ReadOptions::paper())?.points;
        let diag = psi::Aabb::from_points(clean.iter().map(|p| p.p))
            .context("empty model")?
            .diagonal();
        let mut clean_outcome: Option<(usize, f64)> = None;
        for case in cases(model, &path, &clean, &shape, diag, seed, out)? {
            eprintln!("  {} ...", case.name);
            let o = run_case(psi, &case, out)?;
            let positions: Vec<DVec3> = o.particles.iter().map(|p| p.p).collect();
            let d = distance_stats(&reference.distances(&positions), diag);
            let fitted: Vec<DVec3> = o.points.iter().map(|p| p.p).collect();
            let dp = distance_stats(&reference.distances(&fitted), diag);
            // What psi was given (a mesh: its face centroids), against the same reference.
            let given = psi::load_points(&case.input, &psi::ReadOptions::paper())
                .with_context(|| format!("reading {}", case.input.display()))?
                .points;
            let given_positions: Vec<DVec3> = given.iter().map(|p| p.p).collect();
            let ds = distances_to(&reference, &given_positions, diag);
            let count = o.particles.len();
            let (clean_count, clean_build) = *clean_outcome.get_or_insert((count, o.build_seconds));
            let other = if case.name.ends_with("-xyz") {
                json!({ "normals_within_30_degrees": normals_within_30(&o.points, &clean) })
            } else if case.name.ends_with("-view") {
                json!({
                    "normals_within_30_degrees": normals_within_30(&o.points, &clean),
                    "farthest_particle_from_the_view_in_spacings": farthest_from_view(&o.particles, &given),
                })
            } else {
                json!({})
            };
            let r = &o.report;
            let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
            let mut other_text = Vec::new();
            if let Some(share) = other["normals_within_30_degrees"].as_f64() {
                other_text.push(format!("normals within 30°: {:.2} %", 100.0 * share));
            }
            if let Some(far) = other["farthest_particle_from_the_view_in_spacings"].as_f64() {
                other_text.push(format!(
                    "farthest particle from the view: {far:.2} local spacings"
                ));
            }
            let other_text = other_text.join("; ");
            md.push_str(&format!(
                "| {} | {} | {:.1e} / {:.1e} / {:.1e} | {} ({:.1e}) | {} | {} | {:.4} | {} | {:.3} | {:.3} ({:.2}×) | {} ({:.2}×) | {:.1e} / {:.1e} / {:.1e} | {:.2} % | {} | {} |\n",
                case.name,
                case.about,
                f(&ds["mean"]),
                f(&ds["p99"]),
                f(&ds["max"]),
                r["input"]["points"],
                f(&dp["mean"]),
                r["input"]["outliers"]["removed"].as_u64().map_or("—".to_owned(), |v| v.to_string()),
                r["input"]["noise_estimate"]["relative"].as_f64().map_or("—".to_owned(), |v| format!("{v:.1e}")),
                f(&r["mpu"]["error_threshold"]["relative"]),
                r["mpu"]["leaves"],
                preprocess_seconds(r),
                o.build_seconds,
                o.build_seconds / clean_build,
                count,
                count as f64 / clean_count as f64,
                f(&d["mean"]),
                f(&d["p99"]),
                f(&d["max"]),
                100.0 * f(&d["within_2e-3"]),
                d["beyond_1e-2"],
                other_text,
            ));
            rows.push(json!({
                "group": "variants",
                "case": case.name,
                "about": case.about,
                "input": r["input"],
                "mpu": { "error_threshold": r["mpu"]["error_threshold"], "leaves": r["mpu"]["leaves"], "build_seconds_median": o.build_seconds },
                "particles": count,
                "count_ratio": count as f64 / clean_count as f64,
                "build_ratio": o.build_seconds / clean_build,
                "distance_to_reference": d,
                "points_distance_to_reference": dp,
                "scan_distance_to_reference": ds,
                "other": other,
            }));
        }
    }
    Ok((md, rows))
}

/// The `cow-coarse` group: `cow_original_5804.ply`, a coarse mesh, against itself.
fn cow_coarse(ctx: &ScanRun) -> Result<(String, Vec<Value>)> {
    let (psi, out) = (&ctx.psi, &ctx.out);
    let mut md = format!("## A coarse mesh against itself\n\n{VARIANTS_HEADER}");
    let mut rows = Vec::new();
    let coarse = ctx.models.join("cow_original_5804.ply");
    if coarse.is_file() {
        eprintln!("cow_original_5804 ...");
        let case = Case {
            name: "cow-coarse".into(),
            input: coarse.clone(),
            extra: Vec::new(),
            about: "the 5 804-triangle cow mesh".into(),
        };
        let o = run_case(psi, &case, out)?;
        let reference = Reference::new(psi::load_mesh(&coarse)?)?;
        let diag = o.report["input"]["bbox_diagonal"].as_f64().unwrap_or(1.0);
        let positions: Vec<DVec3> = o.particles.iter().map(|p| p.p).collect();
        let d = distance_stats(&reference.distances(&positions), diag);
        let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
        md.push_str(&format!(
            "| {} | {} | 0 (the mesh itself) | {} | — | — | {:.4} | {} | {:.3} | {:.3} | {} | {:.1e} / {:.1e} / {:.1e} | {:.2} % | {} | against this mesh |\n",
            case.name,
            case.about,
            o.report["input"]["points"],
            f(&o.report["mpu"]["error_threshold"]["relative"]),
            o.report["mpu"]["leaves"],
            preprocess_seconds(&o.report),
            o.build_seconds,
            o.particles.len(),
            f(&d["mean"]),
            f(&d["p99"]),
            f(&d["max"]),
            100.0 * f(&d["within_2e-3"]),
            d["beyond_1e-2"],
        ));
        rows.push(json!({
            "group": "cow-coarse",
            "case": case.name,
            "input": o.report["input"],
            "particles": o.particles.len(),
            "distance_to_reference": d,
        }));
    }
    Ok((md, rows))
}

/// Every group of `cargo xtask scans`, in the order they run.
const GROUPS: [&str; 7] = [
    "variants",
    "cow-coarse",
    "dragon-scan",
    "multiview",
    "flat",
    "outliers",
    "density",
];

/// The groups run when `--only` names none: all but the long `outliers` sweep and `density`.
const DEFAULT_GROUPS: [&str; 5] = ["variants", "cow-coarse", "dragon-scan", "multiview", "flat"];

/// The groups run when `--only` names models and no group: those run per model.
const MODEL_GROUPS: [&str; 2] = ["variants", "multiview"];

pub(crate) fn run(flags: &Flags) -> Result<()> {
    let only = flags.only.clone().unwrap_or_default();
    let (named_groups, named_models): (Vec<String>, Vec<String>) =
        only.into_iter().partition(|n| GROUPS.contains(&n.as_str()));
    let groups: Vec<&str> = if !named_groups.is_empty() {
        GROUPS
            .into_iter()
            .filter(|g| named_groups.iter().any(|n| n == g))
            .collect()
    } else if !named_models.is_empty() {
        MODEL_GROUPS.to_vec()
    } else {
        DEFAULT_GROUPS.to_vec()
    };
    let model_names = if named_models.is_empty() {
        MODELS.iter().map(|m| m.to_string()).collect()
    } else {
        named_models
    };
    let ctx = ScanRun {
        psi: build_release()?,
        models: models_dir(flags)?,
        out: project_root().join("target/xtask/scans"),
        model_names,
        seeds: flags.seeds.clone().or(flags.seed.map(|s| s..s + 1)),
    };
    std::fs::create_dir_all(&ctx.out).with_context(|| format!("creating {}", ctx.out.display()))?;
    let seed = flags.seed.unwrap_or(1);
    let mut md = String::new();
    let mut rows = Vec::new();
    for group in &groups {
        let (text, mut group_rows) = match *group {
            "variants" => variants(&ctx, seed)?,
            "cow-coarse" => cow_coarse(&ctx)?,
            "dragon-scan" => dragon_scan(&ctx)?,
            "multiview" => multiview(&ctx)?,
            "flat" => flat(&ctx)?,
            "outliers" => outlier_sweep(&ctx)?,
            "density" => density(&ctx)?,
            other => unreachable!("group {other} is listed in GROUPS"),
        };
        md.push_str(&text);
        md.push('\n');
        rows.append(&mut group_rows);
    }
    md.push_str(&summary(&rows));
    print!("{md}");
    if let Some(path) = &flags.json {
        let value = json!({
            "host": host::host(),
            "revision": host::revision(&project_root()),
            "psi_binary_sha256": host::sha256(&ctx.psi).ok(),
            "seed": seed,
            "seeds": ctx.seeds.as_ref().map(|s| [s.start, s.end]),
            "groups": groups,
            "models": ctx.model_names,
            "rows": rows,
        });
        psi::save_json(path, &value).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}
