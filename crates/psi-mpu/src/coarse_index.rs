//! The coarse points: one input point in [`COARSE`], chosen by a hash of its position (so the
//! choice depends on the point set only), in a kd-tree of their own. Large neighbourhoods are
//! thinned to a subset of these without visiting the whole ball; after an edit the index is
//! derived from the earlier one in the time of the points moved.

use glam::DVec3;
use psi_octree::PointIndex;

/// One point in this many (by position hash) is a coarse point.
pub(crate) const COARSE: u64 = 16;

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

/// The coarse point subset in a kd-tree whose items are the points' indices in the full set.
#[derive(Debug)]
pub(crate) struct CoarseIndex {
    index: PointIndex,
}

impl CoarseIndex {
    /// The coarse points of `positions` (shape: N, local frame).
    pub(crate) fn new(positions: &[DVec3]) -> Self {
        let ids: Vec<u32> = (0..positions.len() as u32)
            .filter(|&i| is_coarse(positions[i as usize]))
            .collect();
        let pts: Vec<DVec3> = ids.iter().map(|&i| positions[i as usize]).collect();
        Self {
            index: PointIndex::with_items(&pts, ids),
        }
    }

    /// The index after the points `moved` took the positions `positions` gives them (shape:
    /// N, the same points in the same order otherwise): equal in its answers to
    /// [`CoarseIndex::new`] of `positions`.
    pub(crate) fn with_moved(&self, moved: &[u32], positions: &[DVec3]) -> Self {
        Self {
            index: self.index.with_moved(moved, positions, is_coarse),
        }
    }

    /// Indices (into the full set) of the coarse points within `r` of `c`.
    pub(crate) fn within(&self, c: DVec3, r: f64) -> Vec<u32> {
        let mut out = Vec::new();
        self.index.within(c, r, &mut out);
        out
    }
}
