//! A tiled MPU build: the cells above the tile depth decided once over all points, then each
//! tile (a cell at the tile depth and its subtree) from its points and a halo, the halo grown
//! until it holds every point the tile's fits read; the decisions are bitwise those of a build
//! over all points ([`psi_mpu::fit_region`]), and the MPU assembled from them equals it.

use std::time::Instant;

use psi_mpu::{
    BuildOptions, CellAddress, CellTable, Mpu, MpuFrame, MpuParams, Region, RegionPoints,
    fit_region,
};
use psi_octree::{Monitor, OrientedPoint};

use crate::decide_tile::{TileOutcome, decide_all, decide_tile};
use crate::{PointsInMemory, TileError, TileParams, TileReport};

/// The decisions of every cell of a tiled build, in the frame they were made in.
#[derive(Clone, Debug)]
pub struct TiledDecisions {
    /// The frame (the one [`MpuFrame::for_points`] gives the whole input).
    pub frame: MpuFrame,
    /// Every cell's decision.
    pub cells: CellTable,
    /// The surface leaves (leaves whose cube holds input points), in address order.
    pub surface: Vec<CellAddress>,
    /// How the tiling went.
    pub report: TileReport,
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
        &RegionPoints::new(points, n),
        &frame,
        params,
        &Region::top(tiles.depth + tiles.shared_levels),
        monitor,
    )?;
    let top_seconds = t0.elapsed().as_secs_f64();
    let top = TileOutcome {
        cells: top.cells,
        crossing: 0,
        fetched: 0,
        grown: 0,
        points: n as u64,
        halo_points: n,
        surface: top.surface,
    };
    let source = PointsInMemory::new(points, frame, tiles.depth);
    let decide = |key, left| {
        let count = source.count(key) as u64;
        decide_tile(
            &frame,
            params,
            tiles,
            key,
            (n, count),
            &top.cells,
            &source,
            left,
            monitor,
        )
    };
    let (cells, surface, mut report) = decide_all(&top, tiles, monitor, &decide)?;
    report.top_seconds = top_seconds;
    Ok(TiledDecisions {
        frame,
        cells,
        surface,
        report,
    })
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
        ..
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
