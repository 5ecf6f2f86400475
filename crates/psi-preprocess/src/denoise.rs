//! Noise taken out of the positions before the fit: each point moved along the normal onto a
//! least-squares surface of its neighbours on the same sheet (one step of moving least squares,
//! after Alexa et al. 2001, with a quadric so that curvature is kept), the neighbourhood about
//! 4.5 noise deviations across. A full quadric over k points places its middle with a variance
//! several times σ²/k (its curvature terms are estimated from the same points), so the
//! curvature comes from three times as many points and only the offset and tilt from the k
//! nearest. The normals become the quadric's normals there. The constants were chosen on the
//! bunny with noise of 0.25 % and 0.5 % of D (`cargo xtask scans`; docs/notes).

use glam::DVec3;
use psi_octree::{OrientedPoint, PointIndex};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::local_fit::QuadricFit;

/// The neighbourhood's radius in noise deviations.
const REACH_PER_SIGMA: f64 = 4.5;

/// Neighbours per fit: at least …
const MIN_NEIGHBOURS: usize = 24;

/// … and at most.
const MAX_NEIGHBOURS: usize = 200;

/// The quadric's curvature is fitted to this many times the neighbours whose offset and tilt
/// place the point.
const CURVATURE_SPAN: usize = 3;

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
    let n = points.len();
    if n < MIN_NEIGHBOURS || sigma.is_nan() || sigma <= 0.0 {
        return DenoiseReport::default();
    }
    let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
    let index = PointIndex::new(&positions);
    // The neighbourhood size: 16 neighbours reach about `reach` (median over a sample), and the
    // count grows with the area.
    let stride = n.div_ceil(2048).max(1);
    let mut reaches: Vec<f64> = (0..n)
        .step_by(stride)
        .collect::<Vec<_>>()
        .par_iter()
        .map(|&i| {
            index
                .nearest(positions[i], 17)
                .last()
                .map_or(0.0, |l| l.1.sqrt())
        })
        .collect();
    let mid = reaches.len() / 2;
    let reach16 = *reaches.select_nth_unstable_by(mid, f64::total_cmp).1;
    let wanted = 16.0 * (REACH_PER_SIGMA * sigma / reach16.max(f64::MIN_POSITIVE)).powi(2);
    let k = (wanted.ceil() as usize)
        .clamp(MIN_NEIGHBOURS, MAX_NEIGHBOURS)
        .min(n);
    let moved: Vec<Option<OrientedPoint>> = points
        .par_iter()
        .map(|p| {
            let near = index.nearest(p.p, CURVATURE_SPAN * k);
            let reach = near.last().map_or(0.0, |l| l.1.sqrt());
            let same_side: Vec<DVec3> = near
                .iter()
                .filter(|(j, _)| points[*j as usize].n.dot(p.n) > 0.0)
                .map(|&(j, _)| positions[j as usize])
                .collect();
            let fit = QuadricFit::of(&same_side, reach)?;
            let close = &same_side[..same_side.len().min(k)];
            let q = p.p - fit.refined_height(p.p, close) * fit.normal();
            let normal = fit.normal_at(q);
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
    use psi_shapes::AnalyticShape;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// A standard normal deviate (Box–Muller).
    fn gauss(rng: &mut Pcg64Mcg) -> f64 {
        let u: f64 = rng.random::<f64>().max(1e-300);
        let v: f64 = rng.random();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

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
                p: p.p + sigma * DVec3::new(gauss(&mut rng), gauss(&mut rng), gauss(&mut rng)),
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
        let bias = points
            .iter()
            .map(|p| torus.signed_distance(p.p))
            .sum::<f64>()
            / points.len() as f64;
        eprintln!(
            "DEBUG rms {before:.3e} -> {after:.3e}, mean signed {bias:.3e}, sigma {sigma:.3e}"
        );
        assert!(after < 0.35 * before, "rms {before:.2e} -> {after:.2e}");
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
