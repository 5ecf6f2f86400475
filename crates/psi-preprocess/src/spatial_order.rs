//! A spatially coherent order of points (Morton, or Z-order, on a 2²¹ grid over their bounding
//! box): nearest-neighbour queries made in this order, over points stored in it, find their
//! data in cache, where a scanner's or a random order scatters them (measured in
//! docs/notes/2026-11-24-real-scans.md).

use glam::DVec3;
use psi_octree::{Aabb, morton_code};
use rayon::prelude::*;

/// A permutation of points into Morton order: `order[k]` is the index (in the caller's order)
/// of the k-th point in Morton order. Ties keep the caller's order, so the permutation is a
/// function of the positions alone.
pub(crate) struct SpatialOrder {
    order: Vec<u32>,
}

impl SpatialOrder {
    /// The Morton order of `positions` (shape: N; non-finite positions go last).
    pub(crate) fn new(positions: &[DVec3]) -> Self {
        let bounds = Aabb::from_points(positions.iter().copied().filter(|p| p.is_finite()));
        let (lo, scale) = bounds.map_or((DVec3::ZERO, 0.0), |b| {
            let e = b.extent().max_element();
            (b.min, if e > 0.0 { 2_097_151.0 / e } else { 0.0 })
        });
        // (key, index) pairs sorted in place: no indirection in the comparisons (a key looked
        // up per comparison misses the cache; notes: 2026-11-26-throughput).
        let mut keyed: Vec<(u64, u32)> = positions
            .par_iter()
            .enumerate()
            .map(|(i, p)| {
                if !p.is_finite() {
                    return (u64::MAX, i as u32);
                }
                let q = ((*p - lo) * scale).clamp(DVec3::ZERO, DVec3::splat(2_097_151.0));
                let key = morton_code([q.x as u64, q.y as u64, q.z as u64]);
                (key, i as u32)
            })
            .collect();
        keyed.par_sort_unstable();
        Self {
            order: keyed.into_iter().map(|k| k.1).collect(),
        }
    }

    /// `values` (shape: N, the caller's order) in Morton order.
    pub(crate) fn gather<T: Copy + Send + Sync>(&self, values: &[T]) -> Vec<T> {
        self.order.par_iter().map(|&i| values[i as usize]).collect()
    }

    /// `sorted` (shape: N, Morton order) back in the caller's order.
    pub(crate) fn scatter<T: Copy>(&self, sorted: &[T]) -> Vec<T> {
        let mut out = sorted.to_vec();
        for (&i, v) in self.order.iter().zip(sorted) {
            out[i as usize] = *v;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gather_and_scatter_are_inverse_and_neighbours_come_together() {
        let positions: Vec<DVec3> = (0..1000)
            .map(|i| DVec3::new(((i * 37) % 100) as f64, ((i * 11) % 10) as f64, 0.0))
            .collect();
        let order = SpatialOrder::new(&positions);
        let sorted = order.gather(&positions);
        assert_eq!(order.scatter(&sorted), positions);
        // Consecutive points in Morton order are near: the mean step is far below the box's.
        let step: f64 = sorted
            .windows(2)
            .map(|w| (w[1] - w[0]).length())
            .sum::<f64>()
            / 999.0;
        assert!(step < 5.0, "{step}");
    }
}
