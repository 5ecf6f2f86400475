//! The k nearest neighbours of every point of a set at once, from a uniform grid: the points of
//! a cell share the candidates of the cells around it, so that a query costs a few hundred
//! distance computations and no tree walk (a kd-tree query per point costs several times
//! more when every point is asked, as a tile's footprint asks).

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use glam::DVec3;

use crate::PointIndex;

/// The grid's cell edge over the median distance to the k-th nearest: cells of a few k points
/// each, so that the hash lookups of a cell's 27 neighbours are shared by many queries (the
/// distances are cheaper than the lookups).
const CELL_PER_KTH: f64 = 1.5;

/// Rings of grid cells searched around a point before its query goes to the kd-tree (a stray
/// point far from the others).
const MAX_RING: i64 = 2;

/// Calls `each(i, nearest)` for every point `i` of `positions` (shape N, any frame) with its
/// `k` nearest points (itself included) as `(index, squared distance)`, nearest first, equal
/// distances by index; fewer when there are fewer than `k` points. `index` is a kd-tree over
/// `positions`, asked for the points whose k nearest lie beyond `MAX_RING` cells (those may
/// order equal distances otherwise). Points are visited cell by cell of a grid whose cell edge
/// is `CELL_PER_KTH` × the median distance to the k-th nearest; the order of the calls is a
/// function of the positions.
pub fn all_k_nearest(
    positions: &[DVec3],
    index: &PointIndex,
    k: usize,
    mut each: impl FnMut(u32, &[(u32, f64)]),
) {
    let n = positions.len();
    if n == 0 || k == 0 {
        return;
    }
    let (lo, hi) = positions
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    let extent = (hi - lo).max_element().max(f64::MIN_POSITIVE);
    // The cell edge: from the median distance to the k-th nearest over up to 64 points
    // spread through the index order (a point's k nearest then lie within its cell's ring of
    // neighbours); any edge gives the right answer, this one few lookups and few rings,
    // whatever strays widen the box.
    let want = k.min(n);
    let mut kth: Vec<f64> = (0..n)
        .step_by(n.div_ceil(64))
        .map(|i| {
            index
                .nearest(positions[i], want)
                .last()
                .map_or(0.0, |&(_, d2)| d2.sqrt())
        })
        .collect();
    kth.sort_unstable_by(f64::total_cmp);
    let h = (CELL_PER_KTH * kth[kth.len() / 2]).max(extent * 1e-9);
    let cell_of = |p: DVec3| {
        let c = ((p - lo) / h).floor();
        [c.x as i64, c.y as i64, c.z as i64]
    };
    let mut order: Vec<u32> = (0..n as u32).collect();
    let keys: Vec<[i64; 3]> = positions.iter().map(|&p| cell_of(p)).collect();
    order.sort_unstable_by_key(|&i| (keys[i as usize], i));
    // The runs of `order` that share a cell, in order, and a map from cell to run.
    let mut runs: Vec<([i64; 3], usize, usize)> = Vec::new();
    let mut start = 0;
    while start < n {
        let key = keys[order[start] as usize];
        let mut end = start + 1;
        while end < n && keys[order[end] as usize] == key {
            end += 1;
        }
        runs.push((key, start, end));
        start = end;
    }
    let cells: HashMap<[i64; 3], (usize, usize), BuildHasherDefault<CellHasher>> = runs
        .iter()
        .map(|&(key, start, end)| (key, (start, end)))
        .collect();
    let mut candidates: Vec<u32> = Vec::new();
    let mut found: Vec<(u32, f64)> = Vec::with_capacity(n.min(4096));
    for &(key, start, end) in &runs {
        // Rings of cells around this one until every point of the cell has its k nearest
        // within the searched cube.
        let mut ring = 1i64;
        let mut pending: Vec<u32> = order[start..end].to_vec();
        while !pending.is_empty() {
            candidates.clear();
            for dz in -ring..=ring {
                for dy in -ring..=ring {
                    for dx in -ring..=ring {
                        let c = [key[0] + dx, key[1] + dy, key[2] + dz];
                        if let Some(&(a, b)) = cells.get(&c) {
                            candidates.extend_from_slice(&order[a..b]);
                        }
                    }
                }
            }
            let low = lo
                + h * DVec3::new(
                    (key[0] - ring) as f64,
                    (key[1] - ring) as f64,
                    (key[2] - ring) as f64,
                );
            let high = low + DVec3::splat(h * (2 * ring + 1) as f64);
            let everything = candidates.len() == n;
            pending.retain(|&q| {
                let x = positions[q as usize];
                found.clear();
                found.extend(
                    candidates
                        .iter()
                        .map(|&j| (j, (positions[j as usize] - x).length_squared())),
                );
                let by = |a: &(u32, f64), b: &(u32, f64)| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0));
                if found.len() > want {
                    found.select_nth_unstable_by(want - 1, by);
                    found.truncate(want);
                }
                found.sort_unstable_by(by);
                // Every point outside the searched cube lies farther than x's distance to
                // the cube's faces.
                let inside = (x - low).min(high - x).min_element();
                let proven = found.len() == want && found[want - 1].1 <= inside * inside;
                if proven || everything {
                    each(q, &found);
                    false
                } else {
                    true
                }
            });
            ring += 1;
            if ring > MAX_RING {
                for &q in &pending {
                    let nearest = index.nearest(positions[q as usize], want);
                    each(q, &nearest);
                }
                pending.clear();
            }
        }
    }
}

/// A multiplicative hash of a cell's three coordinates (the default SipHash costs more than the
/// distances a query computes; the keys are not chosen by an adversary).
#[derive(Default)]
struct CellHasher(u64);

impl Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }

    fn write_i64(&mut self, v: i64) {
        self.write_u64(v as u64);
    }

    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    fn write_usize(&mut self, v: usize) {
        self.write_u64(v as u64);
    }
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    use super::*;

    /// Against the brute force: points on a sphere, a dense cluster and far strays, every k.
    #[test]
    fn all_k_nearest_is_the_brute_force() {
        let mut positions = Vec::new();
        let mut rng = Pcg64Mcg::seed_from_u64(12345);
        let mut next = || rng.random::<f64>();
        for _ in 0..1500 {
            let z = 2.0 * next() - 1.0;
            let t = std::f64::consts::TAU * next();
            let r = (1.0 - z * z).sqrt();
            positions.push(DVec3::new(r * t.cos(), r * t.sin(), z));
        }
        for _ in 0..200 {
            positions.push(DVec3::new(0.3, 0.2, 1.0) + 1e-3 * DVec3::new(next(), next(), next()));
        }
        positions.push(DVec3::new(40.0, -3.0, 2.0));
        positions.push(DVec3::new(-25.0, 9.0, 0.5));
        // Exact duplicates, for the ties.
        positions.push(positions[7]);
        positions.push(positions[7]);
        let index = PointIndex::new(&positions);
        for k in [1, 9, 20] {
            let mut seen = vec![false; positions.len()];
            all_k_nearest(&positions, &index, k, |q, nearest| {
                let x = positions[q as usize];
                let mut brute: Vec<(u32, f64)> = (0..positions.len() as u32)
                    .map(|j| (j, (positions[j as usize] - x).length_squared()))
                    .collect();
                brute.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
                brute.truncate(k);
                assert_eq!(nearest, &brute[..], "point {q}, k {k}");
                assert!(!seen[q as usize]);
                seen[q as usize] = true;
            });
            assert!(seen.iter().all(|&s| s), "k {k}: every point answered");
        }
        let mut calls = 0;
        let few = PointIndex::new(&positions[..3]);
        all_k_nearest(&positions[..3], &few, 9, |_, nearest| {
            assert_eq!(nearest.len(), 3);
            calls += 1;
        });
        assert_eq!(calls, 3);
    }
}
