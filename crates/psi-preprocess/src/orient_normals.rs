//! Normal consistency of an oriented point set: detection of flipped normals and reorientation
//! by propagation over a nearest-neighbour graph (Hoppe et al. 1992: a spanning tree that
//! prefers nearly parallel normals, oriented from an extreme point whose outward direction is
//! known).

use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use psi_octree::{Monitor, MortonIndex, OrientedPoint};

use crate::median::total_order_key;
use crate::neighbour_graph::{Graph, K, SlotGraphs, morton_index_of, slot_graphs};
use crate::spanning_forest::maximum_spanning_forest;

/// What the consistency check found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NormalConsistency {
    /// Neighbour pairs on the same sheet that were compared.
    pub pairs: usize,
    /// Of those, pairs whose normals point to opposite sides.
    pub opposed: usize,
}

impl NormalConsistency {
    /// Share of compared pairs with opposed normals (0 for a consistently oriented sample).
    pub fn opposed_fraction(&self) -> f64 {
        if self.pairs == 0 {
            0.0
        } else {
            self.opposed as f64 / self.pairs as f64
        }
    }

    /// The counts of two checks together (parts of one check, [`crate::part_normal_consistency`]).
    pub fn merge(self, other: NormalConsistency) -> NormalConsistency {
        NormalConsistency {
            pairs: self.pairs + other.pairs,
            opposed: self.opposed + other.opposed,
        }
    }
}

/// For every `stride`-th point (points 0, stride, 2·stride, … with finite coordinates, in
/// Morton order: neighbouring queries share cache): its K nearest other points j (not
/// coincident), with n_i·n_j and whether the pair is on the same sheet: the offset between the
/// points is mostly tangential (|n_i·(p_j − p_i)| ≤ ½|p_j − p_i|), so the two faces of a thin
/// part do not pair as long as they are farther apart than the sample spacing (closer sheets
/// are locally indistinguishable from flipped normals).
fn neighbour_pairs(
    points: &[OrientedPoint],
    index: &MortonIndex,
    stride: usize,
) -> Vec<Vec<(u32, f64, bool)>> {
    let ids = index.ids();
    // A pair: the neighbour j of point i at squared distance d2 (world units²).
    let pair = |i: usize, j: u32, d2: f64| {
        let (p, q) = (&points[i], &points[j as usize]);
        let same = p.n.dot(q.p - p.p).abs() <= 0.5 * d2.sqrt();
        (j, p.n.dot(q.n), same)
    };
    let queried: Vec<usize> = ids
        .iter()
        .map(|&i| i as usize)
        .filter(|i| i % stride == 0)
        .collect();
    queried
        .par_iter()
        .map(|&i| {
            index
                .nearest(points[i].p, K + 1)
                .into_iter()
                .map(|(s, d2)| (ids[s as usize], d2))
                .filter(|&(j, d2)| j as usize != i && d2 > 0.0)
                .map(|(j, d2)| pair(i, j, d2))
                .collect()
        })
        .collect()
}

/// Counts same-sheet neighbour pairs whose normals oppose (shape: N points, unit normals),
/// querying the neighbours of at most `max_queries` evenly strided points.
pub fn check_normal_consistency(points: &[OrientedPoint], max_queries: usize) -> NormalConsistency {
    check_normal_consistency_in(points, &morton_index_of(points), max_queries)
}

/// [`check_normal_consistency`], `index` the Morton index of the points' positions.
pub(crate) fn check_normal_consistency_in(
    points: &[OrientedPoint],
    index: &MortonIndex,
    max_queries: usize,
) -> NormalConsistency {
    let stride = points.len().div_ceil(max_queries.max(1)).max(1);
    let graph = neighbour_pairs(points, index, stride);
    let mut c = NormalConsistency::default();
    for edges in &graph {
        for &(_, dot, same) in edges {
            c.pairs += usize::from(same);
            c.opposed += usize::from(same && dot < 0.0);
        }
    }
    c
}

/// An edge of the spanning tree to be: slots `to` and `from`, and their original indices, which
/// break ties between equal weights (the tree does not depend on the points' order).
#[derive(PartialEq)]
struct Candidate {
    weight: f64,
    to_id: u32,
    from_id: u32,
    to: u32,
    from: u32,
}

impl Eq for Candidate {}

impl Ord for Candidate {
    fn cmp(&self, other: &Self) -> Ordering {
        self.weight
            .total_cmp(&other.weight)
            .then(other.to_id.cmp(&self.to_id))
            .then(other.from_id.cmp(&self.from_id))
    }
}

impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// Carries the orientation of `seeds` (points already `done`) to the points not yet done that
/// they reach over `adj` and then `fallback`, by a maximum-|n_i·n_j| spanning tree (Prim,
/// grown from all seeds at once) in which every `adj` edge outranks every `fallback` edge (its
/// weight is |n_i·n_j| + 1): the tree within each `adj` island is the one `adj` alone gives,
/// and an island is reached from its neighbours instead of starting on its own. Each point
/// reached takes the side of the point it was reached from, and is marked done. Returns the
/// number flipped.
fn propagate(
    points: &mut [OrientedPoint],
    (adj, fallback): (&Graph, &Graph),
    ids: &[u32],
    done: &mut [bool],
    seeds: &[u32],
    monitor: &Monitor<'_>,
) -> usize {
    let mut heap = BinaryHeap::new();
    let push =
        |heap: &mut BinaryHeap<Candidate>, from: u32, points: &[OrientedPoint], done: &[bool]| {
            let tiers = [(adj, 1.0), (fallback, 0.0)];
            for (graph, rank) in tiers {
                for &to in graph.row(from as usize) {
                    if !done[to as usize] {
                        let dot = points[from as usize].n.dot(points[to as usize].n);
                        let weight = dot.abs() + rank;
                        heap.push(Candidate {
                            weight,
                            to_id: ids[to as usize],
                            from_id: ids[from as usize],
                            to,
                            from,
                        });
                    }
                }
            }
        };
    for &i in seeds {
        push(&mut heap, i, points, done);
    }
    let mut flips = 0;
    let mut pops = 0u32;
    while let Some(Candidate { to, from, .. }) = heap.pop() {
        pops = pops.wrapping_add(1);
        if pops.is_multiple_of(4096) && monitor.stopped() {
            break;
        }
        if done[to as usize] {
            continue;
        }
        done[to as usize] = true;
        if points[to as usize].n.dot(points[from as usize].n) < 0.0 {
            points[to as usize].n = -points[to as usize].n;
            flips += 1;
        }
        push(&mut heap, to, points, done);
    }
    flips
}

/// Reorients normals consistently: the point with the largest x of the largest same-sheet
/// island gets a normal with positive x (it is on the convex hull, so outward is +x there),
/// then the maximum-|n_i·n_j| spanning forest carries the orientation over the same-sheet
/// pairs and, from island to island, over the other nearest-neighbour pairs (every same-sheet
/// edge weighs 1 more; Kruskal, ties to the lower input indices: the tree Hoppe et al. grow by
/// Prim); a tree no pair links to one already oriented starts again from its own largest x.
/// Returns the number of normals flipped. Deterministic, whatever the thread count.
pub fn orient_normals(points: &mut [OrientedPoint]) -> usize {
    orient_normals_with(points, &Monitor::silent())
}

/// [`orient_normals`], stopping early once `monitor`'s flag is set (checked between its
/// steps: the neighbour graphs, the spanning forest; the caller then discards the points).
pub fn orient_normals_with(points: &mut [OrientedPoint], monitor: &Monitor<'_>) -> usize {
    orient_normals_in(points, morton_index_of(points), monitor)
}

/// [`orient_normals_with`], `index` the Morton index of the points' positions (dropped as soon
/// as the neighbours are found: the graphs need the memory).
pub(crate) fn orient_normals_in(
    points: &mut [OrientedPoint],
    index: MortonIndex,
    monitor: &Monitor<'_>,
) -> usize {
    // In Morton order (slots), where the propagation's next points lie in cache.
    let Some(mut graphs) = slot_graphs(points, index, monitor) else {
        return 0;
    };
    let SlotGraphs {
        ids,
        sorted,
        same: adj,
        other: fallback,
    } = &mut graphs;
    let n = sorted.len();
    let mut done = vec![false; n];
    let (adj, fallback, points_in_slots, ids) = (&*adj, &*fallback, &*sorted, &*ids);
    // The seeds' order (largest x first) and the same-sheet islands are made beside the
    // forest: they need only the graphs, and the forest's serial joins leave a core idle.
    let by_x = || {
        // Largest x first, ties to the lower original index: sorted by a key (x's total order,
        // reversed, and the index), where comparing the points read them at random.
        let mut keyed: Vec<(Reverse<i64>, u32, u32)> = (0..n as u32)
            .into_par_iter()
            .map(|i| {
                let x = points_in_slots[i as usize].p.x;
                (Reverse(total_order_key(x)), ids[i as usize], i)
            })
            .collect();
        keyed.par_sort_unstable();
        keyed.into_par_iter().map(|k| k.2).collect::<Vec<u32>>()
    };
    // The maximum-|n_i·n_j| spanning forest, every same-sheet edge above every other one,
    // then each tree oriented from its first seed along its edges.
    let forest = || {
        maximum_spanning_forest(n, ids, |i, out| {
            for (graph, rank) in [(adj, 1.0), (fallback, 0.0)] {
                for &j in graph.row(i) {
                    let dot = points_in_slots[i].n.dot(points_in_slots[j as usize].n);
                    out.push((j, dot.abs() + rank));
                }
            }
        })
    };
    let ((mut order, island), forest) = rayon::join(|| rayon::join(by_x, || islands(adj)), forest);
    // The first seed: the largest x of the largest same-sheet island (the whole surface,
    // usually), so that a small island at the extreme does not set everyone's side.
    let mut size = vec![0usize; n];
    for &c in &island {
        size[c as usize] += 1;
    }
    let largest = size.iter().copied().max().unwrap_or(0);
    if let Some(first) = order
        .iter()
        .position(|&i| size[island[i as usize] as usize] == largest)
    {
        order[..=first].rotate_right(1);
    }
    if monitor.stopped() {
        return 0;
    }
    let mut flips = 0;
    let mut stack = Vec::new();
    for &seed in &order {
        if done[seed as usize] {
            continue;
        }
        if sorted[seed as usize].n.x < 0.0 {
            sorted[seed as usize].n = -sorted[seed as usize].n;
            flips += 1;
        }
        done[seed as usize] = true;
        stack.push(seed);
        while let Some(from) = stack.pop() {
            for &to in forest.row(from as usize) {
                if !done[to as usize] {
                    done[to as usize] = true;
                    if sorted[to as usize].n.dot(sorted[from as usize].n) < 0.0 {
                        sorted[to as usize].n = -sorted[to as usize].n;
                        flips += 1;
                    }
                    stack.push(to);
                }
            }
        }
    }
    graphs.write_normals(points);
    flips
}

/// The connected components of `adj` (symmetric): per point, the smallest point index of its
/// component.
fn islands(adj: &Graph) -> Vec<u32> {
    let mut label = vec![u32::MAX; adj.len()];
    let mut stack = Vec::new();
    for start in 0..adj.len() {
        if label[start] != u32::MAX {
            continue;
        }
        label[start] = start as u32;
        stack.push(start as u32);
        while let Some(i) = stack.pop() {
            for &j in adj.row(i as usize) {
                if label[j as usize] == u32::MAX {
                    label[j as usize] = start as u32;
                    stack.push(j);
                }
            }
        }
    }
    label
}

/// A normal whose angle to the sensor's direction has a cosine at least this is oriented by the
/// sensor; nearer the silhouette, where a small error in the normal flips that test, by
/// propagation from such points.
const FACING: f64 = 0.3;

/// Orients normals toward `viewpoint` (world units), the sensor of a single range scan: every
/// point that faces it clearly (|cos| ≥ 0.3 between its normal and the direction to the sensor)
/// gets the side facing it, n·(viewpoint − p) > 0; the others, nearer the view's silhouette,
/// take their side from those by propagation over the same-sheet neighbour graph (Prim's
/// maximum-|n_i·n_j| tree grown from all the facing points at once), or the sensor's when no
/// such neighbour reaches them. Returns the number flipped. Deterministic.
///
/// ```
/// use glam::DVec3;
/// use psi_octree::OrientedPoint;
/// use psi_preprocess::orient_toward;
///
/// let mut points = vec![OrientedPoint { p: DVec3::ZERO, n: DVec3::NEG_Z }];
/// assert_eq!(orient_toward(&mut points, DVec3::new(0.0, 0.0, 5.0)), 1);
/// assert_eq!(points[0].n, DVec3::Z);
/// ```
pub fn orient_toward(points: &mut [OrientedPoint], viewpoint: glam::DVec3) -> usize {
    let facing = |p: &OrientedPoint| p.n.dot((viewpoint - p.p).normalize_or_zero());
    let mut flips = 0;
    let mut done: Vec<bool> = points.iter().map(|p| facing(p).abs() >= FACING).collect();
    for (p, d) in points.iter_mut().zip(&done) {
        if *d && facing(p) < 0.0 {
            p.n = -p.n;
            flips += 1;
        }
    }
    let silent = Monitor::silent();
    if done.iter().any(|d| !d)
        && let Some(mut graphs) = slot_graphs(points, morton_index_of(points), &silent)
    {
        // By slot (Morton order), then back.
        let mut slot_done: Vec<bool> = graphs.ids.iter().map(|&i| done[i as usize]).collect();
        let seeds: Vec<u32> = (0..slot_done.len() as u32)
            .filter(|&s| slot_done[s as usize])
            .collect();
        let SlotGraphs {
            ids, sorted, same, ..
        } = &mut graphs;
        let none = Graph::empty();
        flips += propagate(sorted, (same, &none), ids, &mut slot_done, &seeds, &silent);
        for (&i, d) in graphs.ids.iter().zip(&slot_done) {
            done[i as usize] = *d;
        }
        graphs.write_normals(points);
    }
    for (p, d) in points.iter_mut().zip(&done) {
        if !*d && facing(p) < 0.0 {
            p.n = -p.n;
            flips += 1;
        }
    }
    flips
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_shapes::AnalyticShape;

    #[test]
    fn detects_and_repairs_flipped_normals() {
        let truth = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        }
        .sample(5000, 2);
        assert_eq!(check_normal_consistency(&truth, usize::MAX).opposed, 0);
        let mut pts = truth.clone();
        for (i, p) in pts.iter_mut().enumerate() {
            if i % 10 == 3 {
                p.n = -p.n;
            }
        }
        let c = check_normal_consistency(&pts, usize::MAX);
        assert!(c.opposed_fraction() > 0.1, "{c:?}");
        let flips = orient_normals(&mut pts);
        assert!(flips >= 400);
        assert_eq!(pts, truth, "every normal restored to the outward one");
    }

    #[test]
    fn thin_sheets_are_not_mistaken_for_flips() {
        // Two sheets 0.06 apart sampled every ≈ 0.018: farther apart than the spacing. (Sheets
        // closer than the spacing are indistinguishable from flips by any local test.)
        let slab = AnalyticShape::Box {
            half: glam::DVec3::new(0.5, 0.5, 0.03),
        }
        .sample(6000, 4);
        assert_eq!(check_normal_consistency(&slab, usize::MAX).opposed, 0);
    }

    #[test]
    fn islands_of_a_noisy_dense_scan_take_their_neighbours_side() {
        use rand::SeedableRng;
        // An ellipsoid sampled densely, its positions' noise about the sample spacing: the
        // same-sheet graph falls apart into islands, each of which used to take its side from
        // its own largest x.
        let truth = AnalyticShape::Ellipsoid {
            radii: glam::DVec3::new(1.0, 0.7, 0.5),
        }
        .sample(60_000, 5);
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(5);
        let positions: Vec<glam::DVec3> = truth
            .iter()
            .map(|p| p.p + 0.006 * psi_shapes::gaussian_vector(&mut rng))
            .collect();
        let normals = crate::estimate_normals(&positions);
        let mut pts: Vec<OrientedPoint> = positions
            .iter()
            .zip(normals)
            .map(|(&p, n)| OrientedPoint { p, n })
            .collect();
        let index = morton_index_of(&pts);
        let label = islands(&slot_graphs(&pts, index, &Monitor::silent()).unwrap().same);
        let mut sizes = std::collections::BTreeMap::new();
        for l in &label {
            *sizes.entry(*l).or_insert(0usize) += 1;
        }
        let largest = sizes.values().copied().max().unwrap();
        assert!(sizes.len() > 20, "{} islands", sizes.len());
        orient_normals(&mut pts);
        // Oracle: the analytic outward normals. Every island outside the largest agrees.
        let wrong = |only_small: bool| {
            pts.iter()
                .zip(&truth)
                .zip(&label)
                .filter(|((p, t), l)| (!only_small || sizes[l] < largest) && p.n.dot(t.n) < 0.0)
                .count()
        };
        let small: usize = sizes.values().filter(|&&s| s < largest).sum();
        assert!(small > 50, "{small} points in small islands");
        assert_eq!(wrong(true), 0, "of {small} points in small islands");
        assert!(wrong(false) <= pts.len() / 2000, "{} wrong", wrong(false));
    }
}
