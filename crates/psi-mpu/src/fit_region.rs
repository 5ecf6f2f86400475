//! The cells of one region of the octree (a tile: the cell at some depth and every cell below
//! it), decided from the points near the region alone, bitwise as a build over the whole input
//! decides them, provided the points cover the balls the fits read (the caller checks
//! [`RegionFit::reach`] against the halo it gathered).
//!
//! Why it is exact: a cell's fit and split decision read only the points within its fit
//! radius R1 (in increasing index order), the global count N (R1 grows until it holds
//! min(N_min + 1, N) points), ε0 and the frame; cell geometry depends on the frame alone.
//! Points given in increasing global index order keep every fit's summation order.

use std::sync::atomic::{AtomicUsize, Ordering};

use glam::DVec3;
use psi_octree::{Cell, Monitor, Octree, OctreeBuild, OctreeParams, OrientedPoint};

use crate::cell_table::{CellAddress, CellDecision, CellTable};
use crate::fit_cell::{CellFit, fit_octree_cell};
use crate::fit_fetched::{BallCache, BallSource, fit_fetched};
use crate::region_points::{IndexedPoints, check_population};
use crate::surface_leaf::leaf_holds_surface;
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
    /// Of those, the cells fitted from their whole ball, fetched ([`FarBalls`]).
    pub fetched: usize,
    /// The region's surface leaves (leaves whose cube holds input points: particles are
    /// seeded there), in arena order.
    pub surface: Vec<CellAddress>,
}

/// How [`decide_cells`] fits a cell: from the cell, the indices of the points in its cube and
/// the positions they index (those given to [`decide_cells`]), the fit, whether the whole input
/// has points in the cube, and whether the fit read its ball from elsewhere (then it does not
/// count in the region's reach).
pub(crate) type CellFitter<'a> =
    dyn Fn(&Cell, &[u32], &[DVec3]) -> Result<(CellFit, bool, bool), MpuError> + Sync + 'a;

/// What [`fit_region`] decides a region from.
#[derive(Clone, Copy)]
pub struct RegionPoints<'a> {
    /// The points (shape: M oriented points, world units, any normal length) in increasing
    /// order of their index in the whole input.
    pub points: &'a [OrientedPoint],
    /// Points in the whole input (N ≥ M).
    pub population: usize,
    /// Decisions made already for some of the region's cells (a tile's upper levels, decided
    /// by the pass above the tiles): taken, not fitted, and not part of the result.
    pub known: Option<&'a CellTable>,
    /// Where the balls of cells reaching beyond the region's halo come from (`None`: such
    /// cells are fitted from `points` and the reach says the result is not exact).
    pub far: Option<FarBalls<'a>>,
    /// The most cells the region may decide (a memory budget's share): past it the build
    /// stops and fails with [`MpuError::TooManyCells`]. `None`: no bound.
    pub max_cells: Option<usize>,
}

impl<'a> RegionPoints<'a> {
    /// All `points` of an input of `population`, nothing known, nothing fetched.
    pub fn new(points: &'a [OrientedPoint], population: usize) -> Self {
        RegionPoints {
            points,
            population,
            known: None,
            far: None,
            max_cells: None,
        }
    }
}

/// How a region's cells whose fits read beyond its halo are fitted: from their whole ball,
/// fetched (a tile's empty cells, whose fit radius grows to the nearest data, would otherwise
/// make the whole tile's halo that wide).
#[derive(Clone, Copy)]
pub struct FarBalls<'a> {
    /// The halo the region's points hold: ∞-distance beyond its cube, world units.
    pub halo: f64,
    /// Where the balls come from.
    pub source: BallSource<'a>,
}

/// Decides the cells of `region` from `input` ([`RegionPoints`]) in `frame` with `params`:
/// bitwise the decisions a build over the whole input in `frame` makes, when the points hold
/// every input point within [`RegionFit::reach`] of the region's cube. Cells above the region
/// split along the path to it; other cells outside it are not fitted.
///
/// Errors: a bad parameter, fewer than N_min + 1 points in the whole input, a non-finite point
/// or zero normal ([`MpuError::BadPoint`], index into `points`), or an interruption by
/// `monitor`.
pub fn fit_region(
    input: &RegionPoints<'_>,
    frame: &MpuFrame,
    params: &MpuParams,
    region: &Region,
    monitor: &Monitor<'_>,
) -> Result<RegionFit, MpuError> {
    let RegionPoints {
        points,
        population,
        known,
        far,
        max_cells,
    } = *input;
    let need = check_population(params, population)?;
    if points.len() < need && far.is_none() {
        // Too few points to grow a fit radius as the whole input would: a larger halo is needed.
        return Ok(RegionFit {
            reach: f64::INFINITY,
            ..Default::default()
        });
    }
    let indexed = IndexedPoints::new(points, frame)?;
    let input = indexed.input(params, population);
    let eps0 = params.error_rel * frame.diagonal;
    let (rc, rh) = region.cube(frame);
    let margin = 1e-9 * frame.root_half;
    let cache = BallCache::default();
    let fit = |cell: &Cell, inside: &[u32], in_cube: &[DVec3]| {
        let local = (points.len() >= need).then(|| fit_octree_cell(&input, cell, eps0));
        match (local, far) {
            (Some(f), Some(far))
                if ((cell.center - rc).abs() + DVec3::splat(f.fit_radius)).max_element() - rh
                    + margin
                    > far.halo =>
            {
                let (f, surface) =
                    fit_fetched(cell, frame, params, population, eps0, &far.source, &cache)?;
                Ok((f, surface, true))
            }
            (Some(f), _) => {
                let points = inside.iter().map(|&i| in_cube[i as usize]);
                let surface = leaf_holds_surface(params, cell, &f, eps0, points);
                Ok((f, surface, false))
            }
            (None, Some(far)) => {
                let (f, surface) =
                    fit_fetched(cell, frame, params, population, eps0, &far.source, &cache)?;
                Ok((f, surface, true))
            }
            (None, None) => unreachable!("returned above"),
        }
    };
    // Only the points in the region's cube (and a rounding's margin around it) fall in its
    // cells: the octree partitions those alone, and the fits read the halo through the index.
    let in_cube: Vec<DVec3> = (indexed.positions().iter())
        .filter(|&&p| (p - rc).abs().max_element() - rh <= margin)
        .copied()
        .collect();
    decide_cells(
        in_cube,
        frame,
        params,
        (region, known, max_cells),
        monitor,
        &fit,
    )
}

/// Runs the octree over `positions` (local frame) in `frame`, fitting each cell of `region` with
/// `fit` (given the cell, the indices of the points in its cube and `positions`; returning the
/// fit and whether the whole input has points in the cube) and splitting it as a whole build would, the
/// cells above the region along the path to it (those in `known` taken, not fitted); returns
/// the region's decisions, reach and surface leaves, or [`MpuError::TooManyCells`] once it
/// would decide more than `max_cells`.
pub(crate) fn decide_cells(
    positions: Vec<DVec3>,
    frame: &MpuFrame,
    params: &MpuParams,
    (region, known, max_cells): (&Region, Option<&CellTable>, Option<usize>),
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
    // Cells decided so far; past the bound nothing more is fitted or split.
    let decided = AtomicUsize::new(0);
    let max = max_cells.unwrap_or(usize::MAX);
    let (octree, decisions) = Octree::build_with(positions, &oparams, options, |v| {
        let cell = v.cell;
        if monitor.stopped() || !region.holds(cell) {
            return (region.is_above(cell) && !monitor.stopped(), None);
        }
        if let Some(d) = known.and_then(|t| t.get(cell.depth, cell.key)) {
            return (d.split, None);
        }
        if decided.fetch_add(1, Ordering::Relaxed) >= max {
            return (false, None);
        }
        let (f, surface, fetched) = match fit(cell, v.points, v.positions) {
            Ok(f) => f,
            Err(e) => {
                failure.lock().expect("not poisoned").get_or_insert(e);
                return (false, None);
            }
        };
        // The same decision as the whole build's (`CellFit::splits`).
        let split = f.splits(cell, eps0, params.max_depth);
        let decision = CellDecision {
            split,
            fit_radius: f.fit_radius,
            leaf: (!split).then_some(f.fit),
        };
        (split, Some((decision, surface, fetched)))
    })?;
    if let Some(e) = failure.into_inner().expect("not poisoned") {
        return Err(e);
    }
    monitor.check()?;
    if decided.into_inner() > max {
        return Err(MpuError::TooManyCells { max });
    }
    let (rc, rh) = region.cube(frame);
    let mut out = RegionFit::default();
    for (cell, decision) in octree.cells().iter().zip(decisions) {
        let Some((decision, surface, fetched)) = decision else {
            continue;
        };
        if surface && !decision.split {
            out.surface.push((cell.depth, cell.key));
        }
        let beyond =
            ((cell.center - rc).abs() + DVec3::splat(decision.fit_radius)).max_element() - rh;
        if beyond > 0.0 {
            out.crossing += 1;
            if !fetched {
                out.reach = out.reach.max(beyond);
            }
            out.fetched += usize::from(fetched);
        }
        out.cells
            .insert((cell.depth, cell.key), decision)
            .expect("each cell is decided once");
    }
    Ok(out)
}
