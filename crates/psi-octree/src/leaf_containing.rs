//! Point location: the leaf whose cube contains a query point.

use glam::DVec3;

use crate::Octree;

impl Octree {
    /// The leaf whose cube contains `x` (world units), descending by the same octant rule that
    /// bucketed the input points, so an input point's leaf is [`Octree::leaf_of_point`]'s.
    /// `None` when `x` is outside the root cube or not finite.
    pub fn leaf_containing(&self, x: DVec3) -> Option<u32> {
        if !x.is_finite() || !self.cells[0].contains(x) {
            return None;
        }
        let mut i = 0u32;
        loop {
            let c = &self.cells[i as usize];
            if c.is_leaf() {
                return Some(i);
            }
            i = c.first_child + c.octant(x) as u32;
        }
    }
}
