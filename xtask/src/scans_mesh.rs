//! The groups of `cargo xtask scans` judged against a reference mesh (issue 28): the real
//! multi-view scan `dragon_stand_scan.xyz` (`dragon-scan`), generated multi-view scans of the
//! shared models (`multiview`) and the 1 % uniform-outlier case over a range of seeds
//! (`outliers`). Each row shows the scan's own distance to the mesh beside the particles' (the
//! real scan's share beyond 2e-3 D by count and by area, [`share_by_area`]), and a ✓/✗ per
//! Done-when item.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use parry3d_f64::shape::TriMesh;
use psi::DVec3;
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;
use serde_json::{Value, json};

use crate::checks::{Check, checks_json};
use crate::coverage::{
    coverage, level_cv, nearest_neighbour_distances, share_by_area, spacing_ceiling,
};
use crate::multiview::{MultiViewParams, multiview_scan};
use crate::outliers::with_uniform_outliers;
use crate::reference::{Reference, distance_stats};
use crate::scan_case::{
    Sampled, ScanRun, clamped_distances, diagonal, distances_to, sample_once, write_positions_ply,
};

/// The real scan's file name (in `../shared/scans`) and its reference mesh's (in the models).
const DRAGON_SCAN: &str = "dragon_stand_scan.xyz";
const DRAGON_MESH: &str = "stanford_dragon_vrip_raw.ply";

/// The radius, over D, of the ball whose point count weighs each scan point in the scan's share
/// beyond 2e-3 D by area ([`share_by_area`]): a few of the real scan's spacings
/// (docs/notes/2026-12-02-real-scan-accuracy.md).
const AREA_BALL: f64 = 3e-3;

/// What a run gives against a reference: the input's and the particles' distances to it (JSON
/// of `distance_stats`, over D, the input's with `beyond_2e-3_by_area`, its share beyond 2e-3 D
/// weighted by area), the largest per-level CV and the levels' text, and how the particles
/// cover the input (JSON of [`coverage`]; `None` when not asked).
struct Measured {
    scan: Value,
    particles: Value,
    level_cv: (f64, String),
    coverage: Option<Value>,
}

impl Measured {
    /// The check that no particle lies beyond 1e-2 D of the reference.
    fn none_beyond(&self) -> Check {
        let beyond = &self.particles["beyond_1e-2"];
        Check::at_most("none beyond 1e-2 D", num(beyond), 0.0, beyond.to_string())
    }
}

/// Measures `run` (made from `inputs`, shape: M, world units) against `reference` with
/// diagonal `diag` (world units).
fn measure(
    reference: &Reference,
    diag: f64,
    inputs: &[DVec3],
    run: &Sampled,
    with_coverage: bool,
) -> Measured {
    let scan_d = clamped_distances(reference, inputs);
    let beyond: Vec<bool> = scan_d.iter().map(|d| *d > 2e-3 * diag).collect();
    let mut scan = distance_stats(&scan_d, diag);
    scan["beyond_2e-3_by_area"] = json!(share_by_area(inputs, &beyond, AREA_BALL * diag));
    let particles = distances_to(reference, &run.particles, diag);
    let coverage = with_coverage.then(|| {
        let nn = nearest_neighbour_distances(&run.particles);
        coverage(&run.particles, &nn, inputs, spacing_ceiling(&run.report).0)
    });
    Measured {
        scan,
        particles,
        level_cv: level_cv(&run.report),
        coverage,
    }
}

/// `x` as a number, NaN when it is not one.
fn num(x: &Value) -> f64 {
    x.as_f64().unwrap_or(f64::NAN)
}

/// `mean / p99 / max` of a `distance_stats` object, over D.
fn triple(d: &Value) -> String {
    format!(
        "{:.1e} / {:.1e} / {:.1e}",
        num(&d["mean"]),
        num(&d["p99"]),
        num(&d["max"])
    )
}

/// `p99 / max` of a [`coverage`] object, or a dash.
fn cover_text(c: &Option<Value>) -> String {
    c.as_ref().map_or("—".into(), |c| {
        format!("{:.2} / {:.2}", num(&c["p99"]), num(&c["max"]))
    })
}

/// The JSON row every group gives: the case, its input and particles, the measurements and
/// the checks (`extra` adds the group's own fields).
fn row(
    group: &str,
    case: &str,
    run: &Sampled,
    m: &Measured,
    checks: &[Check],
    extra: Value,
) -> Value {
    let r = &run.report;
    let mut row = json!({
        "group": group,
        "case": case,
        "input": r["input"],
        "mpu": { "error_threshold": r["mpu"]["error_threshold"], "leaves": r["mpu"]["leaves"] },
        "particles": run.particles.len(),
        "max_spacing": r["particles"]["max_spacing"],
        "added_by_ceiling": r["particles"]["added_by_ceiling"],
        "levels": r["particles"]["after"]["levels"],
        "largest_level_cv": m.level_cv.0,
        "scan_distance_to_reference": m.scan,
        "distance_to_reference": m.particles,
        "coverage": m.coverage,
        "psi_seconds": run.seconds,
        "checks": checks_json(checks),
    });
    if let (Some(row), Value::Object(extra)) = (row.as_object_mut(), extra) {
        row.extend(extra);
    }
    row
}

/// Where the real scan is: beside the models folder, else `../shared/scans`.
fn dragon_scan_path(ctx: &ScanRun) -> Option<PathBuf> {
    [
        ctx.models.join("../scans").join(DRAGON_SCAN),
        crate::project_root()
            .join("../shared/scans")
            .join(DRAGON_SCAN),
    ]
    .into_iter()
    .find(|p| p.is_file())
}

/// The `dragon-scan` group: psi on the real 15-view scan, judged against the reconstruction
/// (D its bounding-box diagonal, 0.266905): share beyond 2e-3 D at most the scan's own, none
/// beyond 1e-2 D, the largest per-level CV at most 0.15.
pub(crate) fn dragon_scan(ctx: &ScanRun) -> Result<(String, Vec<Value>)> {
    let mesh_path = ctx.models.join(DRAGON_MESH);
    let Some(scan_path) = dragon_scan_path(ctx).filter(|_| mesh_path.is_file()) else {
        eprintln!("skipping dragon-scan: {DRAGON_SCAN} or {DRAGON_MESH} not found");
        return Ok((String::new(), Vec::new()));
    };
    eprintln!("dragon-scan ...");
    let mesh =
        psi::load_mesh(&mesh_path).with_context(|| format!("reading {}", mesh_path.display()))?;
    let diag = diagonal(mesh.vertices.iter().copied())?;
    let reference = Reference::new(mesh)?;
    let inputs: Vec<DVec3> = psi::load_points(&scan_path, &psi::ReadOptions::paper())
        .with_context(|| format!("reading {}", scan_path.display()))?
        .points
        .iter()
        .map(|p| p.p)
        .collect();
    let run = sample_once(ctx, &scan_path, &[], "dragon-scan")?;
    let m = measure(&reference, diag, &inputs, &run, true);
    let own = 1.0 - num(&m.scan["within_2e-3"]);
    let share = 1.0 - num(&m.particles["within_2e-3"]);
    let checks = [
        Check::at_most(
            "share beyond 2e-3 D ≤ the scan's own",
            share,
            own,
            format!("{:.2} %", 100.0 * share),
        ),
        m.none_beyond(),
        Check::at_most(
            "largest per-level CV ≤ 0.15",
            m.level_cv.0,
            0.15,
            format!("{:.3}", m.level_cv.0),
        ),
    ];
    let mut md = format!(
        "## The real scan `{DRAGON_SCAN}` against `{DRAGON_MESH}` (D = {diag:.6})\n\nDistances over the mesh's D; the scan's share beyond 2e-3 D also by area (each point weighted by 1 / the points within 3e-3 D of it: the particles sample by area, the scan where the scanner saw best), for information; coverage: input points' distance to the nearest particle in local spacings (the mean nearest-neighbour distance of the particles within 5 ceilings), p99 / max, for information.\n\n| points | scan: mean / p99 / max (D) | scan beyond 2e-3 D (by area) | outliers removed | particles | particles: mean / p99 / max (D) | beyond 2e-3 D [≤ scan's {:.2} %] | beyond 1e-2 D [0] | largest level CV [≤ 0.15] (levels) | coverage p99 / max | psi s |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
        100.0 * own
    );
    md.push_str(&format!(
        "| {} | {} | {:.2} % ({:.2} %) | {} | {} | {} | {} | {} | {} ({}) | {} | {:.1} |\n",
        inputs.len(),
        triple(&m.scan),
        100.0 * own,
        100.0 * num(&m.scan["beyond_2e-3_by_area"]),
        run.report["input"]["outliers"]["removed"],
        run.particles.len(),
        triple(&m.particles),
        checks[0].cell(),
        checks[1].cell(),
        checks[2].cell(),
        m.level_cv.1,
        cover_text(&m.coverage),
        run.seconds,
    ));
    let row_in_core = row(
        "dragon-scan",
        "dragon-scan",
        &run,
        &m,
        &checks,
        json!({ "diagonal": diag }),
    );
    // The same scan out of core within 256 MiB (64 MiB cannot hold its MPU's 77 000 cells, and
    // the run refuses it): every preprocessing step (denoising, where the noise asks for it).
    let scratch = ctx.out.join("dragon-scan-ooc.psi-scratch");
    // (Afresh: a run resumed from an earlier one's tiles would time nothing.)
    if scratch.exists() {
        std::fs::remove_dir_all(&scratch)
            .with_context(|| format!("removing {}", scratch.display()))?;
    }
    let ooc_flags: Vec<String> = ["--max-memory", "256MiB", "--scratch"]
        .iter()
        .map(|s| s.to_string())
        .chain([scratch.display().to_string()])
        .collect();
    let ooc = sample_once(ctx, &scan_path, &ooc_flags, "dragon-scan-ooc")?;
    let mo = measure(&reference, diag, &inputs, &ooc, true);
    let pre = &ooc.report["tiles"]["preprocessing"];
    md.push_str(&format!(
        "\nOut of core (`--max-memory 256MiB`, {} tiles, the relaxation reading {} of the points; \
         ε0 {:.4} D from the {}; points denoised: {}): {} particles, mean / p99 / max {} D, \
         beyond 2e-3 D {:.2} %, beyond 1e-2 D {}, largest level CV {:.3}, coverage p99 / max {}, \
         {:.1} s; {} points left out.\n",
        ooc.report["tiles"]["count"],
        ooc.report["tiles"]["sampling"]["relax_points"],
        num(&ooc.report["mpu"]["error_threshold"]["relative"]),
        ooc.report["mpu"]["error_threshold"]["source"]
            .as_str()
            .unwrap_or("?"),
        pre["denoised"]["moved"],
        ooc.particles.len(),
        triple(&mo.particles),
        100.0 * (1.0 - num(&mo.particles["within_2e-3"])),
        mo.particles["beyond_1e-2"],
        mo.level_cv.0,
        cover_text(&mo.coverage),
        ooc.seconds,
        pre["outliers"]["removed"],
    ));
    let row_ooc = row(
        "dragon-scan",
        "dragon-scan-out-of-core",
        &ooc,
        &mo,
        &[],
        json!({ "diagonal": diag, "preprocessing": pre }),
    );
    Ok((md, vec![row_in_core, row_ooc]))
}

/// A shared model's mesh, its parry copy, its reference and its D (world units).
fn load_model(path: &Path) -> Result<(psi::TriangleMesh, TriMesh, Reference, f64)> {
    let mesh = psi::load_mesh(path).with_context(|| format!("reading {}", path.display()))?;
    let shape = TriMesh::new(mesh.vertices.clone(), mesh.faces.clone())
        .map_err(|e| anyhow::anyhow!("{}: {e:?}", path.display()))?;
    let diag = diagonal(mesh.vertices.iter().copied())?;
    Ok((mesh.clone(), shape, Reference::new(mesh)?, diag))
}

/// The `multiview` group: per model and seed (default 0–4), a generated multi-view scan
/// ([`MultiViewParams::issue_28`]) through `psi sample`: count within ±25 % of the clean mesh's
/// run, at least 99.5 % of particles within 2e-3 D, none beyond 1e-2 D, the largest per-level
/// CV at most 0.12.
pub(crate) fn multiview(ctx: &ScanRun) -> Result<(String, Vec<Value>)> {
    let seeds = ctx.seeds_or(0..5);
    let mut md = format!(
        "## Generated multi-view scans (seeds {}–{})\n\n10 views at 2 D, each moved by a rigid pose error of m ∈ 0.05–0.2 % D (largest displacement), half of the returns with |n·ray| < 0.15 standing off along the ray by 1–5e-3 D, merged x y z only. Distances over the mesh's D; counts against `psi sample` on the mesh; coverage (input points' distance to the nearest particle in local spacings, p99 / max) for information.\n\n| case | scan points (grazing moved; largest pose error, D) | scan: mean / p99 / max (D) | scan beyond 2e-3 D | particles × clean [0.75–1.25] | particles: mean / p99 / max (D) | within 2e-3 D [≥ 99.5 %] | beyond 1e-2 D [0] | largest level CV [≤ 0.12] (levels) | coverage p99 / max | psi s |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
        seeds.start,
        seeds.end.saturating_sub(1)
    );
    let mut rows = Vec::new();
    for (model, path) in ctx.present_models() {
        eprintln!("{model} multiview ...");
        let (mesh, shape, reference, diag) = load_model(&path)?;
        let clean = sample_once(ctx, &path, &[], &format!("{model}-mv-clean"))?
            .particles
            .len();
        for seed in seeds.clone() {
            let name = format!("{model}-multiview-{seed}");
            eprintln!("  {name} ...");
            let scan = multiview_scan(
                &mesh,
                &shape,
                &MultiViewParams::issue_28(mesh.faces.len()),
                seed,
            )?;
            let input = ctx.out.join(format!("{name}.ply"));
            write_positions_ply(&input, &scan.points)?;
            let run = sample_once(ctx, &input, &[], &name)?;
            let m = measure(&reference, diag, &scan.points, &run, true);
            let ratio = run.particles.len() as f64 / clean as f64;
            let within = num(&m.particles["within_2e-3"]);
            let checks = [
                Check::between(
                    "count within ±25 % of the clean mesh's",
                    ratio,
                    (0.75, 1.25),
                    format!("{} ({ratio:.2}×)", run.particles.len()),
                ),
                Check::at_least(
                    "≥ 99.5 % within 2e-3 D",
                    within,
                    0.995,
                    format!("{:.2} %", 100.0 * within),
                ),
                m.none_beyond(),
                Check::at_most(
                    "largest per-level CV ≤ 0.12",
                    m.level_cv.0,
                    0.12,
                    format!("{:.3}", m.level_cv.0),
                ),
            ];
            let grazing: usize = scan.views.iter().map(|v| v.grazing_moved).sum();
            let pose = scan
                .views
                .iter()
                .map(|v| v.max_displacement)
                .fold(0.0, f64::max);
            md.push_str(&format!(
                "| {name} | {} ({grazing}; {pose:.1e}) | {} | {:.3} % | {} | {} | {} | {} | {} ({}) | {} | {:.1} |\n",
                scan.points.len(),
                triple(&m.scan),
                100.0 * (1.0 - num(&m.scan["within_2e-3"])),
                checks[0].cell(),
                triple(&m.particles),
                checks[1].cell(),
                checks[2].cell(),
                checks[3].cell(),
                m.level_cv.1,
                cover_text(&m.coverage),
                run.seconds,
            ));
            let views: Vec<Value> = scan.views.iter().map(|v| v.to_json()).collect();
            let extra = json!({ "model": model, "seed": seed, "diagonal": diag, "clean_particles": clean, "count_ratio": ratio, "views": views });
            rows.push(row("multiview", &name, &run, &m, &checks, extra));
        }
    }
    Ok((md, rows))
}

/// The `outliers` group: the 1 % uniform-outlier case of the scan variants (the mesh's points
/// with face normals, plus 1 % uniform in the box with random normals) per model and seed
/// (default 0–19): no particle beyond 1e-2 D.
pub(crate) fn outlier_sweep(ctx: &ScanRun) -> Result<(String, Vec<Value>)> {
    let seeds = ctx.seeds_or(0..20);
    let mut md = format!(
        "## 1 % uniform outliers over seeds {}–{}\n\nThe points of each mesh (one per triangle, face normals) plus 1 % drawn uniformly in the bounding box with random normals; distances over the mesh's D, counts against `psi sample` on the mesh.\n\n| case | points | scan: mean / p99 / max (D) | outliers removed | particles (× clean) | particles: mean / p99 / max (D) | within 2e-3 D | beyond 1e-2 D [0] | largest level CV (levels) |\n|---|---|---|---|---|---|---|---|---|\n",
        seeds.start,
        seeds.end.saturating_sub(1)
    );
    let mut rows = Vec::new();
    for (model, path) in ctx.present_models() {
        eprintln!("{model} outliers ...");
        let (_, _, reference, diag) = load_model(&path)?;
        let clean_points = psi::load_points(&path, &psi::ReadOptions::paper())?.points;
        let clean = sample_once(ctx, &path, &[], &format!("{model}-out-clean"))?
            .particles
            .len();
        for seed in seeds.clone() {
            let name = format!("{model}-outliers-1-seed{seed}");
            let points = with_uniform_outliers(&clean_points, &mut Pcg64Mcg::seed_from_u64(seed))?;
            let input = ctx.out.join(format!("{name}.ply"));
            psi::save_points(&input, &points)
                .with_context(|| format!("writing {}", input.display()))?;
            let run = sample_once(ctx, &input, &[], &name)?;
            let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
            let m = measure(&reference, diag, &positions, &run, false);
            let checks = [m.none_beyond()];
            let ratio = run.particles.len() as f64 / clean as f64;
            md.push_str(&format!(
                "| {name} | {} | {} | {} | {} ({ratio:.2}×) | {} | {:.2} % | {} | {:.3} ({}) |\n",
                points.len(),
                triple(&m.scan),
                run.report["input"]["outliers"]["removed"],
                run.particles.len(),
                triple(&m.particles),
                100.0 * num(&m.particles["within_2e-3"]),
                checks[0].cell(),
                m.level_cv.0,
                m.level_cv.1,
            ));
            let extra = json!({ "model": model, "seed": seed, "diagonal": diag, "clean_particles": clean, "count_ratio": ratio });
            rows.push(row("outliers", &name, &run, &m, &checks, extra));
        }
    }
    Ok((md, rows))
}
