//! The crease rescue of a cell's fit (psi's addition to Ohtake's selection): where a smooth
//! fit was chosen but the normals show a crease, the sharp fit from approximately extreme
//! normals is tried too and kept when it at least halves the error.

use glam::DVec3;

use crate::fit_sharp::{fit_corner, fit_edge};
use crate::select_fit::{LeafFit, Neighbourhood};
use crate::{FitKind, LocalFunction, MpuParams};

/// A local fit with its error: the largest Taubin distance within the nominal radius, world
/// units.
pub(crate) struct ScoredFit {
    pub(crate) fit: LeafFit,
    pub(crate) error: f64,
}

/// The crease rescue (psi's addition, explained in [`CreaseRescue::apply`]) of one cell.
pub(crate) struct CreaseRescue<'a> {
    /// The length unit of the least-squares solves (world units).
    pub(crate) solve_unit: f64,
    pub(crate) params: &'a MpuParams,
    /// ε0, world units.
    pub(crate) eps0: f64,
    /// The cell's nominal support radius R, world units.
    pub(crate) radius: f64,
    /// The cell's error measure of a function, which may stop once it exceeds the second
    /// argument (world units): it is then only known to exceed it.
    pub(crate) error_of: &'a dyn Fn(&LocalFunction, f64) -> f64,
}

/// A smooth fit whose error is at most this fraction of the cell's radius R is near-exact: the
/// rescue leaves it. An error measure that stops early must not stop below this times R, so
/// that whether the rescue is tried does not depend on the order the points are scanned in.
pub(crate) const NEAR_EXACT: f64 = 1e-3;

impl CreaseRescue<'_> {
    /// Applied to `scored`, a fit of the points `ball`: returns the fit to keep.
    pub(crate) fn apply(&self, ball: Neighbourhood<'_>, scored: ScoredFit) -> ScoredFit {
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
            && error > NEAR_EXACT * self.radius
            && let Some(sharp) = sharp_candidate(ball, self.solve_unit, params)
        {
            // The sharp fit is kept only below this error, so its scan may stop above it (an
            // error kept is then exact, and one that stopped is not kept, in any scan order).
            let bar = 0.5 * error.min(self.eps0);
            let sharp_error = (self.error_of)(&sharp.function, bar);
            let better = sharp_error < bar;
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
