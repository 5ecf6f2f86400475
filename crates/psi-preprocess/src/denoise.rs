//! Noise taken out of the positions before the fit: each point moved along the normal onto a
//! least-squares surface of its neighbours on the same sheet (one step of moving least squares,
//! after Alexa et al. 2001, with a quadric so that curvature is kept), the neighbourhood about
//! 4.5 noise deviations across. A full quadric over k points places its middle with a variance
//! several times σ²/k (its curvature terms are estimated from the same points), so the
//! curvature comes from three times as many points and only the offset and tilt from the k
//! nearest. The normals become the quadric's normals there. The constants were chosen on the
//! bunny with noise of 0.25 % and 0.5 % of D (`cargo xtask scans`; docs/notes/2026-11-24-real-scans.md).

use glam::DVec3;
use psi_octree::{Monitor, OrientedPoint, PointIndex};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::local_fit::QuadricFit;
use crate::median::median;
use crate::spatial_order::SpatialOrder;

/// The neighbourhood's radius in noise deviations.
const REACH_PER_SIGMA: f64 = 4.5;

/// Neighbours per fit: at least …
const MIN_NEIGHBOURS: usize = 24;

/// … and at most.
const MAX_NEIGHBOURS: usize = 200;

/// The quadric's curvature is fitted to this many times the neighbours whose offset and tilt
/// place the point.
const CURVATURE_SPAN: usize = 3;

/// The ball searched for the wide neighbourhood: this multiple of its median radius.
const WIDE_BALL: f64 = 1.15;

/// What [`denoise`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DenoiseReport {
    /// Neighbours per fit.
    pub neighbours: usize,
    /// Points moved.
    pub moved: usize,
    /// The root mean square of the moves, world units.
    pub rms_move: f64,
}

/// Moves each of `points` (shape: N, world units, unit normals consistently oriented) along the
/// normal of its neighbourhood onto the least-squares quadratic height field of its k nearest
/// points whose normals face its own side (n_i·n_j > 0: the other face of a thin part is left
/// out); its normal becomes the height field's there. k is chosen so that the neighbourhood's
/// radius is about 4.5 noise deviations `sigma` (world units), between 24 and 200. A point
/// whose same-side neighbours give no fit is left as it is. Every point moves from the old
/// positions (the result does not depend on the order or the thread count).
///
/// ```
/// use glam::DVec3;
/// use psi_octree::OrientedPoint;
/// use psi_preprocess::denoise;
///
/// // The plane z = 0 sampled every 1 with heights ±0.3 alternating: pulled flat.
/// let mut points: Vec<OrientedPoint> = (0..2500)
///     .map(|i| OrientedPoint {
///         p: DVec3::new((i % 50) as f64, (i / 50) as f64, if i % 2 == 0 { 0.3 } else { -0.3 }),
///         n: DVec3::Z,
///     })
///     .collect();
/// denoise(&mut points, 0.3);
/// let mean = points.iter().map(|p| p.p.z.abs()).sum::<f64>() / 2500.0;
/// assert!(mean < 0.05, "{mean}");
/// assert!(points.iter().all(|p| p.n.z > 0.9));
/// ```
pub fn denoise(points: &mut [OrientedPoint], sigma: f64) -> DenoiseReport {
    denoise_with(points, sigma, &Monitor::silent())
}

/// [`denoise`], stopping early once `monitor`'s flag is set (checked per point: the points
/// are then partly moved, and the caller discards them).
pub fn denoise_with(
    points: &mut [OrientedPoint],
    sigma: f64,
    monitor: &Monitor<'_>,
) -> DenoiseReport {
    let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
    let order = SpatialOrder::new(&positions);
    let mut sorted = order.gather(points);
    let report = denoise_in_order(&mut sorted, sigma, monitor);
    points.copy_from_slice(&order.scatter(&sorted));
    report
}

/// The median over up to 256 of `positions` (evenly by index) of the distance to the `count`-th
/// nearest (world units).
fn median_reach(index: &PointIndex, positions: &[DVec3], count: usize) -> f64 {
    let stride = positions.len().div_ceil(256).max(1);
    let mut reaches: Vec<f64> = (0..positions.len())
        .step_by(stride)
        .collect::<Vec<_>>()
        .par_iter()
        .map(|&i| {
            index
                .nearest(positions[i], count)
                .last()
                .map_or(0.0, |l| l.1.sqrt())
        })
        .collect();
    median(&mut reaches)
}

/// Orders neighbours (index, squared distance) by distance, then index.
fn by_distance(a: &(u32, f64), b: &(u32, f64)) -> std::cmp::Ordering {
    a.1.total_cmp(&b.1).then(a.0.cmp(&b.0))
}

/// [`denoise`] of `points` already in a spatially coherent order.
fn denoise_in_order(
    points: &mut [OrientedPoint],
    sigma: f64,
    monitor: &Monitor<'_>,
) -> DenoiseReport {
    let n = points.len();
    if n < MIN_NEIGHBOURS || sigma.is_nan() || sigma <= 0.0 {
        return DenoiseReport::default();
    }
    let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
    let index = PointIndex::new(&positions);
    // The neighbourhood size: 16 neighbours reach about `reach16`, and the count grows with the
    // area.
    let reach16 = median_reach(&index, &positions, 17);
    let wanted = 16.0 * (REACH_PER_SIGMA * sigma / reach16.max(f64::MIN_POSITIVE)).powi(2);
    let k = (wanted.ceil() as usize)
        .clamp(MIN_NEIGHBOURS, MAX_NEIGHBOURS)
        .min(n);
    let wide = (CURVATURE_SPAN * k).min(n);
    let wide_reach = median_reach(&index, &positions, wide);
    // The `count` nearest points to `at` (index, squared distance): from the ball of `radius`
    // about `at` when it provably holds them (its `count` nearest lie inside it; a ball query
    // cut to the nearest is cheaper than a k-nearest query for such counts, notes:
    // 2026-11-24-real-scans.md), else from the k-nearest query.
    let nearest = |at: DVec3, count: usize, radius: f64| {
        let mut ball = Vec::new();
        index.within(at, radius, &mut ball);
        if ball.len() >= count {
            let mut d: Vec<(u32, f64)> = ball
                .iter()
                .map(|&j| (j, (positions[j as usize] - at).length_squared()))
                .collect();
            d.select_nth_unstable_by(count - 1, by_distance);
            d.truncate(count);
            if d.iter().all(|n| n.1 <= radius * radius) {
                return d;
            }
        }
        index.nearest(at, count)
    };
    // The positions of `near` on the side of `normal`, and the distance to the farthest of all.
    let same_side = |near: &[(u32, f64)], normal: DVec3| {
        let reach = near.iter().map(|n| n.1).fold(0.0, f64::max).sqrt();
        let kept: Vec<DVec3> = near
            .iter()
            .filter(|(j, _)| points[*j as usize].n.dot(normal) > 0.0)
            .map(|&(j, _)| positions[j as usize])
            .collect();
        (kept, reach)
    };
    // The quadric of a point's neighbourhood: curvature from its 3k nearest on its side, offset
    // and tilt from its k nearest (found among the former when they prove it).
    let local_fit = |p: &OrientedPoint| {
        let mut near = nearest(p.p, wide, WIDE_BALL * wide_reach);
        let (pts, reach) = same_side(&near, p.n);
        let fit = QuadricFit::of(&pts, reach)?;
        // The k nearest are the k nearest of the wide neighbourhood (k ≤ wide).
        if near.len() > k {
            near.select_nth_unstable_by(k - 1, by_distance);
            near.truncate(k);
        }
        Some((fit.refined(&same_side(&near, p.n).0), fit))
    };
    let moved: Vec<Option<OrientedPoint>> = points
        .par_iter()
        .map(|p| {
            if monitor.stopped() {
                return None;
            }
            // The position from the refined fit, the normal from the wide one (its tilt is
            // averaged over more points).
            let (refined, wide_fit) = local_fit(p)?;
            let q = p.p - refined.height(p.p) * refined.normal();
            let normal = wide_fit.normal_at(q);
            if !q.is_finite() || normal == DVec3::ZERO {
                return None;
            }
            let n = if normal.dot(p.n) < 0.0 {
                -normal
            } else {
                normal
            };
            Some(OrientedPoint { p: q, n })
        })
        .collect();
    let mut report = DenoiseReport {
        neighbours: k,
        ..DenoiseReport::default()
    };
    let mut sum2 = 0.0;
    for (p, m) in points.iter_mut().zip(moved) {
        if let Some(m) = m {
            sum2 += (m.p - p.p).length_squared();
            report.moved += 1;
            *p = m;
        }
    }
    report.rms_move = (sum2 / report.moved.max(1) as f64).sqrt();
    report
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_shapes::{AnalyticShape, gaussian_vector};
    use rand::SeedableRng;
    use rand_pcg::Pcg64Mcg;

    /// A noisy torus comes out several times closer to the true surface, its normals closer to
    /// the true ones; a thin slab keeps both faces.
    #[test]
    fn noise_is_taken_out_and_sheets_kept_apart() {
        let torus = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        };
        let truth = torus.sample(40_000, 3);
        let spacing = (torus.area() / 40_000.0).sqrt();
        let sigma = 0.7 * spacing;
        let mut rng = Pcg64Mcg::seed_from_u64(4);
        let mut points: Vec<OrientedPoint> = truth
            .iter()
            .map(|p| OrientedPoint {
                p: p.p + sigma * gaussian_vector(&mut rng),
                n: p.n,
            })
            .collect();
        let rms = |pts: &[OrientedPoint]| {
            (pts.iter()
                .map(|p| torus.signed_distance(p.p).powi(2))
                .sum::<f64>()
                / pts.len() as f64)
                .sqrt()
        };
        let before = rms(&points);
        denoise(&mut points, sigma);
        let after = rms(&points);
        assert!(after < 0.3 * before, "rms {before:.2e} -> {after:.2e}");
        let tilted = points
            .iter()
            .zip(&truth)
            .filter(|(p, t)| p.n.dot(t.n) < 10f64.to_radians().cos())
            .count();
        assert!(
            tilted * 10 < points.len(),
            "{tilted} normals off by more than 10°"
        );

        let slab = AnalyticShape::Box {
            half: DVec3::new(0.5, 0.5, 0.015),
        }
        .sample(30_000, 5);
        let mut thin = slab.clone();
        denoise(&mut thin, 0.5 * (2.1f64 / 30_000.0).sqrt());
        for (p, t) in thin.iter().zip(&slab) {
            if t.n.z.abs() > 0.99 && t.p.x.abs() < 0.45 && t.p.y.abs() < 0.45 {
                assert!((p.p.z - t.p.z).abs() < 2e-3, "{:?} -> {:?}", t.p, p.p);
            }
        }
    }
}
