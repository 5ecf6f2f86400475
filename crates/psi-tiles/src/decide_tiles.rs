//! A tiled MPU build: the cells above the tile depth decided once over all points, then each
//! tile (a cell at the tile depth and its subtree) from its points and a halo, the halo grown
//! until it holds every point the tile's fits read; the decisions are bitwise those of a build
//! over all points ([`psi_mpu::fit_region`]), and the MPU assembled from them equals it.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use psi_mpu::{BuildOptions, CellTable, Mpu, MpuFrame, MpuParams, Region, RegionFit, fit_region};
use psi_octree::{Monitor, OrientedPoint};
use rayon::prelude::*;

use crate::tile_buckets::TileBuckets;
use crate::{TileError, TileParams, TileReport};

/// The decisions of every cell of a tiled build, in the frame they were made in.
#[derive(Clone, Debug)]
pub struct TiledDecisions {
    /// The frame (the one [`MpuFrame::for_points`] gives the whole input).
    pub frame: MpuFrame,
    /// Every cell's decision.
    pub cells: CellTable,
    /// How the tiling went.
    pub report: TileReport,
}

/// One tile's outcome.
struct TileOutcome {
    fit: RegionFit,
    grown: usize,
    points: usize,
    halo_points: usize,
}

/// Decides the cells of the MPU of `points` (shape N, world units, any normal length) with
/// `params`, tile by tile as `tiles` says: bitwise the decisions of [`Mpu::build`]. Tiles run
/// in parallel; the result does not depend on their order or the thread count. Progress:
/// stage `"tiles"`, tiles decided of all.
///
/// Errors: those of [`Mpu::build`], a bad tiling parameter, an interruption.
pub fn decide_tiled(
    points: &[OrientedPoint],
    params: &MpuParams,
    tiles: &TileParams,
    monitor: &Monitor<'_>,
) -> Result<TiledDecisions, TileError> {
    tiles.validate()?;
    let frame = MpuFrame::for_points(points, params)?;
    let n = points.len();
    let t0 = Instant::now();
    let top = fit_region(
        points,
        n,
        &frame,
        params,
        &Region::top(tiles.depth),
        monitor,
    )?;
    let top_seconds = t0.elapsed().as_secs_f64();
    let keys = tile_keys(&top.cells, tiles.depth);
    let t1 = Instant::now();
    let buckets = TileBuckets::new(points, &frame, tiles.depth);
    let done = AtomicU64::new(0);
    let total = keys.len() as u64;
    monitor.report("tiles", 0, total);
    let outcomes: Vec<Result<TileOutcome, TileError>> = keys
        .par_iter()
        .map(|&key| {
            let out = decide_tile(points, &frame, params, tiles, key, &buckets, monitor);
            let k = done.fetch_add(1, Ordering::Relaxed) + 1;
            monitor.report("tiles", k, total);
            out
        })
        .collect();
    let mut report = TileReport {
        count: keys.len(),
        depth: tiles.depth,
        halo: tiles.halo,
        top_cells: top.cells.len(),
        top_seconds,
        ..Default::default()
    };
    let mut cells = top.cells;
    for outcome in outcomes {
        let o = outcome?;
        report.points_per_tile.push(o.points);
        report.halo_points.push(o.halo_points);
        report.halos_grown += o.grown;
        report.crossing_cells += o.fit.crossing;
        cells.merge(o.fit.cells).map_err(TileError::Conflict)?;
    }
    report.cells = cells.len();
    report.tile_seconds = t1.elapsed().as_secs_f64();
    Ok(TiledDecisions {
        frame,
        cells,
        report,
    })
}

/// Decides the tile `key` from its points and a halo, growing the halo until the fits' reach
/// lies inside it (or the halo holds every point).
fn decide_tile(
    points: &[OrientedPoint],
    frame: &MpuFrame,
    params: &MpuParams,
    tiles: &TileParams,
    key: [u32; 3],
    buckets: &TileBuckets,
    monitor: &Monitor<'_>,
) -> Result<TileOutcome, TileError> {
    let region = Region::tile(tiles.depth, key);
    let (center, half) = region.cube(frame);
    // Rounding of the reach and of the gathering test, far below any spacing.
    let margin = 1e-9 * frame.root_half;
    let mut halo = tiles.halo * 2.0 * half;
    let mut grown = 0;
    loop {
        let ids = buckets.gather(points, frame, center, half, halo);
        let local: Vec<OrientedPoint> = ids.iter().map(|&i| points[i as usize]).collect();
        let fit = fit_region(&local, points.len(), frame, params, &region, monitor)?;
        if fit.reach + margin <= halo || ids.len() == points.len() {
            return Ok(TileOutcome {
                fit,
                grown,
                points: buckets.count(key),
                halo_points: ids.len(),
            });
        }
        grown += 1;
        halo = grown_halo(fit.reach, halo, half, margin);
    }
}

/// The tiles under the cells `top` decided: the children of the cells just above the tile
/// depth that split, in key order.
pub(crate) fn tile_keys(top: &CellTable, depth: u8) -> Vec<[u32; 3]> {
    let mut keys: Vec<[u32; 3]> = top
        .iter()
        .filter(|(a, d)| a.0 + 1 == depth && d.split())
        .flat_map(|(a, _)| {
            (0..8u32).map(move |o| {
                [
                    2 * a.1[0] + (o & 1),
                    2 * a.1[1] + ((o >> 1) & 1),
                    2 * a.1[2] + ((o >> 2) & 1),
                ]
            })
        })
        .collect();
    keys.sort_unstable();
    keys
}

/// The next halo after a tile's fits reached `reach` beyond a halo of `halo` (half-edge
/// `half`): enough for that reach, and at least a quarter more (infinite reach: too few
/// points, doubled).
pub(crate) fn grown_halo(reach: f64, halo: f64, half: f64, margin: f64) -> f64 {
    if reach.is_finite() {
        (reach + 2.0 * margin).max(1.25 * halo)
    } else {
        (2.0 * halo).max(half)
    }
}

/// The MPU of `points` built tile by tile ([`decide_tiled`]) and assembled from the decisions:
/// equal to [`Mpu::build`] of the same points (same cells, bitwise the same local functions,
/// hence the same f and ∇f), with the tiling's report.
///
/// ```
/// use psi_mpu::{Mpu, MpuParams};
/// use psi_octree::Monitor;
/// use psi_shapes::AnalyticShape;
/// use psi_tiles::{TileParams, build_tiled};
///
/// let points = AnalyticShape::Sphere { radius: 1.0 }.sample(4000, 1);
/// let params = MpuParams::paper();
/// let (tiled, report) = build_tiled(&points, &params, &TileParams::at_depth(2), &Monitor::silent()).unwrap();
/// assert!(report.count >= 8);
/// let whole = Mpu::build(&points, &params).unwrap();
/// let x = glam::DVec3::new(0.3, 0.9, -0.2);
/// assert_eq!(tiled.value(x).to_bits(), whole.value(x).to_bits());
/// ```
pub fn build_tiled(
    points: &[OrientedPoint],
    params: &MpuParams,
    tiles: &TileParams,
    monitor: &Monitor<'_>,
) -> Result<(Mpu, TileReport), TileError> {
    let TiledDecisions {
        frame,
        cells,
        mut report,
    } = decide_tiled(points, params, tiles, monitor)?;
    let t = Instant::now();
    let options = BuildOptions {
        frame: Some(frame),
        known_cells: Some(&cells),
        monitor: *monitor,
        ..Default::default()
    };
    let mpu = Mpu::build_with(points, params, options)?;
    report.assemble_seconds = t.elapsed().as_secs_f64();
    Ok((mpu, report))
}
