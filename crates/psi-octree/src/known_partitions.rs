//! Partitions a rebuild takes from an earlier octree: a cell the earlier octree split over the
//! same points is split the same way without looking at its points again.

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

    /// The earlier octree's cell at the address of child `k` of the cell at `o`'s address
    /// ([`NO_CELL`] when it has none).
    pub(crate) fn child_of(&self, o: u32, k: u32) -> u32 {
        if o == NO_CELL {
            return NO_CELL;
        }
        self.old.children(o).map_or(NO_CELL, |c| c.start + k)
    }
}
