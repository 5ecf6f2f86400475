//! Repeated positions in a [`MortonIndex`]: the points whose position equals, coordinate by
//! coordinate, that of a point with a smaller index (a child module of `morton_index`, which
//! owns the fields). Equal positions share a Morton key, so they sit in one run of equal keys,
//! where the slots come in index order; only those runs are compared, and the scan adds no sort
//! of its own.

use std::cmp::Ordering;

use glam::DVec3;
use rayon::prelude::*;

use super::MortonIndex;

/// A run of equal keys longer than this is sorted by position before it is compared, so that a
/// point repeated very many times costs a sort, not every pair.
const PAIRWISE: usize = 32;

/// Orders positions coordinate by coordinate (finite positions; −0 and +0 compare equal: a
/// coordinate plus +0 is +0 for both).
fn by_position(a: &DVec3, b: &DVec3) -> Ordering {
    let (a, b) = (*a + DVec3::ZERO, *b + DVec3::ZERO);
    a.x.total_cmp(&b.x)
        .then(a.y.total_cmp(&b.y))
        .then(a.z.total_cmp(&b.z))
}

/// Whether two positions are the same point: every coordinate equal (`==`, so −0 = +0).
fn same(a: DVec3, b: DVec3) -> bool {
    a.x == b.x && a.y == b.y && a.z == b.z
}

impl MortonIndex {
    /// The original indices, ascending, of the indexed points whose position equals that of
    /// an indexed point with a smaller index (every copy but the first of a repeated
    /// position). Deterministic and independent of the thread count.
    pub fn repeated_positions(&self) -> Vec<u32> {
        // The runs of equal keys longer than one slot.
        let starts: Vec<usize> = (1..self.len())
            .into_par_iter()
            .filter(|&s| {
                self.keys[s] == self.keys[s - 1] && (s < 2 || self.keys[s - 1] != self.keys[s - 2])
            })
            .map(|s| s - 1)
            .collect();
        let mut repeated: Vec<u32> = starts
            .par_iter()
            .flat_map_iter(|&start| {
                let key = self.keys[start];
                let end = start + self.keys[start..].partition_point(|&k| k == key);
                self.repeats_in(start..end)
            })
            .collect();
        repeated.par_sort_unstable();
        repeated
    }

    /// The repeated points of the slots `run` (equal keys, slots in index order).
    fn repeats_in(&self, run: std::ops::Range<usize>) -> Vec<u32> {
        let slots: Vec<usize> = run.collect();
        if slots.len() <= PAIRWISE {
            return slots
                .iter()
                .enumerate()
                .filter(|&(k, &s)| {
                    slots[..k]
                        .iter()
                        .any(|&t| same(self.points[t], self.points[s]))
                })
                .map(|(_, &s)| self.ids[s])
                .collect();
        }
        // By position, ties by index (the slots' order): the first of each group is kept.
        let mut sorted = slots;
        sorted.sort_by(|&a, &b| by_position(&self.points[a], &self.points[b]).then(a.cmp(&b)));
        sorted
            .windows(2)
            .filter(|w| same(self.points[w[0]], self.points[w[1]]))
            .map(|w| self.ids[w[1]])
            .collect()
    }
}
