//! Exact k-nearest-neighbour search over points sorted in Morton (Z-) order, and the implicit
//! octree that order carries: a cell of level l (the bounding cube cut 2^l times along each
//! axis) is a contiguous run of the sorted points, so no tree is stored. Two ways in:
//! [`MortonIndex::nearest`] for any query point (a depth-first search of the cells around it,
//! nearest first, pruned by the k-th distance found), and [`MortonIndex::map_nearest`] for
//! every indexed point's own neighbours in one parallel sweep, cell by cell, where the points of
//! a cell share the candidates gathered from the 27 cells around it (issue "Throughput": a
//! kd-tree query per point dominated dense runs; notes: 2026-11-26-throughput).
//!
//! Neighbours come in increasing (squared distance, original index) order: the result is a
//! function of the positions alone, whatever the thread count or the way the search met them.

use std::collections::BinaryHeap;

use glam::DVec3;
use rayon::prelude::*;

use crate::Aabb;

/// Bits of the quantised coordinates per axis (the finest level).
const BITS: u32 = 21;

/// The largest quantised coordinate.
const GRID: f64 = ((1u64 << BITS) - 1) as f64;

/// A cell of at most this many points is scanned whole instead of split into its children.
const SCAN: usize = 32;

/// The sweep's cells hold on average at least this many times k points, so that the k nearest
/// of most points lie inside the 27 cells around them.
const OCCUPANCY: f64 = 0.4;

/// Spreads the low 21 bits of `x` to every third bit.
fn spread(x: u64) -> u64 {
    let mut x = x & 0x1f_ffff;
    x = (x | x << 32) & 0x1f_0000_0000_ffff;
    x = (x | x << 16) & 0x1f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    (x | x << 2) & 0x1249_2492_4924_9249
}

/// The Morton (Z-order) code of integer coordinates `c` (each below 2^21): their bits
/// interleaved, x lowest.
///
/// ```
/// assert_eq!(psi_octree::morton_code([1, 0, 0]), 1);
/// assert_eq!(psi_octree::morton_code([0, 1, 1]), 0b110);
/// assert_eq!(psi_octree::morton_code([3, 0, 0]), 0b1001);
/// ```
pub fn morton_code(c: [u64; 3]) -> u64 {
    morton(c)
}

/// [`morton_code`].
fn morton(c: [u64; 3]) -> u64 {
    spread(c[0]) | spread(c[1]) << 1 | spread(c[2]) << 2
}

/// The first position in `keys` (ascending) whose key is at least `key`, searched outward from
/// position `near` by doubling steps, then by bisection.
fn lower_bound_near(keys: &[u64], key: u64, near: usize) -> usize {
    let n = keys.len();
    let near = near.min(n);
    let (lo, hi) = if near < n && keys[near] < key {
        // After `near`: widen until a key reaches `key` or the end.
        let (mut lo, mut step) = (near + 1, 1);
        loop {
            let hi = (near + step).min(n);
            if hi == n || keys[hi] >= key {
                break (lo, hi);
            }
            lo = hi + 1;
            step *= 2;
        }
    } else {
        // At or before `near`: widen until a key falls below `key` or the start.
        let (mut hi, mut step) = (near, 1);
        loop {
            let lo = near.saturating_sub(step);
            if lo == 0 || keys[lo] < key {
                break (lo, hi);
            }
            hi = lo;
            step *= 2;
        }
    };
    lo + keys[lo..hi].partition_point(|&k| k < key)
}

/// Squared distance from `x` to the box `(low, high)` (0 inside).
fn box_distance2((low, high): (DVec3, DVec3), x: DVec3) -> f64 {
    (low - x).max(x - high).max(DVec3::ZERO).length_squared()
}

/// A neighbour: `(squared distance, original index, slot)`.
type Found = (f64, u32, u32);

/// A neighbour as one sortable key: the squared distance's bits (non-negative, so ordered as
/// the distances), then the original index, then the slot: the (distance, original index)
/// order of neighbours, the original index breaking ties.
type Key = u128;

fn pack(d2: f64, id: u32, slot: u32) -> Key {
    (u128::from(d2.to_bits()) << 64) | (u128::from(id) << 32) | u128::from(slot)
}

/// The squared distance of a key.
fn key_distance2(key: Key) -> f64 {
    f64::from_bits((key >> 64) as u64)
}

/// The neighbour of a key.
fn unpack(key: Key) -> Found {
    (key_distance2(key), (key >> 32) as u32, key as u32)
}

/// The k best neighbours met so far: a max-heap of their keys, so that a nearer one replaces
/// the worst in O(log k) (k reaches 256 in the noise estimate's searches).
struct Best {
    k: usize,
    heap: BinaryHeap<Key>,
}

impl Best {
    fn new(k: usize) -> Self {
        Self {
            k,
            heap: BinaryHeap::with_capacity(k),
        }
    }

    fn full(&self) -> bool {
        self.heap.len() >= self.k
    }

    /// The k-th squared distance (infinite until k are found).
    fn worst(&self) -> f64 {
        match self.heap.peek() {
            Some(&top) if self.full() => key_distance2(top),
            _ => f64::INFINITY,
        }
    }

    fn offer(&mut self, f: Found) {
        let key = pack(f.0, f.1, f.2);
        if !self.full() {
            self.heap.push(key);
        } else if let Some(mut top) = self.heap.peek_mut()
            && key < *top
        {
            *top = key;
        }
    }

    fn clear(&mut self) {
        self.heap.clear();
    }

    /// The neighbours found, nearest first; the list is left empty.
    fn take_sorted(&mut self) -> Vec<Found> {
        let keys = std::mem::take(&mut self.heap).into_sorted_vec();
        keys.into_iter().map(unpack).collect()
    }
}

/// Points sorted in Morton order over their bounding cube, for exact nearest-neighbour queries
/// (world units; squared distances in world units²). Points with a non-finite coordinate are
/// left out: never a neighbour, and their sweep entries have no neighbours.
///
/// ```
/// use glam::DVec3;
/// use psi_octree::MortonIndex;
///
/// let points: Vec<DVec3> = (0..1000).map(|i| DVec3::new((i % 10) as f64, (i / 10 % 10) as f64, (i / 100) as f64)).collect();
/// let index = MortonIndex::new(&points);
/// // The 7 nearest of a grid corner: itself, its 3 edge neighbours, 3 face diagonals.
/// let near = index.nearest(DVec3::ZERO, 7);
/// assert_eq!(near.len(), 7);
/// assert_eq!(index.ids()[near[0].0 as usize], 0);
/// assert_eq!(near[6].1, 2.0);
/// // Every point's 6 nearest others, slot by slot: an inner point has its 6 at distance 1.
/// let counts = index.map_nearest(6, |_, near| near.iter().filter(|n| n.1 == 1.0).count());
/// let inner = index.ids().iter().position(|&i| i == 555).unwrap();
/// assert_eq!(counts[inner], 6);
/// ```
pub struct MortonIndex {
    /// The cube's low corner, world units.
    lo: DVec3,
    /// Quantised units per world unit.
    scale: f64,
    /// Slack added to every cell's extent when pruning, world units (rounding of quantisation).
    slack: f64,
    /// Morton keys, ascending (shape: M, the finite points).
    keys: Vec<u64>,
    /// Original index of each slot (shape: M).
    ids: Vec<u32>,
    /// Positions by slot (shape: M).
    points: Vec<DVec3>,
    /// Occupied cells per level (shape: 22).
    cells: [usize; BITS as usize + 1],
}

/// The Morton key of `p` (world units, finite) in the frame of low corner `lo` and `scale`
/// quantised units per world unit, clamped to the grid.
fn key_in(p: DVec3, lo: DVec3, scale: f64) -> u64 {
    let q = ((p - lo) * scale).clamp(DVec3::ZERO, DVec3::splat(GRID));
    morton([q.x as u64, q.y as u64, q.z as u64])
}

/// The number of occupied cells of each level (shape: 22) over ascending `keys`: consecutive
/// keys fall apart at the level of their highest differing bit.
fn cells_per_level(keys: &[u64]) -> [usize; BITS as usize + 1] {
    let mut first_split = [0usize; BITS as usize + 1];
    for w in keys.windows(2) {
        let x = w[0] ^ w[1];
        if x != 0 {
            let bit = 63 - x.leading_zeros();
            first_split[(BITS - bit / 3) as usize] += 1;
        }
    }
    let mut cells = [1usize; BITS as usize + 1];
    for l in 1..=BITS as usize {
        cells[l] = cells[l - 1] + first_split[l];
    }
    cells
}

impl std::fmt::Debug for MortonIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MortonIndex")
            .field("len", &self.len())
            .finish()
    }
}

impl MortonIndex {
    /// Sorts `positions` (shape: N, world units) into Morton order, ties by index.
    ///
    /// # Panics
    ///
    /// When N ≥ 2^32 − 1 (indices are 32-bit).
    pub fn new(positions: &[DVec3]) -> Self {
        assert!(
            positions.len() < u32::MAX as usize,
            "MortonIndex: {} points, at most 2^32 - 2",
            positions.len()
        );
        let bounds = Aabb::from_points(positions.iter().copied().filter(|p| p.is_finite()));
        let (lo, extent) = bounds.map_or((DVec3::ZERO, 0.0), |b| (b.min, b.extent().max_element()));
        let scale = if extent > 0.0 { GRID / extent } else { 0.0 };
        let mut keyed: Vec<(u64, u32)> = positions
            .par_iter()
            .enumerate()
            .filter(|(_, p)| p.is_finite())
            .map(|(i, p)| (key_in(*p, lo, scale), i as u32))
            .collect();
        keyed.par_sort_unstable();
        let keys: Vec<u64> = keyed.par_iter().map(|k| k.0).collect();
        let ids: Vec<u32> = keyed.par_iter().map(|k| k.1).collect();
        let points = ids.par_iter().map(|&i| positions[i as usize]).collect();
        Self {
            lo,
            scale,
            // Rounding of positions far from the origin as well as of the quantisation.
            slack: 1e-9 * extent + 8.0 * f64::EPSILON * (lo.abs().max_element() + extent),
            cells: cells_per_level(&keys),
            keys,
            ids,
            points,
        }
    }

    /// The index of the slots for which `keep` holds, in the same order and frame (no sort).
    pub fn subset(&self, keep: impl Fn(usize) -> bool + Sync) -> Self {
        let slots: Vec<usize> = (0..self.len())
            .into_par_iter()
            .filter(|&s| keep(s))
            .collect();
        let keys: Vec<u64> = slots.par_iter().map(|&s| self.keys[s]).collect();
        Self {
            lo: self.lo,
            scale: self.scale,
            slack: self.slack,
            cells: cells_per_level(&keys),
            keys,
            ids: slots.par_iter().map(|&s| self.ids[s]).collect(),
            points: slots.par_iter().map(|&s| self.points[s]).collect(),
        }
    }

    /// The index of the points for which `keep` (shape: N, by original index) holds, numbered
    /// as `Vec::retain` with `keep` numbers them (a point's new index is the number of kept
    /// points before it): the index [`MortonIndex::new`] makes of the retained positions, up to
    /// its frame, so every query answers the same (answers depend on the positions alone).
    /// Same frame and order, no sort.
    ///
    /// # Panics
    ///
    /// When `keep` is shorter than an indexed point's original index.
    pub fn retained(&self, keep: &[bool]) -> Self {
        let mut rank = Vec::with_capacity(keep.len());
        let mut kept = 0u32;
        for &k in keep {
            rank.push(kept);
            kept += u32::from(k);
        }
        let sub = self.subset(|s| keep[self.ids[s] as usize]);
        Self {
            ids: sub.ids.par_iter().map(|&i| rank[i as usize]).collect(),
            ..sub
        }
    }

    /// Indexed points (the finite ones).
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// Whether no point is indexed.
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// The original index of each slot (shape: M).
    pub fn ids(&self) -> &[u32] {
        &self.ids
    }

    /// The positions by slot (shape: M, world units).
    pub fn points(&self) -> &[DVec3] {
        &self.points
    }

    /// Edge of a cell of `level`, world units.
    fn cell_edge(&self, level: u32) -> f64 {
        if self.scale > 0.0 {
            (1u64 << (BITS - level)) as f64 / self.scale
        } else {
            0.0
        }
    }

    /// The cell coordinates of `x` at `level`, clamped into the grid.
    fn cell_of(&self, x: DVec3, level: u32) -> [u64; 3] {
        let q = ((x - self.lo) * self.scale).clamp(DVec3::ZERO, DVec3::splat(GRID));
        let shift = BITS - level;
        [
            q.x as u64 >> shift,
            q.y as u64 >> shift,
            q.z as u64 >> shift,
        ]
    }

    /// The slots of cell `c` of `level` within the slots `within` (which hold it).
    fn cell_range(&self, c: [u64; 3], level: u32, within: (usize, usize)) -> (usize, usize) {
        let shift = 3 * (BITS - level);
        let first = morton(c) << shift;
        let keys = &self.keys[within.0..within.1];
        let a = keys.partition_point(|&k| k < first);
        let b = if level == 0 {
            keys.len()
        } else {
            a + keys[a..].partition_point(|&k| k >> shift == first >> shift)
        };
        (within.0 + a, within.0 + b)
    }

    /// [`MortonIndex::cell_range`] over all slots, searched outward from slot `near` (a
    /// galloping search: neighbouring cells lie mostly near in Morton order, so the search
    /// stays in cache where a binary search over all keys would not).
    fn cell_range_near(&self, c: [u64; 3], level: u32, near: usize) -> (usize, usize) {
        if level == 0 {
            return (0, self.len());
        }
        let shift = 3 * (BITS - level);
        let a = lower_bound_near(&self.keys, morton(c) << shift, near);
        let b = lower_bound_near(&self.keys, (morton(c) + 1) << shift, a);
        (a, b)
    }

    /// Child `t` (octant bits x, y, z) of cell `c` of `level`, whose slots are `range`: its
    /// cell coordinates at `level + 1` and its slots.
    fn child(
        &self,
        c: [u64; 3],
        level: u32,
        range: (usize, usize),
        t: u64,
    ) -> ([u64; 3], (usize, usize)) {
        let cc = [
            2 * c[0] + (t & 1),
            2 * c[1] + (t >> 1 & 1),
            2 * c[2] + (t >> 2),
        ];
        (cc, self.cell_range(cc, level + 1, range))
    }

    /// Squared distance from `x` to cell `c` of `level` (grown by the slack).
    fn cell_distance2(&self, x: DVec3, c: [u64; 3], level: u32) -> f64 {
        box_distance2(self.cell_box(c, level), x)
    }

    /// The low and high corners of cell `c` of `level`, grown by the slack (world units).
    fn cell_box(&self, c: [u64; 3], level: u32) -> (DVec3, DVec3) {
        let w = self.cell_edge(level);
        let lo = self.lo + DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) * w;
        (lo - self.slack, lo + DVec3::splat(w) + self.slack)
    }

    /// How far from `x` the block of cells of `level` within `ring` cells of cell `c` (3 × 3 × 3
    /// for ring 1) reaches in every direction (no limit on a side where the grid ends), less
    /// the slack.
    fn block_reach(&self, x: DVec3, c: [u64; 3], level: u32, ring: u64) -> f64 {
        let w = self.cell_edge(level);
        let last = (1u64 << level) - 1;
        let mut reach = f64::INFINITY;
        for a in 0..3 {
            if c[a] >= ring {
                reach = reach.min(x[a] - (self.lo[a] + (c[a] - ring) as f64 * w));
            }
            if c[a] + ring <= last {
                reach = reach.min(self.lo[a] + (c[a] + ring + 1) as f64 * w - x[a]);
            }
        }
        reach - self.slack
    }

    /// Offers the points of cell `c` of `level` (slots `range`) to `best`, nearest children first.
    fn visit(
        &self,
        x: DVec3,
        skip: u32,
        c: [u64; 3],
        level: u32,
        range: (usize, usize),
        best: &mut Best,
    ) {
        if range.0 == range.1 || self.cell_distance2(x, c, level) > best.worst() {
            return;
        }
        if range.1 - range.0 <= SCAN || level == BITS {
            for s in range.0..range.1 {
                if s as u32 != skip {
                    let d2 = (self.points[s] - x).length_squared();
                    best.offer((d2, self.ids[s], s as u32));
                }
            }
            return;
        }
        // The occupied children, nearest first (on the stack: this runs once per cell visited).
        let mut children = [(0.0, [0u64; 3], (0usize, 0usize)); 8];
        let mut count = 0;
        for t in 0..8u64 {
            let (cc, r) = self.child(c, level, range, t);
            if r.0 < r.1 {
                children[count] = (self.cell_distance2(x, cc, level + 1), cc, r);
                count += 1;
            }
        }
        let children = &mut children[..count];
        children.sort_by(|a, b| a.0.total_cmp(&b.0));
        for &(_, cc, r) in children.iter() {
            self.visit(x, skip, cc, level + 1, r, best);
        }
    }

    /// The `k` nearest indexed points to `x` other than slot `skip` (`u32::MAX`: none), first
    /// trying the 27 cells of `level` around `x`, then coarser levels until the block holds them.
    fn search(&self, x: DVec3, k: usize, skip: u32, mut level: u32) -> Vec<Found> {
        if k == 0 || !x.is_finite() || self.is_empty() {
            return Vec::new();
        }
        loop {
            let mut best = Best::new(k);
            let c = self.cell_of(x, level);
            let last = (1u64 << level) - 1;
            let home = self.cell_range(c, level, (0, self.len())).0;
            for dz in -1i64..=1 {
                for dy in -1i64..=1 {
                    for dx in -1i64..=1 {
                        let cc = [c[0] as i64 + dx, c[1] as i64 + dy, c[2] as i64 + dz];
                        if cc.iter().any(|&v| v < 0 || v > last as i64) {
                            continue;
                        }
                        let cc = cc.map(|v| v as u64);
                        let r = self.cell_range_near(cc, level, home);
                        self.visit(x, skip, cc, level, r, &mut best);
                    }
                }
            }
            let reach = self.block_reach(x, c, level, 1);
            if level == 0 || (best.full() && best.worst() <= reach * reach.abs()) {
                return best.take_sorted();
            }
            level = level.saturating_sub(2);
        }
    }

    /// The `k` nearest indexed points to `x` (world units) as `(slot, squared distance)`, in
    /// increasing (distance, original index) order; fewer when fewer are indexed, none for a
    /// non-finite `x`.
    pub fn nearest(&self, x: DVec3, k: usize) -> Vec<(u32, f64)> {
        let k = k.min(self.len());
        let level = self.level_for(k);
        self.search(x, k, u32::MAX, level)
            .into_iter()
            .map(|f| (f.2, f.0))
            .collect()
    }

    /// The `k` nearest indexed points to the point at `slot` other than itself, as `(slot,
    /// squared distance)` in increasing (distance, original index) order: the neighbours
    /// [`MortonIndex::map_nearest`] gives that slot, for one point alone.
    ///
    /// # Panics
    ///
    /// When `slot` is not below [`MortonIndex::len`].
    pub fn nearest_other(&self, slot: usize, k: usize) -> Vec<(u32, f64)> {
        let k = k.min(self.len().saturating_sub(1));
        let level = self.level_for(k);
        self.search(self.points[slot], k, slot as u32, level)
            .into_iter()
            .map(|f| (f.2, f.0))
            .collect()
    }

    /// The number of indexed points whose Morton key (in this index's frame) is below that of
    /// `x` (world units; clamped to the index's cube): the slot `x` would take in the order,
    /// before any point of its key. A non-finite `x` ranks 0.
    pub fn rank_of(&self, x: DVec3) -> usize {
        if !x.is_finite() {
            return 0;
        }
        let key = key_in(x, self.lo, self.scale);
        self.keys.partition_point(|&k| k < key)
    }

    /// The finest level whose occupied cells hold on average at least `OCCUPANCY × k` points.
    fn level_for(&self, k: usize) -> u32 {
        let target = OCCUPANCY * k.max(1) as f64;
        (1..=BITS)
            .take_while(|&l| self.len() as f64 / self.cells[l as usize] as f64 >= target)
            .last()
            .unwrap_or(0)
    }
}

#[path = "nearest_sweep.rs"]
mod nearest_sweep;

#[path = "morton_ball.rs"]
mod morton_ball;

#[path = "repeated_positions.rs"]
mod repeated_positions;

#[cfg(test)]
#[path = "morton_index_tests.rs"]
mod tests;
