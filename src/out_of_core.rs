//! Sampling a file larger than memory (issue "Beyond one machine"): its points streamed into
//! tile files in a scratch directory, the MPU decided tile by tile from them
//! ([`psi_tiles::decide_store`]), the particles seeded by octant of the root
//! ([`psi_tiles::seed_store_octant`]) and relaxed at once ([`psi_tiles::sample_tiled_from`]). The CLI's `--max-memory` and Python's `sample_files` both
//! run this.
//!
//! The preprocessing steps that read the whole input (the outlier search, the noise estimate,
//! the inward-normals check) are not done tile by tile yet: a run out of core takes oriented
//! points as they are, and says so up front when asked for those steps.

use std::fs;
use std::io::BufReader;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::Instant;

use psi_io::{Format, PointStream, ReadOptions, chunk_oriented_points};
use psi_mpu::{MpuFrame, MpuParams};
use psi_octree::{Aabb, Monitor, OrientedPoint};
use psi_particles::{ParticleParams, Particles, Quality};
use psi_tiles::{
    TileParams, TileReport, TileSampleReport, TileStore, TileWriter, decide_store,
    sample_tiled_from, seed_store_octant,
};

use crate::PsiError;
use crate::files::{check_not_dir, extension_format, open_error, read_error};
use crate::read_ahead::{AHEAD, read_ahead};

/// Bytes a tile's build holds per point of the tile: its points with their halo in the MPU's
/// arrays, kd-tree and footprint table, and the balls its far cells fetch (the peaks this is
/// set from: docs/notes/2026-11-25-tiles.md).
const BYTES_PER_TILE_POINT: u64 = 1500;
/// Bytes a point of the whole input costs wherever it is: its coarse copy (1 in 16 of 56
/// bytes) and its share of the cell table.
const BYTES_PER_INPUT_POINT: u64 = 8;

/// Memory of one point held by the relaxation's MPU (an MPU assembled from the decisions: the
/// point, its local position, the kd-tree, the octree's order and the data footprint's cache),
/// with room to spare.
const BYTES_PER_RELAX_POINT: u64 = 400;
/// Points streamed per chunk.
const CHUNK: usize = 1 << 18;
/// The least budget whose partition decodes the input ahead ([`read_ahead`]): 16 × the chunks
/// held ahead (576 MiB), so that they stay a small share of it.
const READ_AHEAD_BUDGET: u64 =
    16 * (AHEAD as u64 + 1) * (CHUNK * std::mem::size_of::<OrientedPoint>()) as u64;

/// How a run out of core may use the machine.
#[derive(Clone, Debug)]
pub struct OutOfCore {
    /// Bytes psi may allocate at once (the process's own baseline aside).
    pub max_memory: u64,
    /// Where the tile files go (created; a run finds its earlier files there and resumes).
    pub scratch: PathBuf,
    /// Tiles at this depth instead of the one `max_memory` gives.
    pub tile_depth: Option<u8>,
}

/// What a run out of core made.
#[derive(Clone, Debug)]
pub struct OutOfCoreRun {
    /// The particles.
    pub particles: Particles,
    /// Their quality (surface distance, spacing per depth level).
    pub after: Quality,
    /// Points read (zero normals dropped).
    pub points: u64,
    /// Points dropped for a zero normal.
    pub dropped: u64,
    /// The tiling of the MPU's decisions.
    pub tiles: TileReport,
    /// The tiled sampling.
    pub sampling: TileSampleReport,
    /// Whether the tile files of an earlier run were used as they were.
    pub resumed: bool,
    /// Seconds: reading and partitioning, deciding the cells, sampling.
    pub seconds: [f64; 3],
}

impl OutOfCore {
    /// The input points the particles' relaxation may hold (its MPU's data test) for `points`
    /// input points: what the budget leaves after the share of the whole input
    /// ([`sample_files_out_of_core`] relaxes all particles at once; their number follows the
    /// surface, not the input).
    pub fn relax_points_for(&self, points: u64) -> usize {
        let shared = points.saturating_mul(BYTES_PER_INPUT_POINT);
        (self.max_memory.saturating_sub(shared) / BYTES_PER_RELAX_POINT) as usize
    }

    /// The tile depth for `points` input points: the shallowest (at least 1, at most 8)
    /// whose tiles, about `points / 4^depth` each on a surface, fit the budget with two
    /// built at once; an error naming the memory needed when even the whole input's share
    /// (coarse points, cell table) would not fit.
    pub fn tile_depth_for(&self, points: u64) -> Result<u8, String> {
        if let Some(d) = self.tile_depth {
            if !(1..=8).contains(&d) {
                return Err(format!("the tile depth must be 1 to 8, not {d}"));
            }
            return Ok(d);
        }
        let shared = points.saturating_mul(BYTES_PER_INPUT_POINT);
        if 2 * shared > self.max_memory {
            return Err(format!(
                "{} points need at least {} MiB out of core (their coarse copy and cell table), \
                 more than --max-memory {} MiB allows",
                points,
                (2 * shared).div_ceil(1 << 20),
                self.max_memory >> 20
            ));
        }
        let per_tile = (self.max_memory - shared) / (2 * BYTES_PER_TILE_POINT);
        (1..=8u8)
            .find(|&d| points / 4u64.pow(u32::from(d)) <= per_tile)
            .ok_or_else(|| {
                format!(
                    "{points} points need tiles deeper than 8 levels within --max-memory {} MiB; \
                     give more memory",
                    self.max_memory >> 20
                )
            })
    }
}

/// Calls `visit` with the oriented points of the file at `path`, chunk by chunk in file
/// order: the scanner formats, XYZ and PLY point clouds streamed, PLY meshes and OBJ read
/// whole first. Returns the
/// points dropped for a zero normal.
fn for_each_points(
    path: &Path,
    format: Option<Format>,
    mut visit: impl FnMut(&[OrientedPoint]) -> Result<(), PsiError>,
) -> Result<u64, PsiError> {
    check_not_dir(path)?;
    let no_normals = || PsiError::OutOfCore {
        path: path.to_path_buf(),
        reason: "has no normals: a run out of core takes oriented points (estimating normals \
                 tile by tile is not done yet); run without --max-memory to estimate them"
            .into(),
    };
    let format = format.or_else(|| extension_format(path));
    // A PLY point cloud streams; a PLY mesh (its faces need every vertex) is read whole.
    let streams = match format {
        Some(Format::Ply) => {
            let file = fs::File::open(path).map_err(|e| open_error(path, e))?;
            PointStream::open(BufReader::new(file), Format::Ply).is_ok()
        }
        Some(f) => f.is_streamed() || f == Format::Xyz,
        None => false,
    };
    match format {
        Some(format) if streams => {
            let file = fs::File::open(path).map_err(|e| open_error(path, e))?;
            let stream =
                PointStream::open(BufReader::new(file), format).map_err(read_error(path))?;
            let (mut first, mut dropped) = (0u64, 0u64);
            let mut failure = None;
            stream
                .for_each_chunk(CHUNK, |chunk| {
                    let result = match chunk_oriented_points(&chunk, first) {
                        None => Err(no_normals()),
                        Some(Err(e)) => Err(read_error(path)(e)),
                        Some(Ok((points, d))) => {
                            dropped += d as u64;
                            visit(&points)
                        }
                    };
                    first += chunk.len() as u64;
                    match result {
                        Ok(()) => ControlFlow::Continue(()),
                        Err(e) => {
                            failure = Some(e);
                            ControlFlow::Break(())
                        }
                    }
                })
                .map_err(read_error(path))?;
            failure.map_or(Ok(dropped), Err)
        }
        _ => {
            let file = crate::load_points_as(path, format, &ReadOptions::paper())?;
            if file.normals == psi_io::NormalSource::Missing {
                return Err(no_normals());
            }
            for chunk in file.points.chunks(CHUNK) {
                visit(chunk)?;
            }
            Ok(file.dropped_points as u64)
        }
    }
}

/// Samples the files at `paths` (one input, their points in this order, as a survey's tiles
/// come; each read as `format`, or as its extension says) out of core:
/// the MPU with `mpu_params` decided tile by tile, bitwise the in-core build of the same
/// points, and particles with `particle_params` (k per leaf: the in-core seeds and count;
/// seeded tile by tile, then relaxed at once). Tile files go to `options.scratch`; a run that finds
/// the files of an earlier run on the same file there resumes from them. Progress: stages
/// `"read"`, `"tiles"`, `"sample tiles"`.
///
/// # Errors
///
/// [`PsiError::Open`] / [`PsiError::Read`] for the input; [`PsiError::OutOfCore`] when it has
/// no normals, the budget is too small, an exact count or uniform mode is asked for, or a
/// scratch file fails (named).
pub fn sample_files_out_of_core(
    paths: &[PathBuf],
    format: Option<Format>,
    mpu_params: &MpuParams,
    particle_params: &ParticleParams,
    options: &OutOfCore,
    monitor: &Monitor<'_>,
) -> Result<OutOfCoreRun, PsiError> {
    let t0 = Instant::now();
    let part = partition_files(paths, format, mpu_params, options, monitor)?;
    let read_seconds = t0.elapsed().as_secs_f64();
    let fail = failure(&paths[0]);
    let t1 = Instant::now();
    let store = &part.store;
    let tiles = out_of_core_tiles(store);
    let decisions =
        decide_store(store, mpu_params, &tiles, monitor).map_err(|e| fail(e.to_string()))?;
    let decide_seconds = t1.elapsed().as_secs_f64();
    let t2 = Instant::now();
    let relax_points = options.relax_points_for(part.points);
    // Each octant's seeds from its file (a cluster's task wrote it), or seeded and written.
    let seeds_of = |octant| {
        seed_store_octant(
            store,
            &tiles,
            &decisions,
            mpu_params,
            particle_params,
            relax_points,
            octant,
            monitor,
        )
    };
    let sampled = sample_tiled_from(
        store,
        &decisions,
        mpu_params,
        particle_params,
        relax_points,
        &seeds_of,
        monitor,
    )
    .map_err(|e| fail(e.to_string()))?;
    Ok(OutOfCoreRun {
        particles: sampled.particles,
        after: sampled.after,
        points: part.points,
        dropped: part.dropped,
        tiles: decisions.report,
        sampling: sampled.report,
        resumed: part.resumed,
        seconds: [read_seconds, decide_seconds, t2.elapsed().as_secs_f64()],
    })
}

/// The input's points in tile files: what [`partition_files`] made or found.
#[derive(Clone, Debug)]
pub struct Partition {
    /// The tile store (in `<scratch>/tiles`).
    pub store: TileStore,
    /// Points in it.
    pub points: u64,
    /// Points dropped for a zero normal (0 when the store was found).
    pub dropped: u64,
    /// Whether the store of an earlier run on the same files was found and used.
    pub resumed: bool,
}

/// The first step of a run out of core (a cluster runs it as one task): the files' points
/// streamed into tile files in `options.scratch` (two passes: the frame and count, then the
/// points), or the store an earlier run on the same files left there. The tile depth follows
/// the budget ([`OutOfCore::tile_depth_for`]).
///
/// # Errors
///
/// As [`sample_files_out_of_core`].
pub fn partition_files(
    paths: &[PathBuf],
    format: Option<Format>,
    mpu_params: &MpuParams,
    options: &OutOfCore,
    monitor: &Monitor<'_>,
) -> Result<Partition, PsiError> {
    let first = paths.first().ok_or_else(|| PsiError::OutOfCore {
        path: PathBuf::new(),
        reason: "no input files given".into(),
    })?;
    let fail = failure(first);
    let source = paths
        .iter()
        .map(|p| source_of(p))
        .collect::<Result<Vec<_>, _>>()?
        .join("\n");
    let dir = options.scratch.join("tiles");
    // An earlier run's store is used when it holds the same files, tiled as this budget
    // tiles them (the particles depend on the tiling).
    if let Ok(store) = TileStore::open(&dir)
        && store.manifest().source == source
        && options.tile_depth_for(store.manifest().population) == Ok(store.manifest().depth)
    {
        let points = store.manifest().population;
        return Ok(Partition {
            store,
            points,
            dropped: 0,
            resumed: true,
        });
    }
    // Pass 1: the frame and the count.
    let mut bounds: Option<Aabb> = None;
    let mut count = 0u64;
    monitor.report("read", 0, 2);
    for_each_input(paths, format, |chunk| {
        count += chunk.len() as u64;
        let b = Aabb::from_points(chunk.iter().map(|p| p.p));
        bounds = match (bounds, b) {
            (Some(a), Some(b)) => Some(Aabb {
                min: a.min.min(b.min),
                max: a.max.max(b.max),
            }),
            (a, b) => a.or(b),
        };
        monitor.check().map_err(|_| fail("interrupted".into()))
    })?;
    let bounds = bounds.ok_or_else(|| fail("holds no points".into()))?;
    let frame = MpuFrame::for_bounds(&bounds, count as usize, mpu_params)
        .map_err(|e| fail(e.to_string()))?;
    let depth = options.tile_depth_for(count).map_err(&fail)?;
    // Pass 2: the points into tile files.
    monitor.report("read", 1, 2);
    let buffer = (options.max_memory / 4 / 56).max(1 << 16) as usize;
    let mut writer =
        TileWriter::create(&dir, frame, depth, buffer, &source).map_err(|e| fail(e.to_string()))?;
    // Decoding the input (on a thread of its own when the pool has two and the budget has
    // room for the chunks ahead) overlaps with writing the tiles.
    let dropped = read_ahead(
        options.max_memory >= READ_AHEAD_BUDGET,
        |visit| for_each_input(paths, format, visit),
        |chunk| {
            writer.push(chunk).map_err(|e| fail(e.to_string()))?;
            monitor.check().map_err(|_| fail("interrupted".into()))
        },
        || fail("stopped".into()),
    )?;
    let store = writer.finish().map_err(|e| fail(e.to_string()))?;
    // The files must not have changed between the two passes.
    let now = paths
        .iter()
        .map(|p| source_of(p))
        .collect::<Result<Vec<_>, _>>()?
        .join("\n");
    if now != source || store.manifest().population != count {
        return Err(fail(
            "the input changed while it was being read; run again".into(),
        ));
    }
    monitor.report("read", 2, 2);
    Ok(Partition {
        store,
        points: count,
        dropped,
        resumed: false,
    })
}

/// The tiling a run out of core uses on `store`: its depth, the default halo and shared
/// levels (what the tasks of [`psi_tiles::decide_store`] take on a cluster).
pub fn out_of_core_tiles(store: &TileStore) -> TileParams {
    TileParams {
        depth: store.manifest().depth,
        ..TileParams::default()
    }
}

/// The error of a run out of core on `path`.
fn failure(path: &Path) -> impl Fn(String) -> PsiError + '_ {
    move |reason| PsiError::OutOfCore {
        path: path.to_path_buf(),
        reason,
    }
}

/// [`sample_files_out_of_core`] of one file.
pub fn sample_file_out_of_core(
    path: &Path,
    format: Option<Format>,
    mpu_params: &MpuParams,
    particle_params: &ParticleParams,
    options: &OutOfCore,
    monitor: &Monitor<'_>,
) -> Result<OutOfCoreRun, PsiError> {
    let paths = [path.to_path_buf()];
    sample_files_out_of_core(
        &paths,
        format,
        mpu_params,
        particle_params,
        options,
        monitor,
    )
}

/// [`for_each_points`] of every file in `paths`, in order; returns the points dropped.
fn for_each_input(
    paths: &[PathBuf],
    format: Option<Format>,
    mut visit: impl FnMut(&[OrientedPoint]) -> Result<(), PsiError>,
) -> Result<u64, PsiError> {
    let mut dropped = 0;
    for path in paths {
        dropped += for_each_points(path, format, &mut visit)?;
    }
    Ok(dropped)
}

/// What identifies the input of a run: its path, size and modification time.
fn source_of(path: &Path) -> Result<String, PsiError> {
    let meta = fs::metadata(path).map_err(|e| open_error(path, e))?;
    let modified = meta
        .modified()
        .ok()
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
        .map_or(0, |d| d.as_nanos());
    let canonical = fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    Ok(format!(
        "{} {} {}",
        canonical.display(),
        meta.len(),
        modified
    ))
}

/// Parses a memory size: a whole number of bytes, or with a unit KiB, MiB, GiB, TiB (powers of
/// 1024; K, M, G, T alike) or KB, MB, GB, TB (powers of 1000); at least 64 MiB.
///
/// ```
/// assert_eq!(psi::parse_memory_size("4GiB"), Ok(4 << 30));
/// assert!(psi::parse_memory_size("12XB").is_err());
/// ```
pub fn parse_memory_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t.find(|c: char| !c.is_ascii_digit()).unwrap_or(t.len());
    let (digits, unit) = t.split_at(split);
    let n: u64 = digits
        .parse()
        .map_err(|_| format!("{text} is not a size such as 4GiB or 512MiB"))?;
    let factor: u64 = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1,
        "kib" | "k" => 1 << 10,
        "mib" | "m" => 1 << 20,
        "gib" | "g" => 1 << 30,
        "tib" | "t" => 1 << 40,
        "kb" => 1_000,
        "mb" => 1_000_000,
        "gb" => 1_000_000_000,
        "tb" => 1_000_000_000_000,
        other => {
            return Err(format!(
                "{text}: unknown unit `{other}` (use KiB, MiB, GiB, TiB)"
            ));
        }
    };
    let bytes = n
        .checked_mul(factor)
        .ok_or_else(|| format!("{text} is too large"))?;
    if bytes < 64 << 20 {
        return Err(format!(
            "{text} is below the 64 MiB a run out of core needs"
        ));
    }
    Ok(bytes)
}

/// The JSON report of a run out of core (what `psi sample --max-memory --json` writes and
/// Python's `sample_files` returns): the inputs, the parameters, the particle count and the
/// `tiles` object.
pub fn out_of_core_json(
    inputs: &[PathBuf],
    mpu_params: &MpuParams,
    particle_params: &ParticleParams,
    options: &OutOfCore,
    run: &OutOfCoreRun,
) -> serde_json::Value {
    serde_json::json!({
        "input": {
            "paths": inputs.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "points": run.points,
            "dropped_zero_normals": run.dropped,
        },
        "mpu": { "error_rel": mpu_params.error_rel, "max_depth": mpu_params.max_depth },
        "particles": {
            "count": run.particles.len(),
            "k": particle_params.k,
            "iterations": particle_params.iterations,
            "after": run.after,
        },
        "tiles": {
            "count": run.tiles.count,
            "depth": run.tiles.depth,
            "halo": run.tiles.halo,
            "points_per_tile": run.tiles.points_per_tile,
            "halo_points": run.tiles.halo_points,
            "halos_grown": run.tiles.halos_grown,
            "balls_fetched": run.tiles.balls_fetched,
            "crossing_cells": run.tiles.crossing_cells,
            "cells": run.tiles.cells,
            "resumed": run.resumed,
            "scratch": options.scratch.display().to_string(),
            "max_memory_bytes": options.max_memory,
            "seconds": {
                "read": run.seconds[0],
                "decide": run.seconds[1],
                "sample": run.seconds[2],
                "seed": run.sampling.seed_seconds,
                "relax": run.sampling.relax_seconds,
            },
            "sampling": run.sampling,
            "preprocessing": "none (points used as given)",
        },
        "peak_memory_bytes": crate::report::peak_memory_bytes(),
    })
}
