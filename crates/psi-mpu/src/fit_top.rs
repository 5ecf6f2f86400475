//! The cells above the tiles decided from the coarse points alone (the points an out-of-core
//! build keeps in memory for them), fetching the whole ball only for the few cells whose fit
//! needs it: bitwise the decisions of a build over all points (notes: tiles).

use glam::DVec3;
use psi_octree::{Cell, Monitor, OrientedPoint};

use crate::fit_cell::{
    COARSE, CellFit, CoarseIndex, FitInput, fit_cell, position_hash, try_fit_cell,
};
use crate::fit_region::{IndexedPoints, check_population, decide_cells, key_of_point, prepare_any};
use crate::{MpuError, MpuFrame, MpuParams, Region, RegionFit};

/// Whether the point at world position `p` is one of the coarse points of an MPU in `frame`
/// (about one in 16, chosen by its local position's bits): the points an out-of-core build
/// keeps in memory for the cells above its tiles ([`fit_top`]).
pub fn is_coarse_point(frame: &MpuFrame, p: DVec3) -> bool {
    position_hash(p - frame.origin).is_multiple_of(COARSE)
}

/// The points within a ball, fetched on demand: `fetch(centre, radius)` (world units) returns
/// every input point within `radius` of `centre` (more is allowed), in increasing order of
/// input index, or why it could not.
pub type FetchBall<'a> = dyn Fn(DVec3, f64) -> Result<Vec<OrientedPoint>, String> + Sync + 'a;

/// [`fit_region`] of the cells above depth `until` from the input's coarse points alone (the
/// points whose position hash selects them, shape C, in increasing input index order; the
/// only points an out-of-core build holds for these levels), fetching the ball of the few
/// cells whose fit needs every point (a cell with few points, or one whose error stays under
/// ε0 among the coarse ones) through `fetch`. Bitwise the decisions of a build over all
/// `population` points in `frame`.
///
/// Errors as [`fit_region`], and [`MpuError::Fetch`] from `fetch`.
pub fn fit_top(
    coarse: &[OrientedPoint],
    population: usize,
    frame: &MpuFrame,
    params: &MpuParams,
    until: u8,
    fetch: &FetchBall<'_>,
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
    let fit = |cell: &Cell, inside: &[u32]| match try_fit_cell(&input, cell.center, cell.half, eps0)
    {
        Some(f) => Ok((f, !inside.is_empty())),
        None => fit_fetched(cell, frame, params, population, eps0, fetch),
    };
    let mut out = decide_cells(
        data.positions.clone(),
        frame,
        params,
        &Region::top(until),
        monitor,
        &fit,
    )?;
    // (The top region's cube is the root: nothing reaches beyond what is fetched.)
    out.reach = 0.0;
    out.crossing = 0;
    Ok(out)
}

/// One cell fitted from the points `fetch` gives within a ball around it, the ball grown until
/// it holds the fit's radius (then every point the fit reads was fetched).
fn fit_fetched(
    cell: &Cell,
    frame: &MpuFrame,
    params: &MpuParams,
    population: usize,
    eps0: f64,
    fetch: &FetchBall<'_>,
) -> Result<(CellFit, bool), MpuError> {
    let margin = 1e-9 * frame.root_half;
    let mut radius = cell.support_radius(params.alpha) * 1.5;
    loop {
        let points =
            fetch(cell.center + frame.origin, radius + 2.0 * margin).map_err(MpuError::Fetch)?;
        if points.len() >= (params.n_min + 1).min(population) {
            let indexed = IndexedPoints::new(&points, frame)?;
            let f = fit_cell(
                &indexed.input(params, population),
                cell.center,
                cell.half,
                eps0,
            );
            if f.fit_radius + margin <= radius || points.len() >= population {
                // The first ball already holds the cube (1.5 R > its circumradius).
                let surface = points
                    .iter()
                    .any(|p| key_of_point(frame, p.p - frame.origin, cell.depth) == cell.key);
                return Ok((f, surface));
            }
            radius = (f.fit_radius + margin).max(1.25 * radius);
        } else {
            radius *= 2.0;
        }
    }
}
