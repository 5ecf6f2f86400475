//! Piecewise fits for sharp features: an edge (two pieces) or a corner (three pieces), each
//! piece a bivariate quadratic (a plane under 6 points), combined by max where convex and min
//! where concave (Ohtake's `QuadricOEdge.cpp` / `QuadricOCorner.cpp`; algorithms.md §1.2 (c)).
//!
//! Ohtake's corner may add a fourth cluster when the third itself holds an edge; psi uses three
//! pieces and lets the error test subdivide such cells instead.

use glam::DVec3;

use crate::fit_bivariate::fit_bivariate;
use crate::{LocalFunction, Quadric};

/// A cluster's fitted piece with its weighted centroid and mean normal.
struct Piece {
    q: Quadric,
    o: DVec3,
    n: DVec3,
}

/// Weighted centroid and mean unit normal of the selected points; uniform weights when all
/// given weights vanish. `None` when nothing is selected or the normals cancel.
pub(crate) fn weighted_frame(pos: &[DVec3], nrm: &[DVec3], w: &[f64]) -> Option<(DVec3, DVec3)> {
    let sum_w: f64 = w.iter().sum();
    let uniform = sum_w <= 0.0;
    let (mut o, mut n, mut s) = (DVec3::ZERO, DVec3::ZERO, 0.0);
    for k in 0..pos.len() {
        let wk = if uniform { 1.0 } else { w[k] };
        o += wk * pos[k];
        n += wk * nrm[k];
        s += wk;
    }
    if s <= 0.0 {
        return None;
    }
    let len = n.length();
    (len > 1e-12 * s).then(|| (o / s, n / len))
}

fn fit_piece(pos: &[DVec3], nrm: &[DVec3], w: &[f64], scale: f64) -> Option<Piece> {
    let (o, n) = weighted_frame(pos, nrm, w)?;
    let q = if pos.len() < 6 {
        Quadric::plane(o, n)
    } else {
        fit_bivariate(pos, w, o, n, scale).unwrap_or_else(|| Quadric::plane(o, n))
    };
    Some(Piece { q, o, n })
}

/// Ohtake's convexity test: with v̂ the unit vector from b's centroid to a's,
/// convex iff acos(v̂·n_a) + acos(−v̂·n_b) < π.
fn convex(a: &Piece, b: &Piece) -> bool {
    let v = (a.o - b.o).normalize_or_zero();
    let a1 = v.dot(a.n).clamp(-1.0, 1.0).acos();
    let a2 = (-v.dot(b.n)).clamp(-1.0, 1.0).acos();
    a1 + a2 < std::f64::consts::PI
}

/// Splits the points by which of `axes` their normal is closest to and fits each cluster.
/// The clusters are laid out one after another in one copy of the points, each in the input's
/// order (the sums of its fit are those of a cluster gathered point by point).
fn clusters<const K: usize>(
    pos: &[DVec3],
    nrm: &[DVec3],
    w: &[f64],
    axes: [DVec3; K],
    scale: f64,
) -> Option<[Piece; K]> {
    let mut of = Vec::with_capacity(pos.len());
    let mut counts = [0usize; K];
    for n in nrm {
        let best =
            (0..K).max_by(|&a, &b| n.dot(axes[a]).total_cmp(&n.dot(axes[b])).then(b.cmp(&a)))?;
        of.push(best);
        counts[best] += 1;
    }
    let mut starts = [0usize; K];
    for c in 1..K {
        starts[c] = starts[c - 1] + counts[c - 1];
    }
    let (mut p, mut n, mut v) = (
        vec![DVec3::ZERO; pos.len()],
        vec![DVec3::ZERO; pos.len()],
        vec![0.0; pos.len()],
    );
    let mut at = starts;
    for (k, &c) in of.iter().enumerate() {
        (p[at[c]], n[at[c]], v[at[c]]) = (pos[k], nrm[k], w[k]);
        at[c] += 1;
    }
    let mut pieces = Vec::with_capacity(K);
    for c in 0..K {
        let r = starts[c]..starts[c] + counts[c];
        pieces.push(fit_piece(&p[r.clone()], &n[r.clone()], &v[r], scale)?);
    }
    pieces.try_into().ok()
}

/// Edge function from the two most different normals `ni`, `nj`.
pub(crate) fn fit_edge(
    pos: &[DVec3],
    nrm: &[DVec3],
    w: &[f64],
    ni: DVec3,
    nj: DVec3,
    scale: f64,
) -> Option<LocalFunction> {
    let [a, b] = clusters(pos, nrm, w, [ni, nj], scale)?;
    let convex = convex(&a, &b);
    Some(LocalFunction::Edge {
        pieces: [a.q, b.q],
        convex,
    })
}

/// Corner function from `ni`, `nj` and the third direction `nk`.
pub(crate) fn fit_corner(
    pos: &[DVec3],
    nrm: &[DVec3],
    w: &[f64],
    axes: [DVec3; 3],
    scale: f64,
) -> Option<LocalFunction> {
    let p = clusters(pos, nrm, w, axes, scale)?;
    let c01 = convex(&p[0], &p[1]);
    let c02 = convex(&p[0], &p[2]);
    let c12 = convex(&p[1], &p[2]);
    // The pair whose relation differs from the other two is combined first; if all agree,
    // any order gives the same max (or min).
    let (order, pair_max, outer_max) = if c01 == c02 && c02 == c12 {
        ([0, 1, 2], c01, c01)
    } else if c02 == c12 {
        ([0, 1, 2], c01, c02)
    } else if c01 == c12 {
        ([0, 2, 1], c02, c01)
    } else {
        ([1, 2, 0], c12, c01)
    };
    let [a, b, c] = p;
    Some(LocalFunction::Corner {
        pieces: [a.q, b.q, c.q],
        order,
        pair_max,
        outer_max,
    })
}
