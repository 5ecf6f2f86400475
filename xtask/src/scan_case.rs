//! Running `psi sample` on a generated scan: the case's input files (XYZ text, binary PLY
//! positions), one or more runs of the release binary with its JSON report, and what every
//! group of `cargo xtask scans` shares (the binary, the folders, the seeds, the models wanted).

use std::io::Write;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result};
use psi::{DVec3, OrientedPoint};
use serde_json::Value;

use crate::reference::{Reference, distance_stats};
use crate::release_binary::run_psi_report;

/// What the groups of `cargo xtask scans` share.
pub(crate) struct ScanRun {
    /// The release `psi` binary.
    pub(crate) psi: PathBuf,
    /// The shared models' folder.
    pub(crate) models: PathBuf,
    /// Where inputs, particles and reports are written (`target/xtask/scans`).
    pub(crate) out: PathBuf,
    /// Models the per-model groups run on.
    pub(crate) model_names: Vec<String>,
    /// Seeds given with `--seeds` (or `--seed S` as `S..S+1`); `None`: each group's own.
    pub(crate) seeds: Option<Range<u64>>,
}

impl ScanRun {
    /// The models of the per-model groups whose files are there, with their paths (a notice
    /// for each one missing).
    pub(crate) fn present_models(&self) -> Vec<(&str, PathBuf)> {
        self.model_names
            .iter()
            .filter_map(|model| {
                let path = self.models.join(format!("{model}.ply"));
                if !path.is_file() {
                    eprintln!("skipping {model}: {} not found", path.display());
                    return None;
                }
                Some((model.as_str(), path))
            })
            .collect()
    }

    /// The seeds of a group whose own default is `default`.
    pub(crate) fn seeds_or(&self, default: Range<u64>) -> Range<u64> {
        self.seeds.clone().unwrap_or(default)
    }
}

/// Writes oriented points (`with_normals`) or positions as an XYZ file.
pub(crate) fn write_xyz(path: &Path, points: &[OrientedPoint], with_normals: bool) -> Result<()> {
    let mut text = String::with_capacity(points.len() * 80);
    for p in points {
        if with_normals {
            text.push_str(&format!(
                "{} {} {} {} {} {}\n",
                p.p.x, p.p.y, p.p.z, p.n.x, p.n.y, p.n.z
            ));
        } else {
            text.push_str(&format!("{} {} {}\n", p.p.x, p.p.y, p.p.z));
        }
    }
    std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))
}

/// Writes positions (shape: N, world units) as a binary little-endian PLY with `property
/// double x y z` only (psi then estimates the normals), through a temporary file renamed into
/// place.
pub(crate) fn write_positions_ply(path: &Path, points: &[DVec3]) -> Result<()> {
    psi::write_atomically(path, |w| {
        let mut w = std::io::BufWriter::with_capacity(1 << 20, w);
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\ncomment psi xtask scans\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\nend_header\n",
            points.len()
        )?;
        for p in points {
            for c in p.to_array() {
                w.write_all(&c.to_le_bytes())?;
            }
        }
        w.flush()
    })
    .with_context(|| format!("writing {}", path.display()))
}

/// One run of `psi sample`: its report, the particle positions and the run's wall seconds.
pub(crate) struct Sampled {
    pub(crate) report: Value,
    pub(crate) particles: Vec<DVec3>,
    pub(crate) seconds: f64,
}

/// Runs `psi sample INPUT EXTRA -o OUT/NAME-particles.ply --json OUT/NAME-report.json -q` and
/// reads what it wrote.
pub(crate) fn sample_once(
    ctx: &ScanRun,
    input: &Path,
    extra: &[String],
    name: &str,
) -> Result<Sampled> {
    let particles = ctx.out.join(format!("{name}-particles.ply"));
    let json = ctx.out.join(format!("{name}-report.json"));
    let start = Instant::now();
    let report = run_psi_report(
        Command::new(&ctx.psi)
            .arg("sample")
            .arg(input)
            .args(extra)
            .arg("-o")
            .arg(&particles)
            .arg("--json")
            .arg(&json)
            .arg("-q"),
        &json,
    )
    .with_context(|| format!("case {name}"))?;
    let seconds = start.elapsed().as_secs_f64();
    let particles = psi::load_points(&particles, &psi::ReadOptions::paper())
        .with_context(|| format!("reading the particles of {name}"))?
        .points
        .iter()
        .map(|p| p.p)
        .collect();
    Ok(Sampled {
        report,
        particles,
        seconds,
    })
}

/// Bounding-box diagonal of `points` (world units); an error when there are none.
pub(crate) fn diagonal(points: impl IntoIterator<Item = DVec3>) -> Result<f64> {
    Ok(psi::Aabb::from_points(points)
        .context("no points")?
        .diagonal())
}

/// The distances from `points` (shape: N, world units) to `reference` (shape: N, world units),
/// each clamped at zero (parry gives −0 or −1e-17 for a point on a triangle).
pub(crate) fn clamped_distances(reference: &Reference, points: &[DVec3]) -> Vec<f64> {
    reference
        .distances(points)
        .into_iter()
        .map(|d| d.max(0.0))
        .collect()
}

/// [`distance_stats`] (over `diag`, world units) of [`clamped_distances`] from `points` to
/// `reference`.
pub(crate) fn distances_to(reference: &Reference, points: &[DVec3], diag: f64) -> Value {
    distance_stats(&clamped_distances(reference, points), diag)
}
