//! `bench scale [N,N,...] [MAX_MEMORY]`: how a run's cost grows with the input, in core and out
//! of core (issue "Beyond one machine"). Inputs are the built-in model sampled at each N with a
//! fixed seed, written as binary PCD with normals (nothing large is committed); each is sampled
//! by the release `psi` in core (the points as given: `--keep-outliers --no-noise-estimate
//! --keep-inward-normals`; skipped when psi's estimate exceeds the memory available) and with
//! `--max-memory` (default 1GiB): wall time, points per second, peak memory, the tiles, whether
//! the counts agree, and the tiled particles' per-level spacing CV and surface distance. Writes
//! `target/xtask/scale/scale.md` and `scale.json`.
//!
//! `cargo xtask bench scale 1000000,3000000 1GiB`

use std::io::Write;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result};
use serde_json::{Value, json};

use crate::release_binary::{build_release, run_psi_report};

/// Writes `points` as a binary PCD with normals (x y z normal_x normal_y normal_z, f64).
fn write_pcd(path: &Path, points: &[psi::OrientedPoint]) -> Result<()> {
    let mut f = std::io::BufWriter::new(
        std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?,
    );
    write!(
        f,
        "VERSION 0.7\nFIELDS x y z normal_x normal_y normal_z\nSIZE 8 8 8 8 8 8\n\
         TYPE F F F F F F\nCOUNT 1 1 1 1 1 1\nWIDTH {n}\nHEIGHT 1\nPOINTS {n}\nDATA binary\n",
        n = points.len()
    )?;
    for p in points {
        for v in [p.p.x, p.p.y, p.p.z, p.n.x, p.n.y, p.n.z] {
            f.write_all(&v.to_le_bytes())?;
        }
    }
    f.flush()?;
    Ok(())
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

pub(crate) fn run(args: &[String]) -> Result<()> {
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
    let psi_bin = build_release()?;
    let dir = crate::project_root().join("target/xtask/scale");
    std::fs::create_dir_all(&dir)?;
    let mut rows = Vec::new();
    let mut md = format!(
        "# Scale: in core and out of core (`--max-memory {budget}`)\n\n\
         Built-in model sampled at N points (seed 1), binary PCD with normals; release build, \
         {} threads.\n\n\
         | N | in core s | in core peak MiB | estimate MiB | out of core s | out of core peak MiB | tiles (depth) | counts | tiled CV per level | tiled max \\|f\\|/\\|∇f\\| / D |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
        rayon::current_num_threads()
    );
    for &n in &sizes {
        let input = dir.join(format!("builtin-{n}.pcd"));
        if !input.is_file() {
            write_pcd(&input, &psi::shapes::sample_builtin(n, 1))?;
        }
        let i = input.to_str().context("path")?;
        let core_out = dir.join(format!("core-{n}.ply"));
        let est = psi::estimate_in_core_bytes(n as u64, true) as f64 / 1048576.0;
        // (With a tenth to spare: a run near all of memory would swap, not measure.)
        let fits = psi::available_memory_bytes().is_none_or(|a| est * 1048576.0 < 0.9 * a as f64);
        let (core, core_s) = if !fits {
            println!("{n}: in core skipped (psi estimates {est:.0} MiB, more than available)");
            (Value::Null, f64::NAN)
        } else {
            timed(
                &psi_bin,
                &[
                    "sample",
                    i,
                    "--keep-outliers",
                    "--no-noise-estimate",
                    "--keep-inward-normals",
                    "-o",
                    core_out.to_str().context("path")?,
                    "-q",
                ],
                &dir.join(format!("core-{n}.json")),
            )?
        };
        let scratch = dir.join(format!("scratch-{n}"));
        let _ = std::fs::remove_dir_all(&scratch);
        let ooc_out = dir.join(format!("ooc-{n}.ply"));
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
            &dir.join(format!("ooc-{n}.json")),
        )?;
        let mib = |v: &Value| v["peak_memory_bytes"].as_f64().unwrap_or(f64::NAN) / 1048576.0;
        let after = &ooc["particles"]["after"];
        let levels: Vec<String> = after["levels"]
            .as_array()
            .map(|l| {
                l.iter()
                    .map(|v| {
                        format!(
                            "{}: {:.3}",
                            v["depth"],
                            v["spacing"]["cv"].as_f64().unwrap_or(f64::NAN)
                        )
                    })
                    .collect()
            })
            .unwrap_or_default();
        let counts = (&core["particles"]["count"], &ooc["particles"]["count"]);
        md += &format!(
            "| {n} | {core_s:.2} | {:.0} | {est:.0} | {ooc_s:.2} | {:.0} | {} ({}) | {} / {} | {} | {:.1e} |\n",
            mib(&core),
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
            "counts": [counts.0, counts.1], "out_of_core_after": after,
        }));
        println!("{n}: in core {core_s:.2} s, out of core {ooc_s:.2} s");
    }
    std::fs::write(dir.join("scale.md"), &md)?;
    std::fs::write(
        dir.join("scale.json"),
        serde_json::to_string_pretty(&json!(rows))?,
    )?;
    println!("{md}\nwrote {}", dir.join("scale.md").display());
    Ok(())
}
