//! The MPU octree as an adaptive grid for particle neighbour search (paper §3): particles are
//! bucketed per leaf, with per-cell subtree counts so empty branches are skipped.

use glam::DVec3;
use psi_octree::{NO_CELL, Octree};

/// Particles bucketed in the cells of an octree (local frame positions).
#[derive(Clone, Debug)]
pub struct OctreeBuckets<'a> {
    tree: &'a Octree,
    /// Particles of cell c: `order[start[c]..start[c] + count[c]]` (leaves and, by nesting,
    /// inner cells).
    start: Vec<u32>,
    count: Vec<u32>,
    order: Vec<u32>,
    positions: Vec<DVec3>,
    /// Particles outside the root cube (always checked).
    outside: Vec<u32>,
}

impl<'a> OctreeBuckets<'a> {
    /// Buckets `positions` (shape: N, the octree's local frame) into `tree`'s leaves.
    pub fn new(tree: &'a Octree, positions: &[DVec3]) -> Self {
        let cells = tree.cells();
        let mut leaf_of = vec![NO_CELL; positions.len()];
        let mut count = vec![0u32; cells.len()];
        let mut outside = Vec::new();
        for (i, p) in positions.iter().enumerate() {
            match tree.leaf_containing(*p) {
                Some(l) => {
                    leaf_of[i] = l;
                    count[l as usize] += 1;
                }
                None => outside.push(i as u32),
            }
        }
        // Depth-first numbering so that every subtree's particles are contiguous.
        let mut start = vec![0u32; cells.len()];
        let mut order_of_cells = Vec::with_capacity(cells.len());
        let mut stack = vec![0u32];
        while let Some(c) = stack.pop() {
            order_of_cells.push(c);
            if let Some(ch) = tree.children(c) {
                stack.extend(ch.rev());
            }
        }
        // Subtree counts, children before parents (arena order is level order).
        for c in (1..cells.len()).rev() {
            let parent = cells[c].parent as usize;
            count[parent] += count[c];
        }
        let mut next = 0u32;
        for &c in &order_of_cells {
            start[c as usize] = next;
            if cells[c as usize].is_leaf() {
                next += count[c as usize];
            }
        }
        let mut fill = start.clone();
        let mut order = vec![0u32; positions.len() - outside.len()];
        for (i, &l) in leaf_of.iter().enumerate() {
            if l != NO_CELL {
                order[fill[l as usize] as usize] = i as u32;
                fill[l as usize] += 1;
            }
        }
        Self {
            tree,
            start,
            count,
            order,
            positions: positions.to_vec(),
            outside,
        }
    }

    /// Calls `visit(j)` for every particle j with |p_j − x| ≤ `radius` (plain, world units;
    /// x in the local frame).
    pub fn for_each_within(&self, x: DVec3, radius: f64, mut visit: impl FnMut(u32)) {
        let r2 = radius * radius;
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(c) = stack.pop() {
            if self.count[c as usize] == 0 {
                continue;
            }
            let cell = self.tree.cell(c);
            let d = ((x - cell.center).abs() - DVec3::splat(cell.half)).max(DVec3::ZERO);
            if d.length_squared() > r2 {
                continue;
            }
            // A subtree entirely inside the ball needs no further tests of cells.
            if cell.is_leaf() {
                let s = self.start[c as usize] as usize;
                for &j in &self.order[s..s + self.count[c as usize] as usize] {
                    if (self.positions[j as usize] - x).length_squared() <= r2 {
                        visit(j);
                    }
                }
            } else {
                stack.extend(cell.first_child..cell.first_child + 8);
            }
        }
        for &j in &self.outside {
            if (self.positions[j as usize] - x).length_squared() <= r2 {
                visit(j);
            }
        }
    }
}
