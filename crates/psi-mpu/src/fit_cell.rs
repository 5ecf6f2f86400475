//! One cell's local fit: gather the neighbourhood (growing R until more than N_min points),
//! select the fit kind as Ohtake's `computeLA`, fit with fallbacks, and measure the error
//! (the largest Taubin distance over the points within the nominal radius). A cell with a
//! large neighbourhood that may split is first fitted from a thin subset of it, which settles
//! most splits at a fraction of the cost.

use glam::DVec3;
use psi_octree::{BallAnswer, PointIndex};

use crate::bspline_weight::bspline;
use crate::coarse_index::{COARSE, CoarseIndex, SPARSE, is_coarse, position_hash};
use crate::crease_rescue::{CreaseRescue, NEAR_EXACT, ScoredFit};
use crate::fit_radius::{Earlier, settle_radius_from};
use crate::ranked_error::ranked_error;
use crate::select_fit::{LeafFit, Neighbourhood, select_and_fit};
use crate::{FitKind, LocalFunction, MpuParams};

/// Everything a cell fit reads: positions in the MPU's local frame, the points for their unit
/// normals.
#[derive(Clone, Copy)]
pub(crate) struct FitInput<'a> {
    pub(crate) positions: &'a [DVec3],
    pub(crate) points: &'a [psi_octree::OrientedPoint],
    /// The kd-tree of all points; `None` while it is being built (see [`try_fit_cell`]).
    pub(crate) index: Option<&'a PointIndex>,
    /// The points whose [`position_hash`] is a multiple of [`COARSE`], and their indices.
    pub(crate) coarse: &'a CoarseIndex,
    pub(crate) params: &'a MpuParams,
    /// Points in the whole input (N): a fit grows its radius until it holds
    /// min(N_min + 1, N) points. `positions.len()` for a build over the whole input; more for
    /// a region built from its points and a halo ([`crate::fit_region`]).
    pub(crate) population: usize,
}

impl<'a> FitInput<'a> {
    /// The same input reading the positions from `positions` (the octree's, once it owns
    /// them).
    pub(crate) fn over<'b>(&self, positions: &'b [DVec3]) -> FitInput<'b>
    where
        'a: 'b,
    {
        FitInput { positions, ..*self }
    }
}

/// The result of fitting one cell.
#[derive(Clone, Debug)]
pub(crate) struct CellFit {
    pub(crate) fit: LeafFit,
    /// The cell's error (world units): the largest Taubin distance within the nominal radius
    /// for a cell that does not split; for one that splits, a distance that exceeds ε0.
    pub(crate) error: f64,
    /// The enlarged radius R1 the fit used (world units).
    pub(crate) fit_radius: f64,
}

impl CellFit {
    /// Whether `cell`, so fitted, splits: its error exceeds `eps0` (world units) and it lies
    /// above `max_depth`.
    pub(crate) fn splits(&self, cell: &psi_octree::Cell, eps0: f64, max_depth: u8) -> bool {
        self.error > eps0 && cell.depth < max_depth
    }
}

/// A fit uses at most about this many points: larger neighbourhoods (coarse cells, whose fits
/// are almost always discarded by the split) are thinned by a hash of each point's coordinates,
/// so the choice depends on the point set only — a rebuild after an edit thins an unchanged
/// neighbourhood identically.
pub(crate) const MAX_FIT_POINTS: usize = 4096;

/// The first fit of a cell that may split reads at most about this many points (thinned as
/// [`MAX_FIT_POINTS`]).
const FIRST_FIT_POINTS: usize = 512;

/// The first fit is tried when the ball holds at least this many coarse points (about 16
/// times as many points), so that its own points determine a quadric well.
const FIRST_FIT_MIN_COARSE: usize = 64;

/// The first fit decides a split when its error among its own kind of points (sparse or
/// coarse) exceeds this many ε0; otherwise the cell is fitted from its whole neighbourhood.
const FIRST_FIT_MARGIN: f64 = 4.0;

/// Fits the cell with centre `center` and half-edge `half` (local frame). The error is the
/// largest Taubin distance within the nominal radius, except that its computation stops once
/// it exceeds `eps0` (the split decision needs no more; a leaf's error is the exact maximum).
/// `may_split`: whether the cell splits when its error exceeds `eps0` (false at the maximum
/// depth, where the fit is kept whatever its error).
pub(crate) fn fit_cell(
    input: &FitInput<'_>,
    center: DVec3,
    half: f64,
    eps0: f64,
    may_split: bool,
) -> CellFit {
    try_fit_cell(input, center, half, eps0, may_split, None)
        .expect("a fit with the full index always completes")
}

/// [`fit_cell`] of an octree cell (local frame), which splits when its error exceeds `eps0`
/// unless it is at the maximum depth.
pub(crate) fn fit_octree_cell(input: &FitInput<'_>, cell: &psi_octree::Cell, eps0: f64) -> CellFit {
    try_fit_octree_cell(input, cell, eps0).expect("a fit with the full index always completes")
}

/// [`try_fit_cell`] of an octree cell, as [`fit_octree_cell`].
pub(crate) fn try_fit_octree_cell(
    input: &FitInput<'_>,
    cell: &psi_octree::Cell,
    eps0: f64,
) -> Option<CellFit> {
    try_fit_octree_cell_near(input, cell, eps0, None)
}

/// [`fit_octree_cell`] of a cell fitted before an edit, as `earlier` says of that fit: the
/// same fit (its radius first sought near the earlier one, its ball read from the earlier
/// ball's answer when that applies), and this fit's ball answer when `earlier.keep_ball`.
pub(crate) fn refit_octree_cell(
    input: &FitInput<'_>,
    cell: &psi_octree::Cell,
    eps0: f64,
    earlier: Earlier<'_>,
) -> (CellFit, Option<BallAnswer>) {
    let may_split = cell.depth < input.params.max_depth;
    try_fit_cell_after(input, cell.center, cell.half, eps0, may_split, earlier)
        .expect("a fit with the full index always completes")
}

/// [`try_fit_cell`] of an octree cell, which splits when its error exceeds `eps0` unless it
/// is at the maximum depth.
fn try_fit_octree_cell_near(
    input: &FitInput<'_>,
    cell: &psi_octree::Cell,
    eps0: f64,
    r1_hint: Option<f64>,
) -> Option<CellFit> {
    let may_split = cell.depth < input.params.max_depth;
    try_fit_cell(input, cell.center, cell.half, eps0, may_split, r1_hint)
}

/// The points a fit reads (shape: K each, local frame), in increasing index order.
struct Gathered {
    positions: Vec<DVec3>,
    normals: Vec<DVec3>,
    weights: Vec<f64>,
}

impl Gathered {
    /// The points `idx` (sorted here) of `input`, weighted for the cell at `center` with fit
    /// radius `r1`.
    fn new(input: &FitInput<'_>, idx: &mut [u32], center: DVec3, r1: f64) -> Self {
        idx.sort_unstable();
        let positions: Vec<DVec3> = idx.iter().map(|&i| input.positions[i as usize]).collect();
        let normals = idx.iter().map(|&i| input.points[i as usize].n).collect();
        let weights = positions
            .iter()
            .map(|p| bspline(1.5 * (*p - center).length() / r1))
            .collect();
        Self {
            positions,
            normals,
            weights,
        }
    }

    fn neighbourhood(&self) -> Neighbourhood<'_> {
        Neighbourhood {
            positions: &self.positions,
            normals: &self.normals,
            weights: &self.weights,
        }
    }
}

/// [`fit_cell`], or `None` when `input.index` is `None` and the fit needs it: only a large cell
/// whose error exceeds ε0 among its coarse points completes without it (bitwise as with it).
/// Local regeneration fits such cells while the kd-tree of all points is being built.
/// `r1_hint`: a likely R1 (world units; see [`settle_radius_from`]), which changes no result.
pub(crate) fn try_fit_cell(
    input: &FitInput<'_>,
    center: DVec3,
    half: f64,
    eps0: f64,
    may_split: bool,
    r1_hint: Option<f64>,
) -> Option<CellFit> {
    let earlier = Earlier {
        r1: r1_hint,
        ..Earlier::default()
    };
    try_fit_cell_after(input, center, half, eps0, may_split, earlier).map(|(fit, _)| fit)
}

/// [`try_fit_cell`] as `earlier` says of the cell's earlier fit, with this fit's ball answer
/// when `earlier.keep_ball` (and a ball was queried).
fn try_fit_cell_after(
    input: &FitInput<'_>,
    center: DVec3,
    half: f64,
    eps0: f64,
    may_split: bool,
    earlier: Earlier<'_>,
) -> Option<(CellFit, Option<BallAnswer>)> {
    let params = input.params;
    // The answer of this fit's ball query, kept for the next refit.
    let kept: std::cell::RefCell<Option<BallAnswer>> = std::cell::RefCell::new(None);
    let r = params.alpha * 2.0 * 3f64.sqrt() * half;
    // R1 = R when more than N_min points lie well within R — the sparse or the coarse points
    // suffice to tell (the margin keeps rounding at the sphere out of it); otherwise the
    // kd-tree decides.
    let need = (params.n_min + 1).min(input.population);
    let inner = r * (1.0 - 1e-9);
    let inside = |set: &[u32]| {
        set.iter()
            .filter(|&&i| (input.positions[i as usize] - center).length_squared() <= inner * inner)
            .count()
    };
    let mut sparse = input.coarse.within_sparse(center, r);
    // The coarse points within R1, gathered only when needed.
    let coarse_cell: std::cell::OnceCell<Vec<u32>> = std::cell::OnceCell::new();
    // The points within R1, gathered only when needed.
    let full_ball: std::cell::OnceCell<Vec<u32>> = std::cell::OnceCell::new();
    // R1 from the kd-tree, with the ball of R1 when the query gave it.
    let settle = |index: &PointIndex, sparse: &mut Vec<u32>| {
        let (r1, ball, answer) = settle_radius_from(index, params, need, center, r, earlier);
        if answer.is_some() {
            *kept.borrow_mut() = answer;
        }
        if let Some(ball) = ball {
            let _ = full_ball.set(ball);
        }
        if r1 != r {
            *sparse = input.coarse.within_sparse(center, r1);
        }
        r1
    };
    let r1 = if inside(&sparse) >= need {
        r
    } else if let (true, Some(index)) = (sparse.is_empty(), input.index) {
        // Without a sparse point within R the ball holds few points (about 256 per sparse
        // point): the coarse points would not settle R1 either.
        settle(index, &mut sparse)
    } else {
        let coarse = input.coarse.within(center, r);
        if inside(&coarse) >= need {
            let _ = coarse_cell.set(coarse);
            r
        } else {
            let r1 = settle(input.index?, &mut sparse);
            if r1 == r {
                let _ = coarse_cell.set(coarse);
            }
            r1
        }
    };
    // (From the ball when it is at hand: the same set, another order, which no decision reads.)
    let coarse = || {
        coarse_cell.get_or_init(|| match full_ball.get() {
            Some(ball) => ball
                .iter()
                .copied()
                .filter(|&i| is_coarse(input.positions[i as usize]))
                .collect(),
            None => input.coarse.within(center, r1),
        })
    };
    // Thinning (a function of the ball's point set only, so a rebuild after an edit thins an
    // unchanged neighbourhood identically). A ball with more than 256 sparse points (about
    // 65 536 points) keeps the sparse points whose hash is a multiple of 256·⌈s/4096⌉, without
    // gathering its coarse points (so a large cell costs the same in any model); one with more
    // than 256 coarse points (about 4096 points) keeps those whose hash is a multiple of
    // 16·⌈c/4096⌉ (at most 4096 of them), without visiting the ball; smaller balls are used
    // whole.
    // The points of `set` (one in `every` of all) whose hash is a multiple of `every` times
    // the thinning that leaves at most `most` of them.
    let thinned = |set: &[u32], every: u64, most: usize| -> Vec<u32> {
        let thin = every * (set.len() as u64).div_ceil(most as u64);
        set.iter()
            .copied()
            .filter(|&i| position_hash(input.positions[i as usize]).is_multiple_of(thin))
            .collect()
    };
    let large = sparse.len() > 256;

    let r2 = r * r;
    // Set when the error needed the whole ball and no kd-tree was given.
    let incomplete = std::cell::Cell::new(false);
    // The points within R1, from the kd-tree once (`None` without one).
    let ball = || -> Option<&Vec<u32>> {
        let index = input.index?;
        Some(full_ball.get_or_init(|| {
            if !(earlier.keep_ball || earlier.ball.is_some()) {
                let mut b = Vec::new();
                index.within(center, r1, &mut b);
                return b;
            }
            let mut answer = index.ball_answer(center, r1, earlier.ball, Vec::new());
            answer.sort_by_id();
            let b = answer.near().iter().map(|n| n.0).collect();
            if earlier.keep_ball {
                *kept.borrow_mut() = Some(answer);
            }
            b
        }))
    };
    // The error of `f` that decides the cell, stopping once it exceeds `limit` (world units):
    // scanned over `first` alone (a first fit's own kind of points), or over the ball when it
    // is at hand, or else over the sparse points of a large ball, then the coarse points (they
    // are part of the ball), and the whole ball only while the maximum stays under the limit.
    let error_of = |f: &LocalFunction, limit: f64, first: Option<&[u32]>| {
        let distance = |p: DVec3| f.taubin_distance(p);
        if let Some(per_rank) = params.error_rank {
            // MpuParams::error_rank: over the thinnest of sparse, coarse, ball with `per_rank`.
            let within = |set: &[u32]| {
                set.iter()
                    .filter(|&&i| (input.positions[i as usize] - center).length_squared() < r2)
                    .count()
            };
            let set: &[u32] = if let Some(first) = first {
                if within(first) < per_rank {
                    // Too few to rank: the first fit decides nothing.
                    return 0.0;
                }
                first
            } else if large && within(&sparse) >= per_rank {
                &sparse
            } else if within(coarse()) >= per_rank {
                coarse()
            } else if let Some(ball) = ball() {
                ball
            } else {
                incomplete.set(true);
                return f64::INFINITY;
            };
            return ranked_error(set, input.positions, center, r2, limit, per_rank, distance);
        }
        let mut e = 0.0f64;
        let mut scan = |set: &[u32]| {
            for &i in set {
                let p = input.positions[i as usize];
                if (p - center).length_squared() < r2 {
                    e = e.max(distance(p));
                    if e > limit {
                        return true;
                    }
                }
            }
            false
        };
        if let Some(first) = first {
            scan(first);
            return e;
        }
        if let Some(ball) = full_ball.get() {
            // (The ball at hand: scanned alone.)
            scan(ball);
            return e;
        }
        if large && scan(&sparse) {
            return e;
        }
        if scan(coarse()) {
            return e;
        }
        let Some(ball) = ball() else {
            incomplete.set(true);
            return f64::INFINITY;
        };
        scan(ball);
        e
    };
    // The fit of `points` with the crease rescue, and its error stopped at `limit`; `None`
    // when the error needed the kd-tree and there is none. `solve_unit`: the length unit of
    // the least-squares solves, in which the relative singular-value cut-offs apply
    // (MpuParams::fit_unit).
    let fit_in = |points: &Gathered, solve_unit: f64, limit: f64, first: Option<&[u32]>| {
        // A scan that stops above both the limit and the rescue's near-exact bound settles
        // every decision below whatever order it reads the points in (the points of a derived
        // kd-tree come in another order than a fresh one's).
        let limit = limit.max(NEAR_EXACT * r);
        let near = points.neighbourhood();
        let fit = select_and_fit(near, center, half, solve_unit, params);
        let error = error_of(&fit.function, limit, first);
        if incomplete.get() {
            // Without the kd-tree the error is unknown: give up before the rescue's work.
            return None;
        }
        let error_at = |f: &LocalFunction, stop: f64| error_of(f, stop.min(limit), first);
        let rescue = CreaseRescue {
            solve_unit,
            params,
            eps0,
            radius: r,
            error_of: &error_at,
        };
        let ScoredFit { fit, error } = rescue.apply(near, ScoredFit { fit, error });
        // (The rescue's errors could need the whole ball too.)
        (!incomplete.get()).then_some(CellFit {
            fit,
            error,
            fit_radius: r1,
        })
    };
    let solve_unit = params.fit_unit.unwrap_or(r1);

    // The first fit (psi's shortcut): a cell whose fit would read many points, and that splits
    // when its error exceeds ε0, is first fitted from at most FIRST_FIT_POINTS of its sparse
    // or coarse points; when that fit's error among those points exceeds FIRST_FIT_MARGIN·ε0
    // the cell splits (a function of the ball's point set, as the full fit). Otherwise, and
    // for every leaf, the fit below decides. The margin keeps the decisions of the full fit
    // (unchanged on the paper's models and the shared scans; docs/notes/2026-11-26-first-fits.md).
    if may_split {
        let source: Option<(&[u32], u64)> = if large {
            (sparse.len() > 2 * FIRST_FIT_POINTS).then_some((&sparse[..], SPARSE))
        } else {
            let c = coarse().len();
            (c >= FIRST_FIT_MIN_COARSE && (c <= 256 || c > 2 * FIRST_FIT_POINTS))
                .then_some((&coarse()[..], COARSE))
        };
        if let Some((set, every)) = source {
            let mut idx = thinned(set, every, FIRST_FIT_POINTS);
            if idx.len() >= 3 {
                let points = Gathered::new(input, &mut idx, center, r1);
                let limit = FIRST_FIT_MARGIN * eps0;
                let first = fit_in(&points, solve_unit, limit, Some(set))
                    .expect("a first fit reads no kd-tree");
                if first.error > limit {
                    return Some((first, kept.take()));
                }
            }
        }
    }

    let mut idx: Vec<u32> = if large {
        thinned(&sparse, SPARSE, MAX_FIT_POINTS)
    } else if coarse().len() > 256 {
        thinned(coarse(), COARSE, MAX_FIT_POINTS)
    } else {
        let ball = ball()?;
        if ball.len() > MAX_FIT_POINTS {
            thinned(ball, 1, MAX_FIT_POINTS)
        } else {
            ball.clone()
        }
    };
    if idx.len() < 3 {
        idx.clone_from(ball()?);
    }
    let points = Gathered::new(input, &mut idx, center, r1);
    let chosen = fit_in(&points, solve_unit, eps0, None)?;
    // MpuParams::leaf_refit: a leaf (its error is within ε0, so it will not split) with a smooth
    // fit — where world-unit cut-offs flatten the quadratic terms — also tries the
    // scale-invariant solve and keeps it when its exact error is smaller. The split decision is
    // unchanged either way: both errors are ≤ ε0. Sharp fits are kept as chosen: a lower error
    // at the points can come with a worse extrapolation along the feature (the thin slab of
    // tests/analytic.rs; docs/notes/2026-11-24-mpu-fits.md). A chosen error of zero (no point
    // within the nominal radius) cannot be bettered, so such a leaf skips the second solve.
    let smooth = |kind: FitKind| {
        matches!(
            kind,
            FitKind::Bivariate | FitKind::GeneralQuadric | FitKind::Plane
        )
    };
    if params.leaf_refit
        && params.fit_unit.is_some()
        && smooth(chosen.fit.kind)
        && chosen.error <= eps0
        && chosen.error > 0.0
    {
        let alt = fit_in(&points, r1, eps0, None)?;
        // The second solve runs the crease rescue too; a sharp result is not taken either.
        if smooth(alt.fit.kind) && alt.error < chosen.error {
            return Some((alt, kept.take()));
        }
    }
    Some((chosen, kept.take()))
}

/// The fit input of a whole build `mpu` (tests: a cell of it fitted again).
#[cfg(test)]
pub(crate) fn input_of<'a>(
    mpu: &'a crate::Mpu,
    coarse: &'a CoarseIndex,
    params: &'a MpuParams,
) -> FitInput<'a> {
    let positions = mpu.octree.positions();
    FitInput {
        positions,
        points: &mpu.points,
        index: Some(&mpu.index),
        coarse,
        params,
        population: positions.len(),
    }
}

#[cfg(test)]
#[path = "fit_cell_tests.rs"]
mod tests;
