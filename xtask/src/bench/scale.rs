//! `bench scale [N,N,...] [MAX_MEMORY] [builtin|dragon]`: how a run's cost grows with the input,
//! in core and out of core (issue "Beyond one machine"). Inputs are sampled at each N with a
//! fixed seed and written as binary PCD with normals (nothing large is committed): the built-in
//! model, or the shared Stanford dragon (`../shared/models/stanford_dragon_vrip_raw.ply`,
//! area-weighted, Gaussian noise of σ = 2e-4 D, the triangles' normals). Each is sampled by the
//! release `psi` in core (its defaults, every preprocessing step the tiled run does too;
//! skipped when psi's estimate exceeds the memory available) and with `--max-memory` (default 1GiB): wall
//! time, peak memory, the tiles, whether the counts agree, and per level the spacing CV out of
//! core over in core (issue 26: within 5 %) and the tiled surface distance; for the dragon,
//! the tiled particles' checks of `reproduce-tables` against the mesh (distance, coverage at
//! 1.5 mean spacings). With `--cluster PYTHON` (an interpreter with psi and Dask installed),
//! each input also runs on `LocalCluster`s of 1, 2, 2 and 1 worker processes of one thread
//! (`python/bench/bench_cluster.py`): mean wall time, points per second, speed-up and parallel
//! efficiency, the largest worker's peak memory, the relaxation's share, and whether the bytes
//! are the command line's. Writes `target/xtask/scale/scale.md` and `scale.json`.
//!
//! `cargo xtask bench scale 1000000,3000000 1GiB dragon [--cluster .venv/bin/python]`

use std::io::Write;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result};
use serde_json::{Value, json};

use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;

use crate::release_binary::{build_release, run_psi_report};
use crate::surface_samples::TriangleSampler;

/// Writes `n` points from `next` as a binary PCD with normals (x y z normal_x normal_y
/// normal_z, f64), to a temporary file renamed when complete.
fn write_pcd(path: &Path, n: usize, mut next: impl FnMut() -> psi::OrientedPoint) -> Result<()> {
    let partial = path.with_extension("pcd.partial");
    let mut f = std::io::BufWriter::new(
        std::fs::File::create(&partial)
            .with_context(|| format!("creating {}", partial.display()))?,
    );
    write!(
        f,
        "VERSION 0.7\nFIELDS x y z normal_x normal_y normal_z\nSIZE 8 8 8 8 8 8\n\
         TYPE F F F F F F\nCOUNT 1 1 1 1 1 1\nWIDTH {n}\nHEIGHT 1\nPOINTS {n}\nDATA binary\n"
    )?;
    for _ in 0..n {
        let p = next();
        for v in [p.p.x, p.p.y, p.p.z, p.n.x, p.n.y, p.n.z] {
            f.write_all(&v.to_le_bytes())?;
        }
    }
    f.flush()?;
    drop(f);
    std::fs::rename(&partial, path).with_context(|| format!("renaming to {}", path.display()))
}

/// The dragon mesh the inputs are sampled from.
fn dragon_mesh() -> std::path::PathBuf {
    crate::project_root().join("../shared/models/stanford_dragon_vrip_raw.ply")
}

/// `reproduce-tables`' checks of the particles in `particles` (their run's report `report`)
/// against the dragon mesh: distances over the mesh's bounding-box diagonal D, coverage.
fn mesh_checks(particles: &Path, report: &Value) -> Result<Value> {
    let mesh = psi::load_mesh(&dragon_mesh())?;
    let (lo, hi) = mesh.vertices.iter().fold(
        (psi::DVec3::INFINITY, psi::DVec3::NEG_INFINITY),
        |(lo, hi), v| (lo.min(*v), hi.max(*v)),
    );
    let mut with_diagonal = report.clone();
    with_diagonal["input"]["bbox_diagonal"] = json!((hi - lo).length());
    crate::tables::check(&dragon_mesh(), particles, &with_diagonal)
}

/// Writes the input of `n` points of `model` to `path`.
fn write_input(path: &Path, model: &str, n: usize) -> Result<()> {
    match model {
        "builtin" => {
            let points = psi::shapes::sample_builtin(n, 1);
            let mut it = points.into_iter();
            write_pcd(path, n, || it.next().expect("n points"))
        }
        "dragon" => {
            let mesh_path =
                crate::project_root().join("../shared/models/stanford_dragon_vrip_raw.ply");
            let mesh = psi::load_mesh(&mesh_path)
                .with_context(|| format!("the dragon mesh ({})", mesh_path.display()))?;
            let sampler = TriangleSampler::from_mesh(&mesh)?;
            let (lo, hi) = mesh.vertices.iter().fold(
                (psi::DVec3::INFINITY, psi::DVec3::NEG_INFINITY),
                |(lo, hi), v| (lo.min(*v), hi.max(*v)),
            );
            let sigma = 2e-4 * (hi - lo).length();
            let mut rng = Pcg64Mcg::seed_from_u64(1);
            write_pcd(path, n, || {
                loop {
                    let (mut p, _) = sampler.sample(&mut rng);
                    p.p += sigma * psi::shapes::gaussian_vector(&mut rng);
                    if p.n != psi::DVec3::ZERO {
                        return p;
                    }
                }
            })
        }
        other => anyhow::bail!("model: builtin or dragon, not {other:?}"),
    }
}

/// Runs `psi` with `args` and its JSON report in `dir`; returns the report and the wall time.
fn timed(psi: &Path, args: &[&str], report: &Path) -> Result<(Value, f64)> {
    let t = Instant::now();
    let j = run_psi_report(
        Command::new(psi).args(args).arg("--json").arg(report),
        report,
    )?;
    Ok((j, t.elapsed().as_secs_f64()))
}

/// The order of the cluster runs: 1, 2, 2, 1 workers. This host's speed drifts within an hour
/// (measured in `docs/notes/2026-12-02-cluster-drift.md`); run in this order, a drift linear in
/// time adds as much to the 1-worker runs' mean as to the 2-worker runs', so their ratio does
/// not see it.
const CLUSTER_ORDER: &str = "1,2,2,1";

/// The cluster runs of `input` ([`CLUSTER_ORDER`]) by `python`'s `bench_cluster.py`, written
/// to `out`; its rows, one per run.
fn cluster_runs(python: &str, input: &str, budget: &str, out: &Path) -> Result<Vec<Value>> {
    let script = crate::project_root().join("python/bench/bench_cluster.py");
    let status = Command::new(python)
        .arg(&script)
        .args([input, "--max-memory", budget, "--workers", CLUSTER_ORDER])
        .arg("--out")
        .arg(out)
        .status()
        .with_context(|| format!("running {python} {}", script.display()))?;
    anyhow::ensure!(status.success(), "{} failed: {status}", script.display());
    let text =
        std::fs::read_to_string(out).with_context(|| format!("reading {}", out.display()))?;
    let rows: Vec<Value> =
        serde_json::from_str(&text).with_context(|| format!("parsing {}", out.display()))?;
    Ok(rows)
}

/// The markdown rows of `cluster` (the runs of [`cluster_runs`]) for `n` points, one per number
/// of workers in the order they first ran: the mean wall time of its runs (each run's in
/// brackets), the speed-up and efficiency of the means over the first count's mean, the peak
/// memory per worker and the relaxation's share (the largest over its runs), and whether every
/// run wrote the bytes `cli_sha` (SHA-256) names, the command line's particles out of core.
fn cluster_rows(n: usize, cluster: &[Value], cli_sha: &str) -> String {
    let seconds = |r: &Value| r["seconds"].as_f64().unwrap_or(f64::NAN);
    let workers = |r: &Value| r["workers"].as_u64().unwrap_or(0);
    let mut counts: Vec<u64> = Vec::new();
    for r in cluster {
        if !counts.contains(&workers(r)) {
            counts.push(workers(r));
        }
    }
    let runs = |w: u64| cluster.iter().filter(move |r| workers(r) == w);
    let mean_of =
        |w: u64, f: &dyn Fn(&Value) -> f64| runs(w).map(f).sum::<f64>() / runs(w).count() as f64;
    let mean = |w: u64| mean_of(w, &seconds);
    // The cells above the tiles: eight tasks of the same work in every run, no Dask traffic
    // between them, so their busy time (summed over the workers) measures how fast the host
    // ran them, alone or side by side.
    let octants = |r: &Value| {
        r["tasks"]["_ooc_top_group"]["busy"]
            .as_f64()
            .unwrap_or(f64::NAN)
    };
    let scheduler = |r: &Value| r["scheduler_cpu_seconds"].as_f64().unwrap_or(f64::NAN);
    let w0 = counts.first().copied().unwrap_or(1);
    let base = mean(w0);
    let mut md = String::new();
    for &w in &counts {
        let s = mean(w);
        let each: Vec<String> = runs(w).map(|r| format!("{:.1}", seconds(r))).collect();
        let peaks: Vec<u64> = runs(w)
            .flat_map(|r| {
                r["worker_peak_bytes"]
                    .as_array()
                    .cloned()
                    .unwrap_or_default()
            })
            .filter_map(|b| b.as_f64())
            .map(|b| (b / 1048576.0).round() as u64)
            .collect();
        let relax = runs(w)
            .map(|r| {
                r["tasks"]["_ooc_sample"]["span"]
                    .as_f64()
                    .unwrap_or(f64::NAN)
                    / seconds(r)
            })
            .fold(0.0, f64::max);
        let same = runs(w).all(|r| r["sha256"].as_str() == Some(cli_sha));
        md += &format!(
            "| {n} | {w} | {s:.1} ({}) | {:.0} | {:.2}× | {:.0} % | {:.1} ({:.2}×) | {:.1} | {} | {:.1} % | {} |\n",
            each.join(", "),
            n as f64 / s,
            base / s,
            100.0 * base / s * w0 as f64 / w as f64,
            mean_of(w, &octants),
            mean_of(w, &octants) / mean_of(w0, &octants),
            mean_of(w, &scheduler),
            peaks.iter().max().map_or("—".into(), |p| p.to_string()),
            100.0 * relax,
            if same { "yes" } else { "NO" },
        );
    }
    md
}

pub(crate) fn run(args: &[String]) -> Result<()> {
    // `--cluster PYTHON` anywhere; the rest positional.
    let (mut positional, mut python) = (Vec::new(), None);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if a == "--cluster" {
            python = Some(
                it.next()
                    .context("--cluster needs a Python interpreter")?
                    .clone(),
            );
        } else {
            positional.push(a.clone());
        }
    }
    let args = &positional;
    let sizes: Vec<usize> = args
        .first()
        .map_or("1000000,3000000", String::as_str)
        .split(',')
        .map(|s| {
            s.trim()
                .parse()
                .context("sizes: comma-separated point counts")
        })
        .collect::<Result<_>>()?;
    let budget = args.get(1).map_or("1GiB", String::as_str).to_owned();
    let model = args.get(2).map_or("builtin", String::as_str).to_owned();
    let psi_bin = build_release()?;
    let dir = crate::project_root().join("target/xtask/scale");
    std::fs::create_dir_all(&dir)?;
    let mut rows = Vec::new();
    let mut md_checks = String::new();
    let mut md_cluster = String::new();
    let mut md = format!(
        "# Scale: in core and out of core (`--max-memory {budget}`)\n\n\
         Model `{model}` sampled at N points (seed 1), binary PCD with normals; release build, \
         {} threads. Both runs with the defaults (outliers, the normals' checks, the noise \
         threshold, denoising where it is called for): the same preprocessing in core and tile \
         by tile.\n\n\
         | N | in core s | in core peak MiB | estimate MiB | out of core s | ratio | out of core peak MiB | tiles (depth) | counts | per level: CV out of core (in core) | tiled max \\|f\\|/\\|∇f\\| / D |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
        rayon::current_num_threads()
    );
    for &n in &sizes {
        let input = dir.join(format!("{model}-{n}.pcd"));
        if !input.is_file() {
            write_input(&input, &model, n)?;
        }
        let i = input.to_str().context("path")?;
        let core_out = dir.join(format!("core-{model}-{n}.ply"));
        let est = psi::estimate_in_core_bytes(n as u64, true) as f64 / 1048576.0;
        // (With a tenth to spare: a run near all of memory would swap, not measure.)
        let fits = psi::available_memory_bytes().is_none_or(|a| est * 1048576.0 < 0.9 * a as f64);
        let (core, core_s) = if !fits {
            println!("{n}: in core skipped (psi estimates {est:.0} MiB, more than available)");
            (Value::Null, f64::NAN)
        } else {
            timed(
                &psi_bin,
                &["sample", i, "-o", core_out.to_str().context("path")?, "-q"],
                &dir.join(format!("core-{model}-{n}.json")),
            )?
        };
        let scratch = dir.join(format!("scratch-{model}-{n}"));
        let _ = std::fs::remove_dir_all(&scratch);
        let ooc_out = dir.join(format!("ooc-{model}-{n}.ply"));
        let (ooc, ooc_s) = timed(
            &psi_bin,
            &[
                "sample",
                i,
                "--max-memory",
                &budget,
                "--scratch",
                scratch.to_str().context("path")?,
                "-o",
                ooc_out.to_str().context("path")?,
                "-q",
            ],
            &dir.join(format!("ooc-{model}-{n}.json")),
        )?;
        let mib = |v: &Value| v["peak_memory_bytes"].as_f64().unwrap_or(f64::NAN) / 1048576.0;
        let after = &ooc["particles"]["after"];
        let core_cv = |depth: &Value| {
            core["particles"]["after"]["levels"]
                .as_array()
                .and_then(|l| l.iter().find(|v| &v["depth"] == depth))
                .and_then(|v| v["spacing"]["cv"].as_f64())
        };
        let levels: Vec<String> = after["levels"]
            .as_array()
            .map(|l| {
                l.iter()
                    .map(|v| {
                        let cv = v["spacing"]["cv"].as_f64().unwrap_or(f64::NAN);
                        let inside = core_cv(&v["depth"])
                            .map_or(String::new(), |c| format!(" ({c:.3}: {:.2})", cv / c));
                        format!("{}: {cv:.3}{inside}", v["depth"])
                    })
                    .collect()
            })
            .unwrap_or_default();
        let counts = (&core["particles"]["count"], &ooc["particles"]["count"]);
        md += &format!(
            "| {n} | {core_s:.2} | {:.0} | {est:.0} | {ooc_s:.2} | {:.2} | {:.0} | {} ({}) | {} / {} | {} | {:.1e} |\n",
            mib(&core),
            ooc_s / core_s,
            mib(&ooc),
            ooc["tiles"]["count"],
            ooc["tiles"]["depth"],
            counts.0,
            counts.1,
            levels.join(", "),
            after["max_surface_distance"].as_f64().unwrap_or(f64::NAN)
        );
        rows.push(json!({
            "points": n, "in_core_seconds": core_s, "in_core_peak_bytes": core["peak_memory_bytes"],
            "estimate_bytes": est * 1048576.0, "out_of_core_seconds": ooc_s,
            "out_of_core_peak_bytes": ooc["peak_memory_bytes"], "tiles": ooc["tiles"],
            "counts": [counts.0, counts.1], "out_of_core_after": after, "model": model,
            "in_core_after": core["particles"]["after"],
        }));
        println!("{n}: in core {core_s:.2} s, out of core {ooc_s:.2} s");
        if let Some(python) = &python {
            let out = dir.join(format!("cluster-{model}-{n}.json"));
            let cluster = cluster_runs(python, i, &budget, &out)?;
            md_cluster += &cluster_rows(n, &cluster, &crate::host::sha256(&ooc_out)?);
            if let Some(row) = rows.last_mut() {
                row["cluster"] = json!(cluster);
            }
        }
        if model == "dragon" {
            // Both runs against the mesh, the in-core one when it ran.
            let core_run = (!core.is_null()).then_some(("in core", &core_out, &core));
            for (run, out, report) in core_run
                .into_iter()
                .chain([("out of core", &ooc_out, &ooc)])
            {
                let checks = mesh_checks(out, report)?;
                let d = |k: &str| checks["distance"][k].as_f64().unwrap_or(f64::NAN);
                md_checks += &format!(
                    "| {n} | {run} | {:.1e} / {:.1e} / {:.1e} | {:.2} % | {:.2} % |\n",
                    d("mean"),
                    d("p99"),
                    d("max"),
                    100.0 * d("within_2e-3"),
                    100.0 * checks["coverage_1.5_spacing"].as_f64().unwrap_or(f64::NAN),
                );
                if let Some(row) = rows.last_mut() {
                    let key = if run == "in core" {
                        "in_core_mesh_checks"
                    } else {
                        "out_of_core_mesh_checks"
                    };
                    row[key] = checks;
                }
            }
        }
    }
    if !md_checks.is_empty() {
        md += &format!(
            "\nAgainst the dragon mesh (`reproduce-tables`' checks):\n\n\
             | N | run | distance mean / p99 / max (D) | within 2e-3 D | coverage (1.5 spacings) |\n\
             |---|---|---|---|---|\n{md_checks}"
        );
    }
    if !md_cluster.is_empty() {
        md += &format!(
            "\nOn `LocalCluster`s of worker processes of one thread each (`psi.distributed`, \
             `max_memory=\"{budget}\"`), run with {} workers in that order; s: the mean of a count's \
             runs (each run's in brackets); speed-up: of the means; efficiency: speed-up over \
             workers; the octants' busy time: the eight tasks of the cells above the tiles, the \
             same work in every run, summed over the workers (over the first count's: how much \
             slower the host ran them side by side); the scheduler's CPU: the bench process's, \
             on the workers' cores; the relaxation's share: its task's span over the run, the \
             largest:\n\n\
             | N | workers | s | points/s | speed-up | efficiency | octants' busy s | scheduler CPU s | peak MiB, largest worker | relaxation share | the CLI's bytes |\n\
             |---|---|---|---|---|---|---|---|---|---|---|\n{md_cluster}",
            CLUSTER_ORDER.replace(',', ", ")
        );
    }
    std::fs::write(dir.join("scale.md"), &md)?;
    std::fs::write(
        dir.join("scale.json"),
        serde_json::to_string_pretty(&json!(rows))?,
    )?;
    println!("{md}\nwrote {}", dir.join("scale.md").display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run of `workers` taking `seconds`, its octants' tasks `octants` busy seconds.
    fn run(workers: u64, seconds: f64, octants: f64) -> Value {
        json!({
            "workers": workers, "seconds": seconds, "scheduler_cpu_seconds": 5.0,
            "worker_peak_bytes": [600.0 * 1048576.0], "sha256": "ab",
            "tasks": {"_ooc_top_group": {"busy": octants}, "_ooc_sample": {"span": 1.1}},
        })
    }

    #[test]
    fn cluster_rows_average_each_count_in_the_order_it_first_ran() {
        // 1, 2, 2, 1: means 110 and 55 s, so 2.00× and 100 %; octants 70 → 77 s, 1.10×.
        let runs = [
            run(1, 100.0, 70.0),
            run(2, 60.0, 77.0),
            run(2, 50.0, 77.0),
            run(1, 120.0, 70.0),
        ];
        let md = cluster_rows(1000, &runs, "ab");
        let rows: Vec<&str> = md.lines().collect();
        assert_eq!(rows.len(), 2, "{md}");
        assert!(rows[0].starts_with("| 1000 | 1 | 110.0 (100.0, 120.0) | 9 | 1.00× | 100 % | 70.0 (1.00×) | 5.0 | 600 | 1.1 % | yes |"), "{md}");
        assert!(rows[1].starts_with("| 1000 | 2 | 55.0 (60.0, 50.0) | 18 | 2.00× | 100 % | 77.0 (1.10×) | 5.0 | 600 | 2.2 % | yes |"), "{md}");
        // Another digest than the command line's is reported.
        assert!(cluster_rows(1000, &runs, "cd").contains("| NO |"));
    }
}
