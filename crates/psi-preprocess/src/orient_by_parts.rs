//! Normal orientation by parts: the orientation [`crate::orient_normals`] gives, bitwise, from
//! parts of the points (tiles, each with a halo of the points around it) that never need to be
//! held together. The tiling issue asks for it: the same maximum-|n·n| spanning forest whatever
//! the tiling, ties broken by the global input index.
//!
//! Why the parts suffice. `orient_normals` orients each tree of the maximum spanning forest of a
//! nearest-neighbour graph (Kruskal, edges in a strict order: weight, then the endpoints'
//! indices) from one seed point. A part that holds every point within the K-th neighbour
//! distance of its own points finds their neighbours exactly, so it knows every edge between
//! two of its own points; an edge of those that its own Kruskal drops is the lightest on a cycle
//! of the whole graph too, so it is in no maximum spanning forest (the cycle property; Tarjan,
//! *Data Structures and Network Algorithms*, 1983, ch. 6). What is left to join, once, is each
//! part's own forest and the edges between parts: at most one edge per point plus the edges
//! across the parts' faces.
//!
//! The propagation needs no tree either: along a kept edge (a, b) with n_a·n_b = d, the
//! depth-first walk gives b the side of a times the sign of d, so each tree's sides are a
//! union-find with parities (a point's side relative to its set's root), joined as Kruskal keeps
//! edges. An edge with d = 0 exactly (orthogonal normals) gives the point reached over it the
//! side its normal has, whatever the other's: those edges cut a tree into pieces whose sides
//! are then set from the seed outward. The seeds are `orient_normals`' own: per tree the point
//! of largest x (ties to the lower index), and for the tree of the largest same-sheet island
//! the largest x of that island.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::DVec3;
use psi_octree::{MortonIndex, OrientedPoint};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::disjoint_sets::Sets;
use crate::median::total_order_key;
use crate::neighbour_graph::K;

/// An edge of the orientation graph between points `lo` < `hi` (global indices): n_lo·n_hi and
/// whether the pair lies on one sheet (from either end, as `orient_normals` judges it).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct OrientEdge {
    /// Global index of the lower end.
    pub lo: u32,
    /// Global index of the higher end.
    pub hi: u32,
    /// n_lo·n_hi (unit normals as the part holds them).
    pub dot: f64,
    /// The pair is on one sheet.
    pub same: bool,
}

impl OrientEdge {
    /// The spanning forest's weight: |n·n|, plus 1 on one sheet (every same-sheet edge above
    /// every other one, as `orient_normals` ranks them).
    fn weight(&self) -> f64 {
        self.dot.abs() + if self.same { 1.0 } else { 0.0 }
    }

    /// Kruskal's order, ascending: heavier first, ties to the lower ends' indices (lower, then
    /// higher). The order [`OrientationJoin::offer`] takes edges in.
    pub fn kruskal_key(&self) -> (u64, u64) {
        (
            !self.weight().to_bits(),
            u64::from(self.lo) << 32 | u64::from(self.hi),
        )
    }
}

/// What one part contributes to the orientation ([`part_orientation_edges`]); small against
/// the part's points: at most one forest edge per own point, and the edges across its faces.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PartEdges {
    /// The part's own maximum spanning forest: the edges between two of its own points that its
    /// Kruskal kept, in the order it kept them (Kruskal's, [`OrientEdge::kruskal_key`]).
    pub forest: Vec<OrientEdge>,
    /// Edges from its own points to points of other parts, as seen from this part's end (the
    /// other part sees the same pair from its end when the pair is among its nearest too).
    pub across: Vec<OrientEdge>,
    /// A spanning forest of the same-sheet edges between its own points (the islands).
    pub same_links: Vec<(u32, u32)>,
}

/// A part's point whose nearest neighbours the part cannot certify: its halo does not reach
/// their distance.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error(
    "point {id}: its {neighbours} nearest reach {reach} (world units), beyond what the part holds"
)]
pub struct IncompletePart {
    /// The point's global index.
    pub id: u32,
    /// How many nearest neighbours were sought.
    pub neighbours: usize,
    /// The distance its neighbours reach (infinite when the part holds fewer than K others).
    pub reach: f64,
}

/// A part's contribution to the orientation: `points` (shape: M, world units, unit normals of
/// either sign) the part's own points and its halo, `ids` (shape: M) their global indices,
/// ascending, `own` (shape: M) which are the part's own (every point is exactly one part's own);
/// `complete(x, r)` tells whether every point of the whole set within `r` of `x` is among
/// `points`. Each own point's K nearest are certified by `complete`, else the uncertain point
/// whose neighbours reach farthest is returned. Deterministic, whatever the thread count.
///
/// # Panics
///
/// When the lengths differ or `ids` do not ascend.
pub fn part_orientation_edges(
    points: &[OrientedPoint],
    ids: &[u32],
    own: &[bool],
    complete: &(dyn Fn(DVec3, f64) -> bool + Sync),
) -> Result<PartEdges, IncompletePart> {
    assert!(points.len() == ids.len() && ids.len() == own.len());
    assert!(ids.is_sorted(), "ids ascend");
    let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
    // Ties among neighbours go to the lower local index, which is the lower global index.
    let index = MortonIndex::new(&positions);
    let slot_ids = index.ids();
    // Per own point (by slot): up to K pairs (local others, `u32::MAX` past the last) and which
    // are on its sheet from its end (bits), or its reach; fixed arrays, no allocation a point.
    let rows: Vec<Result<([u32; K], u8), IncompletePart>> = index.map_nearest(K, |s, near| {
        let (mut to, mut same) = ([u32::MAX; K], 0u8);
        let i = slot_ids[s] as usize;
        if !own[i] {
            return Ok((to, same));
        }
        let p = &points[i];
        let reach = if near.len() < K {
            f64::INFINITY
        } else {
            near[K - 1].1.sqrt()
        };
        if !complete(p.p, reach) {
            return Err(IncompletePart {
                id: ids[i],
                neighbours: K,
                reach,
            });
        }
        for (k, &(t, d2)) in near.iter().filter(|n| n.1 > 0.0).enumerate() {
            let q = &points[slot_ids[t as usize] as usize];
            to[k] = slot_ids[t as usize];
            if p.n.dot(q.p - p.p).abs() <= 0.5 * d2.sqrt() {
                same |= 1 << k;
            }
        }
        Ok((to, same))
    });
    let rows = certified(rows)?;
    // Directed pairs (local ends), then each undirected pair once, same-sheet from either end.
    let mut inner: Vec<(u32, u32, bool)> = Vec::new();
    let mut across: Vec<OrientEdge> = Vec::new();
    for (s, (to, same_bits)) in rows.into_iter().enumerate() {
        let a = slot_ids[s];
        for (k, &b) in to.iter().enumerate().take_while(|(_, b)| **b != u32::MAX) {
            let same = same_bits >> k & 1 == 1;
            if own[b as usize] {
                inner.push((a.min(b), a.max(b), same));
            } else {
                let (lo, hi) = (
                    ids[a as usize].min(ids[b as usize]),
                    ids[a as usize].max(ids[b as usize]),
                );
                let dot = points[a as usize].n.dot(points[b as usize].n);
                across.push(OrientEdge { lo, hi, dot, same });
            }
        }
    }
    inner.par_sort_unstable();
    let mut edges: Vec<(u32, u32, OrientEdge)> = Vec::with_capacity(inner.len());
    for (a, b, same) in inner {
        match edges.last_mut() {
            Some(last) if (last.0, last.1) == (a, b) => last.2.same |= same,
            _ => edges.push((
                a,
                b,
                OrientEdge {
                    lo: ids[a as usize],
                    hi: ids[b as usize],
                    dot: points[a as usize].n.dot(points[b as usize].n),
                    same,
                },
            )),
        }
    }
    edges.par_sort_unstable_by_key(|e| e.2.kruskal_key());
    let n = points.len();
    let (mut trees, mut sheets) = (Sets::new(n), Sets::new(n));
    let mut part = PartEdges::default();
    for &(a, b, e) in &edges {
        if trees.join(a, b) {
            part.forest.push(e);
        }
        if e.same && sheets.join(a, b) {
            part.same_links.push((e.lo, e.hi));
        }
    }
    across.par_sort_unstable_by_key(|e| (e.lo, e.hi));
    part.across = across;
    Ok(part)
}

/// The rows when every own point was certified, else the uncertain point whose neighbours
/// reach farthest (a halo grown to its reach certifies them all in one more try).
pub(crate) fn certified<T>(rows: Vec<Result<T, IncompletePart>>) -> Result<Vec<T>, IncompletePart> {
    let worst = rows
        .iter()
        .filter_map(|r| r.as_ref().err())
        .max_by(|a, b| a.reach.total_cmp(&b.reach).then(b.id.cmp(&a.id)));
    match worst {
        Some(&e) => Err(e),
        None => Ok(rows.into_iter().map(|r| r.expect("certified")).collect()),
    }
}

/// Union-find with parities: each member's side relative to its set's root (union by the
/// smaller root; a lookup points the path at the root, each member with its parity to it).
struct SidedSets {
    parent: Vec<u32>,
    /// Whether the member's side is the opposite of its parent's.
    flip: Vec<bool>,
}

impl SidedSets {
    fn new(n: usize) -> Self {
        Self {
            parent: (0..n as u32).collect(),
            flip: vec![false; n],
        }
    }

    /// The root of `i` and whether `i`'s side is the opposite of the root's.
    fn root(&mut self, i: u32) -> (u32, bool) {
        // The root and i's parity to it, then each member of the path pointed at the root with
        // its own parity (i's, less the flips passed).
        let (mut at, mut parity) = (i, false);
        while self.parent[at as usize] != at {
            parity ^= self.flip[at as usize];
            at = self.parent[at as usize];
        }
        let root = at;
        let (mut at, mut own) = (i, parity);
        while at != root {
            let (next, step) = (self.parent[at as usize], self.flip[at as usize]);
            self.parent[at as usize] = root;
            self.flip[at as usize] = own;
            own ^= step;
            at = next;
        }
        (root, parity)
    }

    /// Joins the sets of `a` and `b` so that b's side is a's, or its opposite when `opposed`.
    fn join(&mut self, a: u32, b: u32, opposed: bool) {
        let ((ra, fa), (rb, fb)) = (self.root(a), self.root(b));
        if ra == rb {
            return;
        }
        let (top, low) = (ra.min(rb), ra.max(rb));
        self.parent[low as usize] = top;
        self.flip[low as usize] = fa ^ fb ^ opposed;
    }
}

/// The edges across parts (`halves`: every part's [`PartEdges::across`]) with each pair once,
/// on one sheet when either end found it so, sorted by their ends.
pub fn merge_across(mut halves: Vec<OrientEdge>) -> Vec<OrientEdge> {
    halves.par_sort_unstable_by_key(|e| (e.lo, e.hi));
    let mut joined: Vec<OrientEdge> = Vec::with_capacity(halves.len());
    for e in halves {
        match joined.last_mut() {
            Some(last) if (last.lo, last.hi) == (e.lo, e.hi) => last.same |= e.same,
            _ => joined.push(e),
        }
    }
    joined
}

/// The join of the parts' contributions over N points (global indices below N), fed one edge
/// at a time in Kruskal's order, so that the edges need not be held (a caller merges the
/// parts' sorted forests from files): the trees, each point's side within the pieces of its
/// tree that no n·n = 0 edge cuts, those edges, and the same-sheet islands. Memory: about 26
/// bytes a point.
pub struct OrientationJoin {
    trees: Sets,
    sides: SidedSets,
    sheets: Sets,
    cuts: Vec<OrientEdge>,
    last: Option<(u64, u64)>,
}

impl OrientationJoin {
    /// The join of `n` points, nothing joined yet.
    pub fn new(n: usize) -> Self {
        Self {
            trees: Sets::new(n),
            sides: SidedSets::new(n),
            sheets: Sets::new(n),
            cuts: Vec::new(),
            last: None,
        }
    }

    /// Puts points `a` and `b` in one same-sheet island (a part's [`PartEdges::same_links`],
    /// or an edge across that is on one sheet); any order.
    pub fn link_same(&mut self, a: u32, b: u32) {
        self.sheets.join(a, b);
    }

    /// Kruskal's step for the next edge (a part's forest edge or an edge across, each pair
    /// once: [`merge_across`]).
    ///
    /// # Panics
    ///
    /// When `e` comes before an edge offered earlier in [`OrientEdge::kruskal_key`]'s order.
    pub fn offer(&mut self, e: OrientEdge) {
        let key = e.kruskal_key();
        assert!(
            self.last.is_none_or(|last| last <= key),
            "edges offered out of Kruskal's order"
        );
        self.last = Some(key);
        if self.trees.join(e.lo, e.hi) {
            if e.dot == 0.0 {
                self.cuts.push(e);
            } else {
                self.sides.join(e.lo, e.hi, e.dot < 0.0);
            }
        }
    }

    /// Per point, whether `orient_normals` flips its normal, once every edge was offered and
    /// every same-sheet link made: `x(i)` is point i's x coordinate and `x_negative(i)` whether
    /// its normal's x is negative (the seeds' rule).
    pub fn flips(
        mut self,
        x: &(dyn Fn(u32) -> f64 + Sync),
        x_negative: &(dyn Fn(u32) -> bool + Sync),
    ) -> Vec<bool> {
        let n = self.sheets.len();
        let (trees, sides, sheets) = (&mut self.trees, &mut self.sides, &mut self.sheets);
        // The seeds: the first point of each tree in the order largest x first (ties to the
        // lower index); the tree of the largest same-sheet island starts at that island's
        // first point.
        let order_key = |i: u32| (Reverse(total_order_key(x(i))), i);
        let mut island_size = vec![0u32; n];
        for i in 0..n as u32 {
            island_size[sheets.root(i) as usize] += 1;
        }
        let largest = island_size.iter().copied().max().unwrap_or(0);
        let mut seed: Vec<u32> = vec![u32::MAX; n];
        let mut first: Option<u32> = None;
        for i in 0..n as u32 {
            let t = trees.root(i) as usize;
            if seed[t] == u32::MAX || order_key(i) < order_key(seed[t]) {
                seed[t] = i;
            }
            if island_size[sheets.root(i) as usize] == largest
                && first.is_none_or(|f| order_key(i) < order_key(f))
            {
                first = Some(i);
            }
        }
        if let Some(f) = first {
            seed[trees.root(f) as usize] = f;
        }
        // Each piece's root side: from its tree's seed, then across the cuts outward (the point
        // a cut reaches keeps its normal's side).
        let mut piece_flip: Vec<Option<bool>> = vec![None; n];
        for &s in seed.iter().filter(|&&s| s != u32::MAX) {
            let (r, f) = sides.root(s);
            piece_flip[r as usize] = Some(x_negative(s) ^ f);
        }
        let mut pending = std::mem::take(&mut self.cuts);
        while !pending.is_empty() {
            let before = pending.len();
            pending.retain(|e| {
                let ((ra, fa), (rb, fb)) = (sides.root(e.lo), sides.root(e.hi));
                match (piece_flip[ra as usize], piece_flip[rb as usize]) {
                    // lo's piece set: hi is reached from lo and keeps its side.
                    (Some(_), None) => {
                        piece_flip[rb as usize] = Some(fb);
                        false
                    }
                    (None, Some(_)) => {
                        piece_flip[ra as usize] = Some(fa);
                        false
                    }
                    (Some(_), Some(_)) => false,
                    (None, None) => true,
                }
            });
            assert!(
                pending.len() < before,
                "every piece hangs from its tree's seed"
            );
        }
        (0..n as u32)
            .map(|i| {
                let (r, f) = sides.root(i);
                piece_flip[r as usize].expect("every piece has a side") ^ f
            })
            .collect()
    }
}

/// The sides of the `n` points whose parts gave `parts` ([`part_orientation_edges`], every
/// part of one partition), all held at once: per point, whether `orient_normals` flips its
/// normal. `x(i)` is point i's x coordinate and `x_negative(i)` whether its normal's x is
/// negative (the seeds' rule). [`OrientationJoin`] does the same from edges streamed in order.
pub fn orientation_flips(
    n: usize,
    parts: &[PartEdges],
    x: &(dyn Fn(u32) -> f64 + Sync),
    x_negative: &(dyn Fn(u32) -> bool + Sync),
) -> Vec<bool> {
    let mut join = OrientationJoin::new(n);
    let mut edges = merge_across(
        parts
            .iter()
            .flat_map(|p| p.across.iter().copied())
            .collect(),
    );
    for e in edges.iter().filter(|e| e.same) {
        join.link_same(e.lo, e.hi);
    }
    for &(a, b) in parts.iter().flat_map(|p| &p.same_links) {
        join.link_same(a, b);
    }
    edges.par_sort_unstable_by_key(|e| e.kruskal_key());
    // Each part's forest is in Kruskal's order already (kept as its Kruskal met them): merged
    // with the edges across, none copied.
    let mut runs: Vec<&[OrientEdge]> = parts.iter().map(|p| p.forest.as_slice()).collect();
    runs.push(&edges);
    let mut heads: BinaryHeap<Reverse<((u64, u64), usize)>> = runs
        .iter()
        .enumerate()
        .filter_map(|(r, run)| run.first().map(|e| Reverse((e.kruskal_key(), r))))
        .collect();
    let mut at = vec![0usize; runs.len()];
    while let Some(Reverse((_, r))) = heads.pop() {
        join.offer(runs[r][at[r]]);
        at[r] += 1;
        if let Some(e) = runs[r].get(at[r]) {
            heads.push(Reverse((e.kruskal_key(), r)));
        }
    }
    join.flips(x, x_negative)
}

/// Orients `points` (shape: N, unit normals of either sign) as [`crate::orient_normals`] does,
/// from `parts` ([`part_orientation_edges`] of a partition of these points, global indices into
/// `points`); returns the number flipped. Bitwise `orient_normals`' normals.
pub fn orient_by_parts(points: &mut [OrientedPoint], parts: &[PartEdges]) -> usize {
    let flips = {
        let pts = &*points;
        orientation_flips(pts.len(), parts, &|i| pts[i as usize].p.x, &|i| {
            pts[i as usize].n.x < 0.0
        })
    };
    let mut count = 0;
    for (p, flip) in points.iter_mut().zip(flips) {
        if flip {
            p.n = -p.n;
            count += 1;
        }
    }
    count
}

#[cfg(test)]
#[path = "orient_by_parts_tests.rs"]
mod tests;
