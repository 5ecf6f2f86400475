//! Whether a point set spans a surface at all: all points at one place, or all on one line,
//! can make no surface, and saying so beats the "too few points" a later step would report.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::local_fit::Moments;

/// How a point set spreads ([`point_spread`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Spread {
    /// Every point at the same place.
    Coincident,
    /// Every point on one straight line (to rounding).
    Collinear,
    /// Spread in at least two directions: a surface may pass through them.
    Surface,
    /// Spread so far that squared distances overflow double precision (coordinates beyond
    /// about 1e154): no distance between them can be computed.
    Unbounded,
}

/// The middle principal variance below this share of the largest is a line: the eigenvalue
/// solver's rounding leaves about 1e-16 of it on an exact line, and a strip a millionth as wide
/// as it is long (1e-12 of the variance) is a line for any purpose here.
const COLLINEAR: f64 = 1e-12;

/// How `positions` (shape N, world units) spread: from their bounding box (zero: coincident)
/// and the eigenvalues of their covariance (the middle one vanishing against the largest:
/// collinear; not finite: unbounded). Non-finite positions are ignored.
///
/// ```
/// use glam::DVec3;
/// use psi_preprocess::{Spread, point_spread};
/// assert_eq!(point_spread(&[DVec3::ONE; 5]), Spread::Coincident);
/// let line: Vec<DVec3> = (0..9).map(|i| DVec3::new(1.0, 2.0, 3.0) * i as f64).collect();
/// assert_eq!(point_spread(&line), Spread::Collinear);
/// let strip: Vec<DVec3> = (0..90).map(|i| DVec3::new(i as f64, 1e-3 * (i % 2) as f64, 0.0)).collect();
/// assert_eq!(point_spread(&strip), Spread::Surface);
/// let far = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::splat(1e300)];
/// assert_eq!(point_spread(&far), Spread::Unbounded);
/// ```
pub fn point_spread(positions: &[DVec3]) -> Spread {
    let finite = || positions.iter().copied().filter(|p| p.is_finite());
    let Some(first) = finite().next() else {
        return Spread::Coincident;
    };
    if finite().all(|p| p == first) {
        return Spread::Coincident;
    }
    let mut moments = Moments::around(first);
    finite().for_each(|p| moments.add(p));
    let cov = moments.covariance();
    if !cov.iter().all(|v| v.is_finite()) {
        return Spread::Unbounded;
    }
    let mut e: Vec<f64> = cov
        .symmetric_eigenvalues()
        .iter()
        .map(|v| v.max(0.0))
        .collect();
    e.sort_by(f64::total_cmp);
    if e[1] <= COLLINEAR * e[2] {
        Spread::Collinear
    } else {
        Spread::Surface
    }
}
