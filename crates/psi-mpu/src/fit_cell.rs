//! One cell's local fit: gather the neighbourhood (growing R until more than N_min points),
//! select the fit kind as Ohtake's `computeLA`, fit with fallbacks, and measure the error
//! (the largest Taubin distance over the points within the nominal radius).

use glam::DVec3;
use psi_octree::PointIndex;

use crate::bspline_weight::bspline;
use crate::coarse_index::{COARSE, CoarseIndex, SPARSE, position_hash};
use crate::fit_radius::{ball_settles_radius, fit_radius};
use crate::fit_sharp::{fit_corner, fit_edge};
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
    /// Largest Taubin distance over the points within the nominal radius (world units).
    pub(crate) error: f64,
    /// The enlarged radius R1 the fit used (world units).
    pub(crate) fit_radius: f64,
}

/// A local fit with its error: the largest Taubin distance within the nominal radius, world
/// units.
struct ScoredFit {
    fit: LeafFit,
    error: f64,
}

/// A fit uses at most about this many points: larger neighbourhoods (coarse cells, whose fits
/// are almost always discarded by the split) are thinned by a hash of each point's coordinates,
/// so the choice depends on the point set only — a rebuild after an edit thins an unchanged
/// neighbourhood identically.
pub(crate) const MAX_FIT_POINTS: usize = 4096;

/// Fits the cell with centre `center` and half-edge `half` (local frame). The error is the
/// largest Taubin distance within the nominal radius, except that its computation stops once
/// it exceeds `eps0` (the split decision needs no more; a leaf's error is the exact maximum).
pub(crate) fn fit_cell(input: &FitInput<'_>, center: DVec3, half: f64, eps0: f64) -> CellFit {
    try_fit_cell(input, center, half, eps0).expect("a fit with the full index always completes")
}

/// [`fit_cell`], or `None` when `input.index` is `None` and the fit needs it: only a large cell
/// whose error exceeds ε0 among its coarse points completes without it (bitwise as with it).
/// Local regeneration fits such cells while the kd-tree of all points is being built.
pub(crate) fn try_fit_cell(
    input: &FitInput<'_>,
    center: DVec3,
    half: f64,
    eps0: f64,
) -> Option<CellFit> {
    let params = input.params;
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
    // The ball of radius R, when the kd-tree was asked for it to settle R1.
    let mut ball_of_r: Option<Vec<u32>> = None;
    let r1 = if inside(&sparse) >= need {
        r
    } else {
        let coarse = input.coarse.within(center, r);
        let enough = inside(&coarse) >= need;
        if enough {
            let _ = coarse_cell.set(coarse);
            r
        } else if let Some(ball) = ball_settles_radius(input.index?, center, r, need) {
            let _ = coarse_cell.set(coarse);
            ball_of_r = Some(ball);
            r
        } else {
            let r1 = fit_radius(input.index?, params, need, center, r);
            if r1 == r {
                let _ = coarse_cell.set(coarse);
            } else {
                sparse = input.coarse.within_sparse(center, r1);
            }
            r1
        }
    };
    let coarse = || coarse_cell.get_or_init(|| input.coarse.within(center, r1));
    // Thinning (a function of the ball's point set only, so a rebuild after an edit thins an
    // unchanged neighbourhood identically). A ball with more than 256 sparse points (about
    // 65 536 points) keeps the sparse points whose hash is a multiple of 256·⌈s/4096⌉, without
    // gathering its coarse points (so a large cell costs the same in any model); one with more
    // than 256 coarse points (about 4096 points) keeps those whose hash is a multiple of
    // 16·⌈c/4096⌉ (at most 4096 of them), without visiting the ball; smaller balls are used
    // whole.
    // The points of `set` (one in `every` of all) whose hash is a multiple of `every` times
    // the thinning that leaves at most MAX_FIT_POINTS of them.
    let thinned = |set: &[u32], every: u64| -> Vec<u32> {
        let thin = every * (set.len() as u64).div_ceil(MAX_FIT_POINTS as u64);
        set.iter()
            .copied()
            .filter(|&i| position_hash(input.positions[i as usize]).is_multiple_of(thin))
            .collect()
    };
    let large = sparse.len() > 256;
    let mut full: Option<Vec<u32>> = None;
    let mut idx: Vec<u32> = if large {
        thinned(&sparse, SPARSE)
    } else if coarse().len() > 256 {
        thinned(coarse(), COARSE)
    } else {
        let ball = match ball_of_r {
            Some(ball) => ball,
            None => {
                let mut ball = Vec::new();
                input.index?.within(center, r1, &mut ball);
                ball
            }
        };
        let kept = if ball.len() > MAX_FIT_POINTS {
            thinned(&ball, 1)
        } else {
            ball.clone()
        };
        full = Some(ball);
        kept
    };
    if idx.len() < 3 {
        let index = input.index?;
        let ball = full.get_or_insert_with(|| {
            let mut b = Vec::new();
            index.within(center, r1, &mut b);
            b
        });
        idx.clone_from(ball);
    }
    idx.sort_unstable();
    let pos: Vec<DVec3> = idx.iter().map(|&i| input.positions[i as usize]).collect();
    let nrm: Vec<DVec3> = idx.iter().map(|&i| input.points[i as usize].n).collect();
    let w: Vec<f64> = pos
        .iter()
        .map(|p| bspline(1.5 * (*p - center).length() / r1))
        .collect();

    let r2 = r * r;
    // The error is a maximum: the sparse points of a large ball and then the coarse points are
    // scanned first (they are part of the ball), and the whole ball only while the maximum
    // stays under ε0.
    let full_ball = std::cell::OnceCell::new();
    if let Some(b) = full {
        let _ = full_ball.set(b);
    }
    // Set when the error needed the whole ball and no kd-tree was given.
    let incomplete = std::cell::Cell::new(false);
    let error_of = |f: &LocalFunction| {
        if let Some(per_rank) = params.error_rank {
            // MpuParams::error_rank: over the thinnest of sparse, coarse, ball with `per_rank`.
            let within = |set: &[u32]| {
                set.iter()
                    .filter(|&&i| (input.positions[i as usize] - center).length_squared() < r2)
                    .count()
            };
            let set: &[u32] = if large && within(&sparse) >= per_rank {
                &sparse
            } else if within(coarse()) >= per_rank {
                coarse()
            } else if let Some(index) = input.index {
                full_ball.get_or_init(|| {
                    let mut b = Vec::new();
                    index.within(center, r1, &mut b);
                    b
                })
            } else {
                incomplete.set(true);
                return f64::INFINITY;
            };
            let distance = |p: DVec3| f.taubin_distance(p);
            return ranked_error(set, input.positions, center, r2, eps0, per_rank, distance);
        }
        let mut e = 0.0f64;
        let mut scan = |set: &[u32]| {
            for &i in set {
                let p = input.positions[i as usize];
                if (p - center).length_squared() < r2 {
                    e = e.max(f.taubin_distance(p));
                    if e > eps0 {
                        return true;
                    }
                }
            }
            false
        };
        if large && scan(&sparse) {
            return e;
        }
        if scan(coarse()) {
            return e;
        }
        let Some(index) = input.index else {
            incomplete.set(true);
            return f64::INFINITY;
        };
        let ball = full_ball.get_or_init(|| {
            let mut b = Vec::new();
            index.within(center, r1, &mut b);
            b
        });
        scan(ball);
        e
    };
    // `solve_unit`: the length unit of the least-squares solves, in which the relative
    // singular-value cut-offs apply (MpuParams::fit_unit).
    let ball = Neighbourhood {
        positions: &pos,
        normals: &nrm,
        weights: &w,
    };
    let fit_in = |solve_unit: f64| {
        let fit = select_and_fit(ball, center, half, solve_unit, params);
        let error = error_of(&fit.function);
        if incomplete.get() {
            // Without the kd-tree the error is unknown: give up before the rescue's work.
            return None;
        }
        let rescue = CreaseRescue {
            solve_unit,
            params,
            eps0,
            radius: r,
            error_of: &error_of,
        };
        let ScoredFit { fit, error } = rescue.apply(ball, ScoredFit { fit, error });
        // (The rescue's errors could need the whole ball too.)
        (!incomplete.get()).then_some(CellFit {
            fit,
            error,
            fit_radius: r1,
        })
    };
    let chosen = fit_in(params.fit_unit.unwrap_or(r1))?;
    // MpuParams::leaf_refit: a leaf (its error is within ε0, so it will not split) with a smooth
    // fit — where world-unit cut-offs flatten the quadratic terms — also tries the
    // scale-invariant solve and keeps it when its exact error is smaller. The split decision is
    // unchanged either way: both errors are ≤ ε0. Sharp fits are kept as chosen: a lower error
    // at the points can come with a worse extrapolation along the feature (the thin slab of
    // tests/analytic.rs; docs/notes/2026-11-24-mpu-fits.md).
    let smooth = matches!(
        chosen.fit.kind,
        FitKind::Bivariate | FitKind::GeneralQuadric | FitKind::Plane
    );
    if params.leaf_refit && params.fit_unit.is_some() && smooth && chosen.error <= eps0 {
        let alt = fit_in(r1)?;
        // The second solve runs the crease rescue too; a sharp result is not taken either.
        let alt_smooth = matches!(
            alt.fit.kind,
            FitKind::Bivariate | FitKind::GeneralQuadric | FitKind::Plane
        );
        if alt_smooth && alt.error < chosen.error {
            return Some(alt);
        }
    }
    Some(chosen)
}

/// The crease rescue (psi's addition, explained in [`CreaseRescue::apply`]) of one cell.
struct CreaseRescue<'a> {
    /// The length unit of the least-squares solves (world units).
    solve_unit: f64,
    params: &'a MpuParams,
    /// ε0, world units.
    eps0: f64,
    /// The cell's nominal support radius R, world units.
    radius: f64,
    /// The cell's error measure.
    error_of: &'a dyn Fn(&LocalFunction) -> f64,
}

impl CreaseRescue<'_> {
    /// Applied to `scored`, a fit of the points `ball`: returns the fit to keep.
    fn apply(&self, ball: Neighbourhood<'_>, scored: ScoredFit) -> ScoredFit {
        let params = self.params;
        let ScoredFit { fit, error } = scored;

        // psi's addition to Ohtake's selection: Ohtake tries sharp pieces only in cells with at
        // most 2·N_min points, so a dense scan's creases are approximated by smooth fits rounded
        // within ε0. When a smooth fit was chosen, the normals show a crease (extreme normals
        // differ by more than 60°) and the smooth fit is not already near-exact, the sharp fit is
        // tried too and kept if it at least halves the error. Where the smooth error exceeds ε0 it
        // is only known to be ≥ ε0 (the computation stopped there), so the sharp fit must then reach
        // ε0/2.
        if params.sharp
            && matches!(fit.kind, FitKind::Bivariate | FitKind::GeneralQuadric)
            && error > 1e-3 * self.radius
            && let Some(sharp) = sharp_candidate(ball, self.solve_unit, params)
        {
            let sharp_error = (self.error_of)(&sharp.function);
            let better = sharp_error < 0.5 * error.min(self.eps0);
            if better {
                return ScoredFit {
                    fit: sharp,
                    error: sharp_error,
                };
            }
        }
        ScoredFit { fit, error }
    }
}

/// The crease test of the rescue: extreme normals more than 60° apart. Ohtake's T_edge (25.8°)
/// would also flag ordinary curvature in large cells, replacing subdivision by creases.
const CREASE_DOT: f64 = 0.5;

/// The sharp fit of a cell with many points, from approximately extreme normals found in
/// linear time (the normal farthest from the mean, then the normal farthest from that one).
fn sharp_candidate(
    ball: Neighbourhood<'_>,
    solve_unit: f64,
    params: &MpuParams,
) -> Option<LeafFit> {
    let Neighbourhood {
        positions: pos,
        normals: nrm,
        weights: w,
    } = ball;
    let mean = nrm.iter().copied().sum::<DVec3>().normalize_or_zero();
    let argmin = |d: DVec3| (0..nrm.len()).min_by(|&a, &b| nrm[a].dot(d).total_cmp(&nrm[b].dot(d)));
    let i = argmin(mean)?;
    let j = argmin(nrm[i])?;
    if nrm[i].dot(nrm[j]) >= CREASE_DOT {
        return None;
    }
    let m = nrm[i].cross(nrm[j]);
    let (k, spread) = (0..nrm.len())
        .map(|k| (k, m.dot(nrm[k]).abs()))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    let (function, kind) = if spread < params.t_corner {
        (
            fit_edge(pos, nrm, w, nrm[i], nrm[j], solve_unit)?,
            FitKind::Edge,
        )
    } else {
        (
            fit_corner(pos, nrm, w, [nrm[i], nrm[j], nrm[k]], solve_unit)?,
            FitKind::Corner,
        )
    };
    Some(LeafFit {
        function,
        kind,
        fallback: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Mpu, MpuParams};
    use psi_shapes::AnalyticShape;

    #[test]
    fn a_fit_without_the_kd_tree_is_the_fit_with_it_or_none() {
        // Enough points that the coarse cells hold more than 256 coarse points.
        let pts = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        }
        .sample(40_000, 5);
        let params = MpuParams::paper();
        let mpu = Mpu::build(&pts, &params).unwrap();
        let positions = mpu.octree.positions();
        let coarse = CoarseIndex::new(positions);
        let with = FitInput {
            positions,
            points: &mpu.points,
            index: Some(&mpu.index),
            coarse: &coarse,
            params: &params,
            population: positions.len(),
        };
        let without = FitInput {
            index: None,
            ..with
        };
        let eps0 = params.error_rel * mpu.frame.diagonal;
        let (mut same, mut gave_up) = (0, 0);
        for c in mpu.octree.cells() {
            let full = fit_cell(&with, c.center, c.half, eps0);
            match try_fit_cell(&without, c.center, c.half, eps0) {
                Some(f) => {
                    assert_eq!(f.fit.function, full.fit.function);
                    assert_eq!(f.fit.kind, full.fit.kind);
                    assert_eq!(f.fit.fallback, full.fit.fallback);
                    assert_eq!(f.error.to_bits(), full.error.to_bits());
                    assert_eq!(f.fit_radius.to_bits(), full.fit_radius.to_bits());
                    assert!(
                        f.error > eps0,
                        "only splitting cells complete without the tree"
                    );
                    same += 1;
                }
                None => gave_up += 1,
            }
        }
        assert!(
            same > 0 && gave_up > 0,
            "{same} completed, {gave_up} gave up"
        );
    }
}
