//! `bench edit`: editing sessions as a user drags a brush (issue "Edits at any size"). Each
//! session is a drag of strokes generated from a seed: a start point and a direction on the
//! surface, each stroke a step along it (a quarter of the radius), pushing the points out by
//! 0.32 % D along the normal; the radius is chosen per model so that a brush holds about the
//! same number of points as the bunny's at 4.8 % D. Every stroke is applied as a frame
//! (`Scene::apply_deferred`, the first iterations of its relaxation) and then settled
//! (`Scene::settle`), as an editor does between frames. Reports per model: the frame's median,
//! worst and first-stroke times, the settle time, the total CPU time per stroke (frame and
//! settle), and the median time by phase; and the bunny's 5 % brush (the one of
//! `reproduce-tables`) applied forth and back, warm. Writes `target/xtask/edit/edit.md` and
//! `edit.json`.
//!
//! `cargo xtask bench edit [MODEL,MODEL,…] [SEEDS] [STROKES] [FIRST_SEED]`
//! (defaults: bunny, igea and the David stand-in; 3 seeds from 1; 20 strokes; a model is a
//! shared model's name or `builtin:N`, N points of the built-in surface)

use std::io::Write;
use std::time::Instant;

use anyhow::{Context, Result};
use psi::octree::{Monitor, PointAttributes, PointIndex};
use psi::regen::{Edit, FRAME_ITERATIONS, RegenReport, Scene};
use psi::{DVec3, MpuParams, OrientedPoint, ParticleParams};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use serde_json::{Value, json};

use crate::median::median;

/// Brush radius on the bunny, as a fraction of the diagonal D (the sessions).
const BUNNY_RADIUS: f64 = 0.048;
/// How far a stroke pushes the points at its centre, as a fraction of D.
const DEPTH: f64 = 0.0032;
/// A stroke's step along the drag, as a fraction of the radius.
const STEP: f64 = 0.25;
/// Random input points over which a radius's median brush population is taken.
const PROBES: usize = 60;

/// The diagonal of the points' bounding box.
fn diagonal(points: &[OrientedPoint]) -> f64 {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for p in points {
        lo = lo.min(p.p);
        hi = hi.max(p.p);
    }
    (hi - lo).length()
}

/// The median number of points within `radius` of `PROBES` input points drawn with a fixed
/// seed.
fn brush_population(points: &[OrientedPoint], index: &PointIndex, radius: f64) -> f64 {
    let mut rng = Pcg64::seed_from_u64(99);
    let counts: Vec<f64> = (0..PROBES)
        .map(|_| {
            let c = points[rng.random_range(0..points.len())].p;
            let mut out = Vec::new();
            index.within(c, radius, &mut out);
            out.len() as f64
        })
        .collect();
    median(&counts)
}

/// The radius whose brushes hold about `target` points (bisection on the median population).
fn radius_for(points: &[OrientedPoint], index: &PointIndex, target: f64) -> f64 {
    let d = diagonal(points);
    let (mut lo, mut hi) = (1e-4 * d, 0.5 * d);
    for _ in 0..40 {
        let mid = (lo * hi).sqrt();
        if brush_population(points, index, mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (lo * hi).sqrt()
}

/// A drag of `strokes` brushes from seed `seed`: centres on input points, a quarter radius
/// apart along a direction kept in the tangent plane, each pushing out by `DEPTH`·D.
pub(crate) fn drag(
    points: &[OrientedPoint],
    index: &PointIndex,
    radius: f64,
    seed: u64,
    strokes: usize,
) -> Vec<Edit> {
    let d = diagonal(points);
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut at = points[rng.random_range(0..points.len())];
    let random = DVec3::new(
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
    );
    let tangent = |n: DVec3, t: DVec3| (t - n * t.dot(n)).try_normalize();
    let mut dir = tangent(at.n, random).unwrap_or_else(|| at.n.any_orthonormal_vector());
    let mut out = Vec::with_capacity(strokes);
    for _ in 0..strokes {
        out.push(Edit::Brush {
            center: at.p,
            radius,
            displacement: DEPTH * d * at.n,
        });
        let target = at.p + STEP * radius * dir;
        let Some((next, _)) = index.nearest_one(target) else {
            break;
        };
        let next = points[next as usize];
        dir = tangent(next.n, next.p - at.p)
            .or_else(|| tangent(next.n, dir))
            .unwrap_or(dir);
        at = next;
    }
    out
}

/// One stroke's figures: its frame, the settle after it, and the phases of its report.
struct Stroke {
    frame: f64,
    settle: f64,
    cpu: f64,
    report: RegenReport,
    build: psi::mpu::BuildPhases,
}

/// Runs `edits` on a fresh scene of `points`, each as a frame of `frame_iterations` and then
/// settled.
fn session(
    points: &[OrientedPoint],
    edits: &[Edit],
    frame_iterations: usize,
) -> Result<Vec<Stroke>> {
    let (mut scene, _) = Scene::new(
        points.to_vec(),
        &MpuParams::paper(),
        &ParticleParams::paper(),
    )?;
    let (none, silent) = (PointAttributes::default(), Monitor::silent());
    let mut out = Vec::with_capacity(edits.len());
    for e in edits {
        let t = Instant::now();
        let report = scene.apply_deferred(e, &none, frame_iterations, &silent)?;
        let frame = t.elapsed().as_secs_f64();
        let settled = scene.settle(usize::MAX);
        out.push(Stroke {
            frame,
            settle: settled.seconds,
            cpu: report.cpu_seconds + settled.cpu_seconds,
            report,
            build: scene.mpu().report().phase_seconds.clone(),
        });
    }
    Ok(out)
}

/// The median time by phase of `strokes` (ms).
fn phases_median(strokes: &[Stroke]) -> Value {
    let pick = |f: &dyn Fn(&Stroke) -> f64| -> Vec<f64> { strokes.iter().map(f).collect() };
    let phase = |f: &dyn Fn(&RegenReport) -> f64| 1e3 * median(&pick(&|s| f(&s.report)));
    let build = |f: &dyn Fn(&psi::mpu::BuildPhases) -> f64| 1e3 * median(&pick(&|s| f(&s.build)));
    json!({
        "edit": phase(&|r| r.edit_seconds),
        "mark": phase(&|r| r.mark_seconds),
        "mpu_rest": phase(&|r| r.mpu_seconds - r.edit_seconds - r.mark_seconds),
        "mpu_prepare": build(&|b| b.prepare),
        "mpu_indexes": build(&|b| b.indexes),
        "mpu_fits_and_octree": build(&|b| b.fits_and_octree),
        "mpu_assemble": build(&|b| b.assemble),
        "particles": phase(&|r| r.particle_seconds),
    })
}

/// One stroke's frame (ms), its size and its phases (ms).
fn stroke_row(s: &Stroke) -> Value {
    let (r, b) = (&s.report, &s.build);
    json!({
        "frame_ms": 1e3 * s.frame,
        "marked_cells": r.marked_cells,
        "regenerated": r.particles_regenerated,
        "edit_ms": 1e3 * r.edit_seconds,
        "mark_ms": 1e3 * r.mark_seconds,
        "mpu_prepare_ms": 1e3 * b.prepare,
        "mpu_ms": 1e3 * r.mpu_seconds,
        // The frame outside the MPU and the particles (replacing the earlier MPU, mostly).
        "rest_ms": 1e3 * (s.frame - r.mpu_seconds - r.particle_seconds),
        "mpu_indexes_ms": 1e3 * b.indexes,
        "mpu_fits_and_octree_ms": 1e3 * b.fits_and_octree,
        "mpu_assemble_ms": 1e3 * b.assemble,
        "particles_ms": 1e3 * r.particle_seconds,
    })
}

/// Median, worst and first of a series (ms).
fn summary(values: &[f64]) -> Value {
    let warm = &values[1.min(values.len())..];
    json!({
        "first_ms": 1e3 * values.first().copied().unwrap_or(f64::NAN),
        "median_ms": 1e3 * median(warm),
        "worst_ms": 1e3 * warm.iter().copied().fold(f64::NAN, f64::max),
    })
}

pub(crate) fn run(args: &[String]) -> Result<()> {
    let mut args = args.iter();
    let models: Vec<String> = match args.next() {
        Some(list) => list.split(',').map(str::to_owned).collect(),
        None => ["bunny", "igea", "david_standin_stanford_dragon"]
            .map(str::to_owned)
            .to_vec(),
    };
    let seeds: u64 = args.next().map_or(Ok(3), |a| a.parse())?;
    let strokes: usize = args.next().map_or(Ok(20), |a| a.parse())?;
    let first_seed: u64 = args.next().map_or(Ok(1), |a| a.parse())?;
    let dir = crate::project_root().join("../shared/models");
    // A shared model by name, or `builtin:N`: N points of the built-in surface (a large input
    // made at run time).
    let load = |name: &str| -> Result<Vec<OrientedPoint>> {
        if let Some(n) = name.strip_prefix("builtin:") {
            let n: usize = n
                .parse()
                .with_context(|| format!("{name}: a point count"))?;
            return Ok(psi::shapes::sample_builtin(n, 0x5051_2007));
        }
        let path = dir.join(format!("{name}.ply"));
        Ok(psi::load_points(&path, &psi::ReadOptions::paper())
            .with_context(|| format!("reading {}", path.display()))?
            .points)
    };
    let bunny = load("bunny")?;
    let bunny_index = PointIndex::new(&bunny.iter().map(|p| p.p).collect::<Vec<_>>());
    let target = brush_population(&bunny, &bunny_index, BUNNY_RADIUS * diagonal(&bunny));
    let mut rows = Vec::new();
    let mut md = format!(
        "# Editing sessions (`cargo xtask bench edit`)\n\n{} drags of {strokes} strokes per model \
         (seeds {first_seed}..{}), brushes holding about {target:.0} points (the bunny's at {:.1} % D), \
         each stroke pushing out by {:.2} % D; frames run {FRAME_ITERATIONS} relaxation \
         iterations, the rest settles after. Times in ms over the warm strokes (all but each \
         drag's first); CPU: the process's, frame and settle, per stroke.\n\n\
         | model | points | radius (% D) | marked cells | regenerated | frame median | frame worst | first stroke | settle median | CPU per stroke median | edit | mark | MPU: kd-trees | marked fits and octree | assemble | particles |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        seeds,
        first_seed + seeds,
        100.0 * BUNNY_RADIUS,
        100.0 * DEPTH
    );
    // Every model's input, kd-tree and brush radius first; then the drags seed by seed, each
    // seed's on every model in turn, so that a change in the machine's speed during the run
    // (a shared VM's varies by 10-25 %) touches every model alike and not their ratios.
    struct Model {
        name: String,
        points: Vec<OrientedPoint>,
        index: PointIndex,
        radius: f64,
        all: Vec<Stroke>,
        firsts: Vec<Stroke>,
    }
    let mut runs = Vec::new();
    for name in &models {
        let points = if name == "bunny" {
            bunny.clone()
        } else {
            load(name)?
        };
        let index = PointIndex::new(&points.iter().map(|p| p.p).collect::<Vec<_>>());
        let radius = radius_for(&points, &index, target);
        runs.push(Model {
            name: name.clone(),
            points,
            index,
            radius,
            all: Vec::new(),
            firsts: Vec::new(),
        });
    }
    for seed in first_seed..first_seed + seeds {
        for m in &mut runs {
            let edits = drag(&m.points, &m.index, m.radius, seed, strokes);
            let mut run = session(&m.points, &edits, FRAME_ITERATIONS)?;
            m.all.extend(run.drain(1..));
            m.firsts.extend(run);
        }
    }
    for m in &runs {
        let Model {
            name,
            points,
            index,
            radius,
            all,
            firsts,
        } = m;
        let (radius, d) = (*radius, diagonal(points));
        let pick = |f: &dyn Fn(&Stroke) -> f64| -> Vec<f64> { all.iter().map(f).collect() };
        let frames = pick(&|s| s.frame);
        let row = json!({
            "model": name,
            "points": points.len(),
            "radius": radius,
            "radius_of_diagonal": radius / d,
            "brush_points": brush_population(points, index, radius),
            "marked_cells_median": median(&pick(&|s| s.report.marked_cells as f64)),
            "regenerated_median": median(&pick(&|s| s.report.particles_regenerated as f64)),
            "frame": summary(&frames),
            "first_strokes_ms": firsts.iter().map(|s| 1e3 * s.frame).collect::<Vec<_>>(),
            "first_strokes": firsts.iter().map(stroke_row).collect::<Vec<_>>(),
            "settle_median_ms": 1e3 * median(&pick(&|s| s.settle)),
            "cpu_per_stroke_median_ms": 1e3 * median(&pick(&|s| s.cpu)),
            "phases_median_ms": phases_median(all),
            // Every warm stroke, in order (drag after drag), to find what the worst ones do.
            "warm_strokes": all.iter().map(stroke_row).collect::<Vec<_>>(),
        });
        let f = &row["frame"];
        let ph = &row["phases_median_ms"];
        md.push_str(&format!(
            "| {name} | {} | {:.2} | {:.0} | {:.0} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |\n",
            points.len(),
            100.0 * radius / d,
            row["marked_cells_median"].as_f64().unwrap_or(0.0),
            row["regenerated_median"].as_f64().unwrap_or(0.0),
            f["median_ms"].as_f64().unwrap_or(f64::NAN),
            f["worst_ms"].as_f64().unwrap_or(f64::NAN),
            1e3 * median(&firsts.iter().map(|s| s.frame).collect::<Vec<_>>()),
            row["settle_median_ms"].as_f64().unwrap_or(f64::NAN),
            row["cpu_per_stroke_median_ms"].as_f64().unwrap_or(f64::NAN),
            ph["edit"].as_f64().unwrap_or(f64::NAN),
            ph["mark"].as_f64().unwrap_or(f64::NAN),
            ph["mpu_indexes"].as_f64().unwrap_or(f64::NAN),
            ph["mpu_fits_and_octree"].as_f64().unwrap_or(f64::NAN),
            ph["mpu_assemble"].as_f64().unwrap_or(f64::NAN),
            ph["particles"].as_f64().unwrap_or(f64::NAN),
        ));
        println!("{name}: {row}");
        rows.push(row);
    }
    // Issue 29's ratios: the David stand-in's frame and CPU medians over the bunny's.
    let row_of = |name: &str| rows.iter().find(|r| r["model"] == name);
    if let (Some(b), Some(d)) = (row_of("bunny"), row_of("david_standin_stanford_dragon")) {
        let ratio =
            |f: &dyn Fn(&Value) -> Option<f64>| f(d).unwrap_or(f64::NAN) / f(b).unwrap_or(f64::NAN);
        md.push_str(&format!(
            "\nThe David stand-in over the bunny: frame median {:.2}×, CPU per stroke median {:.2}×.\n",
            ratio(&|r| r["frame"]["median_ms"].as_f64()),
            ratio(&|r| r["cpu_per_stroke_median_ms"].as_f64()),
        ));
    }
    let big = big_brush(&bunny)?;
    let ms = |a: &str, b: &str| big[a][b].as_f64().unwrap_or(f64::NAN);
    let ph = |p: &str| {
        big["frame"]["phases_median_ms"][p]
            .as_f64()
            .unwrap_or(f64::NAN)
    };
    md.push_str(&format!(
        "\nThe bunny's 5 % brush (`reproduce-tables`' second brush) applied forth and back, \
         warm strokes: frame median {:.1} ms, worst {:.1} ms; eager (full relaxation) median \
         {:.1} ms, worst {:.1} ms. The frame's median phases: mark {:.1}, kd-trees {:.1}, \
         marked fits and octree {:.1}, assemble {:.1}, particles {:.1} ms.\n",
        ms("frame", "median_ms"),
        ms("frame", "worst_ms"),
        ms("eager", "median_ms"),
        ms("eager", "worst_ms"),
        ph("mark"),
        ph("mpu_indexes"),
        ph("mpu_fits_and_octree"),
        ph("mpu_assemble"),
        ph("particles"),
    ));
    let out = crate::project_root().join("target/xtask/edit");
    std::fs::create_dir_all(&out)?;
    std::fs::write(out.join("edit.md"), &md)?;
    let report = json!({
        "host": crate::host::host(),
        "strokes": strokes,
        "seeds": seeds,
        "first_seed": first_seed,
        "brush_points": target,
        "models": rows,
        "bunny_big_brush": big,
    });
    let mut f = std::fs::File::create(out.join("edit.json"))?;
    writeln!(f, "{}", serde_json::to_string_pretty(&report)?)?;
    print!("{md}");
    println!("wrote {}", out.display());
    Ok(())
}

/// The bunny's 5 % brush forth and back, 21 strokes, each a frame then settled: the warm
/// strokes' frame median and worst (ms), and the eager stroke's (frame and full relaxation);
/// with the frames' median time by phase.
fn big_brush(bunny: &[OrientedPoint]) -> Result<Value> {
    let b = crate::edits::BRUSHES[1].1;
    let brush = |k: usize| Edit::Brush {
        center: DVec3::new(b[0], b[1], b[2]),
        radius: b[3],
        displacement: DVec3::new(b[4], b[5], b[6]) * if k.is_multiple_of(2) { 1.0 } else { -1.0 },
    };
    let edits: Vec<Edit> = (0..21).map(brush).collect();
    let mut out = serde_json::Map::new();
    for (name, frame) in [("frame", FRAME_ITERATIONS), ("eager", usize::MAX)] {
        let strokes = session(bunny, &edits, frame)?;
        let times: Vec<f64> = strokes.iter().map(|s| s.frame).collect();
        let mut row = summary(&times);
        // The warm strokes' median time by phase.
        row["phases_median_ms"] = phases_median(&strokes[1..]);
        out.insert(name.to_owned(), row);
    }
    Ok(Value::Object(out))
}
