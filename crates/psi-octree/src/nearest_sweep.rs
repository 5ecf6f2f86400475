//! The all-points sweep of a [`MortonIndex`]: every indexed point's k nearest others, cell
//! by cell, each point starting from its predecessor's reach (a child module of
//! `morton_index`, which owns the fields).

use glam::DVec3;
use rayon::prelude::*;

use super::{BITS, Best, Found, MortonIndex, closer, morton};
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
        self.map_nearest_until(k, &|| false, f)
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
        let mapped = self.map_nearest_until(k, &|| monitor.stopped(), f);
        monitor.check()?;
        // (A stop seen by a cell is seen by the check above: the flag is never cleared.)
        debug_assert_eq!(mapped.len(), self.len());
        Ok(mapped)
    }

    /// [`map_nearest`](Self::map_nearest) leaving out the cells that start once `stop()` holds
    /// (the result is then shorter than the index).
    fn map_nearest_until<T: Send>(
        &self,
        k: usize,
        stop: &(dyn Fn() -> bool + Sync),
        f: impl Fn(usize, &[(u32, f64)]) -> T + Sync,
    ) -> Vec<T> {
        let k = k.min(self.len().saturating_sub(1));
        if k == 0 {
            return (0..self.len()).map(|s| f(s, &[])).collect();
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
                if stop() {
                    return Vec::new();
                }
                let (a, b) = (starts[cell], starts[cell + 1]);
                let c = self.cell_of(self.points[a], level);
                let near_cells = cells_at(c, cell, &offsets[..inner]);
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
                let mut within: Vec<Found> = Vec::with_capacity(4 * k);
                (a..b)
                    .map(|s| {
                        let x = self.points[s];
                        let reach1 = self.block_reach(x, c, level, 1);
                        // Fast path: gather the points within the bound, keep the k nearest.
                        if let Some((p, r)) = previous {
                            let bound = r + (x - p).length();
                            if k > 0 && bound <= reach1 {
                                let b2 = bound * bound * (1.0 + 1e-12);
                                within.clear();
                                for (cc, (ra, rb)) in &near_cells {
                                    if self.cell_distance2(x, *cc, level) > b2 {
                                        continue;
                                    }
                                    for t in *ra..*rb {
                                        let d2 = (self.points[t] - x).length_squared();
                                        if t != s && d2 <= b2 {
                                            within.push((d2, self.ids[t], t as u32));
                                        }
                                    }
                                }
                                if within.len() >= k {
                                    within.select_nth_unstable_by(k - 1, closer);
                                    let firsts = &mut within[..k];
                                    firsts.sort_unstable_by(closer);
                                    previous = Some((x, firsts[k - 1].0.sqrt()));
                                    near.clear();
                                    near.extend(firsts.iter().map(|g| (g.2, g.0)));
                                    return f(s, &near);
                                }
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
                        let fallback;
                        let found = if held {
                            &best.found
                        } else {
                            fallback = self.search(x, k, s as u32, level.saturating_sub(2));
                            &fallback
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
