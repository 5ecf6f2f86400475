//! The noise level of a point cloud's positions, from the data alone: per sampled point, a
//! quadratic height field fitted by least squares to its nearest neighbours, whose residual
//! (with the fit's six degrees of freedom removed) estimates the noise along the normal there;
//! the median over the sampled points is robust to the minority of neighbourhoods that a
//! crease, a corner or a thin part spoils. A quadric absorbs the surface's curvature, so a
//! clean curved surface reads as nearly noise-free.

use glam::DVec3;
use psi_octree::MortonIndex;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::local_fit::QuadricFit;
use crate::median::median;

/// Neighbours per fit.
pub(crate) const NEIGHBOURS: usize = 32;

/// At most this many points are sampled (evenly by index): the estimate is one number.
const MAX_SAMPLES: usize = 8192;

/// What [`estimate_noise`] found.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NoiseEstimate {
    /// The standard deviation of the positions' noise along the surface normal, world units
    /// (plain, not squared). For isotropic Gaussian noise of standard deviation σ per axis,
    /// this estimates σ.
    pub sigma: f64,
    /// Points whose neighbourhood gave an estimate.
    pub samples: usize,
}

/// Estimates the noise of `positions` (shape: N, world units): the median over up to 8192
/// points, sampled evenly by index, of √(RSS/(k − 6)) for the least-squares quadratic height
/// field over the plane of each point's k = 32 nearest points (corrected for the median of a
/// χ² distribution). Where that noise is large against the neighbourhoods' radius, the estimate
/// is made again on up to 2048 of the samples with neighbourhoods seven estimated deviations
/// across (at most 256 points). Zero for fewer than 7 points. Deterministic and independent of
/// the thread count.
///
/// ```
/// use glam::DVec3;
/// use psi_preprocess::estimate_noise;
///
/// // A clean paraboloid sampled every 0.02 reads as nearly noise-free.
/// let bowl: Vec<DVec3> = (0..2500)
///     .map(|i| {
///         let (x, y) = ((i % 50) as f64 / 49.0, (i / 50) as f64 / 49.0);
///         DVec3::new(x, y, 0.3 * x * x - 0.2 * x * y)
///     })
///     .collect();
/// assert!(estimate_noise(&bowl).sigma < 1e-3 * 0.02);
/// ```
pub fn estimate_noise(positions: &[DVec3]) -> NoiseEstimate {
    estimate_noise_in(positions, &MortonIndex::new(positions))
}

/// [`estimate_noise`], `index` the Morton index of `positions`.
pub(crate) fn estimate_noise_in(positions: &[DVec3], index: &MortonIndex) -> NoiseEstimate {
    noise_and_reach_in(positions, index).0
}

/// [`estimate_noise_in`], and the median over the samples of the distance to their 32nd
/// nearest point (world units; 0 when no sample had neighbours).
pub(crate) fn noise_and_reach_in(positions: &[DVec3], index: &MortonIndex) -> (NoiseEstimate, f64) {
    let residuals = |round: NoiseRound| {
        let samples: Vec<usize> = (0..positions.len()).step_by(round.stride).collect();
        Ok::<_, std::convert::Infallible>(sample_residuals(positions, index, &samples, round.k))
    };
    let Ok(found) = noise_by_rounds(positions.len(), residuals);
    found
}

/// A round of the noise estimate over N points: every `stride`-th point by input index is a
/// sample (points 0, stride, 2·stride, …), read with its `k` nearest (itself among them).
/// Which points are samples depends on their indices alone, so parts of the input can each
/// take theirs ([`crate::part_noise_samples`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct NoiseRound {
    /// Input indices between samples.
    pub stride: usize,
    /// Points per fit (the sample itself included).
    pub k: usize,
}

impl NoiseRound {
    /// Whether the point of input index `i` is a sample of this round.
    pub fn holds(&self, i: usize) -> bool {
        i.is_multiple_of(self.stride)
    }
}

/// The noise estimate of N = `n` points and the median reach of the first round's samples
/// (world units), from `residuals(round)`: for each sample of `round` whose `round.k`
/// nearest have a quadric fit, that fit's residual deviation and the distance to the k-th
/// (world units), in any order. The first round reads the 32 nearest of up to 8192 samples;
/// where the noise it finds is large against their reach, a second round reads up to 256
/// nearest of up to 2048 of those samples ([`estimate_noise`]). An error of `residuals` is
/// passed on.
pub fn noise_by_rounds<E>(
    n: usize,
    mut residuals: impl FnMut(NoiseRound) -> Result<Vec<(f64, f64)>, E>,
) -> Result<(NoiseEstimate, f64), E> {
    let none = NoiseEstimate {
        sigma: 0.0,
        samples: 0,
    };
    if n < 7 {
        return Ok((none, 0.0));
    }
    let first = NoiseRound {
        stride: n.div_ceil(MAX_SAMPLES).max(1),
        k: NEIGHBOURS,
    };
    let Some((sigma, reach)) = medians(residuals(first)?, first.k) else {
        return Ok((none, 0.0));
    };
    let samples = n.div_ceil(first.stride);
    // Noise comparable to the neighbourhood's radius is cut off by it (a point displaced far
    // along the normal is not among the nearest): then again with neighbourhoods about
    // REACH_PER_SIGMA noise deviations across.
    let wanted = (NEIGHBOURS as f64 * (REACH_PER_SIGMA * sigma / reach).powi(2)).ceil() as usize;
    let (sigma, samples) = if wanted > NEIGHBOURS {
        let widest = widest_round(n);
        let wide = NoiseRound {
            stride: widest.stride,
            k: wanted.min(widest.k),
        };
        let sigma = medians(residuals(wide)?, wide.k).map_or(sigma, |(s, _)| s);
        (sigma, n.div_ceil(wide.stride))
    } else {
        (sigma, samples)
    };
    Ok((NoiseEstimate { sigma, samples }, reach))
}

/// The samples the second round of [`noise_by_rounds`] over `n` points (at least 7) reads when
/// it runs, and the most neighbours it may read them with: a caller that holds the points in
/// the first round can read these neighbourhoods then ([`crate::part_noise_reading_wide`]) and
/// take the second round's fits from them ([`wide_residuals`]).
pub fn widest_round(n: usize) -> NoiseRound {
    let first_stride = n.div_ceil(MAX_SAMPLES).max(1);
    let samples = n.div_ceil(first_stride);
    NoiseRound {
        stride: first_stride * samples.div_ceil(MAX_WIDE_SAMPLES).max(1),
        k: MAX_NEIGHBOURS.min(n),
    }
}

/// A sample's nearest points read ahead for a later round ([`crate::part_noise_reading_wide`]):
/// positions (world units) and squared distances in increasing (distance, input index) order,
/// as `MortonIndex::nearest` gives them, as many as the part held whole.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WideNeighbourhood {
    /// The nearest points.
    pub near: Vec<(DVec3, f64)>,
}

impl WideNeighbourhood {
    /// Whether the sample's `k` nearest are among these.
    pub fn reads(&self, k: usize) -> bool {
        self.near.len() >= k
    }
}

/// The fits of a round of `k` neighbours from neighbourhoods read ahead, each of which
/// [`WideNeighbourhood::reads`] `k`: bitwise the fits of those samples read with their `k`
/// nearest.
pub fn wide_residuals(neighbourhoods: &[WideNeighbourhood], k: usize) -> Vec<(f64, f64)> {
    neighbourhoods
        .iter()
        .filter_map(|w| {
            let near = &w.near[..k];
            let pts: Vec<DVec3> = near.iter().map(|&(p, _)| p).collect();
            let reach = near.last().map_or(0.0, |n| n.1.sqrt());
            Some((QuadricFit::of(&pts, reach)?.sigma(), reach))
        })
        .collect()
}

/// Neighbourhoods at least this many estimated noise deviations across (radius).
const REACH_PER_SIGMA: f64 = 7.0;

/// At most this many neighbours per fit.
const MAX_NEIGHBOURS: usize = 256;

/// At most this many samples with wide neighbourhoods.
const MAX_WIDE_SAMPLES: usize = 2048;

/// Per sample of `samples` (input indices) whose `k` nearest points have a quadric fit: its
/// residual deviation and the distance to the k-th (world units).
fn sample_residuals(
    positions: &[DVec3],
    index: &MortonIndex,
    samples: &[usize],
    k: usize,
) -> Vec<(f64, f64)> {
    // Queried in Morton order, where neighbouring queries share cache (the medians do not
    // depend on the order; a non-finite sample has no neighbours, so no fit, either way).
    let mut chosen = vec![false; positions.len()];
    for &i in samples {
        chosen[i] = true;
    }
    let in_order: Vec<usize> = index
        .ids()
        .iter()
        .map(|&i| i as usize)
        .filter(|&i| chosen[i])
        .collect();
    in_order
        .par_iter()
        .filter_map(|&i| {
            let near = index.nearest(positions[i], k);
            sample_residual(index.points(), &near)
        })
        .collect()
}

/// The residual deviation of the quadric over a sample's nearest points `near` (slots of an
/// index whose points by slot are `by_slot`, with squared distances, nearest first) and the
/// distance to the last (world units); `None` without a fit.
pub(crate) fn sample_residual(by_slot: &[DVec3], near: &[(u32, f64)]) -> Option<(f64, f64)> {
    let pts: Vec<DVec3> = near.iter().map(|&(j, _)| by_slot[j as usize]).collect();
    let reach = near.last().map_or(0.0, |n| n.1.sqrt());
    Some((QuadricFit::of(&pts, reach)?.sigma(), reach))
}

/// The corrected median of the residual deviations `found` (fits over `k` points each) and the
/// median distance to their k-th point; `None` when empty.
fn medians(found: Vec<(f64, f64)>, k: usize) -> Option<(f64, f64)> {
    if found.is_empty() {
        return None;
    }
    let mut sigmas: Vec<f64> = found.iter().map(|f| f.0).collect();
    let mut reaches: Vec<f64> = found.iter().map(|f| f.1).collect();
    let sigma = median(&mut sigmas);
    let reach = median(&mut reaches);
    // The median of χ²_ν/ν for ν = k − 6 is about (1 − 2/(9ν))³ (Wilson–Hilferty): the median
    // of √(RSS/ν) is about its square root times σ.
    let nu = k.saturating_sub(6).max(1) as f64;
    let correction = (1.0 - 2.0 / (9.0 * nu)).powi(3).sqrt();
    Some((sigma / correction, reach))
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_shapes::{AnalyticShape, gaussian_vector};
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// A plane with known isotropic Gaussian noise gives back that noise, from a tenth to one
    /// and a half of the sample spacing.
    #[test]
    fn a_noisy_plane_gives_back_its_noise() {
        let mut rng = Pcg64Mcg::seed_from_u64(1);
        let n = 40_000;
        let spacing = 1.0 / (n as f64).sqrt();
        for relative in [0.1, 0.3, 0.7, 1.5] {
            let sigma = relative * spacing;
            let points: Vec<DVec3> = (0..n)
                .map(|_| {
                    DVec3::new(rng.random(), rng.random(), 0.0) + sigma * gaussian_vector(&mut rng)
                })
                .collect();
            let got = estimate_noise(&points).sigma;
            assert!(
                (got / sigma - 1.0).abs() < 0.1,
                "noise {relative} spacing: estimated {got:.3e} for {sigma:.3e}"
            );
        }
    }

    /// A clean curved surface reads as nearly noise-free; the same with noise reads its noise.
    #[test]
    fn a_torus_reads_its_noise_not_its_curvature() {
        let torus = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.3,
        };
        let points = torus.sample(30_000, 2);
        let clean: Vec<DVec3> = points.iter().map(|p| p.p).collect();
        let spacing = (torus.area() / 30_000.0).sqrt();
        assert!(estimate_noise(&clean).sigma < 0.02 * spacing);
        let mut rng = Pcg64Mcg::seed_from_u64(5);
        let sigma = 0.5 * spacing;
        let noisy: Vec<DVec3> = clean
            .iter()
            .map(|p| *p + sigma * gaussian_vector(&mut rng))
            .collect();
        let got = estimate_noise(&noisy).sigma;
        assert!(
            (got / sigma - 1.0).abs() < 0.15,
            "{got:.3e} for {sigma:.3e}"
        );
    }
}
