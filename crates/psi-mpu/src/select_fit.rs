//! The choice and the fit of a cell's local function (Ohtake's `computeLA`, alg. §1): a
//! general quadric where normals disagree (a fold), a bivariate quadratic over the mean
//! normal's plane otherwise, an edge or corner function for a few points whose normals show a
//! crease, each falling back on the next simpler kind when degenerate.

use glam::DVec3;

use crate::fit_bivariate::fit_bivariate;
use crate::fit_general_quadric::{auxiliary_points, fit_general_quadric};
use crate::fit_sharp::{fit_corner, fit_edge, weighted_frame};
use crate::{FitKind, LocalFunction, MpuParams, Quadric};

/// A local function with how it was chosen.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct LeafFit {
    pub(crate) function: LocalFunction,
    pub(crate) kind: FitKind,
    /// The selected kind failed and a simpler one was used.
    pub(crate) fallback: bool,
}

/// The points a cell's fit reads (shape: K each, local frame): positions, unit normals and
/// their weights b(1.5·|p − c| / R1).
#[derive(Clone, Copy)]
pub(crate) struct Neighbourhood<'a> {
    pub(crate) positions: &'a [DVec3],
    pub(crate) normals: &'a [DVec3],
    pub(crate) weights: &'a [f64],
}

/// Ohtake's selection test, then the fit with its fallbacks (sharp → general quadric →
/// bivariate → plane).
pub(crate) fn select_and_fit(
    ball: Neighbourhood<'_>,
    center: DVec3,
    half: f64,
    solve_unit: f64,
    params: &MpuParams,
) -> LeafFit {
    let Neighbourhood {
        positions: pos,
        normals: nrm,
        weights: w,
    } = ball;
    let leaf = |function, kind, fallback| LeafFit {
        function,
        kind,
        fallback,
    };
    let Some((o, nbar)) =
        weighted_frame(pos, nrm, w).or_else(|| nearest_point_frame(pos, nrm, center))
    else {
        // No points at all (cannot happen with a non-empty input): a plane through the centre.
        return leaf(
            LocalFunction::Smooth(Quadric::plane(center, DVec3::Z)),
            FitKind::Plane,
            true,
        );
    };
    let plane = || LocalFunction::Smooth(Quadric::plane(o, nbar));
    let bivariate = || fit_bivariate(pos, w, o, nbar, solve_unit).map(LocalFunction::Smooth);
    let general = || {
        let aux = auxiliary_points(center, half, pos, nrm);
        fit_general_quadric(pos, w, &aux, o, solve_unit)
            .filter(|q| gradient_is_healthy(q, pos))
            .map(LocalFunction::Smooth)
    };

    let chosen = if !params.sharp || pos.len() > 2 * params.n_min {
        if nrm.iter().any(|n| nbar.dot(*n) < 0.0) {
            FitKind::GeneralQuadric
        } else {
            FitKind::Bivariate
        }
    } else {
        sharp_kind(nrm, params)
    };
    let attempt = match chosen {
        FitKind::GeneralQuadric => general(),
        FitKind::Bivariate => bivariate(),
        FitKind::Edge => {
            let (i, j) = most_different(nrm);
            fit_edge(pos, nrm, w, nrm[i], nrm[j], solve_unit)
        }
        FitKind::Corner => {
            let (i, j) = most_different(nrm);
            let m = nrm[i].cross(nrm[j]);
            let k = (0..nrm.len())
                .max_by(|&a, &b| m.dot(nrm[a]).abs().total_cmp(&m.dot(nrm[b]).abs()))
                .unwrap_or(0);
            fit_corner(pos, nrm, w, [nrm[i], nrm[j], nrm[k]], solve_unit)
        }
        FitKind::Plane => Some(plane()),
    };
    if let Some(f) = attempt.filter(LocalFunction::is_finite) {
        return leaf(f, chosen, false);
    }
    // Fallback chain: a failed sharp fit tries the general quadric; then bivariate; then plane.
    if matches!(chosen, FitKind::Edge | FitKind::Corner)
        && let Some(f) = general()
    {
        return leaf(f, FitKind::GeneralQuadric, true);
    }
    if chosen != FitKind::Bivariate
        && let Some(f) = bivariate()
    {
        return leaf(f, FitKind::Bivariate, true);
    }
    leaf(plane(), FitKind::Plane, true)
}

/// Frame of the point nearest the centre (used when the weighted normals cancel).
fn nearest_point_frame(pos: &[DVec3], nrm: &[DVec3], center: DVec3) -> Option<(DVec3, DVec3)> {
    let k = (0..pos.len()).min_by(|&a, &b| {
        (pos[a] - center)
            .length_squared()
            .total_cmp(&(pos[b] - center).length_squared())
    })?;
    Some((pos[k], nrm[k]))
}

/// The pair of normals with the smallest dot product ("from Kobbelt SIG'01").
fn most_different(nrm: &[DVec3]) -> (usize, usize) {
    let mut best = (0, 0, f64::INFINITY);
    for i in 0..nrm.len() {
        for j in i + 1..nrm.len() {
            let d = nrm[i].dot(nrm[j]);
            if d < best.2 {
                best = (i, j, d);
            }
        }
    }
    (best.0, best.1)
}

/// The sharp-branch selection (few points): edge, corner or bivariate.
fn sharp_kind(nrm: &[DVec3], params: &MpuParams) -> FitKind {
    if nrm.len() < 2 {
        return FitKind::Bivariate;
    }
    let (i, j) = most_different(nrm);
    if nrm[i].dot(nrm[j]) >= params.t_edge {
        return FitKind::Bivariate;
    }
    // m is not normalised in Ohtake's code: |m| = sin θ_ij.
    let m = nrm[i].cross(nrm[j]);
    let spread = nrm.iter().map(|n| m.dot(*n).abs()).fold(0.0f64, f64::max);
    if spread < params.t_corner {
        FitKind::Edge
    } else {
        FitKind::Corner
    }
}

/// A general quadric is rejected when its gradient nearly vanishes on the data (mean |∇Q| below
/// 0.1, where a distance-like fit has ≈ 1): the fit collapsed towards Q ≡ 0.
fn gradient_is_healthy(q: &Quadric, pos: &[DVec3]) -> bool {
    if pos.is_empty() {
        return false;
    }
    let mean: f64 = pos
        .iter()
        .map(|p| q.value_and_gradient(*p).1.length())
        .sum::<f64>()
        / pos.len() as f64;
    mean > 0.1
}
