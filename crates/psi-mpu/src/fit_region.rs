//! The cells of one region of the octree (a tile: the cell at some depth and every cell below
//! it), decided from the points near the region alone, bitwise as a build over the whole input
//! decides them, provided the points cover the balls the fits read (the caller checks
//! [`RegionFit::reach`] against the halo it gathered).
//!
//! Why it is exact: a cell's fit and split decision read only the points within its fit
//! radius R1 (in increasing index order), the global count N (R1 grows until it holds
//! min(N_min + 1, N) points), ε0 and the frame; cell geometry depends on the frame alone.
//! Points given in increasing global index order keep every fit's summation order.

use std::borrow::Cow;

use glam::DVec3;
use psi_octree::{Cell, Monitor, Octree, OctreeBuild, OctreeParams, OrientedPoint, PointIndex};

use crate::build::prepare;
use crate::cell_table::{CellDecision, CellTable};
use crate::fit_cell::{CellFit, CoarseIndex, FitInput, fit_cell, try_fit_cell};
use crate::{MpuError, MpuFrame, MpuParams};

/// A region of the octree: the cell at `depth` with integer `key` and the cells below it down
/// to, but not including, depth `until` (`None`: all the way down).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Region {
    /// Depth of the region's top cell (0: the root).
    pub depth: u8,
    /// Integer key of the top cell at its depth.
    pub key: [u32; 3],
    /// Cells at this depth and below are left to other regions (the tiles under a top pass).
    pub until: Option<u8>,
}

impl Region {
    /// The whole octree down to, not including, depth `until`.
    pub fn top(until: u8) -> Region {
        Region {
            depth: 0,
            key: [0; 3],
            until: Some(until),
        }
    }

    /// The cell at `depth` with `key` and everything below it.
    pub fn tile(depth: u8, key: [u32; 3]) -> Region {
        Region {
            depth,
            key,
            until: None,
        }
    }

    /// Whether `cell` is in the region (at or below its top cell, above `until`).
    pub fn holds(&self, cell: &Cell) -> bool {
        cell.depth >= self.depth
            && self.until.is_none_or(|u| cell.depth < u)
            && (0..3).all(|a| cell.key[a] >> (cell.depth - self.depth) == self.key[a])
    }

    /// Whether `cell` is a strict ancestor of the region's top cell.
    fn is_above(&self, cell: &Cell) -> bool {
        cell.depth < self.depth
            && (0..3).all(|a| self.key[a] >> (self.depth - cell.depth) == cell.key[a])
    }

    /// The top cell's cube in `frame`: centre (local frame) and half-edge (world units), by the
    /// octree's own halving from the root, so bitwise its cell's.
    pub fn cube(&self, frame: &MpuFrame) -> (DVec3, f64) {
        let (mut center, mut half) = (frame.root_center, frame.root_half);
        for level in (0..self.depth).rev() {
            let h = 0.5 * half;
            let bit = |a: usize| ((self.key[a] >> level) & 1) as f64 * 2.0 - 1.0;
            center += h * DVec3::new(bit(0), bit(1), bit(2));
            half = h;
        }
        (center, half)
    }
}

/// What [`fit_region`] decided and how far it read.
#[derive(Clone, Debug, Default)]
pub struct RegionFit {
    /// The region's cells and their decisions.
    pub cells: CellTable,
    /// How far beyond the region's cube (∞-norm, world units) the balls of its fits reach:
    /// the decisions are exact when the points given hold every input point within this
    /// distance of the cube. Infinite when fewer than min(N_min + 1, N) points were given.
    pub reach: f64,
    /// Fitted cells whose fit ball crosses the faces of the region's cube.
    pub crossing: usize,
}

/// Decides the cells of `region` from `points` (shape: M oriented points, world units, any
/// normal length, in increasing order of their index in the whole input, which has
/// `population` ≥ M points), in `frame` with `params`: bitwise the decisions a build over the
/// whole input in `frame` makes, when `points` hold every input point within
/// [`RegionFit::reach`] of the region's cube. Cells above the region split along the path to
/// it; other cells outside it are not fitted.
///
/// Errors: a bad parameter, fewer than N_min + 1 points in the whole input, a non-finite point
/// or zero normal ([`MpuError::BadPoint`], index into `points`), a point outside the frame's
/// root cube, or an interruption by `monitor`.
pub fn fit_region(
    points: &[OrientedPoint],
    population: usize,
    frame: &MpuFrame,
    params: &MpuParams,
    region: &Region,
    monitor: &Monitor<'_>,
) -> Result<RegionFit, MpuError> {
    params.validate()?;
    let need = params.n_min + 1;
    if population < need {
        return Err(MpuError::TooFewPoints {
            got: population,
            need,
        });
    }
    if points.len() < need {
        // Too few points to grow a fit radius as the whole input would: a larger halo is needed.
        return Ok(RegionFit {
            reach: f64::INFINITY,
            ..Default::default()
        });
    }
    let data = prepare(Cow::Borrowed(points), params, frame, Vec::new(), false)?;
    let index = PointIndex::new(&data.positions);
    let coarse = CoarseIndex::new(&data.positions);
    let input = FitInput {
        positions: &[],
        points: &data.points,
        index: Some(&index),
        coarse: &coarse,
        params,
        population,
    };
    let eps0 = params.error_rel * frame.diagonal;
    let oparams = OctreeParams {
        box_scale: params.box_scale,
        alpha: params.alpha,
        max_depth: params.max_depth,
    };
    let options = OctreeBuild {
        root: Some(frame.root()),
        ..Default::default()
    };
    let (octree, decisions) = Octree::build_with(data.positions, &oparams, options, |v| {
        let cell = v.cell;
        if monitor.stopped() || !region.holds(cell) {
            return (region.is_above(cell) && !monitor.stopped(), None);
        }
        // The same decision as the whole build's (crate::build).
        let f = fit_cell(&input.over(v.positions), cell.center, cell.half, eps0);
        let split = f.error > eps0 && cell.depth < params.max_depth;
        let decision = CellDecision {
            split,
            fit_radius: f.fit_radius,
            leaf: (!split).then_some(f.fit),
        };
        (split, Some(decision))
    })?;
    monitor.check()?;
    let (rc, rh) = region.cube(frame);
    let mut out = RegionFit::default();
    for (cell, decision) in octree.cells().iter().zip(decisions) {
        let Some(decision) = decision else { continue };
        let beyond =
            ((cell.center - rc).abs() + DVec3::splat(decision.fit_radius)).max_element() - rh;
        if beyond > 0.0 {
            out.crossing += 1;
            out.reach = out.reach.max(beyond);
        }
        out.cells
            .insert((cell.depth, cell.key), decision)
            .expect("each cell is decided once");
    }
    Ok(out)
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
    params.validate()?;
    let need = params.n_min + 1;
    if population < need {
        return Err(MpuError::TooFewPoints {
            got: population,
            need,
        });
    }
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
    let region = Region::top(until);
    let failure = std::sync::Mutex::new(None);
    let oparams = OctreeParams {
        box_scale: params.box_scale,
        alpha: params.alpha,
        max_depth: params.max_depth,
    };
    let options = OctreeBuild {
        root: Some(frame.root()),
        ..Default::default()
    };
    let positions = data.positions.clone();
    let (octree, decisions) = Octree::build_with(positions, &oparams, options, |v| {
        let cell = v.cell;
        if monitor.stopped() || !region.holds(cell) {
            return (false, None);
        }
        let fitted = match try_fit_cell(&input, cell.center, cell.half, eps0) {
            Some(f) => Ok(f),
            None => fit_fetched(cell, frame, params, population, eps0, fetch),
        };
        let f = match fitted {
            Ok(f) => f,
            Err(e) => {
                failure.lock().expect("not poisoned").get_or_insert(e);
                return (false, None);
            }
        };
        let split = f.error > eps0 && cell.depth < params.max_depth;
        let decision = CellDecision {
            split,
            fit_radius: f.fit_radius,
            leaf: (!split).then_some(f.fit),
        };
        (split, Some(decision))
    })?;
    if let Some(e) = failure.into_inner().expect("not poisoned") {
        return Err(e);
    }
    monitor.check()?;
    let mut out = RegionFit::default();
    for (cell, decision) in octree.cells().iter().zip(decisions) {
        if let Some(decision) = decision {
            out.cells
                .insert((cell.depth, cell.key), decision)
                .expect("each cell is decided once");
        }
    }
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
) -> Result<CellFit, MpuError> {
    let margin = 1e-9 * frame.root_half;
    let mut radius = cell.support_radius(params.alpha) * 1.5;
    loop {
        let points =
            fetch(cell.center + frame.origin, radius + 2.0 * margin).map_err(MpuError::Fetch)?;
        if points.len() >= (params.n_min + 1).min(population) {
            let data = prepare_any(&points, frame)?;
            let index = PointIndex::new(&data.positions);
            let coarse = CoarseIndex::new(&data.positions);
            let input = FitInput {
                positions: &data.positions,
                points: &data.points,
                index: Some(&index),
                coarse: &coarse,
                params,
                population,
            };
            let f = fit_cell(&input, cell.center, cell.half, eps0);
            if f.fit_radius + margin <= radius || points.len() >= population {
                return Ok(f);
            }
            radius = (f.fit_radius + margin).max(1.25 * radius);
        } else {
            radius *= 2.0;
        }
    }
}

/// [`prepare`] of any number of points (a region's share of the input may be below N_min).
fn prepare_any(
    points: &[OrientedPoint],
    frame: &MpuFrame,
) -> Result<crate::build::Prepared, MpuError> {
    for (index, p) in points.iter().enumerate() {
        let len = p.n.length();
        if !p.p.is_finite() || !len.is_finite() || len <= 0.0 {
            return Err(MpuError::BadPoint { index });
        }
    }
    let points: Vec<OrientedPoint> = points
        .iter()
        .map(|p| OrientedPoint {
            p: p.p,
            n: p.n / p.n.length(),
        })
        .collect();
    let positions = points.iter().map(|p| p.p - frame.origin).collect();
    Ok(crate::build::Prepared { positions, points })
}
