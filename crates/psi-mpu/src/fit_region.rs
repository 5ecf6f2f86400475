//! The cells of one region of the octree (a tile: the cell at some depth and every cell below
//! it), decided from the points near the region alone, bitwise as a build over the whole input
//! decides them, provided the points cover the balls the fits read (the caller checks
//! [`RegionFit::reach`] against the halo it gathered).
//!
//! Why it is exact: a cell's fit and split decision read only the points within its fit
//! radius R1 (in increasing index order), the global count N (R1 grows until it holds
//! min(N_min + 1, N) points), ε0 and the frame; cell geometry depends on the frame alone.
//! Points given in increasing global index order keep every fit's summation order.

use glam::DVec3;
use psi_octree::{Cell, Monitor, Octree, OctreeBuild, OctreeParams, OrientedPoint, PointIndex};

use crate::cell_table::{CellAddress, CellDecision, CellTable};
use crate::fit_cell::{CellFit, CoarseIndex, FitInput, fit_cell};
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
    /// The region's surface leaves (leaves whose cube holds input points: particles are
    /// seeded there), in arena order.
    pub surface: Vec<CellAddress>,
}

/// How [`decide_cells`] fits a cell: from the cell and the indices of the points in its cube,
/// the fit and whether the whole input has points in the cube.
pub(crate) type CellFitter<'a> =
    dyn Fn(&Cell, &[u32]) -> Result<(CellFit, bool), MpuError> + Sync + 'a;

/// The key at `depth` of the cell holding local position `x` by the octree's own rule (the
/// octant comparisons from the root with its halving arithmetic), so a point on a face lands
/// where the octree puts it.
pub(crate) fn key_of_point(frame: &MpuFrame, x: DVec3, depth: u8) -> [u32; 3] {
    let (mut center, mut half) = (frame.root_center, frame.root_half);
    let mut key = [0u32; 3];
    for _ in 0..depth {
        let h = 0.5 * half;
        let bits = [x.x >= center.x, x.y >= center.y, x.z >= center.z];
        let sign = |b: bool| if b { 1.0 } else { -1.0 };
        center += h * DVec3::new(sign(bits[0]), sign(bits[1]), sign(bits[2]));
        for a in 0..3 {
            key[a] = 2 * key[a] + u32::from(bits[a]);
        }
        half = h;
    }
    key
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
    let need = check_population(params, population)?;
    if points.len() < need {
        // Too few points to grow a fit radius as the whole input would: a larger halo is needed.
        return Ok(RegionFit {
            reach: f64::INFINITY,
            ..Default::default()
        });
    }
    let indexed = IndexedPoints::new(points, frame)?;
    let input = indexed.input(params, population);
    let eps0 = params.error_rel * frame.diagonal;
    let fit = |cell: &Cell, inside: &[u32]| {
        Ok((
            fit_cell(&input, cell.center, cell.half, eps0),
            !inside.is_empty(),
        ))
    };
    decide_cells(
        indexed.data.positions.clone(),
        frame,
        params,
        region,
        monitor,
        &fit,
    )
}

/// Points ready for fitting: unit normals, local positions, their kd-tree and coarse index.
pub(crate) struct IndexedPoints {
    data: crate::build::Prepared,
    index: PointIndex,
    coarse: CoarseIndex,
}

impl IndexedPoints {
    /// `points` (world units, any normal length) in `frame`.
    pub(crate) fn new(points: &[OrientedPoint], frame: &MpuFrame) -> Result<Self, MpuError> {
        let data = prepare_any(points, frame)?;
        let index = PointIndex::new(&data.positions);
        let coarse = CoarseIndex::new(&data.positions);
        Ok(IndexedPoints {
            data,
            index,
            coarse,
        })
    }

    /// The fits' input over these points, the whole input having `population` points.
    pub(crate) fn input<'a>(&'a self, params: &'a MpuParams, population: usize) -> FitInput<'a> {
        FitInput {
            positions: &self.data.positions,
            points: &self.data.points,
            index: Some(&self.index),
            coarse: &self.coarse,
            params,
            population,
        }
    }
}

/// Checks the parameters and that the whole input has more than N_min points; returns
/// N_min + 1.
pub(crate) fn check_population(params: &MpuParams, population: usize) -> Result<usize, MpuError> {
    params.validate()?;
    let need = params.n_min + 1;
    if population < need {
        return Err(MpuError::TooFewPoints {
            got: population,
            need,
        });
    }
    Ok(need)
}

/// Runs the octree over `positions` (local frame) in `frame`, fitting each cell of `region` with
/// `fit` (given the cell and the indices of the points in its cube; returning the fit and
/// whether the whole input has points in the cube) and splitting it as a whole build would, the
/// cells above the region along the path to it; returns the region's decisions, reach and
/// surface leaves.
pub(crate) fn decide_cells(
    positions: Vec<DVec3>,
    frame: &MpuFrame,
    params: &MpuParams,
    region: &Region,
    monitor: &Monitor<'_>,
    fit: &CellFitter<'_>,
) -> Result<RegionFit, MpuError> {
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
    let failure = std::sync::Mutex::new(None);
    let (octree, decisions) = Octree::build_with(positions, &oparams, options, |v| {
        let cell = v.cell;
        if monitor.stopped() || !region.holds(cell) {
            return (region.is_above(cell) && !monitor.stopped(), None);
        }
        let (f, surface) = match fit(cell, v.points) {
            Ok(f) => f,
            Err(e) => {
                failure.lock().expect("not poisoned").get_or_insert(e);
                return (false, None);
            }
        };
        // The same decision as the whole build's (crate::build).
        let split = f.error > eps0 && cell.depth < params.max_depth;
        let decision = CellDecision {
            split,
            fit_radius: f.fit_radius,
            leaf: (!split).then_some(f.fit),
        };
        (split, Some((decision, surface)))
    })?;
    if let Some(e) = failure.into_inner().expect("not poisoned") {
        return Err(e);
    }
    monitor.check()?;
    let (rc, rh) = region.cube(frame);
    let mut out = RegionFit::default();
    for (cell, decision) in octree.cells().iter().zip(decisions) {
        let Some((decision, surface)) = decision else {
            continue;
        };
        if surface && !decision.split {
            out.surface.push((cell.depth, cell.key));
        }
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

/// Validated points with unit normals and their local-frame positions (any number of them: a
/// region's share of the input may be below N_min).
pub(crate) fn prepare_any(
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
