//! Stray clumps: small groups of points lying apart from the rest of the data, off the surface
//! it describes — what a scanner leaves where it saw dust or a reflection (GitHub issue 28).
//! [`crate::find_outliers`] judges a point by its 16 nearest neighbours, so a clump of a few
//! dozen points supports itself and survives it; this step judges the group instead.
//!
//! Points are linked when at most a link distance h apart (h = 2 % of the bounding-box
//! diagonal D, more for sparse data); a group is a set of points connected by links, so a group
//! lies farther than h from every other point. A group is a stray clump when it is small (at
//! most [`CLUMP_POINTS`] points within a box of 2h a side) and lies off the surface of the rest
//! of the data: no point of a larger group within 3h, or more than h/2 from the tangent plane
//! of a well-sampled surface at the nearest such point. The last test keeps what a scan leaves
//! where it saw a surface only in fragments (a fragment lies in the plane of the data beside
//! it, or beside data too sparse for a plane), while a clump hovers above a surface
//! (docs/notes/2026-11-25-real-scans-2.md: the dragon scan).
//!
//! The groups come from a grid of cubes whose adjacent cubes' points are always linked, the
//! few links between non-adjacent cubes from ball queries on a Morton index: linear time,
//! exact (a brute-force twin of the definition checks it), and a verdict that reads only the
//! data near a point.

use glam::DVec3;
use psi_octree::{Aabb, Monitor, MortonIndex};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::disjoint_sets::Sets;
use crate::local_fit::fit_plane;
use crate::median::median;

/// A group of at most this many points can be a stray clump.
pub const CLUMP_POINTS: usize = 100;

/// The least link distance relative to the bounding-box diagonal D: a clump lies farther than
/// this from every other point.
pub const CLUMP_GAP: f64 = 0.02;

/// The link distance is at least this many typical sample spacings: with h = 3 spacings a
/// point of a surface has about 9π ≈ 28 others within h, and a surface sampled that densely
/// does not fall apart into small groups (the chance that a point has none is e^-28).
pub(crate) const SPACING_LINKS: f64 = 3.0;

/// The typical sample spacing is this quantile of the points' spacings, a high one: the
/// sparser parts of a scan (grazing views, borders) must hold together too.
pub(crate) const SPACING_QUANTILE: f64 = 0.9;

/// Points whose spacing is measured (evenly spread over the input's order).
pub(crate) const SPACING_SAMPLES: usize = 4096;

/// A point's spacing: d·√(π/16), d the distance to its 16th nearest other point (16 points
/// fill the disc of radius d at that spacing; as in [`crate::find_outliers`]).
pub(crate) const SPACING_NEIGHBOURS: usize = 16;

/// A clump fits in a box of this many link distances a side, so that deciding whether a point
/// belongs to one reads only the data near it (see [`find_clumps`]).
pub(crate) const SPAN_LINKS: f64 = 2.0;

/// A small group with no point of a larger group within this many link distances lies off
/// every surface.
pub(crate) const SEARCH_LINKS: f64 = 3.0;

/// A small group is off the surface when its point q nearest a larger group's point s lies
/// farther than this many link distances from the tangent plane at s …
pub(crate) const OFF_PLANE_LINKS: f64 = 0.5;

/// … that plane fitted to the points within this many link distances of s (hundreds of points
/// in a scan: a normal steady against the noise) …
pub(crate) const PLANE_LINKS: f64 = 0.5;

/// … and only where the surface is well sampled: at least this share of the points a surface
/// at the median spacing holds there. Near a sparsely sampled part, which a scan leaves in
/// fragments, a small group may be one more fragment: it is kept (the dragon scan has two
/// such groups on the reference surface: docs/notes/2026-11-25-real-scans-2.md).
pub(crate) const SUPPORT_SHARE: f64 = 0.25;

/// Clumps holding more than this share of the points are no clumps: the data are too sparse
/// or too fragmented for the test, and all are kept.
pub(crate) const MAX_SHARE: f64 = 0.01;

/// What [`find_clumps`] found.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Clumps {
    /// Per point (shape: N): whether it belongs to a stray clump.
    pub mask: Vec<bool>,
    /// Stray clumps found.
    pub groups: usize,
    /// Points in them (the `true`s of `mask`).
    pub points: usize,
    /// Points in stray clumps that were kept because they were more than 1 % of the input (0
    /// normally: such data are too sparse or fragmented for the test).
    pub withheld: usize,
    /// The link distance h used, world units (0 for fewer than two distinct points).
    pub link: f64,
}

/// Finds the stray clumps of `positions` (shape: N, world units; finite). With D the diagonal
/// of their bounding box and the link distance h = max(0.02 D, 3 s), s the 90th percentile of
/// the points' sample spacings (d16·√(π/16), d16 the distance to the 16th nearest other point,
/// measured on up to 4096 points), points at most h apart are linked. A point belongs to a
/// stray clump when the group of points connected to it by links holds at most
/// [`CLUMP_POINTS`] points within a box of 2h a side, and either no point of a larger group
/// lies within 3h of it, or the pair of its point q and such a point s at the least distance
/// has q farther than h/2 from the least-squares plane of the points within h/2 of s, and
/// those are at least a quarter of the points a surface at the median spacing has there.
///
/// So a clump of up to 100 points within 0.04 D, farther than 0.02 D from every other point and
/// either farther than 0.06 D from the rest or more than 0.01 D above the tangent plane of a
/// well-sampled surface beside it, is found (for sparse data, where 3 s > 0.02 D, the same
/// with h = 3 s); a point within h of a group of more than 100 points never is. When the
/// clumps hold more than 1 % of the points none is reported ([`Clumps::withheld`]).
///
/// Reach: whether a point p belongs to a clump depends only on h and the median spacing (two
/// statistics of the whole input) and on the points within (4√3 + 4) h ≈ 11h of p: its group
/// (within 2√3 h), the points within 3h of that, whether each lies in a small group (within
/// 2√3 h + h of it) and the plane within h/2 of the nearest. So tiles given those statistics
/// and a halo of 11h (0.22 D) decide their points as the whole input does (tested), but for
/// the 1 % rule. Deterministic and independent of the thread count.
///
/// ```
/// use glam::DVec3;
/// use psi_preprocess::find_clumps;
///
/// // A 100 × 100 grid of points on a plane and a clump of 8 points 20 spacings above it.
/// let mut points: Vec<DVec3> = (0..10_000)
///     .map(|i| DVec3::new((i % 100) as f64, (i / 100) as f64, 0.0))
///     .collect();
/// for i in 0..8 {
///     let corner = DVec3::new((i % 2) as f64, (i / 2 % 2) as f64, (i / 4) as f64);
///     points.push(DVec3::new(50.0, 50.0, 20.0) + corner);
/// }
/// let found = find_clumps(&points);
/// assert_eq!((found.groups, found.points), (1, 8));
/// assert!(found.mask[10_000..].iter().all(|&m| m));
/// ```
pub fn find_clumps(positions: &[DVec3]) -> Clumps {
    find_clumps_with(positions, &Monitor::silent())
}

/// [`find_clumps`], stopping early once `monitor`'s flag is set (the result is then empty and
/// the caller discards it).
pub fn find_clumps_with(positions: &[DVec3], monitor: &Monitor<'_>) -> Clumps {
    find_clumps_in(positions, &MortonIndex::new(positions), monitor)
}

/// [`find_clumps_with`], `index` the Morton index of `positions`.
pub(crate) fn find_clumps_in(
    positions: &[DVec3],
    index: &MortonIndex,
    monitor: &Monitor<'_>,
) -> Clumps {
    let (groups, link) = stray_groups(positions, index, monitor);
    let mut found = Clumps {
        mask: vec![false; positions.len()],
        link,
        ..Clumps::default()
    };
    let points = groups.iter().map(Vec::len).sum();
    if points as f64 > MAX_SHARE * positions.len() as f64 {
        found.withheld = points;
        return found;
    }
    (found.groups, found.points) = (groups.len(), points);
    for &i in groups.iter().flatten() {
        found.mask[i as usize] = true;
    }
    found
}

/// The stray clumps of `positions` (shape: N, world units; `index` their Morton index) before
/// the 1 % rule: each as ascending point indices, in the order of their first points; and the
/// link distance h (0 for fewer than two distinct points). None once `monitor`'s flag is set.
fn stray_groups(
    positions: &[DVec3],
    index: &MortonIndex,
    monitor: &Monitor<'_>,
) -> (Vec<Vec<u32>>, f64) {
    let Some(bounds) = Aabb::from_points(positions.iter().copied()) else {
        return (Vec::new(), 0.0);
    };
    let diagonal = bounds.diagonal();
    if !(diagonal > 0.0 && diagonal.is_finite()) || positions.len() >= u32::MAX as usize {
        return (Vec::new(), 0.0);
    }
    let scale = Scale::of(positions, index, diagonal);
    (clumps_at(positions, index, &scale, monitor), scale.link)
}

/// The stray clumps of `positions` (shape: N ≥ 1, indexed by `index`) at `scale` (that of
/// these points, or of a larger set they are a part of), as [`stray_groups`] gives them.
fn clumps_at(
    positions: &[DVec3],
    index: &MortonIndex,
    scale: &Scale,
    monitor: &Monitor<'_>,
) -> Vec<Vec<u32>> {
    if monitor.stopped() {
        return Vec::new();
    }
    let origin = positions.iter().fold(DVec3::INFINITY, |m, &p| m.min(p));
    let mut groups = small_groups(positions, index, origin, scale.link);
    if monitor.stopped() {
        return Vec::new();
    }
    let mut in_small = vec![false; positions.len()];
    for &i in groups.iter().flatten() {
        in_small[i as usize] = true;
    }
    let stray: Vec<bool> = groups
        .par_iter()
        .map(|g| off_surface(g, positions, index, scale, &in_small))
        .collect();
    let mut stray = stray.into_iter();
    groups.retain(|_| stray.next().unwrap_or(false));
    groups
}

/// The scale of a point set: the link distance and how many points a well-sampled surface
/// holds near a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Scale {
    /// The link distance h, world units.
    pub(crate) link: f64,
    /// Points within h/2 of a point on a surface sampled at the median spacing s:
    /// π (h/2)² / s² (0 when s is 0).
    pub(crate) dense: f64,
}

impl Scale {
    /// The scale of `positions` (shape: N ≥ 1) indexed by `index`, of bounding-box diagonal
    /// `diagonal`: h = max(0.02 D, 3 × the 90th percentile of the spacing), the spacings
    /// measured on every ⌈N / 4096⌉-th point.
    fn of(positions: &[DVec3], index: &MortonIndex, diagonal: f64) -> Scale {
        let stride = positions.len().div_ceil(SPACING_SAMPLES).max(1);
        let sampled: Vec<usize> = (0..positions.len()).step_by(stride).collect();
        let spacings: Vec<f64> = sampled
            .par_iter()
            .map(|&i| {
                let near = index.nearest(positions[i], SPACING_NEIGHBOURS + 1);
                spacing_of(near.last().map_or(0.0, |&(_, d2)| d2.sqrt()))
            })
            .collect();
        Scale::from_spacings(spacings, diagonal)
    }

    /// The scale of points of bounding-box diagonal `diagonal` whose sampled spacings are
    /// `spacings` (shape: S ≥ 1, any order).
    pub(crate) fn from_spacings(mut spacings: Vec<f64>, diagonal: f64) -> Scale {
        let k = ((spacings.len() - 1) as f64 * SPACING_QUANTILE) as usize;
        let high = *spacings.select_nth_unstable_by(k, f64::total_cmp).1;
        let typical = median(&mut spacings);
        let link = (CLUMP_GAP * diagonal).max(SPACING_LINKS * high);
        let dense = if typical > 0.0 {
            std::f64::consts::PI * (PLANE_LINKS * link / typical).powi(2)
        } else {
            0.0
        };
        Scale { link, dense }
    }
}

/// A point's sample spacing from the distance `reach` to its 16th nearest other point.
pub(crate) fn spacing_of(reach: f64) -> f64 {
    reach * (std::f64::consts::PI / SPACING_NEIGHBOURS as f64).sqrt()
}

/// Bits per cube coordinate in a cube key.
pub(crate) const KEY_BITS: u32 = 21;

/// The key of the cube with integer coordinates `c` (each in 0..2²¹).
pub(crate) fn cube_key(c: [u64; 3]) -> u64 {
    c[0] | c[1] << KEY_BITS | c[2] << (2 * KEY_BITS)
}

/// The edge of the cubes whose adjacent cubes' points are always linked at link distance
/// `link`: link / (2√3) (world units).
pub(crate) fn cube_edge(link: f64) -> f64 {
    link / (2.0 * 3f64.sqrt())
}

/// The key of the cube of edge `edge` holding world position `p` (≥ `origin`), its
/// coordinates counted from 1 (so that every neighbour's are ≥ 0) and clamped.
pub(crate) fn cube_key_of(p: DVec3, origin: DVec3, edge: f64) -> u64 {
    let limit = ((1u64 << KEY_BITS) - 2) as f64;
    let c = ((p - origin) / edge)
        .floor()
        .clamp(DVec3::ZERO, DVec3::splat(limit - 1.0))
        .to_array()
        .map(|c| c as u64 + 1);
    cube_key(c)
}

/// Joins in `sets` (one set per entry of `cubes`, sorted cube keys) every two 26-adjacent
/// cubes.
pub(crate) fn join_adjacent(cubes: &[u64], sets: &mut Sets) {
    for (c, &key) in cubes.iter().enumerate() {
        let at = [0, 1, 2].map(|a| key >> (a * KEY_BITS) & ((1 << KEY_BITS) - 1));
        // Offset (x, y, z) ∈ {-1, 0, 1}³ has number 13 + x + 3y + 9z, and its cube's key is
        // larger than this one's exactly when that number is: the 13 neighbours with larger
        // keys (the other 13 join from theirs).
        for d in 14..27u64 {
            let off = [d % 3, d / 3 % 3, d / 9].map(|o| o as i64 - 1);
            let near = cube_key([0, 1, 2].map(|a| (at[a] as i64 + off[a]) as u64));
            if let Ok(other) = cubes.binary_search(&near) {
                sets.join(c as u32, other as u32);
            }
        }
    }
}

/// The groups of `positions` (shape: N, indexed by `index`, all ≥ `origin`) under links of at
/// most `link` that hold at most [`CLUMP_POINTS`] points in a box of at most 2 `link` a side:
/// each as ascending point indices, the groups in the order of their first points.
///
/// First cubes of edge e = link / (2√3): two points in the same or in 26-adjacent cubes are at
/// most 2√3·e = link apart, so each set of occupied cubes connected by adjacency lies within
/// one group, and a set of more than 100 points or wider than 2 `link` belongs to no small
/// group. Only the points of the other sets are then linked exactly, by ball queries: the
/// links between points of non-adjacent cubes. (Cubes per axis: at most D / e + 1 ≈ 174, as
/// link ≥ 0.02 D.)
fn small_groups(
    positions: &[DVec3],
    index: &MortonIndex,
    origin: DVec3,
    link: f64,
) -> Vec<Vec<u32>> {
    let n = positions.len();
    let edge = cube_edge(link);
    let keys: Vec<u64> = positions
        .par_iter()
        .map(|&p| cube_key_of(p, origin, edge))
        .collect();
    let mut cubes = keys.clone();
    cubes.par_sort_unstable();
    cubes.dedup();
    let cube_of: Vec<u32> = keys
        .par_iter()
        .map(|k| cubes.binary_search(k).unwrap_or(0) as u32)
        .collect();
    let mut sets = Sets::new(cubes.len());
    join_adjacent(&cubes, &mut sets);
    let span = SPAN_LINKS * link;
    let small = |sets: &mut Sets| -> Vec<bool> {
        let mut count = vec![0usize; cubes.len()];
        let mut boxes = vec![(DVec3::INFINITY, DVec3::NEG_INFINITY); cubes.len()];
        for (i, &p) in positions.iter().enumerate() {
            let r = sets.root(cube_of[i]) as usize;
            count[r] += 1;
            boxes[r] = (boxes[r].0.min(p), boxes[r].1.max(p));
        }
        (0..cubes.len())
            .map(|r| count[r] <= CLUMP_POINTS && (boxes[r].1 - boxes[r].0).max_element() <= span)
            .collect()
    };
    let candidate = small(&mut sets);
    let roots: Vec<u32> = (0..cubes.len() as u32).map(|c| sets.root(c)).collect();
    let linked: Vec<Vec<u32>> = (0..n)
        .into_par_iter()
        .filter(|&i| candidate[roots[cube_of[i] as usize] as usize])
        .map(|i| {
            let mut near = Vec::new();
            index.within(positions[i], link, &mut near);
            let mut other: Vec<u32> = near.iter().map(|&j| cube_of[j as usize]).collect();
            other.retain(|&c| roots[c as usize] != roots[cube_of[i] as usize]);
            other.push(cube_of[i]);
            other
        })
        .collect();
    for cubes_linked in &linked {
        let (&own, others) = cubes_linked.split_last().unwrap_or((&0, &[]));
        for &c in others {
            sets.join(own, c);
        }
    }
    let small_now = small(&mut sets);
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); cubes.len()];
    for i in 0..n {
        let r = sets.root(cube_of[i]) as usize;
        if small_now[r] {
            members[r].push(i as u32);
        }
    }
    let mut groups: Vec<Vec<u32>> = members.into_iter().filter(|g| !g.is_empty()).collect();
    groups.sort_unstable_by_key(|g| g[0]);
    groups
}

/// Whether `group` (ascending point indices) lies off the surface of the rest of the data, at
/// `scale`, `in_small` (shape: N) marking the points of all small groups: no point of a larger
/// group within 3h of it, or the least-distance pair of its point q and such a point s (ties
/// to the lower indices) with q farther than h/2 from the least-squares plane of the points
/// within h/2 of s, and those at least a quarter of `scale.dense`.
fn off_surface(
    group: &[u32],
    positions: &[DVec3],
    index: &MortonIndex,
    scale: &Scale,
    in_small: &[bool],
) -> bool {
    let link = scale.link;
    let order = |a: &(f64, u32, u32), b: &(f64, u32, u32)| {
        a.0.total_cmp(&b.0).then((a.1, a.2).cmp(&(b.1, b.2)))
    };
    let nearest = group
        .iter()
        .filter_map(|&q| {
            let mut near = Vec::new();
            index.within_distances(positions[q as usize], SEARCH_LINKS * link, &mut near);
            near.into_iter()
                .filter(|&(j, _)| !in_small[j as usize])
                .map(|(j, d2)| (d2, q, j))
                .min_by(order)
        })
        .min_by(order);
    let Some((_, q, s)) = nearest else {
        return true;
    };
    let (q, s) = (positions[q as usize], positions[s as usize]);
    let mut near = Vec::new();
    index.within(s, PLANE_LINKS * link, &mut near);
    if (near.len() as f64) < SUPPORT_SHARE * scale.dense {
        return false;
    }
    near.sort_unstable(); // sums in index order
    fit_plane(near.iter().map(|&j| positions[j as usize]))
        .is_some_and(|plane| (q - s).dot(plane.normal).abs() > OFF_PLANE_LINKS * link)
}

#[cfg(test)]
#[path = "find_clumps_tests.rs"]
mod tests;
