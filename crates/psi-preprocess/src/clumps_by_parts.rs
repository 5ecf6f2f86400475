//! The stray-clump search by parts ([`crate::find_clumps`] over points read part by part, as
//! tiles of a store give them), bitwise the search over all points: its two statistics from
//! sampled spacings, each measured among the points of a cube around its sample
//! ([`clump_spacing_in_cube`], [`ClumpScale::of_spacings`]); the cubes of edge h/(2√3)
//! counted and boxed part by part ([`ClumpCubes`]), whose adjacent cubes' points are always
//! linked, so that a set of occupied cubes connected by adjacency of more than 100 points or
//! wider than 2h holds no clump; only the points of the other sets (a scan's clumps and its
//! sparsest fragments) are then read again with the points around them
//! ([`clumps_of_candidates`]). Indices are the points' ranks among those searched (the
//! in-core search's indices).

use std::collections::BTreeMap;

use glam::DVec3;
use psi_octree::MortonIndex;

use crate::disjoint_sets::Sets;
use crate::find_clumps::{
    CLUMP_POINTS, MAX_SHARE, OFF_PLANE_LINKS, PLANE_LINKS, SEARCH_LINKS, SPACING_NEIGHBOURS,
    SPACING_SAMPLES, SPAN_LINKS, SUPPORT_SHARE, Scale, cube_edge, cube_key_of, join_adjacent,
    spacing_of,
};
use crate::local_fit::fit_plane;

/// The two statistics of the whole input the search reads: the link distance h and the points
/// a well-sampled surface holds within h/2 (world units; [`crate::find_clumps`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClumpScale(Scale);

impl ClumpScale {
    /// Indices between the sampled spacings among `n` points (0, stride, 2·stride, …).
    pub fn spacing_stride(n: u64) -> u64 {
        n.div_ceil(SPACING_SAMPLES as u64).max(1)
    }

    /// The scale of points of bounding-box diagonal `diagonal` (world units) whose sampled
    /// spacings ([`clump_spacing_in_cube`], every sample's) are `spacings` (any order; not
    /// empty).
    pub fn of_spacings(spacings: Vec<f64>, diagonal: f64) -> ClumpScale {
        ClumpScale(Scale::from_spacings(spacings, diagonal))
    }

    /// The link distance h, world units.
    pub fn link(&self) -> f64 {
        self.0.link
    }
}

/// The sampled spacing of the point at `x` (world units; shape of `cube`: M) as
/// [`crate::find_clumps`] measures it among all the points it searches, from `cube`, those
/// of them within the cube of half-edge `reach` around `x` (`x` among them): `None` when its
/// 16th nearest other point may lie beyond `reach`, unless `holds_all` (the cube holds every
/// point searched; then fewer than 16 others are measured as in core). A pass out of core
/// finds each sample's cube in the tile files.
pub fn clump_spacing_in_cube(x: DVec3, cube: &[DVec3], reach: f64, holds_all: bool) -> Option<f64> {
    let k = SPACING_NEIGHBOURS + 1;
    let near = MortonIndex::new(cube).nearest(x, k);
    let distance = near.last().map_or(0.0, |&(_, d2)| d2.sqrt());
    (holds_all || (near.len() == k && distance < reach)).then(|| spacing_of(distance))
}

/// The occupied cubes of edge h/(2√3) from the bounding box's low corner: per cube key, its
/// points' count and box (world units), gathered part by part ([`ClumpCubes::add`],
/// [`ClumpCubes::merge`]).
#[derive(Clone, Debug)]
pub struct ClumpCubes {
    origin: DVec3,
    edge: f64,
    cubes: BTreeMap<u64, (u64, DVec3, DVec3)>,
}

impl ClumpCubes {
    /// No points yet, for points whose bounding box's low corner is `origin` at `scale`.
    pub fn new(origin: DVec3, scale: &ClumpScale) -> Self {
        ClumpCubes {
            origin,
            edge: cube_edge(scale.0.link),
            cubes: BTreeMap::new(),
        }
    }

    /// Counts the point at `p` (world units).
    pub fn add(&mut self, p: DVec3) {
        let e = self
            .cubes
            .entry(cube_key_of(p, self.origin, self.edge))
            .or_insert((0, p, p));
        *e = (e.0 + 1, e.1.min(p), e.2.max(p));
    }

    /// Both parts' points (of the same origin and scale).
    pub fn merge(mut self, other: ClumpCubes) -> ClumpCubes {
        for (k, (n, lo, hi)) in other.cubes {
            let e = self.cubes.entry(k).or_insert((0, lo, hi));
            *e = (e.0 + n, e.1.min(lo), e.2.max(hi));
        }
        self
    }

    /// The cube key of `p`.
    fn key(&self, p: DVec3) -> u64 {
        cube_key_of(p, self.origin, self.edge)
    }

    /// The cubes (sorted keys) and their sets joined by adjacency.
    fn components(&self) -> (Vec<u64>, Sets) {
        let keys: Vec<u64> = self.cubes.keys().copied().collect();
        let mut sets = Sets::new(keys.len());
        join_adjacent(&keys, &mut sets);
        (keys, sets)
    }

    /// Per root of `sets` (over the cubes in key order): whether its points are at most
    /// [`CLUMP_POINTS`] within a box of `span` a side.
    fn small_roots(&self, sets: &mut Sets, span: f64) -> Vec<bool> {
        let n = self.cubes.len();
        let mut count = vec![0u64; n];
        let mut boxes = vec![(DVec3::INFINITY, DVec3::NEG_INFINITY); n];
        for (c, (k, lo, hi)) in self.cubes.values().enumerate() {
            let r = sets.root(c as u32) as usize;
            count[r] += k;
            boxes[r] = (boxes[r].0.min(*lo), boxes[r].1.max(*hi));
        }
        (0..n)
            .map(|r| {
                count[r] <= CLUMP_POINTS as u64 && (boxes[r].1 - boxes[r].0).max_element() <= span
            })
            .collect()
    }

    /// The candidate cubes: those of the sets of adjacent occupied cubes that hold at most
    /// [`CLUMP_POINTS`] points within a box of 2h a side (world units, `scale` as in
    /// [`ClumpCubes::new`]). A point outside them belongs to no clump.
    pub fn candidates(&self, scale: &ClumpScale) -> Candidates {
        let span = SPAN_LINKS * scale.0.link;
        let (keys, mut sets) = self.components();
        let small = self.small_roots(&mut sets, span);
        let cubes = keys
            .iter()
            .enumerate()
            .filter(|&(c, _)| small[sets.root(c as u32) as usize])
            .map(|(_, &k)| k)
            .collect();
        Candidates { cubes }
    }
}

/// The cubes whose points may belong to a clump ([`ClumpCubes::candidates`]).
#[derive(Clone, Debug, Default)]
pub struct Candidates {
    cubes: Vec<u64>,
}

impl Candidates {
    /// Whether a point at `p` may belong to a clump (`cubes` the cubes it was found from).
    pub fn holds(&self, cubes: &ClumpCubes, p: DVec3) -> bool {
        self.cubes.binary_search(&cubes.key(p)).is_ok()
    }

    /// Whether no point may.
    pub fn is_empty(&self) -> bool {
        self.cubes.is_empty()
    }
}

/// The stray clumps among `n` points from the candidates' points `candidates` ((index,
/// world position), every point [`Candidates::holds`] accepts), given `cubes` and `scale` (of
/// all `n` points) and `gather(lo, hi)`, the points (index, position) in the closed box
/// `lo..=hi` (world units; any order): each clump as ascending indices, the clumps in the order
/// of their first points, none when they hold more than 1 % of the points (then their count is
/// returned as withheld). Bitwise [`crate::find_clumps`] of all points. An error of `gather` is
/// passed on.
pub fn clumps_of_candidates<E>(
    n: u64,
    cubes: &ClumpCubes,
    scale: &ClumpScale,
    mut candidates: Vec<(u64, DVec3)>,
    gather: &mut dyn FnMut(DVec3, DVec3) -> Result<Vec<(u64, DVec3)>, E>,
) -> Result<(Vec<Vec<u64>>, u64), E> {
    let link = scale.0.link;
    let span = SPAN_LINKS * link;
    let (keys, mut sets) = cubes.components();
    let cube_index = |p: DVec3| keys.binary_search(&cubes.key(p)).unwrap_or(0) as u32;
    candidates.sort_unstable_by_key(|c| c.0);
    // Each candidate set's points with the points within h of them: their cubes are linked.
    let mut by_set: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
    for (k, c) in candidates.iter().enumerate() {
        by_set
            .entry(sets.root(cube_index(c.1)))
            .or_default()
            .push(k);
    }
    let mut links: Vec<(u32, u32)> = Vec::new();
    for members in by_set.values() {
        let (lo, hi) = box_of(members.iter().map(|&k| candidates[k].1));
        let around = gather(lo - DVec3::splat(link), hi + DVec3::splat(link))?;
        for &k in members {
            let p = candidates[k].1;
            let own = cube_index(p);
            for &(_, q) in &around {
                if (q - p).length_squared() <= link * link {
                    links.push((own, cube_index(q)));
                }
            }
        }
    }
    for (a, b) in links {
        sets.join(a, b);
    }
    let small = cubes.small_roots(&mut sets, span);
    let mut groups: BTreeMap<u32, Vec<u64>> = BTreeMap::new();
    for c in &candidates {
        let r = sets.root(cube_index(c.1));
        if small[r as usize] {
            groups.entry(r).or_default().push(c.0);
        }
    }
    let mut groups: Vec<Vec<u64>> = groups.into_values().collect();
    groups.sort_unstable_by_key(|g| g[0]);
    let in_small: Vec<u64> = {
        let mut all: Vec<u64> = groups.iter().flatten().copied().collect();
        all.sort_unstable();
        all
    };
    let position = |i: u64| {
        let k = candidates
            .binary_search_by_key(&i, |c| c.0)
            .expect("a candidate");
        candidates[k].1
    };
    let mut stray = Vec::with_capacity(groups.len());
    for g in &groups {
        let (lo, hi) = box_of(g.iter().map(|&i| position(i)));
        let reach = DVec3::splat((SEARCH_LINKS + PLANE_LINKS) * link);
        let mut around = gather(lo - reach, hi + reach)?;
        around.sort_unstable_by_key(|a| a.0);
        stray.push(off_surface(g, &position, &around, &scale.0, &in_small));
    }
    let mut stray = stray.into_iter();
    groups.retain(|_| stray.next().unwrap_or(false));
    let points: u64 = groups.iter().map(|g| g.len() as u64).sum();
    if points as f64 > MAX_SHARE * n as f64 {
        return Ok((Vec::new(), points));
    }
    Ok((groups, 0))
}

/// The box of `points` (world units).
fn box_of(points: impl Iterator<Item = DVec3>) -> (DVec3, DVec3) {
    points.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
        (lo.min(p), hi.max(p))
    })
}

/// [`crate::find_clumps`]'s test of whether `group` (ascending indices, `position` of each)
/// lies off the surface, on `around` (the points within 3.5h of it, ascending indices) and
/// `in_small` (the indices of all small groups' points, ascending).
fn off_surface(
    group: &[u64],
    position: &dyn Fn(u64) -> DVec3,
    around: &[(u64, DVec3)],
    scale: &Scale,
    in_small: &[u64],
) -> bool {
    let link = scale.link;
    let reach2 = (SEARCH_LINKS * link) * (SEARCH_LINKS * link);
    let order = |a: &(f64, u64, u64), b: &(f64, u64, u64)| {
        a.0.total_cmp(&b.0).then((a.1, a.2).cmp(&(b.1, b.2)))
    };
    let nearest = group
        .iter()
        .filter_map(|&q| {
            let x = position(q);
            around
                .iter()
                .filter(|(j, _)| in_small.binary_search(j).is_err())
                .map(|&(j, p)| ((p - x).length_squared(), q, j))
                .filter(|&(d2, _, _)| d2 <= reach2)
                .min_by(order)
        })
        .min_by(order);
    let Some((_, q, s)) = nearest else {
        return true;
    };
    let (q, s) = (position(q), around[around.partition_point(|a| a.0 < s)].1);
    let r = PLANE_LINKS * link;
    let near: Vec<DVec3> = around
        .iter()
        .filter(|(_, p)| (*p - s).length_squared() <= r * r)
        .map(|a| a.1)
        .collect();
    if (near.len() as f64) < SUPPORT_SHARE * scale.dense {
        return false;
    }
    fit_plane(near).is_some_and(|plane| (q - s).dot(plane.normal).abs() > OFF_PLANE_LINKS * link)
}
