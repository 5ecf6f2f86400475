//! The coarse points: one input point in [`COARSE`], chosen by a hash of its position (so the
//! choice depends on the point set only), in a kd-tree of their own; and one in [`SPARSE`]
//! among them, in another. Large neighbourhoods are
//! thinned to a subset of these without visiting the whole ball; after an edit the index is
//! derived from the earlier one in the time of the points moved.

use glam::DVec3;
use psi_octree::PointIndex;

/// One point in this many (by position hash) is a coarse point.
pub(crate) const COARSE: u64 = 16;

/// One point in this many is a sparse point (a coarse point too: one coarse point in 16).
pub(crate) const SPARSE: u64 = COARSE * COARSE;

/// A hash of a position's bits (for identity-based thinning).
pub(crate) fn position_hash(p: DVec3) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for v in [p.x, p.y, p.z] {
        h ^= v.to_bits();
        h = h.wrapping_mul(0x0100_0000_01b3).rotate_left(29);
    }
    h ^ (h >> 31)
}

/// Whether a position (local frame) is a coarse point's.
pub(crate) fn is_coarse(p: DVec3) -> bool {
    position_hash(p).is_multiple_of(COARSE)
}

/// Whether a position (local frame) is a sparse point's.
fn is_sparse(p: DVec3) -> bool {
    position_hash(p).is_multiple_of(SPARSE)
}

/// The coarse point subset and, within it, the sparse one, each in a kd-tree whose items are
/// the points' indices in the full set.
#[derive(Debug)]
pub(crate) struct CoarseIndex {
    index: PointIndex,
    sparse: PointIndex,
}

impl CoarseIndex {
    /// The coarse points of `positions` (shape: N, local frame).
    pub(crate) fn new(positions: &[DVec3]) -> Self {
        let ids: Vec<u32> = (0..positions.len() as u32)
            .filter(|&i| is_coarse(positions[i as usize]))
            .collect();
        let pts: Vec<DVec3> = ids.iter().map(|&i| positions[i as usize]).collect();
        let sparse_ids: Vec<u32> = ids
            .iter()
            .copied()
            .filter(|&i| is_sparse(positions[i as usize]))
            .collect();
        let sparse_pts: Vec<DVec3> = sparse_ids.iter().map(|&i| positions[i as usize]).collect();
        Self {
            index: PointIndex::with_items(&pts, ids),
            sparse: PointIndex::with_items(&sparse_pts, sparse_ids),
        }
    }

    /// The index after the points `moved` took the positions `positions` gives them (shape:
    /// N, the same points in the same order otherwise): equal in its answers to
    /// [`CoarseIndex::new`] of `positions`.
    pub(crate) fn with_moved(&self, moved: &[u32], positions: &[DVec3]) -> Self {
        Self {
            index: self.index.with_moved(moved, positions, is_coarse),
            sparse: self.sparse.with_moved(moved, positions, is_sparse),
        }
    }

    /// Indices (into the full set) of the sparse points within `r` of `c`.
    pub(crate) fn within_sparse(&self, c: DVec3, r: f64) -> Vec<u32> {
        let mut out = Vec::new();
        self.sparse.within(c, r, &mut out);
        out
    }

    /// Indices (into the full set) of the coarse points within `r` of `c`.
    pub(crate) fn within(&self, c: DVec3, r: f64) -> Vec<u32> {
        let mut out = Vec::new();
        self.index.within(c, r, &mut out);
        out
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;
    use psi_octree::PointIndex;
    use psi_shapes::AnalyticShape;

    use super::CoarseIndex;
    use crate::fit_cell::{FitInput, fit_cell, try_fit_cell};
    use crate::{Mpu, MpuParams};

    /// A ball of more than 256 sparse points is fitted from them alone: the same fit with and
    /// without the kd-tree, and the same (to rounding) whatever the points' order, since the
    /// thinning reads the point set only; for the cells whose balls are that large.
    #[test]
    fn large_balls_are_fitted_from_their_sparse_points_whatever_the_order() {
        let pts = AnalyticShape::Sphere { radius: 1.0 }.sample(90_000, 8);
        let params = MpuParams::paper();
        let mpu = Mpu::build(&pts, &params).unwrap();
        let positions = mpu.octree.positions();
        let coarse = CoarseIndex::new(positions);
        let input = crate::fit_cell::input_of(&mpu, &coarse, &params);
        // The same points in reverse order, with their own trees.
        let reversed_points: Vec<_> = mpu.points.iter().rev().copied().collect();
        let reversed: Vec<DVec3> = positions.iter().rev().copied().collect();
        let reversed_index = PointIndex::new(&reversed);
        let reversed_coarse = CoarseIndex::new(&reversed);
        let other = FitInput {
            positions: &reversed,
            points: &reversed_points,
            index: Some(&reversed_index),
            coarse: &reversed_coarse,
            ..input
        };
        let eps0 = params.error_rel * mpu.frame.diagonal;
        let mut large = 0;
        for c in mpu.octree.cells().iter().filter(|c| c.depth <= 1) {
            let r = params.alpha * 2.0 * 3f64.sqrt() * c.half;
            if coarse.within_sparse(c.center, r).len() <= 256 {
                continue;
            }
            large += 1;
            let a = fit_cell(&input, c.center, c.half, eps0, true);
            let b = fit_cell(&other, c.center, c.half, eps0, true);
            let without = try_fit_cell(
                &FitInput {
                    index: None,
                    ..input
                },
                c.center,
                c.half,
                eps0,
                true,
                None,
            )
            .expect("a large splitting cell needs no kd-tree");
            // Without the tree: bitwise. Reversed: the same points in another summation
            // order, so equal to rounding.
            assert_eq!(without.fit.function, a.fit.function);
            for f in [&b, &without] {
                assert_eq!(f.fit.kind, a.fit.kind);
                assert_eq!(f.fit_radius.to_bits(), a.fit_radius.to_bits());
                assert_eq!(f.error > eps0, a.error > eps0);
                for p in positions.iter().step_by(997) {
                    psi_shapes::assert_near!(
                        f.fit.function.taubin_distance(*p),
                        a.fit.function.taubin_distance(*p),
                        1e-9
                    );
                }
            }
        }
        assert!(large > 0, "no ball held more than 256 sparse points");
    }
}
