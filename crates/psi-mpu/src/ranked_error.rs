//! A cell's error as an order statistic (`MpuParams::error_rank`): the ⌈n/M⌉-th largest
//! distance of n points from the cell's fit, for noisy point clouds. The largest of n noisy
//! distances grows with n (about σ·√(2 ln n) over the fit's own misfit), so with the paper's
//! maximum a denser sampling of the same surface splits more cells; a fixed rank per M points
//! reads the same tail quantile at any density (notes: 2026-11-25-density-invariance).

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::DVec3;

/// A distance ordered by `total_cmp` (the heap's element).
#[derive(Clone, Copy, PartialEq)]
struct Distance(f64);

impl Eq for Distance {}

impl PartialOrd for Distance {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Distance {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// The ⌈n/`per_rank`⌉-th largest of `distance(p)` over the n points `p` of `set` (indices into
/// `positions`, local frame) closer than √`r2` to `center`; 0 when there are none. Stops as soon
/// as that many distances exceed `eps0` (world units; the split decision needs no more) and
/// returns the smallest of the largest ones seen then, which exceeds `eps0`.
pub(crate) fn ranked_error(
    set: &[u32],
    positions: &[DVec3],
    center: DVec3,
    r2: f64,
    eps0: f64,
    per_rank: usize,
    distance: impl Fn(DVec3) -> f64,
) -> f64 {
    let inside = || {
        set.iter()
            .map(|&i| positions[i as usize])
            .filter(move |p| (*p - center).length_squared() < r2)
    };
    let rank = inside().count().div_ceil(per_rank.max(1));
    if rank == 0 {
        return 0.0;
    }
    // The `rank` largest distances so far (a min-heap of them) and how many exceed ε0.
    let mut largest: BinaryHeap<Reverse<Distance>> = BinaryHeap::with_capacity(rank);
    let mut above = 0;
    for p in inside() {
        let d = distance(p);
        above += usize::from(d > eps0);
        // The heap full, a distance replaces its least only when larger (pushing it and popping
        // the least would leave the same values).
        if largest.len() < rank {
            largest.push(Reverse(Distance(d)));
        } else if let Some(mut least) = largest.peek_mut()
            && d.total_cmp(&least.0.0).is_gt()
        {
            *least = Reverse(Distance(d));
        }
        if above >= rank {
            break;
        }
    }
    largest.peek().map_or(0.0, |Reverse(Distance(d))| *d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The brute-force twin: sort all distances within the radius, take the rank-th largest.
    fn sorted_rank(values: &[f64], per_rank: usize) -> f64 {
        let mut v = values.to_vec();
        v.sort_by(|a, b| b.total_cmp(a));
        let rank = v.len().div_ceil(per_rank);
        if rank == 0 { 0.0 } else { v[rank - 1] }
    }

    #[test]
    fn the_rank_matches_sorting_and_stops_only_above_eps0() {
        // Points on a line at x = i, "distance" a scrambled function of x.
        let positions: Vec<DVec3> = (0..1000).map(|i| DVec3::new(i as f64, 0.0, 0.0)).collect();
        let value = |p: DVec3| ((p.x * 7919.0) % 1000.0) / 1000.0;
        for (n, per_rank) in [
            (1, 4),
            (10, 4),
            (257, 256),
            (1000, 256),
            (1000, 1),
            (999, 37),
        ] {
            let set: Vec<u32> = (0..n as u32).collect();
            let r2 = (n as f64 - 0.5).powi(2);
            let values: Vec<f64> = positions[..n].iter().map(|&p| value(p)).collect();
            let expected = sorted_rank(&values, per_rank);
            // ε0 above every value: no early stop, the exact rank.
            let exact = ranked_error(&set, &positions, DVec3::ZERO, r2, 2.0, per_rank, value);
            assert_eq!(exact, expected, "n {n} per rank {per_rank}");
            // ε0 below the answer: the result exceeds ε0 exactly when the exact one does.
            for eps0 in [0.1, 0.5, 0.9, 0.999] {
                let early = ranked_error(&set, &positions, DVec3::ZERO, r2, eps0, per_rank, value);
                assert_eq!(early > eps0, expected > eps0, "n {n} eps0 {eps0}");
                if expected <= eps0 {
                    assert_eq!(early, expected);
                }
            }
        }
        // Points beyond the radius do not count.
        let set: Vec<u32> = (0..1000).collect();
        let near = ranked_error(&set, &positions, DVec3::ZERO, 100.0, 2.0, 1, value);
        let first: Vec<f64> = positions[..10].iter().map(|&p| value(p)).collect();
        assert_eq!(near, sorted_rank(&first, 1));
    }
}
