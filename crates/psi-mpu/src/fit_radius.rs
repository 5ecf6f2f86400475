//! A cell's fitting radius R1 (Ohtake's enlarged support radius, alg. §1.1): from the kd-tree's
//! k-nearest distance, or from the ball of radius R when that ball settles it by itself.

use glam::DVec3;
use psi_octree::PointIndex;

use crate::MpuParams;

/// The enlarged fitting radius: R1 = R + m·λR for the smallest m ≥ 0 with more than N_min
/// points in B(c, R1) (all points when there are fewer: `need` = min(N_min + 1, N)), computed
/// from the `need`-th nearest distance instead of Ohtake's loop, with the same result.
pub(crate) fn fit_radius(
    index: &PointIndex,
    params: &MpuParams,
    need: usize,
    center: DVec3,
    r: f64,
) -> f64 {
    let nearest = index.nearest(center, need);
    let Some(&(_, d2)) = nearest.last() else {
        return r;
    };
    let d = d2.sqrt();
    if d <= r {
        return r;
    }
    let step = params.lambda * r;
    let m = ((d - r) / step).ceil();
    let mut r1 = r + m * step;
    // Guard against rounding leaving the needed point just outside.
    while r1 < d {
        r1 += step;
    }
    r1
}

/// The ball of radius `r` around `center` when it settles R1 = R by itself: it holds at least
/// `need` points and the `need`-th smallest of its distances passes [`fit_radius`]'s test. The
/// ball holds every point within `r` (the kd-tree's own squared distances, the same a k-nearest
/// query computes), so its `need`-th smallest distance is the `need`-th nearest distance and R1
/// is what [`fit_radius`] would find, without its k-nearest query. `None`: ask [`fit_radius`].
pub(crate) fn ball_settles_radius(
    index: &PointIndex,
    center: DVec3,
    r: f64,
    need: usize,
) -> Option<Vec<u32>> {
    if need == 0 {
        return None;
    }
    let mut near = Vec::new();
    index.within_distances(center, r, &mut near);
    if near.len() < need {
        return None;
    }
    let mut d2: Vec<f64> = near.iter().map(|n| n.1).collect();
    let (_, kth, _) = d2.select_nth_unstable_by(need - 1, f64::total_cmp);
    (kth.sqrt() <= r).then(|| near.into_iter().map(|n| n.0).collect())
}
