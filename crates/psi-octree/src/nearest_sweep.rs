//! The all-points sweep of a [`MortonIndex`]: every indexed point's k nearest others, cell
//! by cell, each point starting from its predecessor's reach (a child module of
//! `morton_index`, which owns the fields). Most points take the block path: the points of the
//! 3 × 3 × 3 cells around a cell are copied once, coordinate by coordinate, and each point of
//! the cell keeps those within a radius the block contains; a point with fewer than k there
//! is searched cell by cell, as [`MortonIndex::nearest`] does.

use glam::DVec3;
use rayon::prelude::*;

use super::{BITS, Best, Key, MortonIndex, box_distance2, key_distance2, morton, pack};
use crate::{Interrupted, Monitor};

impl MortonIndex {
    /// For every slot s (in slot order), `f(s, near)` with `near` the `k` nearest other indexed
    /// points as `(slot, squared distance)` in increasing (distance, original index) order (a
    /// coincident twin is a neighbour; fewer than k when fewer are indexed). In parallel, cell by
    /// cell; the result does not depend on the thread count.
    pub fn map_nearest<T: Send>(
        &self,
        k: usize,
        f: impl Fn(usize, &[(u32, f64)]) -> T + Sync,
    ) -> Vec<T> {
        self.map_nearest_until(k, &|| false, &|_| true, f)
    }

    /// [`map_nearest`](Self::map_nearest), stopping once `monitor`'s flag is set (checked per
    /// cell of a few dozen points, before their searches): `Err(Interrupted)` then, the same
    /// result otherwise.
    pub fn map_nearest_with<T: Send>(
        &self,
        k: usize,
        monitor: &Monitor<'_>,
        f: impl Fn(usize, &[(u32, f64)]) -> T + Sync,
    ) -> Result<Vec<T>, Interrupted> {
        let mapped = self.map_nearest_until(k, &|| monitor.stopped(), &|_| true, f);
        monitor.check()?;
        // (A stop seen by a cell is seen by the check above: the flag is never cleared.)
        assert_eq!(mapped.len(), self.len());
        Ok(mapped)
    }

    /// [`map_nearest`](Self::map_nearest) for the slots `want` accepts alone (shape: one per
    /// wanted slot, in slot order): each the same answer the whole sweep gives it, in the time
    /// of the cells holding wanted slots.
    pub fn map_nearest_of<T: Send>(
        &self,
        k: usize,
        want: &(dyn Fn(usize) -> bool + Sync),
        f: impl Fn(usize, &[(u32, f64)]) -> T + Sync,
    ) -> Vec<T> {
        self.map_nearest_until(k, &|| false, want, f)
    }

    /// [`map_nearest`](Self::map_nearest) for the slots `want` accepts, leaving out the cells
    /// that start once `stop()` holds (the result is then shorter).
    fn map_nearest_until<T: Send>(
        &self,
        k: usize,
        stop: &(dyn Fn() -> bool + Sync),
        want: &(dyn Fn(usize) -> bool + Sync),
        f: impl Fn(usize, &[(u32, f64)]) -> T + Sync,
    ) -> Vec<T> {
        let k = k.min(self.len().saturating_sub(1));
        if k == 0 {
            return (0..self.len())
                .filter(|&s| want(s))
                .map(|s| f(s, &[]))
                .collect();
        }
        let level = self.level_for(k);
        let shift = 3 * (BITS - level);
        // The occupied cells of `level`: their first slots, and one past the last.
        let mut starts: Vec<usize> = vec![0];
        starts.extend(
            (1..self.len()).filter(|&s| self.keys[s] >> shift != self.keys[s - 1] >> shift),
        );
        starts.push(self.len());
        let cell_keys: Vec<u64> = starts[..starts.len() - 1]
            .iter()
            .map(|&s| self.keys[s] >> shift)
            .collect();
        let last = (1u64 << level) - 1;
        // Offsets to the cells within two of a cell, by ring, each ring nearest first.
        let mut offsets: Vec<[i64; 3]> = Vec::with_capacity(125);
        for dz in -2i64..=2 {
            for dy in -2i64..=2 {
                for dx in -2i64..=2 {
                    offsets.push([dx, dy, dz]);
                }
            }
        }
        let ring = |o: &[i64; 3]| o.iter().map(|v| v.abs()).max().unwrap_or(0);
        offsets.sort_by_key(|o| (ring(o), o.iter().map(|v| v * v).sum::<i64>()));
        let inner = offsets.iter().filter(|o| ring(o) <= 1).count();
        // The cell of `key` among `cell_keys`, searched outward from cell `from` (neighbours
        // in space are mostly near in Morton order: the search stays in cache).
        let find = |key: u64, from: usize| -> Option<usize> {
            let (mut lo, mut hi);
            if key >= cell_keys[from] {
                let mut step = 1;
                lo = from;
                loop {
                    hi = (from + step).min(cell_keys.len());
                    if hi == cell_keys.len() || cell_keys[hi] > key {
                        break;
                    }
                    lo = hi;
                    step *= 2;
                }
            } else {
                let mut step = 1;
                hi = from;
                loop {
                    lo = from.saturating_sub(step);
                    if lo == 0 || cell_keys[lo] <= key {
                        break;
                    }
                    hi = lo;
                    step *= 2;
                }
            }
            let j = lo + cell_keys[lo..hi].partition_point(|&k| k < key);
            (j < cell_keys.len() && cell_keys[j] == key).then_some(j)
        };
        // The occupied cells at `offsets` from cell `c` (cell number `from`), with their slots.
        let cells_at =
            |c: [u64; 3], from: usize, offsets: &[[i64; 3]]| -> Vec<([u64; 3], (usize, usize))> {
                offsets
                    .iter()
                    .filter_map(|o| {
                        let cc = [c[0] as i64 + o[0], c[1] as i64 + o[1], c[2] as i64 + o[2]];
                        if cc.iter().any(|&v| v < 0 || v > last as i64) {
                            return None;
                        }
                        let cc = cc.map(|v| v as u64);
                        let j = find(morton(cc), from)?;
                        Some((cc, (starts[j], starts[j + 1])))
                    })
                    .collect()
            };
        (0..cell_keys.len())
            .into_par_iter()
            .with_min_len(16)
            .flat_map_iter(|cell| {
                let (a, b) = (starts[cell], starts[cell + 1]);
                if stop() || !(a..b).any(want) {
                    return Vec::new();
                }
                let c = self.cell_of(self.points[a], level);
                let near_cells = cells_at(c, cell, &offsets[..inner]);
                let block = Block::gather(self, &near_cells, level);
                let mut hits = Hits::default();
                let mut outer_cells = None;
                let mut near: Vec<(u32, f64)> = Vec::with_capacity(k);
                let mut best = Best::new(k);
                // Offers the points of `cells` (nearer than the k-th found) to `best`.
                let scan =
                    |x: DVec3, s: usize, cells: &[([u64; 3], (usize, usize))], best: &mut Best| {
                        for (cc, (ra, rb)) in cells {
                            if self.cell_distance2(x, *cc, level) > best.worst() {
                                continue;
                            }
                            for t in *ra..*rb {
                                let d2 = (self.points[t] - x).length_squared();
                                if t != s && d2 <= best.worst() {
                                    best.offer((d2, self.ids[t], t as u32));
                                }
                            }
                        }
                    };
                let holds =
                    |best: &Best, reach: f64| best.full() && best.worst() <= reach * reach.abs();
                // The previous point and its k-th distance: every point has k others within
                // that distance plus the step from the previous one (its k nearest and
                // itself, less the point if it was one of them).
                let mut previous: Option<(DVec3, f64)> = None;
                // (A point left out only loosens the next one's first bound.)
                (a..b)
                    .filter(|&s| want(s))
                    .map(|s| {
                        let x = self.points[s];
                        let reach1 = self.block_reach(x, c, level, 1);
                        // Fast path: gather the points of the block within a radius that
                        // stays inside it — the bound from the previous point when it does,
                        // else the block's reach — and keep the k nearest when there are k.
                        let bound = previous
                            .map(|(p, r)| r + (x - p).length())
                            .filter(|&bound| bound <= reach1);
                        let radius2 = match bound {
                            Some(bound) => bound * bound * (1.0 + 1e-12),
                            None => reach1 * reach1.abs(),
                        };
                        if radius2 > 0.0 {
                            let keys = hits.within(&block, x, s as u32, radius2, &self.ids);
                            if keys.len() >= k {
                                keys.select_nth_unstable(k - 1);
                                let firsts = &mut keys[..k];
                                firsts.sort_unstable();
                                near.clear();
                                near.extend(
                                    firsts.iter().map(|&key| (key as u32, key_distance2(key))),
                                );
                                previous = Some((x, near[k - 1].1.sqrt()));
                                return f(s, &near);
                            }
                        }
                        best.clear();
                        scan(x, s, &near_cells, &mut best);
                        let mut held = holds(&best, reach1);
                        if !held {
                            let outer = outer_cells
                                .get_or_insert_with(|| cells_at(c, cell, &offsets[inner..]));
                            scan(x, s, outer, &mut best);
                            held = holds(&best, self.block_reach(x, c, level, 2));
                        }
                        let found = if held {
                            best.take_sorted()
                        } else {
                            self.search(x, k, s as u32, level.saturating_sub(2))
                        };
                        previous = (found.len() == k).then(|| (x, found[k - 1].0.sqrt()));
                        near.clear();
                        near.extend(found.iter().map(|g| (g.2, g.0)));
                        f(s, &near)
                    })
                    .collect::<Vec<T>>()
            })
            .collect()
    }
}

/// The points of the 3 × 3 × 3 cells around a sweep cell, coordinate by coordinate (so that the
/// distance loops run over plain arrays), with each cell's box grown by the index's slack and
/// its range in the arrays.
struct Block {
    /// Per cell: its box (grown by the slack) and its range in the arrays.
    cells: Vec<((DVec3, DVec3), usize, usize)>,
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    slots: Vec<u32>,
}

impl Block {
    /// The block of `cells` (cell coordinates at `level`, slot ranges) of `index`.
    fn gather(index: &MortonIndex, cells: &[([u64; 3], (usize, usize))], level: u32) -> Self {
        let count: usize = cells.iter().map(|(_, (a, b))| b - a).sum();
        let mut block = Block {
            cells: Vec::with_capacity(cells.len()),
            x: Vec::with_capacity(count),
            y: Vec::with_capacity(count),
            z: Vec::with_capacity(count),
            slots: Vec::with_capacity(count),
        };
        for &(c, (a, b)) in cells {
            let start = block.x.len();
            for (t, p) in index.points[a..b].iter().enumerate() {
                block.x.push(p.x);
                block.y.push(p.y);
                block.z.push(p.z);
                block.slots.push((a + t) as u32);
            }
            block
                .cells
                .push((index.cell_box(c, level), start, block.x.len()));
        }
        block
    }
}

/// Scratch of [`Hits::within`].
#[derive(Default)]
struct Hits {
    d2: Vec<f64>,
    at: Vec<u32>,
    keys: Vec<Key>,
}

impl Hits {
    /// The points of `block` within squared distance `radius2` of `x`, other than slot `skip`,
    /// as keys (unordered). The test is written without branches (the hits are too irregular for
    /// the branch predictor); a cell farther than the radius is skipped whole.
    fn within(
        &mut self,
        block: &Block,
        x: DVec3,
        skip: u32,
        radius2: f64,
        ids: &[u32],
    ) -> &mut [Key] {
        let n = block.x.len();
        if self.at.len() < n {
            self.at.resize(n, 0);
            self.d2.resize(n, 0.0);
        }
        let mut count = 0;
        for &(cell_box, a, b) in &block.cells {
            if box_distance2(cell_box, x) > radius2 {
                continue;
            }
            // The distances first (a loop over plain arrays the compiler vectorises), then the
            // hits kept.
            let d2 = &mut self.d2[a..b];
            let coords = block.x[a..b].iter().zip(&block.y[a..b]).zip(&block.z[a..b]);
            for (d, ((px, py), pz)) in d2.iter_mut().zip(coords) {
                // As `(p - x).length_squared()`, to the bit.
                let (dx, dy, dz) = (px - x.x, py - x.y, pz - x.z);
                *d = dx * dx + dy * dy + dz * dz;
            }
            for (j, &d) in d2.iter().enumerate() {
                self.at[count] = (a + j) as u32;
                count += usize::from(d <= radius2);
            }
        }
        self.keys.clear();
        for &j in &self.at[..count] {
            let slot = block.slots[j as usize];
            if slot != skip {
                self.keys
                    .push(pack(self.d2[j as usize], ids[slot as usize], slot));
            }
        }
        &mut self.keys
    }
}
