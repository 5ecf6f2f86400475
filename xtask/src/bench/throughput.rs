//! `bench throughput [N,N,...] [normals,xyz]`: what `psi sample` costs per point on dense
//! scans (issue "Throughput"). Inputs are seeded area-weighted samplings of the shared dragon
//! mesh with Gaussian noise of σ = 2e-4 D, written once as binary float PLY (x y z, with or
//! without face normals) under `target/xtask/throughput/` (nothing large is committed); each is
//! sampled once by the release `psi` with its default pipeline. Reported per input: wall and
//! CPU time, points per second, peak memory per point, and each stage's wall and CPU time (the
//! report's `stage_seconds`); then the bunny end to end and in uniform mode (10 000 particles), medians
//! of 5 runs. Checks against the Done-when items. Writes `throughput.md` and
//! `throughput.json` there.
//!
//! `cargo xtask bench throughput 1000000,10000000,30000000 normals,xyz`

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;
use serde_json::{Value, json};

use crate::checks::{Check, checks_json};
use crate::median::median;
use crate::release_binary::{build_release, run_psi_report};
use crate::surface_samples::TriangleSampler;

/// The mesh sampled (in `../shared/models`).
const MESH: &str = "stanford_dragon_vrip_raw.ply";

/// Noise of the samplings' positions, in D (the inputs).
const SIGMA: f64 = 2e-4;

/// The samplings' seed.
const SEED: u64 = 30;

/// Runs per bunny timing (the issue: median of 5).
const BUNNY_RUNS: usize = 5;

/// A stage counts in the "both cores busy" check when it takes at least this share of the run.
const BUSY_STAGE_SHARE: f64 = 0.02;

/// Writes `n` noisy samples of `sampler` as binary little-endian float PLY at `path` (x y z,
/// and nx ny nz when `normals`), streamed: the points are never all in memory.
fn write_sampling(
    path: &Path,
    sampler: &TriangleSampler,
    n: usize,
    sigma: f64,
    normals: bool,
) -> Result<()> {
    let tmp = path.with_extension("ply.part");
    let mut w = std::io::BufWriter::with_capacity(
        1 << 22,
        std::fs::File::create(&tmp).with_context(|| format!("creating {}", tmp.display()))?,
    );
    let props = if normals {
        "property float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
    } else {
        "property float x\nproperty float y\nproperty float z\n"
    };
    write!(
        w,
        "ply\nformat binary_little_endian 1.0\ncomment psi xtask bench throughput: {MESH}, sigma {SIGMA} D, seed {SEED}\nelement vertex {n}\n{props}end_header\n"
    )?;
    let mut rng = Pcg64Mcg::seed_from_u64(SEED);
    for _ in 0..n {
        let (p, _) = sampler.sample(&mut rng);
        let q = p.p + sigma * psi::shapes::gaussian_vector(&mut rng);
        let mut values = vec![q.x, q.y, q.z];
        if normals {
            values.extend([p.n.x, p.n.y, p.n.z]);
        }
        for v in values {
            w.write_all(&(v as f32).to_le_bytes())?;
        }
    }
    w.flush()?;
    drop(w);
    std::fs::rename(&tmp, path).with_context(|| format!("renaming to {}", path.display()))
}

/// Runs `psi sample INPUT EXTRA -o DIR/NAME-particles.ply --json DIR/NAME.json -q`; the report and the
/// wall seconds.
fn sample(
    psi: &Path,
    dir: &Path,
    input: &Path,
    extra: &[&str],
    name: &str,
) -> Result<(Value, f64)> {
    let json = dir.join(format!("{name}.json"));
    let t = Instant::now();
    let report = run_psi_report(
        Command::new(psi)
            .arg("sample")
            .arg(input)
            .args(extra)
            .arg("-o")
            .arg(dir.join(format!("{name}-particles.ply")))
            .arg("--json")
            .arg(&json)
            .arg("-q"),
        &json,
    )
    .with_context(|| format!("run {name}"))?;
    Ok((report, t.elapsed().as_secs_f64()))
}

/// One dense run's measures.
struct Dense {
    name: String,
    points: usize,
    normals: bool,
    wall: f64,
    report: Value,
}

impl Dense {
    /// `(stage, wall s, CPU s)` from the report's `stage_seconds`.
    fn stages(&self) -> Vec<(String, f64, f64)> {
        self.report["stage_seconds"]
            .as_array()
            .map(|a| {
                a.iter()
                    .map(|s| {
                        (
                            s["stage"].as_str().unwrap_or("?").to_owned(),
                            s["wall_seconds"].as_f64().unwrap_or(f64::NAN),
                            s["cpu_seconds"].as_f64().unwrap_or(f64::NAN),
                        )
                    })
                    .collect()
            })
            .unwrap_or_default()
    }

    fn cpu(&self) -> f64 {
        self.stages().iter().map(|s| s.2).sum()
    }

    fn peak_bytes(&self) -> f64 {
        self.report["peak_memory_bytes"]
            .as_f64()
            .unwrap_or(f64::NAN)
    }
}

fn parse_sizes(arg: Option<&String>) -> Result<Vec<usize>> {
    arg.map_or("1000000,10000000,30000000", String::as_str)
        .split(',')
        .map(|s| {
            s.trim()
                .parse()
                .context("sizes: comma-separated point counts")
        })
        .collect()
}

pub(crate) fn run(args: &[String]) -> Result<()> {
    let sizes = parse_sizes(args.first())?;
    let variants: Vec<bool> = args
        .get(1)
        .map_or("normals,xyz", String::as_str)
        .split(',')
        .map(|v| match v.trim() {
            "normals" => Ok(true),
            "xyz" => Ok(false),
            other => bail!("variant {other}: normals or xyz"),
        })
        .collect::<Result<_>>()?;
    let models = crate::project_root().join("../shared/models");
    let mesh_path = models.join(MESH);
    if !mesh_path.is_file() {
        bail!(
            "{} not found: the throughput inputs sample it",
            mesh_path.display()
        );
    }
    let psi_bin = build_release()?;
    let dir = crate::project_root().join("target/xtask/throughput");
    std::fs::create_dir_all(&dir)?;
    let mesh =
        psi::load_mesh(&mesh_path).with_context(|| format!("reading {}", mesh_path.display()))?;
    let diag = crate::scan_case::diagonal(mesh.vertices.iter().copied())?;
    let sampler = TriangleSampler::from_mesh(&mesh)?;
    drop(mesh);

    let mut dense = Vec::new();
    for &n in &sizes {
        for &normals in &variants {
            let name = format!("dragon-{n}-{}", if normals { "normals" } else { "xyz" });
            let input: PathBuf = dir.join(format!("{name}.ply"));
            if !input.is_file() {
                eprintln!("writing {} ...", input.display());
                write_sampling(&input, &sampler, n, SIGMA * diag, normals)?;
            }
            eprintln!("{name} ...");
            let (report, wall) = sample(&psi_bin, &dir, &input, &[], &name)?;
            let run = Dense {
                name,
                points: n,
                normals,
                wall,
                report,
            };
            eprintln!(
                "  {:.1} s, {:.0} k points/s, {:.0} B/point",
                run.wall,
                n as f64 / run.wall / 1e3,
                run.peak_bytes() / n as f64
            );
            dense.push(run);
        }
    }

    let bunny = models.join("bunny.ply");
    let mut bunny_rows = Vec::new();
    if bunny.is_file() {
        for (label, extra) in [
            ("bunny", vec![]),
            (
                "bunny uniform 10 000",
                vec!["--count", "10000", "--uniform"],
            ),
        ] {
            let walls: Vec<f64> = (0..BUNNY_RUNS)
                .map(|k| sample(&psi_bin, &dir, &bunny, &extra, &format!("bunny-{k}")).map(|r| r.1))
                .collect::<Result<_>>()?;
            bunny_rows.push((label, median(&walls), walls));
        }
    } else {
        eprintln!("skipping the bunny: {} not found", bunny.display());
    }

    let (md, checks) = write_up(&dense, &bunny_rows);
    std::fs::write(dir.join("throughput.md"), &md)?;
    let runs: Vec<Value> = dense
        .iter()
        .map(|d| {
            json!({
                "input": d.name, "points": d.points, "normals": d.normals,
                "wall_seconds": d.wall, "cpu_seconds": d.cpu(),
                "points_per_second": d.points as f64 / d.wall,
                "peak_memory_bytes": d.report["peak_memory_bytes"],
                "stage_seconds": d.report["stage_seconds"],
                "particles": d.report["particles"]["count"],
            })
        })
        .collect();
    let bunny_json: Vec<Value> = bunny_rows
        .iter()
        .map(|(l, m, w)| json!({"run": l, "median_seconds": m, "runs_seconds": w}))
        .collect();
    std::fs::write(
        dir.join("throughput.json"),
        serde_json::to_string_pretty(&json!({
            "threads": rayon::current_num_threads(),
            "dense": runs,
            "bunny": bunny_json,
            "checks": checks_json(&checks),
        }))?,
    )?;
    println!("{md}\nwrote {}", dir.join("throughput.md").display());
    Ok(())
}

/// The report's Markdown and its checks.
fn write_up(dense: &[Dense], bunny: &[(&str, f64, Vec<f64>)]) -> (String, Vec<Check>) {
    let mut md = format!(
        "# Throughput: `psi sample` on dense samplings of `{MESH}`\n\n\
         Seeded area-weighted samplings (σ = {SIGMA} D, seed {SEED}), binary float PLY; release \
         build, {} threads, default pipeline.\n\n\
         | input | wall s | CPU s | points/s | peak B/point | particles |\n|---|---|---|---|---|---|\n",
        rayon::current_num_threads()
    );
    let mut checks = Vec::new();
    for d in dense {
        md += &format!(
            "| {} | {:.2} | {:.2} | {:.0} k | {:.0} | {} |\n",
            d.name,
            d.wall,
            d.cpu(),
            d.points as f64 / d.wall / 1e3,
            d.peak_bytes() / d.points as f64,
            d.report["particles"]["count"]
        );
    }
    md += "\n## Stages (wall s / CPU s, µs per point)\n\n| input | stages |\n|---|---|\n";
    for d in dense {
        let cells: Vec<String> = d
            .stages()
            .iter()
            .map(|(s, w, c)| format!("{s} {w:.2}/{c:.2} ({:.2})", 1e6 * w / d.points as f64))
            .collect();
        md += &format!("| {} | {} |\n", d.name, cells.join(", "));
    }
    for d in dense {
        if d.points == 10_000_000 && d.normals {
            checks.push(Check::at_most(
                "10 M with normals: wall",
                d.wall,
                10.0,
                format!("{:.2} s", d.wall),
            ));
            let b = d.peak_bytes() / d.points as f64;
            checks.push(Check::at_most(
                "10 M with normals: peak memory per point",
                b,
                100.0,
                format!("{b:.0} B"),
            ));
        }
        if d.points == 30_000_000 && !d.normals {
            checks.push(Check::at_most(
                "30 M without normals: wall",
                d.wall,
                45.0,
                format!("{:.2} s", d.wall),
            ));
            for (s, w, c) in d.stages() {
                if w >= BUSY_STAGE_SHARE * d.wall {
                    checks.push(Check::at_least(
                        "30 M without normals: each stage's CPU / wall",
                        c / w,
                        1.7,
                        format!("{s} {:.2}", c / w),
                    ));
                }
            }
        }
        // Per-point time at 30 M against 1 M, the same variant, stage by stage.
        if d.points == 30_000_000
            && let Some(small) = dense
                .iter()
                .find(|e| e.points == 1_000_000 && e.normals == d.normals)
        {
            let small_stages = small.stages();
            for (s, w, _) in d.stages() {
                if w < BUSY_STAGE_SHARE * d.wall {
                    continue;
                }
                let Some((_, w1, _)) = small_stages.iter().find(|t| t.0 == s) else {
                    continue;
                };
                let ratio = (w / 30.0) / w1;
                checks.push(Check::at_most(
                    "per-point time of each stage, 30 M over 1 M",
                    ratio,
                    1.5,
                    format!(
                        "{}: {s} {ratio:.2}",
                        if d.normals { "with normals" } else { "x y z" }
                    ),
                ));
            }
        }
    }
    if !bunny.is_empty() {
        md += &format!(
            "\n## Bunny, `psi sample` wall time, median of {BUNNY_RUNS}\n\n| run | median s | runs |\n|---|---|---|\n"
        );
    }
    for (label, m, w) in bunny {
        let runs: Vec<String> = w.iter().map(|x| format!("{x:.3}")).collect();
        md += &format!("| {label} | {m:.3} | {} |\n", runs.join(" "));
        let (item, limit) = if label.contains("uniform") {
            ("bunny uniform 10 000: wall", 0.4)
        } else {
            ("bunny end to end: wall", 0.2)
        };
        checks.push(Check::at_most(item, *m, limit, format!("{m:.3} s")));
    }
    md += "\n## Checks\n\n| item | target | value | pass |\n|---|---|---|---|\n";
    for c in &checks {
        md += &format!(
            "| {} | {} | {} | {} |\n",
            c.item,
            c.target,
            c.text,
            if c.pass { "✓" } else { "✗" }
        );
    }
    (md, checks)
}
