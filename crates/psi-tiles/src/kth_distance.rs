//! The distance from a place to its k-th nearest input point, from a tile store's sub-cell
//! runs: the sub-cells within a search radius, nearest first, read until the next one lies
//! farther than the k-th distance so far; the radius doubled while that is not settled (a
//! wider round reads only the sub-cells it adds to those read before). A far
//! cell's fit radius R1 follows from it (Ohtake's R1 grows to the N_min + 1-th nearest point),
//! so its ball is fetched at R1 instead of at a guess past it (notes: 2026-11-26-far-balls).

use std::collections::{BinaryHeap, HashSet};

use glam::DVec3;

use crate::sub_cells::{SUB, box_distance, occupied_sub_cells, sub_cell_box};
use crate::tile_records::{RECORD, record_position, tile_key};
use crate::tile_store::tile_path;
use crate::{TileError, TileStore};

/// A squared distance ordered by `total_cmp`, for the heap of the k nearest.
#[derive(Clone, Copy, PartialEq)]
struct Dist2(f64);

impl Eq for Dist2 {}

impl PartialOrd for Dist2 {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Dist2 {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

impl TileStore {
    /// The distance (world units) from world position `center` to its `k`-th nearest input
    /// point (ties counted), or `None` when the input has fewer than `k` points or the store
    /// has no sub-cell runs. Exact: every point nearer than the answer is read.
    ///
    /// Errors: a tile file that is missing, truncated or corrupted (named).
    pub fn kth_distance(&self, center: DVec3, k: usize) -> Result<Option<f64>, TileError> {
        let m = self.manifest();
        let cells = (SUB * SUB * SUB) as usize;
        if k == 0 || k as u64 > m.population || m.tiles.iter().any(|t| t.runs.len() != cells + 1) {
            return Ok(None);
        }
        let frame = m.frame;
        let tile_edge = 2.0 * frame.root_half / f64::from(1u32 << m.depth);
        let mut reach = 2.0 * tile_edge / f64::from(SUB);
        // The k nearest distances among the sub-cells read so far, and those sub-cells: a
        // wider round reads only the ones it adds (the heap holds the k nearest of all read).
        let mut heap: BinaryHeap<Dist2> = BinaryHeap::with_capacity(k + 1);
        let mut read: HashSet<(usize, usize)> = HashSet::new();
        loop {
            let grown = DVec3::splat(reach + tile_edge);
            let lo = tile_key(&frame, m.depth, center - grown);
            let hi = tile_key(&frame, m.depth, center + grown);
            // The non-empty sub-cells within `reach`, nearest first.
            let mut near: Vec<(f64, usize, usize)> = Vec::new();
            for (i, t) in m.tiles.iter().enumerate() {
                if (0..3).any(|a| t.key[a] < lo[a] || t.key[a] > hi[a]) {
                    continue;
                }
                for (s, sub) in occupied_sub_cells(&t.runs) {
                    let d = box_distance(center, sub_cell_box(&frame, m.depth, t.key, sub));
                    if d <= reach {
                        near.push((d * d, i, s));
                    }
                }
            }
            near.sort_by(|a, b| a.0.total_cmp(&b.0));
            for &(d2, i, s) in &near {
                if heap.len() == k && heap.peek().is_some_and(|top| d2 > top.0) {
                    break;
                }
                if !read.insert((i, s)) {
                    continue;
                }
                let t = &m.tiles[i];
                let range = [(t.runs[s], t.runs[s + 1])];
                let bytes = self.read_ranges(&tile_path(self.dir(), t.key), t, Some(&range))?;
                for r in bytes.chunks_exact(RECORD) {
                    let e2 = (record_position(r) - center).length_squared();
                    if heap.len() < k {
                        heap.push(Dist2(e2));
                    } else if heap.peek().is_some_and(|top| e2 < top.0) {
                        heap.pop();
                        heap.push(Dist2(e2));
                    }
                }
            }
            // Settled when the k-th distance lies within the sub-cells considered.
            if let Some(top) = heap.peek().filter(|_| heap.len() == k)
                && top.0 <= reach * reach
            {
                return Ok(Some(top.0.sqrt()));
            }
            reach *= 2.0;
        }
    }
}
