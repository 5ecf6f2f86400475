//! The cells above the tiles decided from the coarse points alone (the points an out-of-core
//! build keeps in memory for them), fetching the whole ball only for the few cells whose fit
//! needs it: bitwise the decisions of a build over all points (notes: tiles).

use glam::DVec3;
use psi_octree::{Cell, Monitor, OrientedPoint};

use crate::coarse_index::{CoarseIndex, is_coarse};
use crate::fit_cell::{FitInput, try_fit_octree_cell};
use crate::fit_fetched::{BallCache, BallSource, fit_fetched};
use crate::fit_region::decide_cells;
use crate::region_points::{check_population, prepare_any};
use crate::{MpuError, MpuFrame, MpuParams, Region, RegionFit};

/// Whether the point at world position `p` is one of the coarse points of an MPU in `frame`
/// (about one in 16, chosen by its local position's bits): the points an out-of-core build
/// keeps in memory for the cells above its tiles ([`fit_top`]).
pub fn is_coarse_point(frame: &MpuFrame, p: DVec3) -> bool {
    is_coarse(p - frame.origin)
}

/// [`crate::fit_region`] of the cells above depth `until` from the input's coarse points alone (the
/// points whose position hash selects them, shape C, in increasing input index order; the
/// only points an out-of-core build holds for these levels), fetching the ball of the few
/// cells whose fit needs every point (a cell with few points, or one whose error stays under
/// ε0 among the coarse ones) from `source`. Bitwise the decisions of a build over all
/// `population` points in `frame`.
///
/// Errors as [`crate::fit_region`], and [`MpuError::Fetch`] from `source`.
pub fn fit_top(
    coarse: &[OrientedPoint],
    population: usize,
    frame: &MpuFrame,
    params: &MpuParams,
    until: u8,
    source: &BallSource<'_>,
    monitor: &Monitor<'_>,
) -> Result<RegionFit, MpuError> {
    fit_top_region(
        coarse,
        population,
        frame,
        params,
        &Region::top(until),
        source,
        monitor,
    )
}

/// [`fit_top`] of the cells of `region` only (its top cell and those below it, down to, not
/// including, `region.until`), so that the pass above the tiles can be split into a task per
/// cell at some depth: the decisions of the regions together are those of one pass, bit for
/// bit (each cell's fit reads only the coarse points and its fetched ball).
///
/// Errors as [`fit_top`].
pub fn fit_top_region(
    coarse: &[OrientedPoint],
    population: usize,
    frame: &MpuFrame,
    params: &MpuParams,
    region: &Region,
    source: &BallSource<'_>,
    monitor: &Monitor<'_>,
) -> Result<RegionFit, MpuError> {
    check_population(params, population)?;
    let data = prepare_any(coarse, frame)?;
    let coarse_index = CoarseIndex::new(&data.positions);
    let input = FitInput {
        positions: &data.positions,
        points: &data.points,
        index: None,
        coarse: &coarse_index,
        params,
        population,
    };
    let eps0 = params.error_rel * frame.diagonal;
    // A fit that completes from the coarse points alone splits (its error exceeds ε0), so
    // whether its cube holds points does not matter; a leaf's is told by its fetched ball.
    let cache = BallCache::default();
    let fit =
        |cell: &Cell, inside: &[u32], _: &[DVec3]| match try_fit_octree_cell(&input, cell, eps0) {
            Some(f) => Ok((f, !inside.is_empty(), false)),
            None => fit_fetched(cell, frame, params, population, eps0, source, &cache)
                .map(|(f, s)| (f, s, true)),
        };
    let mut out = decide_cells(
        data.positions.clone(),
        frame,
        params,
        (region, None, None),
        monitor,
        &fit,
    )?;
    // (Every coarse point is given, and the rest is fetched: nothing reaches beyond.)
    out.reach = 0.0;
    out.crossing = 0;
    Ok(out)
}
