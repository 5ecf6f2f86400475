//! A cell fitted from the points fetched within a ball around it, the ball grown until it
//! holds the fit's radius: then every point the fit reads was fetched, and the fit is the
//! whole build's (cells above the tiles, and a tile's cells whose fits read beyond its halo).

use std::sync::{Arc, Mutex};

use glam::DVec3;
use psi_octree::{Cell, OrientedPoint};

use crate::fit_cell::{CellFit, fit_octree_cell};
use crate::fit_radius::radius_reaching;
use crate::region_points::{IndexedPoints, key_of_point};
use crate::surface_leaf::leaf_holds_surface;
use crate::{MpuError, MpuFrame, MpuParams};

/// The points within a ball, fetched on demand: `fetch(centre, radius)` (world units) returns
/// every input point within `radius` of `centre` (more is allowed), in increasing order of
/// input index, or why it could not.
pub type FetchBall<'a> = dyn Fn(DVec3, f64) -> Result<Vec<OrientedPoint>, String> + Sync + 'a;

/// The distance (world units) from a world position to its `k`-th nearest input point, or
/// `None` when the source cannot tell (or the input has fewer than `k` points); or why it
/// failed. With it, a far cell's ball is fetched at its fit radius R1 itself.
pub type KthDistance<'a> = dyn Fn(DVec3, usize) -> Result<Option<f64>, String> + Sync + 'a;

/// Where the points of cells fitted from their whole ball come from.
#[derive(Clone, Copy)]
pub struct BallSource<'a> {
    /// The balls.
    pub fetch: &'a FetchBall<'a>,
    /// The k-th nearest distance, when the source can tell: the first ball fetched is then
    /// the one of the cell's fit radius.
    pub kth: Option<&'a KthDistance<'a>>,
}

/// Balls fetched before, each with its points indexed: a cell whose ball lies inside one of
/// them fits from it without a fetch (neighbouring far cells read nearly the same ball, and
/// indexing a ball costs more than fitting from it). Any superset of a ball gives the same fit.
#[derive(Default)]
pub(crate) struct BallCache {
    balls: Mutex<Vec<FetchedBall>>,
}

/// The cache holds at most about this many points (then it starts again): what a region's
/// fetched balls may keep in memory.
const CACHED_POINTS: usize = 1 << 18;

/// A fetched ball's radius over the one asked for (the margin kept for neighbouring cells).
/// Far cells are mostly empty cells whose radius grows until it meets the data, where the
/// count of points climbs steeply with the radius: twice the radius fetched and indexed far
/// more points than the fit reads (notes: 2026-11-26-far-balls).
const WIDER: f64 = 1.1;

/// How a ball with too few points for a fit grows before it is fetched again (gently, for the
/// same reason).
const GROW: f64 = 1.1;

/// A fetched ball: every input point within `radius` of `center` (local frame) is in `points`.
struct FetchedBall {
    center: DVec3,
    radius: f64,
    points: Arc<(IndexedPoints, usize)>,
}

impl BallCache {
    /// Indexed points holding every input point within `radius` of local `center`, and how
    /// many they are: from a cached ball, or fetched (a ball [`WIDER`], kept for the next).
    fn ball(
        &self,
        center: DVec3,
        radius: f64,
        wider: f64,
        frame: &MpuFrame,
        fetch: &FetchBall<'_>,
    ) -> Result<Arc<(IndexedPoints, usize)>, MpuError> {
        {
            let balls = self.balls.lock().expect("not poisoned");
            if let Some(b) = balls
                .iter()
                .find(|b| (b.center - center).length() + radius <= b.radius)
            {
                return Ok(Arc::clone(&b.points));
            }
        }
        let wide = wider * radius;
        let points = fetch(center + frame.origin, wide).map_err(MpuError::Fetch)?;
        let n = points.len();
        let indexed = Arc::new((IndexedPoints::new(&points, frame)?, n));
        let mut balls = self.balls.lock().expect("not poisoned");
        if balls.iter().map(|b| b.points.1).sum::<usize>() + n > CACHED_POINTS {
            balls.clear();
        }
        balls.push(FetchedBall {
            center,
            radius: wide,
            points: Arc::clone(&indexed),
        });
        Ok(indexed)
    }
}

/// One cell fitted from the points within a ball around it (from `cache`, or fetched), the
/// ball grown until it holds the fit's radius (then every point the fit reads was there);
/// with `source.kth`, the first ball is the one of R1 (from the N_min + 1-th nearest distance,
/// Ohtake's rule). Returns the fit and whether the cell's cube holds input points.
pub(crate) fn fit_fetched(
    cell: &Cell,
    frame: &MpuFrame,
    params: &MpuParams,
    population: usize,
    eps0: f64,
    source: &BallSource<'_>,
    cache: &BallCache,
) -> Result<(CellFit, bool), MpuError> {
    let BallSource { fetch, kth } = *source;
    let margin = 1e-9 * frame.root_half;
    let r = cell.support_radius(params.alpha);
    let mut radius = r * 1.5;
    let mut wider = WIDER;
    let need = (params.n_min + 1).min(population);
    if let Some(kth) = kth
        && let Some(d) = kth(cell.center + frame.origin, need).map_err(MpuError::Fetch)?
    {
        // (Rounding may leave the fit's R1 a step above: the loop then grows the ball.)
        radius = radius_reaching(d, r, params.lambda) + margin;
        wider = 1.0;
    }
    loop {
        let ball = cache.ball(cell.center, radius + 2.0 * margin, wider, frame, fetch)?;
        let (indexed, n) = (&ball.0, ball.1);
        if n >= need {
            let f = fit_octree_cell(&indexed.input(params, population), cell, eps0);
            if f.fit_radius + margin <= radius || n >= population {
                // The first ball already holds the cube (1.5 R, or R1 ≥ R, exceeds its
                // circumradius).
                // (Only points in or at the cube can be in it: the exact rule for those alone.)
                let reach = cell.half + margin;
                let inside = indexed.positions().iter().copied().filter(|&x| {
                    (x - cell.center).abs().max_element() <= reach
                        && key_of_point(frame, x, cell.depth) == cell.key
                });
                let surface = leaf_holds_surface(params, cell, &f, eps0, inside);
                return Ok((f, surface));
            }
            radius = (f.fit_radius + margin).max(1.25 * radius);
        } else {
            radius *= GROW;
        }
    }
}
