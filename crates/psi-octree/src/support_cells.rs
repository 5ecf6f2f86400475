//! Support query: every cell, at any depth, whose support ball (radius α × main diagonal)
//! contains a point. MPU blending visits exactly these cells.

use glam::DVec3;

use crate::{NO_CELL, Octree};

impl Octree {
    /// Calls `visit(cell_index, squared_distance_to_centre)` for every cell (inner or leaf) whose
    /// closed support ball contains `x`: |x − c|² ≤ R², R = α·2√3·half. Distances are squared,
    /// world units².
    ///
    /// A cell's children are only examined when the cell itself contains `x` in its support; this
    /// pruning is exact for α ≥ 0.5, because a child's ball then lies inside its parent's. For
    /// α < 0.5 use [`Octree::for_each_support_cell_exhaustive`].
    #[inline]
    pub fn for_each_support_cell(&self, x: DVec3, mut visit: impl FnMut(u32, f64)) {
        let k = self.params.alpha * 2.0 * 3f64.sqrt();
        let root = &self.cells[0];
        let d2 = (x - root.center).length_squared();
        let r = k * root.half;
        if d2.partial_cmp(&(r * r)).is_none_or(|o| o.is_gt()) {
            return;
        }
        // Explicit stack: at most 8 pending siblings per level.
        let mut stack = [0u32; 8 * (crate::DEPTH_LIMIT as usize + 1)];
        let mut top = 0usize;
        visit(0, d2);
        if root.first_child != NO_CELL {
            stack[0] = root.first_child;
            top = 1;
        }
        while top > 0 {
            top -= 1;
            let first = stack[top];
            for i in first..first + 8 {
                let c = &self.cells[i as usize];
                let d2 = (x - c.center).length_squared();
                let r = k * c.half;
                if d2 <= r * r {
                    visit(i, d2);
                    if c.first_child != NO_CELL {
                        stack[top] = c.first_child;
                        top += 1;
                    }
                }
            }
        }
    }

    /// The same set as [`Octree::for_each_support_cell`], collected in visiting order.
    pub fn support_cells(&self, x: DVec3) -> Vec<u32> {
        let mut out = Vec::new();
        self.for_each_support_cell(x, |i, _| out.push(i));
        out
    }

    /// Brute force over every cell, for any α (the oracle of the pruned query).
    pub fn for_each_support_cell_exhaustive(&self, x: DVec3, mut visit: impl FnMut(u32, f64)) {
        let alpha = self.params.alpha;
        for (i, c) in self.cells.iter().enumerate() {
            let d2 = (x - c.center).length_squared();
            let r = c.support_radius(alpha);
            if d2 <= r * r {
                visit(i as u32, d2);
            }
        }
    }
}
