//! Radius query over the input points using the octree itself as the search structure.

use glam::DVec3;

use crate::Octree;

impl Octree {
    /// Appends to `out` the indices of input points `p` with |p − x| ≤ `radius` (plain radius,
    /// world units), visiting only cells whose cube meets the ball. Order: by leaf, then bucket.
    pub fn points_within(&self, x: DVec3, radius: f64, out: &mut Vec<u32>) {
        let r2 = radius * radius;
        let mut stack: Vec<u32> = vec![0];
        while let Some(i) = stack.pop() {
            let c = &self.cells[i as usize];
            // Squared distance from x to the cube.
            let d = ((x - c.center).abs() - DVec3::splat(c.half)).max(DVec3::ZERO);
            if d.length_squared() > r2 {
                continue;
            }
            if c.is_leaf() {
                for &p in &self.order[c.start as usize..c.end as usize] {
                    if (self.positions[p as usize] - x).length_squared() <= r2 {
                        out.push(p);
                    }
                }
            } else {
                stack.extend((c.first_child..c.first_child + 8).rev());
            }
        }
    }
}
