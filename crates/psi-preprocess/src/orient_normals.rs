//! Normal consistency of an oriented point set: detection of flipped normals and reorientation
//! by propagation over a nearest-neighbour graph (Hoppe et al. 1992: a spanning tree that
//! prefers nearly parallel normals, oriented from an extreme point whose outward direction is
//! known).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use psi_octree::{Monitor, OrientedPoint, PointIndex};

/// Neighbours per point in the graph.
const K: usize = 8;

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
}

/// Neighbour pairs (i, j, n_i·n_j) on the same sheet: the offset between the points is mostly
/// tangential (|n_i·(p_j − p_i)| ≤ ½|p_j − p_i|), so the two faces of a thin part do not pair
/// as long as they are farther apart than the sample spacing (closer sheets are locally
/// indistinguishable from flipped normals).
fn same_sheet_pairs(points: &[OrientedPoint], stride: usize) -> Vec<Vec<(u32, f64)>> {
    let positions: Vec<_> = points.iter().map(|p| p.p).collect();
    let index = PointIndex::new(&positions);
    points
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            if i % stride != 0 {
                return Vec::new();
            }
            index
                .nearest(p.p, K + 1)
                .into_iter()
                .filter(|&(j, d2)| {
                    let j = j as usize;
                    j != i && d2 > 0.0 && p.n.dot(points[j].p - p.p).abs() <= 0.5 * d2.sqrt()
                })
                .map(|(j, _)| (j, p.n.dot(points[j as usize].n)))
                .collect()
        })
        .collect()
}

/// Counts same-sheet neighbour pairs whose normals oppose (shape: N points, unit normals),
/// querying the neighbours of at most `max_queries` evenly strided points.
pub fn check_normal_consistency(points: &[OrientedPoint], max_queries: usize) -> NormalConsistency {
    let stride = points.len().div_ceil(max_queries.max(1)).max(1);
    let graph = same_sheet_pairs(points, stride);
    let mut c = NormalConsistency::default();
    for edges in &graph {
        for &(_, dot) in edges {
            c.pairs += 1;
            c.opposed += usize::from(dot < 0.0);
        }
    }
    c
}

#[derive(PartialEq)]
struct Candidate {
    weight: f64,
    to: u32,
    from: u32,
}

impl Eq for Candidate {}

impl Ord for Candidate {
    fn cmp(&self, other: &Self) -> Ordering {
        self.weight
            .total_cmp(&other.weight)
            .then(other.to.cmp(&self.to))
            .then(other.from.cmp(&self.from))
    }
}

impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// The symmetric same-sheet neighbour graph of `points` (each point's neighbours, sorted).
fn neighbour_graph(points: &[OrientedPoint]) -> Vec<Vec<u32>> {
    let graph = same_sheet_pairs(points, 1);
    let mut adj: Vec<Vec<u32>> = graph
        .iter()
        .map(|e| e.iter().map(|&(j, _)| j).collect())
        .collect();
    for (i, edges) in graph.iter().enumerate() {
        for &(j, _) in edges {
            adj[j as usize].push(i as u32);
        }
    }
    for a in &mut adj {
        a.sort_unstable();
        a.dedup();
    }
    adj
}

/// Carries the orientation of `seeds` (points already `done`) to the points not yet done that
/// they reach over `adj`, by a maximum-|n_i·n_j| spanning tree (Prim, grown from all seeds at
/// once): each point reached takes the side of the point it was reached from, and is marked
/// done. Returns the number flipped.
fn propagate(
    points: &mut [OrientedPoint],
    adj: &[Vec<u32>],
    done: &mut [bool],
    seeds: &[u32],
    monitor: &Monitor<'_>,
) -> usize {
    let mut heap = BinaryHeap::new();
    let push =
        |heap: &mut BinaryHeap<Candidate>, from: u32, points: &[OrientedPoint], done: &[bool]| {
            for &to in &adj[from as usize] {
                if !done[to as usize] {
                    let weight = points[from as usize].n.dot(points[to as usize].n).abs();
                    heap.push(Candidate { weight, to, from });
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

/// Reorients normals consistently: per connected component of the neighbour graph, the point
/// with the largest x gets a normal with positive x (it is on the convex hull, so outward is +x
/// there), then a maximum-|n_i·n_j| spanning tree (Prim) carries the orientation. Returns the
/// number of normals flipped. Deterministic.
pub fn orient_normals(points: &mut [OrientedPoint]) -> usize {
    orient_normals_with(points, &Monitor::silent())
}

/// [`orient_normals`], stopping early once `monitor`'s flag is set (checked every few
/// thousand points; the caller then discards the points).
pub fn orient_normals_with(points: &mut [OrientedPoint], monitor: &Monitor<'_>) -> usize {
    let adj = neighbour_graph(points);
    if monitor.stopped() {
        return 0;
    }
    let n = points.len();
    let mut done = vec![false; n];
    let mut order: Vec<u32> = (0..n as u32).collect();
    order.sort_by(|&a, &b| {
        points[b as usize]
            .p
            .x
            .total_cmp(&points[a as usize].p.x)
            .then(a.cmp(&b))
    });
    let mut flips = 0;
    for &seed in &order {
        if done[seed as usize] {
            continue;
        }
        if points[seed as usize].n.x < 0.0 {
            points[seed as usize].n = -points[seed as usize].n;
            flips += 1;
        }
        done[seed as usize] = true;
        flips += propagate(points, &adj, &mut done, &[seed], monitor);
        if monitor.stopped() {
            break;
        }
    }
    flips
}

/// A normal whose angle to the sensor's direction has a cosine at least this is oriented by the
/// sensor; nearer the silhouette, where a small error in the normal flips that test, by
/// propagation from such points.
const FACING: f64 = 0.3;

/// Orients normals toward `viewpoint` (world units), the sensor of a single range scan: every
/// point that faces it clearly (|cos| ≥ 0.3 between its normal and the direction to the sensor)
/// gets the side facing it, n·(viewpoint − p) > 0; the others, nearer the view's silhouette,
/// take their side from those by propagation over the neighbour graph (as
/// [`orient_normals`]), or the sensor's when no such neighbour reaches them. Returns the number
/// flipped. Deterministic.
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
    if done.iter().any(|d| !d) {
        let adj = neighbour_graph(points);
        let seeds: Vec<u32> = (0..points.len() as u32)
            .filter(|&i| done[i as usize])
            .collect();
        flips += propagate(points, &adj, &mut done, &seeds, &Monitor::silent());
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
}
