//! A kd-tree over point positions (kiddo 6), the alternative to [`crate::Octree::points_within`],
//! and its version after some points moved: the earlier tree, shared, with the moved points'
//! entries set aside and a small tree of their new positions beside it (an edit's cost follows
//! the points it moves, not the model; `docs/notes/2026-11-25-edit-index.md`).
//!
//! All kiddo calls of the workspace live in this file, so a change of kiddo's API touches only it.

use std::num::NonZeroUsize;
use std::sync::{Arc, Weak};

use glam::DVec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};

/// The kd-tree type of every index.
pub(crate) type Tree = ImmutableKdTree<f64, 3>;

/// Point counts from which the tree is built in parallel (kiddo's default is 262 144). The
/// resulting tree does not depend on the thread count (checked bitwise on 70k- and 480k-point
/// models with 1 and 2 threads).
const PARALLEL_FROM: usize = 32_768;

/// A version keeps at most `MOVED_FLOOR + n / MOVED_SHARE` moved points beside its base tree
/// (n the base's entries); past that the base is built again (the unit tests cross the line
/// often with a lower floor).
const MOVED_FLOOR: usize = if cfg!(test) { 100 } else { 4096 };
const MOVED_SHARE: usize = 32;

/// A kd-tree over positions (shape: N, world units); its items are indices into them, or the
/// ids given with them ([`PointIndex::with_items`]). Queries answer with the same sets, in some
/// order, whether the index was built afresh or derived by [`PointIndex::with_moved`].
pub struct PointIndex {
    /// The base tree (shared between versions).
    tree: Option<Arc<ImmutableKdTree<f64, 3>>>,
    /// The id of each base entry, ascending; `None`: entry k is id k.
    items: Option<Arc<[u32]>>,
    /// Ids moved since the base was built, ascending, and the same as a bit set: their base
    /// entries are stale.
    moved: Vec<u32>,
    stale: Vec<u64>,
    /// The moved ids' current entries (those the filter kept).
    overlay: Option<ImmutableKdTree<f64, 3>>,
    /// Live entries.
    len: usize,
}

impl std::fmt::Debug for PointIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PointIndex")
            .field("len", &self.len())
            .field("moved", &self.moved.len())
            .finish()
    }
}

/// Calls `f(item, squared distance)` for the entries of `t` with squared distance ≤ `r2`
/// from `x`, in no particular order.
fn ball_of(t: &ImmutableKdTree<f64, 3>, x: DVec3, r2: f64, mut f: impl FnMut(u32, f64)) {
    t.query(&x.to_array())
        .within::<SquaredEuclidean<f64>>(r2)
        .unsorted()
        .visit(|n| f(n.item, n.distance));
}

/// The `k` entries of `t` nearest `x` as `(item, squared distance)`, nearest first.
fn nearest_of(t: &ImmutableKdTree<f64, 3>, x: DVec3, k: NonZeroUsize) -> Vec<(u32, f64)> {
    t.query(&x.to_array())
        .nearest_n::<SquaredEuclidean<f64>>(k)
        .execute()
        .iter()
        .map(|n| (n.item, n.distance))
        .collect()
}

/// A kiddo tree over `points` whose item k is `item(k)`; `None` when empty or too large.
fn tree_of(points: &[DVec3], item: impl Fn(usize) -> u32) -> Option<ImmutableKdTree<f64, 3>> {
    if points.is_empty() || points.len() >= u32::MAX as usize {
        return None;
    }
    // Built straight from the positions (no coordinate copy: 1.7 MB for the bunny, which a
    // local regeneration would page in afresh).
    ImmutableKdTree::builder()
        .with_parallel_construction_threshold(PARALLEL_FROM)
        .build_from_source(points, |p: &DVec3, d| p[d], |i, _| item(i))
        .ok()
}

impl PointIndex {
    /// Builds the index. Non-finite positions are indexed as given; an empty slice gives an
    /// empty index whose queries return nothing.
    pub fn new(points: &[DVec3]) -> Self {
        let tree = tree_of(points, |i| i as u32);
        Self::based(tree, None)
    }

    /// Builds the index of `points` (shape: K) whose items are `items` (shape: K, ascending
    /// ids, e.g. the indices of a subset in a larger set).
    ///
    /// # Panics
    ///
    /// When the lengths differ or the ids do not ascend.
    pub fn with_items(points: &[DVec3], items: Vec<u32>) -> Self {
        assert_eq!(points.len(), items.len(), "one item per point");
        assert!(items.is_sorted(), "items ascend");
        let tree = tree_of(points, |i| items[i]);
        Self::based(tree, Some(items.into()))
    }

    fn based(tree: Option<ImmutableKdTree<f64, 3>>, items: Option<Arc<[u32]>>) -> Self {
        let len = tree.as_ref().map_or(0, |t| t.size());
        Self {
            tree: tree.map(Arc::new),
            items,
            moved: Vec::new(),
            stale: Vec::new(),
            overlay: None,
            len,
        }
    }

    /// The index after the points `moved` (ids) took new positions: `positions` (shape: N,
    /// every id's current position), an id indexed when `keep(position)` (always true for an
    /// index of all points; a subset's membership test otherwise). Costs time in the number
    /// of points moved since the base tree was built, which is built again (over the ids
    /// `0..N` that `keep` accepts) once they are many.
    pub fn with_moved(
        &self,
        moved: &[u32],
        positions: &[DVec3],
        keep: impl Fn(DVec3) -> bool,
    ) -> PointIndex {
        let mut all = self.moved.clone();
        all.extend_from_slice(moved);
        all.sort_unstable();
        all.dedup();
        let base_len = self.tree.as_ref().map_or(0, |t| t.size());
        if all.len() > MOVED_FLOOR + base_len / MOVED_SHARE {
            return match &self.items {
                None => PointIndex::new(positions),
                Some(_) => {
                    let ids: Vec<u32> = (0..positions.len() as u32)
                        .filter(|&i| keep(positions[i as usize]))
                        .collect();
                    let pts: Vec<DVec3> = ids.iter().map(|&i| positions[i as usize]).collect();
                    PointIndex::with_items(&pts, ids)
                }
            };
        }
        let mut stale = self.stale.clone();
        for &id in moved {
            let (word, bit) = ((id / 64) as usize, id % 64);
            if stale.len() <= word {
                stale.resize(word + 1, 0);
            }
            stale[word] |= 1 << bit;
        }
        let overlay_ids: Vec<u32> = all
            .iter()
            .copied()
            .filter(|&i| keep(positions[i as usize]))
            .collect();
        let pts: Vec<DVec3> = overlay_ids.iter().map(|&i| positions[i as usize]).collect();
        let overlay = tree_of(&pts, |k| overlay_ids[k]);
        // Live base entries: those of ids not moved.
        let in_base = |id: u32| match &self.items {
            None => (id as usize) < base_len,
            Some(items) => items.binary_search(&id).is_ok(),
        };
        let stale_in_base = all.iter().filter(|&&id| in_base(id)).count();
        PointIndex {
            tree: self.tree.clone(),
            items: self.items.clone(),
            len: base_len - stale_in_base + overlay_ids.len(),
            moved: all,
            stale,
            overlay,
        }
    }

    /// Number of indexed points.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether nothing is indexed.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether this version keeps more than half the moved points after which
    /// [`PointIndex::with_moved`] builds the base again: a caller with time to spare (between
    /// an editor's frames) builds a fresh index now rather than in a later frame.
    pub fn is_crowded(&self) -> bool {
        let base_len = self.tree.as_ref().map_or(0, |t| t.size());
        2 * self.moved.len() > MOVED_FLOOR + base_len / MOVED_SHARE
    }

    /// Whether id `id`'s base entry is stale.
    #[inline]
    pub(crate) fn is_stale(&self, id: u32) -> bool {
        self.stale
            .get((id / 64) as usize)
            .is_some_and(|w| w & (1 << (id % 64)) != 0)
    }

    /// Appends to `out` the indices of points with |p − x| ≤ `radius` (plain radius; kiddo is
    /// given the squared radius), in no particular order.
    pub fn within(&self, x: DVec3, radius: f64, out: &mut Vec<u32>) {
        self.each_within(x, radius * radius, |id, _| out.push(id));
    }

    /// Appends to `out` `(index, squared distance)` of the points with |p − x| ≤ `radius`, in
    /// no particular order; the squared distances are those [`PointIndex::nearest`] reports.
    pub fn within_distances(&self, x: DVec3, radius: f64, out: &mut Vec<(u32, f64)>) {
        self.each_within(x, radius * radius, |id, d2| out.push((id, d2)));
    }

    /// The base tree, weakly (a token of the base for [`crate::BallAnswer`]).
    pub(crate) fn base_weak(&self) -> Option<Weak<ImmutableKdTree<f64, 3>>> {
        self.tree.as_ref().map(Arc::downgrade)
    }

    /// Whether `base` is this index's base tree.
    pub(crate) fn has_base(&self, base: &Weak<ImmutableKdTree<f64, 3>>) -> bool {
        self.tree
            .as_ref()
            .is_some_and(|t| std::ptr::eq(Arc::as_ptr(t), base.as_ptr()))
    }

    /// Calls `f(id, squared distance)` for the moved entries (their current positions) with
    /// squared distance ≤ `r2`.
    pub(crate) fn each_within_overlay(&self, x: DVec3, r2: f64, f: impl FnMut(u32, f64)) {
        if let Some(o) = &self.overlay {
            ball_of(o, x, r2, f);
        }
    }

    /// Calls `f(id, squared distance)` for every live entry with squared distance ≤ `r2`.
    pub(crate) fn each_within(&self, x: DVec3, r2: f64, mut f: impl FnMut(u32, f64)) {
        self.each_within_base(x, r2, &mut f);
        if let Some(o) = &self.overlay {
            ball_of(o, x, r2, &mut f);
        }
    }

    /// [`PointIndex::each_within`] over the base tree's live entries only.
    fn each_within_base(&self, x: DVec3, r2: f64, mut f: impl FnMut(u32, f64)) {
        // The base's stale entries are left out; the overlay holds only live ones.
        let Some(t) = self.tree.as_deref() else {
            return;
        };
        ball_of(t, x, r2, |id, d2| {
            if self.moved.is_empty() || !self.is_stale(id) {
                f(id, d2);
            }
        });
    }

    /// The nearest point to `x` as `(index, squared distance)`; `None` for an empty index.
    pub fn nearest_one(&self, x: DVec3) -> Option<(u32, f64)> {
        if self.moved.is_empty() {
            let t = self.tree.as_ref()?;
            let n = t
                .query(&x.to_array())
                .nearest_one::<SquaredEuclidean<f64>>()
                .execute();
            return Some((n.item, n.distance));
        }
        self.nearest(x, 1).first().copied()
    }

    /// [`PointIndex::nearest`] of entry `id` at its position `x`: the same answer (equal
    /// distances aside, which either may order by index). A moved entry's neighbours are
    /// mostly moved too, so that the earlier tree's nearest are stale: they are sought among
    /// the moved entries first, and the earlier tree is asked only for its live entries within
    /// the k-th distance found there.
    pub fn nearest_of_entry(&self, id: u32, x: DVec3, k: usize) -> Vec<(u32, f64)> {
        let (Some(want), Some(overlay)) = (NonZeroUsize::new(k), &self.overlay) else {
            return self.nearest(x, k);
        };
        if !self.is_stale(id) {
            return self.nearest(x, k);
        }
        let mut out = nearest_of(overlay, x, want);
        let Some(&(_, bound)) = out.get(k - 1) else {
            return self.nearest(x, k);
        };
        // The k nearest live entries lie within the overlay's k-th distance; the overlay's
        // entries within it are among its k nearest.
        self.each_within_base(x, bound, |i, d2| out.push((i, d2)));
        out.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        out.truncate(k);
        out
    }

    /// The `k` nearest points to `x` as `(index, squared distance)`, nearest first.
    pub fn nearest(&self, x: DVec3, k: usize) -> Vec<(u32, f64)> {
        let Some(want) = NonZeroUsize::new(k) else {
            return Vec::new();
        };
        let query = |t: &ImmutableKdTree<f64, 3>, k: NonZeroUsize| nearest_of(t, x, k);
        let Some(base) = &self.tree else {
            return self
                .overlay
                .as_ref()
                .map_or_else(Vec::new, |o| query(o, want));
        };
        if self.moved.is_empty() {
            return query(base, want);
        }
        // The base's k nearest, the stale ones left out, and the overlay's k nearest.
        let found = query(base, want);
        let exhausted = found.len() < k;
        let mut out: Vec<(u32, f64)> = found
            .into_iter()
            .filter(|&(id, _)| !self.is_stale(id))
            .collect();
        let complete = out.len() == k || exhausted;
        let overlay = self
            .overlay
            .as_ref()
            .map_or_else(Vec::new, |o| query(o, want));
        out.extend_from_slice(&overlay);
        if !complete {
            // Stale entries hid some of the base's nearest live ones, all within the k-th
            // distance of what was found (moved points are dense where they moved, so the
            // overlay usually supplies k): gather the base's ball of that radius instead of
            // asking it for ever more neighbours. The overlay's entries within it are among
            // its k nearest, found already.
            out.sort_by(|a, b| a.1.total_cmp(&b.1));
            let bound = if out.len() >= k {
                out[k - 1].1
            } else {
                f64::INFINITY
            };
            out = overlay;
            // (Fewer than k live entries found at all: every entry.)
            let r2 = if bound.is_finite() { bound } else { f64::MAX };
            self.each_within_base(x, r2, |id, d2| out.push((id, d2)));
        }
        out.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        out.truncate(k);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force: the ids within `r` of `x` and the sorted squared distances of all points.
    fn brute(points: &[DVec3], live: &[u32], x: DVec3, r: f64) -> (Vec<u32>, Vec<f64>) {
        let mut within: Vec<u32> = live
            .iter()
            .copied()
            .filter(|&i| (points[i as usize] - x).length_squared() <= r * r)
            .collect();
        within.sort_unstable();
        let mut d: Vec<f64> = live
            .iter()
            .map(|&i| (points[i as usize] - x).length_squared())
            .collect();
        d.sort_by(f64::total_cmp);
        (within, d)
    }

    /// A seeded stream of pseudo-random numbers in [0, 1).
    fn numbers(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed;
        move || {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn moved_versions_answer_as_a_fresh_tree_and_brute_force() {
        let mut rnd = numbers(3);
        let n = 3000;
        let mut points: Vec<DVec3> = (0..n).map(|_| DVec3::new(rnd(), rnd(), rnd())).collect();
        // Every other id in a subset index (the coarse points' kind).
        let keep = |p: DVec3| ((p.x * 1e6) as u64).is_multiple_of(2);
        let subset = |points: &[DVec3]| -> Vec<u32> {
            (0..points.len() as u32)
                .filter(|&i| keep(points[i as usize]))
                .collect()
        };
        let mut all = PointIndex::new(&points);
        let ids = subset(&points);
        let pts: Vec<DVec3> = ids.iter().map(|&i| points[i as usize]).collect();
        let mut part = PointIndex::with_items(&pts, ids);
        // Many small moves: the versions pass the rebuild threshold on the way.
        for round in 0..40 {
            let c = DVec3::new(rnd(), rnd(), rnd());
            let moved: Vec<u32> = (0..n as u32)
                .filter(|&i| (points[i as usize] - c).length() < 0.15)
                .collect();
            for &i in &moved {
                points[i as usize] += 0.05 * DVec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
            }
            all = all.with_moved(&moved, &points, |_| true);
            part = part.with_moved(&moved, &points, keep);
            let every: Vec<u32> = (0..n as u32).collect();
            let live = subset(&points);
            assert_eq!(all.len(), n, "round {round}");
            assert_eq!(part.len(), live.len(), "round {round}");
            for q in 0..30 {
                let x = DVec3::new(rnd(), rnd(), rnd());
                let r = 0.02 + 0.2 * rnd();
                for (index, ids) in [(&all, &every), (&part, &live)] {
                    let (want, dist) = brute(&points, ids, x, r);
                    let mut got = Vec::new();
                    index.within(x, r, &mut got);
                    got.sort_unstable();
                    assert_eq!(got, want, "round {round} query {q}");
                    let k = 1 + q % 17;
                    let near = index.nearest(x, k);
                    let d: Vec<f64> = near.iter().map(|n| n.1).collect();
                    assert_eq!(d, dist[..k.min(dist.len())], "round {round} query {q}");
                    for (id, d2) in near {
                        assert_eq!((points[id as usize] - x).length_squared(), d2);
                    }
                    assert_eq!(index.nearest_one(x).map(|n| n.1), dist.first().copied());
                    // From an entry's own position, moved or not.
                    let moved_live: Vec<u32> = moved
                        .iter()
                        .copied()
                        .filter(|m| ids.binary_search(m).is_ok())
                        .collect();
                    let e = if q % 2 == 0 && !moved_live.is_empty() {
                        moved_live[q % moved_live.len()]
                    } else {
                        ids[q % ids.len()]
                    };
                    let y = points[e as usize];
                    let near = index.nearest_of_entry(e, y, k);
                    let (_, dist) = brute(&points, ids, y, 0.0);
                    let d: Vec<f64> = near.iter().map(|n| n.1).collect();
                    assert_eq!(d, dist[..k.min(dist.len())], "round {round} entry {e}");
                }
            }
        }
    }
}
