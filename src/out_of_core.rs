//! Sampling a file larger than memory (issue "Beyond one machine"): its points streamed into
//! tile files in a scratch directory (`partition.rs`), the MPU decided tile by tile from them
//! ([`psi_tiles::decide_store`]), the particles seeded by octant of the root
//! ([`psi_tiles::seed_store_octant`]) and relaxed at once ([`psi_tiles::sample_tiled_from`]). The CLI's `--max-memory` and Python's `sample_files` both
//! run this.
//!
//! The preprocessing done tile by tile, bitwise the in-core steps: repeated points and the
//! outlier search's strays left out (`tile_outliers.rs`), points without normals given
//! them, estimated and oriented (`tile_normals.rs`), given normals that point inward flipped
//! and the noise's error threshold (`store_checks.rs`), denoising where the noise calls for
//! it (`tile_denoise.rs`); the stray-clump search follows the outlier search's
//! (`tile_clumps.rs`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use psi_io::Format;
use psi_mpu::MpuParams;
use psi_octree::Monitor;
use psi_particles::{ParticleParams, Particles, Quality};
use psi_preprocess::{ErrorThreshold, PreprocessParams};
use psi_tiles::{
    TileError, TileParams, TileReport, TileSampleReport, TileStore, decide_store,
    sample_tiled_from, seed_store_octant,
};

use crate::PsiError;
use crate::budget::OutOfCore;
use crate::partition::failure;
use crate::partition_preprocessed::{PreprocessedPartition, partition_preprocessed};
use crate::store_checks::{OutOfCoreMpu, StoreChecks, check_store};
use crate::tile_outliers::StrayTally;

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
    /// The ceiling on spacing applied (world units; `None` when there is none).
    pub max_spacing: Option<f64>,
    /// Whether the tile files of an earlier run were used as they were.
    pub resumed: bool,
    /// Whether the input had no normals and they were estimated and oriented tile by tile.
    pub normals_estimated: bool,
    /// What the outlier step left out (`None` when it did not run).
    pub strays: Option<StrayTally>,
    /// The level the estimated normals' planes were fitted at (one point in 4^level; `None`
    /// when given, or found in the store of an earlier run).
    pub normals_level: Option<u32>,
    /// What the checks before the MPU found (the inward normals, the noise).
    pub checks: StoreChecks,
    /// The MPU's error threshold (the given one, the noise's or the paper's).
    pub error: ErrorThreshold,
    /// The MPU's parameters the run used.
    pub mpu_params: MpuParams,
    /// Seconds of the checks (counted in the reading's too; 0 when found).
    pub checks_seconds: f64,
    /// Seconds: reading and partitioning (and the checks), deciding the cells, sampling.
    pub seconds: [f64; 3],
}

/// Samples the files at `paths` (one input, their points in this order, as a survey's tiles
/// come; each read as `format`, or as its extension says) out of core:
/// the preprocessing steps of `preprocess` that run out of core (the outlier step, normals
/// estimated where there are none, given normals that point inward flipped, the noise
/// estimate), the MPU with `mpu`'s parameters decided tile by tile, bitwise the in-core build
/// of the same points (the error threshold given, else the noise's or the paper's, and the
/// cell error's rank, as in core: [`crate::StoreChecks::mpu_params`]), and particles with `particle_params` (k per leaf: the in-core seeds and count;
/// seeded tile by tile, then relaxed at once, then the ceiling on spacing, its passes reading
/// the tiles). Tile files go to `options.scratch`; a run that finds
/// the files of an earlier run on the same file there resumes from them. Progress: stages
/// `"read"` (with the outlier step `"standings"`, `"strays"`, `"clumps"`; for points without
/// normals, the stages of `tile_normals.rs`), the checks' `"noise"` (or `"inward"`), then
/// `"tiles"`, `"sample tiles"`, `"relax"`, `"cover"`.
///
/// # Errors
///
/// [`PsiError::Open`] / [`PsiError::Read`] for the input; [`PsiError::OutOfCore`] when it has
/// no normals and its noise asks for them among a coarser subset, the budget is too small, an exact count or uniform mode is asked for, or a
/// scratch file fails (named).
pub fn sample_files_out_of_core(
    paths: &[PathBuf],
    format: Option<Format>,
    preprocess: &PreprocessParams,
    mpu: &OutOfCoreMpu,
    particle_params: &ParticleParams,
    options: &OutOfCore,
    monitor: &Monitor<'_>,
) -> Result<OutOfCoreRun, PsiError> {
    let t0 = Instant::now();
    let PreprocessedPartition {
        partition: part,
        strays,
        normals_estimated,
        normals_level,
        checks,
    } = partition_preprocessed(paths, format, preprocess, &mpu.params, options, monitor)?;
    let t_checks = Instant::now();
    let at = (options, &mpu.params);
    let (store, checks) = check_store(part.store.clone(), checks, at, monitor)?;
    let checks_seconds = t_checks.elapsed().as_secs_f64();
    let (mpu_params, error) = checks.mpu_params(mpu);
    let mpu_params = &mpu_params;
    let read_seconds = t0.elapsed().as_secs_f64();
    let fail = failure(&paths[0]);
    let t1 = Instant::now();
    let store = &store;
    let tiles = out_of_core_tiles(store, Some(options));
    let decisions = decide_store(store, mpu_params, &tiles, monitor).map_err(|e| {
        fail(decisions_failure(
            e,
            options.max_memory,
            mpu_params.error_rel,
        ))
    })?;
    let decide_seconds = t1.elapsed().as_secs_f64();
    let t2 = Instant::now();
    let population = store.manifest().population;
    let relax_points = options.relax_points_for(population, decisions.cells.len() as u64);
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
        max_spacing: sampled.field.ceiling,
        resumed: part.resumed,
        normals_estimated,
        strays,
        normals_level,
        checks,
        error,
        mpu_params: *mpu_params,
        checks_seconds,
        seconds: [read_seconds, decide_seconds, t2.elapsed().as_secs_f64()],
    })
}

/// The tiling a run out of core uses on `store`: its depth, the default halo and shared
/// levels (what the tasks of [`psi_tiles::decide_store`] take on a cluster), and the most cells
/// `budget` holds for the store's points ([`OutOfCore::max_cells_for`]; a task of tiles bounds
/// each tile's by it).
pub fn out_of_core_tiles(store: &TileStore, budget: Option<&OutOfCore>) -> TileParams {
    TileParams {
        depth: store.manifest().depth,
        max_cells: budget.map(|b| b.max_cells_for(store.manifest().population)),
        ..TileParams::default()
    }
}

/// Why the decisions of a run out of core within `max_memory` bytes failed (`e`); for more
/// cells than the budget holds, what sets their number (ε0, `error_rel` × D) and what to change.
pub fn decisions_failure(e: TileError, max_memory: u64, error_rel: f64) -> String {
    let TileError::TooManyCells { max } = e else {
        return e.to_string();
    };
    format!(
        "the MPU needs more than {max} cells, more than --max-memory {} MiB holds (about {} \
         bytes each, beside the process's own {} MiB, the input's share and the relaxation's \
         points): give more memory, or a larger \
         --mpu-error (mpu_error=) for fewer cells (its error threshold is ε0 = {error_rel:.2e} D \
         now; an ε0 below the points' noise splits cells down to a few points each)",
        max_memory >> 20,
        crate::budget::BYTES_PER_CELL,
        crate::budget::PROCESS_BYTES >> 20,
    )
}

/// [`sample_files_out_of_core`] of one file.
pub fn sample_file_out_of_core(
    path: &Path,
    format: Option<Format>,
    preprocess: &PreprocessParams,
    mpu: &OutOfCoreMpu,
    particle_params: &ParticleParams,
    options: &OutOfCore,
    monitor: &Monitor<'_>,
) -> Result<OutOfCoreRun, PsiError> {
    let paths = [path.to_path_buf()];
    sample_files_out_of_core(
        &paths,
        format,
        preprocess,
        mpu,
        particle_params,
        options,
        monitor,
    )
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
        "mpu": {
            "error_rel": run.error.relative,
            "error_threshold": run.error,
            "error_rank": run.mpu_params.error_rank,
            "max_depth": run.mpu_params.max_depth,
        },
        "particles": {
            "count": run.particles.len(),
            "k": particle_params.k,
            "iterations": particle_params.iterations,
            "after": run.after,
            // The ceiling on spacing applied, as in core.
            "max_spacing": run.max_spacing,
            "added_by_ceiling": run.sampling.cover.added,
            "replaced_by_ceiling": run.sampling.cover.removed,
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
                "checks": run.checks_seconds,
                "decide": run.seconds[1],
                "top": run.tiles.top_seconds,
                "sample": run.seconds[2],
                "seed": run.sampling.seed_seconds,
                "relax": run.sampling.relax_seconds,
                "cover": run.sampling.cover.seconds,
            },
            "sampling": run.sampling,
            "preprocessing": {
                "normals": if run.normals_estimated {
                    "estimated and oriented tile by tile"
                } else {
                    "given"
                },
                "normals_level": run.normals_level,
                "outliers": run.strays.map(|t| serde_json::json!({
                    "removed": t.removed(),
                    "repeated": t.repeated,
                    "far": t.far,
                    "off_surface": t.off_surface,
                    "clumps": t.clumps,
                })),
                "inward_normals_flipped": run.checks.inward_normals_flipped,
                "inward_votes": run.checks.inward,
                "noise": run.checks.noise,
                "noise_rel": run.checks.noise_rel,
                "normal_consistency": run.checks.consistency.map(|c| serde_json::json!({
                    "pairs_checked": c.pairs,
                    "opposed_fraction": c.opposed_fraction(),
                })),
                "denoised": run.checks.denoised,
                "noise_rel_after": run.checks.noise_rel_after(),
            },
        },
        "peak_memory_bytes": crate::report::peak_memory_bytes(),
    })
}
