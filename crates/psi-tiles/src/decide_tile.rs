//! One tile decided from its points and a halo, the halo grown until the tile's fits lie inside
//! it; and the tiles of a build run in parallel and merged with the cells above them. Shared by
//! the build in memory and the build from a tile store.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use psi_mpu::{
    BallSource, CellAddress, CellTable, FarBalls, MpuError, MpuFrame, MpuParams, Region,
    RegionPoints, fit_region,
};
use psi_octree::Monitor;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::{PointSource, TileError, TileParams, TileReport};

/// One tile's decisions and how they were reached.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(crate) struct TileOutcome {
    pub(crate) cells: CellTable,
    pub(crate) crossing: usize,
    /// Cells that fetched their ball beyond the halo.
    pub(crate) fetched: usize,
    pub(crate) grown: usize,
    /// Points in the tile's cube.
    pub(crate) points: u64,
    /// Points it was decided from (cube and final halo).
    pub(crate) halo_points: usize,
    /// Its surface leaves.
    pub(crate) surface: Vec<CellAddress>,
}

/// Decides the tile `key` (at `tiles.depth`) of an input of `population` points, its points
/// from `gather` (the tile's upper levels taken from `top`), growing the halo from `tiles.halo` × the tile edge until the fits' reach lies
/// inside it (or the halo holds every point). `points` is the count in its cube, for the report.
/// Past `max_cells` cells the tile stops: [`TileError::TooManyCells`] with the run's bound.
#[allow(clippy::too_many_arguments)]
pub(crate) fn decide_tile(
    frame: &MpuFrame,
    params: &MpuParams,
    tiles: &TileParams,
    key: [u32; 3],
    (population, points): (usize, u64),
    top: &CellTable,
    source: &dyn PointSource,
    max_cells: Option<u64>,
    monitor: &Monitor<'_>,
) -> Result<TileOutcome, TileError> {
    let region = Region::tile(tiles.depth, key);
    let (center, half) = region.cube(frame);
    // Rounding of the reach and of the gathering test, far below any spacing.
    let margin = 1e-9 * frame.root_half;
    let mut halo = tiles.halo * 2.0 * half;
    let mut grown = 0;
    loop {
        let local = source.gather_box(center, half, halo)?;
        // A cell whose fit reads beyond the halo (an empty cell's radius grows to the nearest
        // data) fetches its own ball instead of widening the whole tile's halo.
        let fetch = |c, r| source.gather_ball(c, r).map_err(|e| e.to_string());
        let kth = |c, k| source.kth_distance(c, k).map_err(|e| e.to_string());
        let far = FarBalls {
            halo: halo - margin,
            source: BallSource {
                fetch: &fetch,
                kth: Some(&kth),
            },
        };
        let input = RegionPoints {
            points: &local,
            population,
            known: Some(top),
            far: Some(far),
            max_cells: max_cells.map(|m| usize::try_from(m).unwrap_or(usize::MAX)),
        };
        let fit =
            fit_region(&input, frame, params, &region, &monitor.quiet()).map_err(|e| match e {
                MpuError::TooManyCells { .. } => TileError::TooManyCells {
                    max: tiles.max_cells.unwrap_or(u64::MAX),
                },
                e => e.into(),
            })?;
        if fit.reach + margin <= halo || local.len() == population {
            return Ok(TileOutcome {
                cells: fit.cells,
                crossing: fit.crossing,
                fetched: fit.fetched,
                grown,
                points,
                halo_points: local.len(),
                surface: fit.surface,
            });
        }
        grown += 1;
        // Enough for that reach and a quarter more; too few points (infinite reach): doubled.
        halo = if fit.reach.is_finite() {
            (fit.reach + 2.0 * margin).max(1.25 * halo)
        } else {
            (2.0 * halo).max(half)
        };
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

/// Runs `decide` on every tile under `top` (in parallel; progress: stage `"tiles"`), given the
/// most cells it may add (what `tiles.max_cells` leaves), and merges their decisions with
/// `top`'s, in tile order; returns every cell's decision and the report (`top_seconds` is the
/// caller's).
pub(crate) fn decide_all(
    top: &TileOutcome,
    tiles: &TileParams,
    monitor: &Monitor<'_>,
    decide: &(dyn Fn([u32; 3], Option<u64>) -> Result<TileOutcome, TileError> + Sync),
) -> Result<(CellTable, Vec<CellAddress>, TileReport), TileError> {
    let mut surface = top.surface.clone();
    let top = top.cells.clone();
    let t = Instant::now();
    let keys = tile_keys(&top, tiles.depth);
    let done = AtomicU64::new(0);
    let total = keys.len() as u64;
    monitor.report("tiles", 0, total);
    // The cells held so far, against the bound: a tile is not started, nor let past what the
    // others leave, nor its outcome kept, once they pass it (so the build stops exactly when
    // all the cells would pass it, whatever the order the tiles end in).
    let held = AtomicU64::new(top.len() as u64);
    let max = tiles.max_cells.unwrap_or(u64::MAX);
    let too_many = TileError::TooManyCells { max };
    let outcomes: Vec<Result<TileOutcome, TileError>> = keys
        .par_iter()
        .map(|&key| {
            if held.load(Ordering::Relaxed) > max {
                return Err(too_many.clone());
            }
            let left = tiles
                .max_cells
                .map(|_| max.saturating_sub(held.load(Ordering::Relaxed)));
            let out = decide(key, left)?;
            let cells = out.cells.len() as u64;
            if held.fetch_add(cells, Ordering::Relaxed) + cells > max {
                return Err(too_many.clone());
            }
            monitor.report("tiles", done.fetch_add(1, Ordering::Relaxed) + 1, total);
            Ok(out)
        })
        .collect();
    let mut report = TileReport {
        count: keys.len(),
        depth: tiles.depth,
        halo: tiles.halo,
        top_cells: top.len(),
        ..Default::default()
    };
    if held.load(Ordering::Relaxed) > max {
        return Err(too_many);
    }
    let mut cells = top;
    for outcome in outcomes {
        let o = outcome?;
        report.points_per_tile.push(o.points as usize);
        report.halo_points.push(o.halo_points);
        report.halos_grown += o.grown;
        report.crossing_cells += o.crossing;
        report.balls_fetched += o.fetched;
        cells.merge(o.cells).map_err(TileError::Conflict)?;
        surface.extend(o.surface);
    }
    surface.sort_unstable();
    report.cells = cells.len();
    report.tile_seconds = t.elapsed().as_secs_f64();
    Ok((cells, surface, report))
}
