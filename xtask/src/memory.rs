//! `cargo xtask memory [--points N]`: builds and samples the built-in model with N points
//! (default 5 000 000) with the release binary and reports time and peak memory.

use std::process::Command;

use anyhow::Result;

use crate::project_root;
use crate::release_binary::{build_release, run_psi_report};

pub(crate) fn run(points: usize) -> Result<()> {
    let psi = build_release()?;
    let out_dir = project_root().join("target/xtask");
    std::fs::create_dir_all(&out_dir)?;
    let report = out_dir.join(format!("memory-{points}.json"));
    let t = std::time::Instant::now();
    let j = run_psi_report(
        Command::new(psi)
            .args([
                "sample",
                "--builtin-points",
                &points.to_string(),
                "--iterations",
                "5",
                "--json",
            ])
            .arg(&report),
        &report,
    )?;
    let peak = j["peak_memory_bytes"].as_f64().unwrap_or(f64::NAN) / (1u64 << 30) as f64;
    println!(
        "{points} points: MPU {:.2} s ({} leaves), {} particles, total {:.1} s, peak memory {peak:.2} GiB",
        j["mpu"]["build_seconds"].as_f64().unwrap_or(f64::NAN),
        j["mpu"]["leaves"],
        j["particles"]["count"],
        t.elapsed().as_secs_f64()
    );
    Ok(())
}
