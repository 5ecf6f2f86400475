//! `bench formats [POINTS]`: how fast psi reads scanner files. A survey-like tile of POINTS
//! points (default 10 000 000) is written with `psi_io::write_las` into a temporary directory,
//! as LAZ and as LAS, and each file is decoded three times through
//! `psi_io::PointStream::for_each_chunk` (the streaming reader the facade uses, from a
//! buffered file, rayon's default pool: all cores), in chunks of 2^18 points (what the facade
//! reads) and of 400 000 (eight whole LAZ chunks); prints the medians as a markdown table.
//! The target (issue 27): a 10 M-point LAZ at ≥ 5 M points/s on 2 cores.
//!
//! The tile: the built-in model (`psi::shapes::sample_builtin`, seeded) scaled by 100 to
//! about 290 m × 290 m × 90 m and moved to (5e5, 5e6, 100) m, colour a smooth function of
//! position, intensity from the normal, ground / building / vegetation classes by the normal.
//! The sampler draws points in random order over the surface, which LAZ's delta coding
//! handles worst; the same points in Morton order (nearby points adjacent, as a scanner's
//! lines are) are timed too.
//!
//! `cargo xtask bench formats` (or `cargo run --release -p xtask -- bench formats 2000000`)

use std::fs::File;
use std::hint::black_box;
use std::io::{BufReader, BufWriter};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use psi::DVec3;
use psi::io::{Format, PointAttributes, PointStream, write_las};
use rayon::prelude::*;

/// Seed of the tile's sampler.
const SEED: u64 = 0x2711_2025;
/// Decoding runs per file.
const RUNS: usize = 3;
/// Points per chunk handed out: 2^18, as `psi_io::read_points_from` (and so the facade)
/// reads, and 400 000, eight whole LAZ chunks of the `las` writer's 50 000 points.
const CHUNKS: [usize; 2] = [1 << 18, 400_000];

pub(crate) fn run(args: &[String]) -> Result<()> {
    let n: usize = match args.first() {
        Some(a) => a.parse().context("POINTS is a whole number")?,
        None => 10_000_000,
    };
    let dir = TempDir::new()?;
    let cores = rayon::current_num_threads();
    println!("{n} points, {cores} threads, files in {}", dir.0.display());

    let t = Instant::now();
    let (positions, attributes) = survey_tile(n);
    println!("sampled the tile in {:.1} s", t.elapsed().as_secs_f64());
    let t = Instant::now();
    let (sorted, sorted_attributes) = morton_order(&positions, &attributes);
    println!(
        "sorted into Morton order in {:.1} s",
        t.elapsed().as_secs_f64()
    );

    let cases = [
        ("LAZ", "sampler (random)", true, &positions, &attributes),
        ("LAS", "sampler (random)", false, &positions, &attributes),
        ("LAZ", "Morton", true, &sorted, &sorted_attributes),
        ("LAS", "Morton", false, &sorted, &sorted_attributes),
    ];
    let mut rows = Vec::new();
    for (i, (format, order, compressed, positions, attributes)) in cases.into_iter().enumerate() {
        let path = dir.0.join(format!("tile{i}.{}", format.to_lowercase()));
        let t = Instant::now();
        let out = BufWriter::new(File::create(&path)?);
        write_las(out, positions, attributes, compressed)
            .with_context(|| format!("writing {}", path.display()))?;
        let write_seconds = t.elapsed().as_secs_f64();
        let bytes = std::fs::metadata(&path)?.len();
        println!(
            "{format} ({order}): written in {write_seconds:.1} s, {:.1} MB",
            bytes as f64 / 1e6
        );
        for chunk in CHUNKS {
            let mut seconds = Vec::new();
            for _ in 0..RUNS {
                let (s, read) = decode(&path, chunk)?;
                anyhow::ensure!(read == n as u64, "read {read} of {n} points");
                seconds.push(s);
            }
            let median = crate::median::median(&seconds);
            let runs = seconds
                .iter()
                .map(|s| format!("{s:.2}"))
                .collect::<Vec<_>>()
                .join(" / ");
            println!("  chunks of {chunk}: decoded in {runs} s");
            rows.push(format!(
                "| {format} | {order} | {:.1} | {:.2} | {write_seconds:.1} | {chunk} | {runs} | **{:.2}** |",
                bytes as f64 / 1e6,
                bytes as f64 / n as f64,
                n as f64 / median / 1e6,
            ));
        }
    }
    println!();
    println!(
        "| format | point order | file (MB) | bytes/point | write (s) | chunk (points) | decode runs (s) | median M points/s |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|---:|");
    for row in rows {
        println!("{row}");
    }
    Ok(())
}

/// Decodes the file at `path` through the streaming reader in chunks of `chunk` points;
/// returns the seconds taken (open included) and the points read.
fn decode(path: &Path, chunk: usize) -> Result<(f64, u64)> {
    let t = Instant::now();
    let file = BufReader::new(File::open(path)?);
    let stream = PointStream::open(file, Format::Las)?;
    let mut sum = DVec3::ZERO;
    let end = stream.for_each_chunk(chunk, |points| {
        // Touch the data so nothing is optimised away.
        sum += points.positions[0];
        black_box(&points);
        ControlFlow::Continue(())
    })?;
    black_box(sum);
    Ok((t.elapsed().as_secs_f64(), end.points))
}

/// The tile's points and attributes (see the module doc).
fn survey_tile(n: usize) -> (Vec<DVec3>, PointAttributes) {
    let origin = DVec3::new(5e5, 5e6, 100.0);
    let points = psi::shapes::sample_builtin(n, SEED);
    let positions: Vec<DVec3> = points.par_iter().map(|p| origin + 100.0 * p.p).collect();
    let colors = points
        .par_iter()
        .map(|p| {
            let q = p.p;
            let channel = |v: f64| (127.5 + 127.5 * v.sin()).round() as u8;
            [
                channel(2.0 * q.x),
                channel(3.0 * q.y + 1.0),
                channel(5.0 * q.z - q.x),
            ]
        })
        .collect();
    let intensity = points
        .par_iter()
        .map(|p| (p.n.z.abs() * 60_000.0).round() as f32)
        .collect();
    let classification = points
        .par_iter()
        .map(|p| match p.n.z {
            z if z > 0.8 => 2,  // ground
            z if z < -0.5 => 6, // building
            _ => 5,             // high vegetation
        })
        .collect();
    let attributes = PointAttributes {
        colors: Some(colors),
        intensity: Some(intensity),
        classification: Some(classification),
    };
    (positions, attributes)
}

/// The points sorted by their Morton code (21 bits an axis over the bounding box).
fn morton_order(
    positions: &[DVec3],
    attributes: &PointAttributes,
) -> (Vec<DVec3>, PointAttributes) {
    let (lo, hi) = positions
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    let cells = ((1u64 << 21) - 1) as f64;
    let scale = cells / (hi - lo).max_element();
    let mut keys: Vec<(u64, u32)> = positions
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let c = ((*p - lo) * scale).to_array().map(|v| v as u64);
            (psi::octree::morton_code(c), i as u32)
        })
        .collect();
    keys.par_sort_unstable();
    let order: Vec<u32> = keys.into_iter().map(|(_, i)| i).collect();
    let sorted = order.par_iter().map(|&i| positions[i as usize]).collect();
    (sorted, attributes.select(&order))
}

/// A directory removed with its files when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new() -> Result<Self> {
        let dir = std::env::temp_dir().join(format!("psi-bench-formats-{}", std::process::id()));
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        Ok(Self(dir))
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
