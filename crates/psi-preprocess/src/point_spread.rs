//! Whether a point set spans a surface at all: all points at one place, or all on one line,
//! can make no surface, and saying so beats the "too few points" a later step would report.

use glam::DVec3;
use rayon::prelude::*;
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
    spread_of(positions.len(), &|i| positions[i])
}

/// Points summed one chunk of this many at a time ([`spread_of`]).
const CHUNK: usize = 1 << 16;

/// [`point_spread`] of the `n` positions `at(0..n)` (no copy of them): in parallel, the
/// moments summed in fixed chunks of [`CHUNK`] points and the chunks' sums added in order, so
/// that the result does not depend on the thread count (one chunk: the serial sums).
pub(crate) fn spread_of(n: usize, at: &(dyn Fn(usize) -> DVec3 + Sync)) -> Spread {
    let Some(first) = (0..n).map(at).find(|p| p.is_finite()) else {
        return Spread::Coincident;
    };
    if !(0..n)
        .into_par_iter()
        .map(at)
        .any(|p| p.is_finite() && p != first)
    {
        return Spread::Coincident;
    }
    let chunks: Vec<Moments> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut m = Moments::around(first);
            (c * CHUNK..n.min((c + 1) * CHUNK))
                .map(at)
                .filter(|p| p.is_finite())
                .for_each(|p| m.add(p));
            m
        })
        .collect();
    let mut moments = Moments::around(first);
    for c in &chunks {
        moments.merge(c);
    }
    spread_of_covariance(&moments.covariance())
}

/// How points of covariance `cov` (of points not all at one place) spread: unbounded when it
/// is not finite, collinear when its middle eigenvalue vanishes against the largest.
fn spread_of_covariance(cov: &nalgebra::Matrix3<f64>) -> Spread {
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

#[cfg(test)]
mod tests {
    use super::*;

    use psi_octree::Aabb;

    /// The spread by the serial definition: the bounding box, then the covariance summed point
    /// after point (the brute-force twin of the chunked sums).
    fn serial_spread(positions: &[DVec3]) -> Spread {
        let finite = || positions.iter().filter(|p| p.is_finite());
        match finite().next() {
            None => Spread::Coincident,
            Some(first) if finite().all(|p| p == first) => Spread::Coincident,
            Some(&first) => {
                let n = finite().count() as f64;
                let mean = finite().map(|&p| p - first).sum::<DVec3>() / n;
                let mut cov = nalgebra::Matrix3::zeros();
                for &p in finite() {
                    let d = p - first - mean;
                    let v = nalgebra::Vector3::new(d.x, d.y, d.z);
                    cov += v * v.transpose() / n;
                }
                spread_of_covariance(&cov)
            }
        }
    }

    /// Inputs of several chunks (a plane, a line with rounding noise, coincident points with
    /// one apart, a thin strip, points with NaNs among them) spread as the serial definition
    /// says, and the same whatever the thread count.
    #[test]
    fn chunked_sums_classify_as_the_serial_definition() {
        let n = 3 * CHUNK + 17;
        let along = |i: usize| (i as f64 * 0.618_033_988_7).fract() * 10.0;
        let cases: Vec<(Vec<DVec3>, Spread)> = vec![
            (
                (0..n)
                    .map(|i| DVec3::new(along(i), along(i * 7 + 3), 0.5))
                    .collect(),
                Spread::Surface,
            ),
            (
                (0..n)
                    .map(|i| DVec3::new(1.0, 2.0, 3.0) * along(i))
                    .collect(),
                Spread::Collinear,
            ),
            (
                (0..n)
                    .map(|i| if i == n - 1 { DVec3::X } else { DVec3::ONE })
                    .collect(),
                Spread::Collinear,
            ),
            (vec![DVec3::splat(4.0); n], Spread::Coincident),
            (
                (0..n)
                    .map(|i| DVec3::new(along(i), 1e-3 * (i % 2) as f64, 0.0))
                    .collect(),
                Spread::Surface,
            ),
            (
                (0..n)
                    .map(|i| match i % 1000 {
                        0 => DVec3::NAN,
                        _ => DVec3::new(along(i), along(i * 3 + 1), along(i * 5 + 2)),
                    })
                    .collect(),
                Spread::Surface,
            ),
        ];
        for (positions, expected) in cases {
            let finite: Vec<DVec3> = positions
                .iter()
                .copied()
                .filter(|p| p.is_finite())
                .collect();
            if finite.len() == positions.len() {
                let at = |i: usize| positions[i];
                assert_eq!(
                    Aabb::from_positions_at(positions.len(), &at),
                    Aabb::from_points(finite)
                );
            }
            assert_eq!(serial_spread(&positions), expected);
            assert_eq!(point_spread(&positions), expected);
            let one = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .unwrap();
            assert_eq!(one.install(|| point_spread(&positions)), expected);
        }
    }
}
