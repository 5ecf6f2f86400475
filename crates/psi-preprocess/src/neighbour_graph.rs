//! The symmetric nearest-neighbour graphs that normal orientation propagates over, built in
//! Morton order (the points' slots in a [`MortonIndex`], where a propagation's next points lie
//! in cache) and stored compressed: one offset per point, the neighbours flat, sorted. Per
//! point, its K nearest others less those that coincide with it; a pair is on the same sheet when
//! the offset between the points is mostly tangential (|n_i·(p_j − p_i)| ≤ ½|p_j − p_i|, from
//! either end), so the two faces of a thin part do not pair as long as they are farther apart
//! than the sample spacing; the other pairs form a second graph (where noise of the order of
//! the sample spacing tilts the offsets, a dense scan's same-sheet graph falls apart into
//! islands; notes: 2026-11-25-density-invariance).

use psi_octree::{Monitor, MortonIndex, OrientedPoint};
use rayon::prelude::*;

/// Neighbours per point.
pub(crate) const K: usize = 8;

/// A graph over points 0..n, compressed: the neighbours of i are `targets[offsets[i]..offsets[i + 1]]`.
pub(crate) struct Graph {
    offsets: Vec<usize>,
    targets: Vec<u32>,
}

/// Rows per parallel block when a graph is built.
const BLOCK: usize = 4096;

impl Graph {
    /// A graph without points (every row empty).
    pub(crate) fn empty() -> Self {
        Self {
            offsets: vec![0],
            targets: Vec::new(),
        }
    }

    /// The neighbours of `i` (none past the last point).
    pub(crate) fn row(&self, i: usize) -> &[u32] {
        match (self.offsets.get(i), self.offsets.get(i + 1)) {
            (Some(&a), Some(&b)) => &self.targets[a..b],
            _ => &[],
        }
    }

    /// The undirected graph over `n` points with `edges` (each listed once, ends below `n`):
    /// an edge (a, b) puts b in row a and a in row b, each row in the edges' order. Flat
    /// arrays, where a vector per point cost a serial allocation each.
    pub(crate) fn from_edges(n: usize, edges: &[(u32, u32)]) -> Self {
        let mut offsets = vec![0usize; n + 1];
        for &(a, b) in edges {
            offsets[a as usize + 1] += 1;
            offsets[b as usize + 1] += 1;
        }
        for i in 0..n {
            offsets[i + 1] += offsets[i];
        }
        let mut next = offsets[..n].to_vec();
        let mut targets = vec![0u32; offsets[n]];
        for &(a, b) in edges {
            targets[next[a as usize]] = b;
            next[a as usize] += 1;
            targets[next[b as usize]] = a;
            next[b as usize] += 1;
        }
        Self { offsets, targets }
    }

    /// Points.
    pub(crate) fn len(&self) -> usize {
        self.offsets.len() - 1
    }

    /// The graph whose row i is what `row(i, out)` appends to `out`; rows are made in
    /// parallel, in blocks, and joined in order.
    fn from_rows(n: usize, row: impl Fn(usize, &mut Vec<u32>) + Sync) -> Self {
        let blocks: Vec<(Vec<usize>, Vec<u32>)> = (0..n.div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| {
                let (mut lens, mut flat) = (Vec::with_capacity(BLOCK), Vec::new());
                for i in b * BLOCK..((b + 1) * BLOCK).min(n) {
                    let before = flat.len();
                    row(i, &mut flat);
                    lens.push(flat.len() - before);
                }
                (lens, flat)
            })
            .collect();
        let mut offsets = Vec::with_capacity(n + 1);
        offsets.push(0);
        let mut targets = Vec::with_capacity(blocks.iter().map(|b| b.1.len()).sum());
        for (lens, flat) in blocks {
            for l in lens {
                offsets.push(offsets[offsets.len() - 1] + l);
            }
            targets.extend(flat);
        }
        Self { offsets, targets }
    }

    /// The graph of the directed `edges` (`(from, to)`, points below `n`) and their reverses,
    /// rows unsorted and with repeats.
    fn raw(n: usize, edges: impl Fn(&mut dyn FnMut(u32, u32))) -> Self {
        let mut offsets = vec![0usize; n + 1];
        edges(&mut |a, b| {
            offsets[a as usize + 1] += 1;
            offsets[b as usize + 1] += 1;
        });
        for i in 0..n {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut targets = vec![0u32; offsets[n]];
        edges(&mut |a, b| {
            targets[fill[a as usize]] = b;
            fill[a as usize] += 1;
            targets[fill[b as usize]] = a;
            fill[b as usize] += 1;
        });
        Self { offsets, targets }
    }
}

/// Points in Morton order with their neighbour graphs.
pub(crate) struct SlotGraphs {
    /// The original index of each slot (shape: M, the points with finite positions).
    pub(crate) ids: Vec<u32>,
    /// The points by slot (shape: M).
    pub(crate) sorted: Vec<OrientedPoint>,
    /// Same-sheet pairs, by slot.
    pub(crate) same: Graph,
    /// The other pairs (none also in `same`), by slot.
    pub(crate) other: Graph,
}

impl SlotGraphs {
    /// The normals of the slots written back to `points` (shape: N, the caller's order).
    pub(crate) fn write_normals(&self, points: &mut [OrientedPoint]) {
        for (&i, p) in self.ids.iter().zip(&self.sorted) {
            points[i as usize].n = p.n;
        }
    }
}

/// The Morton index of `points`' positions (shape: N).
pub(crate) fn morton_index_of(points: &[OrientedPoint]) -> MortonIndex {
    let positions: Vec<_> = points.iter().map(|p| p.p).collect();
    MortonIndex::new(&positions)
}

/// The neighbour graphs of `points` (shape: N, unit normals of either sign; `index` their
/// Morton index, dropped once the neighbours are found, before the graphs' memory peaks); None
/// once
/// `monitor`'s flag is set (checked during the neighbour search).
pub(crate) fn slot_graphs(
    points: &[OrientedPoint],
    index: MortonIndex,
    monitor: &Monitor<'_>,
) -> Option<SlotGraphs> {
    let ids = index.ids().to_vec();
    let sorted: Vec<OrientedPoint> = ids.par_iter().map(|&i| points[i as usize]).collect();
    // Per slot: up to K neighbours (u32::MAX past the last) and which are on the same sheet.
    let pairs = index.map_nearest_with(K, monitor, |s, near| {
        let (mut to, mut same) = ([u32::MAX; K], 0u8);
        let p = &sorted[s];
        for (k, &(t, d2)) in near.iter().filter(|n| n.1 > 0.0).enumerate() {
            let q = &sorted[t as usize];
            to[k] = t;
            if p.n.dot(q.p - p.p).abs() <= 0.5 * d2.sqrt() {
                same |= 1 << k;
            }
        }
        (to, same)
    });
    let pairs: Vec<([u32; K], u8)> = pairs.ok()?;
    drop(index);
    let n = sorted.len();
    let edges = |on_sheet: bool| {
        let pairs = &pairs;
        move |emit: &mut dyn FnMut(u32, u32)| {
            for (s, (to, same)) in pairs.iter().enumerate() {
                for (k, &t) in to.iter().enumerate() {
                    if t != u32::MAX && (same >> k & 1 == 1) == on_sheet {
                        emit(s as u32, t);
                    }
                }
            }
        }
    };
    let raw_same = Graph::raw(n, edges(true));
    let raw_other = Graph::raw(n, edges(false));
    drop(pairs);
    let same = Graph::from_rows(n, |i, out| {
        let mut row: Vec<u32> = raw_same.row(i).to_vec();
        row.sort_unstable();
        row.dedup();
        out.extend(row);
    });
    drop(raw_same);
    let other = Graph::from_rows(n, |i, out| {
        let mut row: Vec<u32> = raw_other.row(i).to_vec();
        row.sort_unstable();
        row.dedup();
        let on_sheet = same.row(i);
        out.extend(
            row.into_iter()
                .filter(|j| on_sheet.binary_search(j).is_err()),
        );
    });
    Some(SlotGraphs {
        ids,
        sorted,
        same,
        other,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_shapes::AnalyticShape;

    /// The graphs against their definition, pair by pair, by brute force.
    #[test]
    fn graphs_match_their_definition() {
        let points = AnalyticShape::Box {
            half: glam::DVec3::new(0.5, 0.4, 0.05),
        }
        .sample(1500, 3);
        let g = slot_graphs(&points, morton_index_of(&points), &Monitor::silent()).unwrap();
        assert_eq!((g.same.len(), g.other.len()), (1500, 1500));
        let n = points.len();
        let mut same = vec![std::collections::BTreeSet::new(); n];
        let mut other = vec![std::collections::BTreeSet::new(); n];
        for i in 0..n {
            let mut by: Vec<(f64, usize)> = (0..n)
                .filter(|&j| j != i)
                .map(|j| ((points[j].p - points[i].p).length_squared(), j))
                .collect();
            by.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            for &(d2, j) in by.iter().take(K).filter(|b| b.0 > 0.0) {
                let on = points[i].n.dot(points[j].p - points[i].p).abs() <= 0.5 * d2.sqrt();
                let g = if on { &mut same } else { &mut other };
                g[i].insert(j as u32);
                g[j].insert(i as u32);
            }
        }
        for s in 0..n {
            let i = g.ids[s] as usize;
            let to_ids = |row: &[u32]| -> std::collections::BTreeSet<u32> {
                row.iter().map(|&t| g.ids[t as usize]).collect()
            };
            assert_eq!(to_ids(g.same.row(s)), same[i], "same, point {i}");
            let expected: std::collections::BTreeSet<u32> =
                other[i].difference(&same[i]).copied().collect();
            assert_eq!(to_ids(g.other.row(s)), expected, "other, point {i}");
            assert!(g.same.row(s).is_sorted() && g.other.row(s).is_sorted());
        }
        assert!(Graph::empty().row(3).is_empty());
    }
}
