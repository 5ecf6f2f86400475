//! Partitions a rebuild takes from an earlier octree: a cell the earlier octree split over the
//! same points is split the same way without looking at its points again.

use std::collections::HashMap;

use glam::DVec3;

use crate::{NO_CELL, Octree};

/// Partitions a rebuild may take from an earlier octree (see [`crate::OctreeBuild::known`]).
#[derive(Clone, Copy, Debug)]
pub struct KnownPartitions<'a> {
    /// The earlier octree: same root cube, and every point it shares with the new build has
    /// the same index in both.
    pub old: &'a Octree,
    /// Per cell of `old`: whether its points may have changed (a point entered or left its
    /// cube); an unflagged cell holds exactly the same points in the new build.
    pub changed: &'a [bool],
    /// When only some points moved and every index and the count were kept (a brush): their
    /// indices, ascending. The build then takes the earlier arrangement of all points with
    /// only these moved between leaves, and every earlier split with its counts corrected,
    /// instead of partitioning again the cells they passed through.
    pub moved: Option<&'a [u32]>,
}

/// The depth-first octant order of cells `a` and `b` of `tree`, neither holding the other.
fn depth_first(tree: &Octree, a: u32, b: u32) -> std::cmp::Ordering {
    let (mut a, mut b) = (a, b);
    while tree.cell(a).depth > tree.cell(b).depth {
        a = tree.cell(a).parent;
    }
    while tree.cell(b).depth > tree.cell(a).depth {
        b = tree.cell(b).parent;
    }
    if a == b {
        return std::cmp::Ordering::Equal;
    }
    // Up to the children of the common ancestor: siblings, in octant (index) order.
    while tree.cell(a).parent != tree.cell(b).parent {
        a = tree.cell(a).parent;
        b = tree.cell(b).parent;
    }
    a.cmp(&b)
}

impl<'a> KnownPartitions<'a> {
    /// The child counts and the point order of the earlier octree's cell `o` (at the address
    /// of a cell of the new build holding `count` points), if it split the same points: each
    /// child's segment holds the child's points, in the order the earlier subtree left them
    /// (the build restores increasing order where the new subtree differs).
    pub(crate) fn partition_at(&self, o: u32, count: u32) -> Option<([u32; 8], &'a [u32])> {
        if o == NO_CELL || self.changed[o as usize] {
            return None;
        }
        let oc = self.old.cell(o);
        let children = self.old.children(o)?;
        if oc.end - oc.start != count {
            return None;
        }
        let mut counts = [0u32; 8];
        for (k, ch) in children.enumerate() {
            let c = self.old.cell(ch);
            counts[k] = c.end - c.start;
        }
        Some((counts, &self.old.order[oc.start as usize..oc.end as usize]))
    }

    /// Writes into `order` the earlier octree's arrangement of the points with the `moved`
    /// ones taken out of the leaves they were in and put, in index order, into the earlier
    /// leaves holding their new `positions` (shape: N, every point's current position, all in
    /// the root cube); returns how many points each earlier cell gained (negative: lost).
    /// Costs a copy of the arrangement and time in the points moved.
    pub(crate) fn patch_order(
        &self,
        moved: &[u32],
        positions: &[DVec3],
        order: &mut Vec<u32>,
    ) -> HashMap<u32, i64> {
        let old = self.old;
        let mut gained: HashMap<u32, i64> = HashMap::new();
        // Per earlier leaf that changes: the points leaving it and those joining it.
        let mut leaving: HashMap<u32, Vec<u32>> = HashMap::new();
        let mut joining: HashMap<u32, Vec<u32>> = HashMap::new();
        for &id in moved {
            let from = old.point_leaf[id as usize];
            let to = old
                .leaf_containing(positions[id as usize])
                .expect("moved points stay in the root cube");
            if from == to {
                continue;
            }
            leaving.entry(from).or_default().push(id);
            joining.entry(to).or_default().push(id);
            for (leaf, step) in [(from, -1), (to, 1)] {
                let mut c = leaf;
                while c != NO_CELL {
                    *gained.entry(c).or_default() += step;
                    c = old.cell(c).parent;
                }
            }
        }
        let mut leaves: Vec<u32> = leaving.keys().chain(joining.keys()).copied().collect();
        // In the order the arrangement lists them: by start, and empty leaves at the same
        // start in depth-first octant order.
        leaves.sort_unstable_by(|&a, &b| {
            (old.cell(a).start.cmp(&old.cell(b).start)).then_with(|| depth_first(old, a, b))
        });
        leaves.dedup();
        order.clear();
        let mut cursor = 0usize;
        for l in leaves {
            let c = old.cell(l);
            let (start, end) = (c.start as usize, c.end as usize);
            order.extend_from_slice(&old.order[cursor..start]);
            let gone = leaving.get(&l).map_or(&[][..], |v| &v[..]);
            let mut bucket: Vec<u32> = old.order[start..end]
                .iter()
                .copied()
                .filter(|id| !gone.contains(id))
                .collect();
            bucket.extend(joining.get(&l).map_or(&[][..], |v| &v[..]));
            bucket.sort_unstable();
            order.extend_from_slice(&bucket);
            cursor = end;
        }
        order.extend_from_slice(&old.order[cursor..]);
        gained
    }

    /// The earlier octree's cell at the address of child `k` of the cell at `o`'s address
    /// ([`NO_CELL`] when it has none).
    pub(crate) fn child_of(&self, o: u32, k: u32) -> u32 {
        if o == NO_CELL {
            return NO_CELL;
        }
        self.old.children(o).map_or(NO_CELL, |c| c.start + k)
    }
}
