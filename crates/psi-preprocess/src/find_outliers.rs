//! Stray points: points that no surface supports. First the points that clearly sit on a
//! surface are found — "core" points: their neighbourhood is about as dense as their
//! neighbours' and as the data's typical one, and they lie on the quadric surface their
//! neighbours describe, within those neighbours' own spread and the sample spacing. Every other
//! point is then judged against the core points near it: it is an outlier when the nearest core
//! point is several sample spacings away, or when it lies off the surface those core points
//! describe. Two stages, so that a clump of stray points, which supports itself, is judged
//! against the surface rather than against itself.

use glam::DVec3;
use psi_octree::{Monitor, MortonIndex};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::local_fit::QuadricFit;
use crate::median::median;

/// Neighbours per point (itself excluded).
pub(crate) const NEIGHBOURS: usize = 16;

/// A core point's 16th-neighbour distance is at most this multiple of the median of its
/// neighbours' …
const LOCAL_DENSITY: f64 = 1.5;

/// … and, unless its neighbours lie on a surface, at most this multiple of the median over
/// all points.
const GLOBAL_DENSITY: f64 = 3.0;

/// Neighbours lie on a surface when their residual standard deviation about their quadric is
/// below this share of their reach (a cloud scattered through a volume gives 0.1–0.2, a
/// sparsely sampled surface far less).
const SURFACE_LIKE: f64 = 0.05;

/// A point sparser than its neighbours is kept without the second stage when its
/// 16th-neighbour distance is at most this multiple of theirs, and they lie on a surface within
/// a sample spacing.
const SPARSE_PART: f64 = 2.5;

/// … and when it lies among them: its offset from their centroid in their plane is at most this
/// share of its 16th-neighbour distance (a point beside a patch is judged by extrapolating the
/// patch's quadric, which can pass anywhere).
const BESIDE: f64 = 0.6;

/// A core point, or a sparse part, has a neighbour near it: its nearest neighbour at most this
/// share of its 16th-neighbour distance away (about 0.25 on a surface sampled evenly, 0.35 at
/// a border; a stray point in a hole of the data has its 16 nearest on the hole's rim, all
/// about as far).
const ISOLATED: f64 = 0.6;

/// A point is off the surface when its distance to the quadric of its neighbours exceeds this
/// many of their residual standard deviations plus [`OFF_SURFACE_SPACINGS`] sample spacings.
const OFF_SURFACE_SPREADS: f64 = 4.0;

/// See [`OFF_SURFACE_SPREADS`]; a core point lies no farther from its neighbours' quadric than
/// the second farthest of them plus this many sample spacings.
const OFF_SURFACE_SPACINGS: f64 = 1.5;

/// Two normals agree when |n_i·n_j| reaches this (60°).
const NORMAL_AGREEMENT: f64 = 0.5;

/// A normal that disagrees with the neighbours' counts against a point this many sample
/// spacings or more off their quadric.
const LIFTED_SPACINGS: f64 = 0.25;

/// A non-core point whose nearest core point is farther than this many sample spacings is an
/// outlier.
const FAR_SPACINGS: f64 = 2.5;

/// What [`find_outliers`] found.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Outliers {
    /// Per point (shape: N): whether it is an outlier.
    pub mask: Vec<bool>,
    /// Outliers farther than a few sample spacings from every point on a surface.
    pub far: usize,
    /// Outliers near the data but off the surface it describes (or, with normals given, with a
    /// normal across it).
    pub off_surface: usize,
}

impl Outliers {
    /// The number of outliers.
    pub fn count(&self) -> usize {
        self.far + self.off_surface
    }

    /// None among `n` points.
    fn none(n: usize) -> Self {
        Outliers {
            mask: vec![false; n],
            ..Outliers::default()
        }
    }
}

/// A point's standing after the first stage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Status {
    /// Clearly on a surface: the second stage judges the others against these.
    Core,
    /// On a surface its neighbours describe, if sparser than they are.
    Inlier,
    /// To be judged against the core points near it.
    Unsure,
}

/// Whether a point whose 16th-neighbour distance is `reach` is within the density bound the
/// median `typical` of those distances over all points sets (3 × it): the one way a point's
/// standing reads the whole input. With `typical` infinite, every point is.
pub(crate) fn dense_globally(reach: f64, typical: f64) -> bool {
    reach <= GLOBAL_DENSITY * typical
}

/// The 16th-neighbour distance → sample spacing: the radius of the disc one of 16 points fills.
fn spacing_of(reach: f64) -> f64 {
    reach * (std::f64::consts::PI / NEIGHBOURS as f64).sqrt()
}

/// Whether `p` lies off `fit`, the quadric surface of its neighbours: farther from it than
/// 4 × their residual standard deviation plus 1.5 × `spacing`, the sample spacing there.
fn off_surface(fit: &QuadricFit, p: DVec3, spacing: f64) -> bool {
    let limit = OFF_SURFACE_SPREADS * fit.sigma() + OFF_SURFACE_SPACINGS * spacing;
    fit.height(p).abs() > limit
}

/// Whether `p` lies outside the band its neighbours `near` occupy about their quadric `fit`:
/// farther from it than the second farthest of them plus 1.5 × `spacing`. The first stage's
/// test: a core point lies among its neighbours, so that a stray point near a detailed surface
/// does not become one and vouch for a second stray point beside it; noisy points outside the
/// band are judged in the second stage, with the residual deviations (notes:
/// 2026-11-26-outlier-pairs).
fn outside_band(fit: &QuadricFit, p: DVec3, spacing: f64, near: &[DVec3]) -> bool {
    let h = fit.height(p).abs();
    let margin = OFF_SURFACE_SPACINGS * spacing;
    // (Most points lie well within a spacing: no need for the neighbours' heights.)
    if h <= margin {
        return false;
    }
    // The second largest of the neighbours' heights: one stray neighbour (a second stray point
    // near this one) does not widen the band.
    let (mut first, mut second) = (0.0f64, 0.0f64);
    for q in near {
        let hq = fit.height(*q).abs();
        if hq > first {
            (first, second) = (hq, first);
        } else if hq > second {
            second = hq;
        }
    }
    h > second + margin
}

/// Finds the points of `positions` (shape: N, world units) that no surface supports. With d(p)
/// the distance from p to its 16th nearest other point and a spacing d·√(π/16), a core point
/// has d(p) ≤ 1.5 × the median of d over those neighbours and its nearest neighbour within
/// 0.6 d(p); lies no farther from the least-squares quadric of those neighbours (refitted
/// without the farthest of them when that one lies more than a spacing and 3 robust
/// deviations off) than the second farthest of them plus 1.5 spacings; with
/// `normals` (shape: N, unit, either sign), unless it lies within a quarter of a spacing of
/// that quadric, has a normal within 60° of (either sign of) at least a quarter of theirs; and,
/// when d(p) > 3 × the median of d over all points, has neighbours that lie on a surface
/// (residual deviation below 0.05 d(p)). A point within both density bounds and within a
/// quarter of a spacing of its neighbours' centroid is a core point without a fit (a shortcut:
/// such a point lies among them, where no fit finds it off). A point that passes the quadric
/// test and is sparser than its neighbours (d(p) up to 2.5 × theirs) but among them (its offset
/// from their centroid in their plane at most 0.6 d(p), its nearest neighbour within 0.6 d(p)),
/// on a quadric that fits them within a spacing, is kept. Any other point is an outlier when
/// its nearest core point is farther than 2.5 spacings of the core points there, or when it
/// lies farther than 4 residual standard deviations plus 1.5 spacings from the quadric of its
/// 16 nearest core points or fails the normal test against them. Inputs of at most 16 points
/// have no outliers; a point with a non-finite coordinate is one (far). Deterministic and
/// independent of the thread count.
///
/// ```
/// use glam::DVec3;
/// use psi_preprocess::find_outliers;
///
/// let mut points: Vec<DVec3> = (0..900)
///     .map(|i| DVec3::new((i % 30) as f64, (i / 30) as f64, 0.0))
///     .collect();
/// points.push(DVec3::new(14.5, 14.5, 6.0)); // six spacings above the grid
/// points.push(DVec3::new(14.5, 14.5, 0.5)); // half a spacing: noise, not an outlier
/// let found = find_outliers(&points, None);
/// assert_eq!(found.count(), 1);
/// assert!(found.mask[900] && !found.mask[901]);
/// ```
pub fn find_outliers(positions: &[DVec3], normals: Option<&[DVec3]>) -> Outliers {
    find_outliers_with(positions, normals, &Monitor::silent())
}

/// [`find_outliers`], stopping early once `monitor`'s flag is set (checked per cell of a few
/// dozen points in the neighbour search, then per point; the result is then meaningless and
/// the caller discards it).
pub fn find_outliers_with(
    positions: &[DVec3],
    normals: Option<&[DVec3]>,
    monitor: &Monitor<'_>,
) -> Outliers {
    // The points in Morton order (slots), where neighbours' data lie together.
    let index = MortonIndex::new(positions);
    let given = normals.filter(|v| v.len() == positions.len());
    let normal_of = given.map(|v| move |i: usize| v[i]);
    let normal_of = normal_of.as_ref().map(|f| f as &NormalOf<'_>);
    find_outliers_in(&index, positions.len(), normal_of, monitor)
}

/// The given unit normal of the point of an index (either sign).
pub(crate) type NormalOf<'a> = dyn Fn(usize) -> DVec3 + Sync + 'a;

/// [`find_outliers_with`] of the `n` points that `index` indexes (its ids: 0..n, the
/// non-finite points left out), `normal_of` giving a point's normal by original index (read
/// only where a point lies a little off its neighbours' quadric: no copy of all normals).
pub(crate) fn find_outliers_in(
    index: &MortonIndex,
    n: usize,
    normal_of: Option<&NormalOf<'_>>,
    monitor: &Monitor<'_>,
) -> Outliers {
    let ids = index.ids();
    let by_slot = normal_of.map(|f| move |s: usize| f(ids[s] as usize));
    let by_slot = by_slot.as_ref().map(|f| f as &NormalOf<'_>);
    let found = outliers_in_order(index, by_slot, monitor);
    // Back to the caller's order; a point with a non-finite coordinate is far from everything.
    let mut mask = vec![true; n];
    for (&i, &m) in ids.iter().zip(&found.mask) {
        mask[i as usize] = m;
    }
    let unindexed = n - index.len();
    Outliers {
        mask,
        far: found.far + unindexed,
        ..found
    }
}

/// Whether point `i`'s given normal lies along the normals of at least a quarter of `near`
/// (either sign: orientation is repaired later), as a point of a surface's does; `true`
/// without normals. Indices as `normal_of` takes them.
pub(crate) fn normal_fits(
    normal_of: Option<&NormalOf<'_>>,
    i: usize,
    near: &mut dyn Iterator<Item = usize>,
) -> bool {
    let Some(normal_of) = normal_of else {
        return true;
    };
    let n_i = normal_of(i);
    let (mut agree, mut count) = (0, 0);
    for j in near {
        count += 1;
        agree += usize::from(n_i.dot(normal_of(j)).abs() >= NORMAL_AGREEMENT);
    }
    4 * agree >= count
}

/// A point's 16 nearest other points (slots, nearest first, ties to the lower index) and the
/// distance to the 16th (world units).
pub(crate) type Nearest = ([u32; NEIGHBOURS], f64);

/// Each point's [`Nearest`] in `index`, by slot; `None` once `monitor`'s flag is set.
pub(crate) fn nearest_of(index: &MortonIndex, monitor: &Monitor<'_>) -> Option<Vec<Nearest>> {
    index
        .map_nearest_with(NEIGHBOURS, monitor, |_, near| nearest_from(near))
        .ok()
}

/// A point's [`Nearest`] from its neighbours as the sweep gives them (slot, squared
/// distance; nearest first, at most [`NEIGHBOURS`]).
pub(crate) fn nearest_from(near: &[(u32, f64)]) -> Nearest {
    let mut slots = [0u32; NEIGHBOURS];
    for (slot, &(j, _)) in slots.iter_mut().zip(near) {
        *slot = j;
    }
    (slots, near.last().map_or(0.0, |l| l.1.sqrt()))
}

/// The first stage's standing of the point at slot `i` of `positions` (shape: N, by slot):
/// from its [`Nearest`] and its neighbours' reaches in `nearest` (shape: N), `typical` the
/// median reach over all points, `normal_of` by slot.
pub(crate) fn status_of(
    i: usize,
    positions: &[DVec3],
    nearest: &[Nearest],
    typical: f64,
    normal_of: Option<&NormalOf<'_>>,
) -> Status {
    let reach = |j: usize| nearest[j].1;
    status_from((i, &nearest[i]), positions, &reach, typical, normal_of)
}

/// [`status_of`] of slot `i` with its [`Nearest`] `near_i`, each slot's 16th-neighbour
/// distance from `reach` (world units; read for `i`'s neighbours alone).
pub(crate) fn status_from(
    (i, (near, reach_i)): (usize, &Nearest),
    positions: &[DVec3],
    reach: &dyn Fn(usize) -> f64,
    typical: f64,
    normal_of: Option<&NormalOf<'_>>,
) -> Status {
    let reach_i = *reach_i;
    let mut around = near.map(|j| reach(j as usize));
    let local = median(&mut around);
    let pts = near.map(|j| positions[j as usize]);
    // Most points of a surface sit among their neighbours, within a fraction of a
    // spacing of their centroid: no fit can find them off it.
    // A point far from its nearest neighbour is neither core nor a sparse part.
    if (positions[near[0] as usize] - positions[i]).length() > ISOLATED * reach_i {
        return Status::Unsure;
    }
    let centroid = pts.iter().sum::<DVec3>() / NEIGHBOURS as f64;
    if reach_i <= LOCAL_DENSITY * local
        && dense_globally(reach_i, typical)
        && (positions[i] - centroid).length() <= LIFTED_SPACINGS * spacing_of(local)
    {
        return Status::Core;
    }
    // (Trimmed: a stray neighbour must not bend the surface towards the point.)
    let Some(fit) = QuadricFit::of_trimmed(&pts, reach_i, spacing_of(local)) else {
        return Status::Unsure;
    };
    let surface_like = fit.sigma() <= SURFACE_LIKE * reach_i;
    let on_it = !outside_band(&fit, positions[i], spacing_of(local), &pts);
    let dense = reach_i <= LOCAL_DENSITY * local;
    let sparse_cloud = !dense_globally(reach_i, typical) && !surface_like;
    // Sparser than its neighbours but on the thin surface they describe: a sparsely
    // sampled part of it (large triangles beside small ones, a scan's border).
    let sparse_part = reach_i <= SPARSE_PART * local
        && fit.sigma() <= spacing_of(local)
        && fit.tangential_offset(positions[i]) <= BESIDE * reach_i;
    // A normal across the surface counts against a point a little off it.
    let lifted = fit.height(positions[i]).abs() > LIFTED_SPACINGS * spacing_of(local);
    let across = lifted && !normal_fits(normal_of, i, &mut near.iter().map(|&j| j as usize));
    match (dense, on_it && !across, sparse_cloud) {
        (true, true, false) => Status::Core,
        (false, true, false) if sparse_part => Status::Inlier,
        _ => Status::Unsure,
    }
}

/// The second stage's verdict on an unsure point (slot `i`, at `x`) given `near`, its 16
/// nearest core points as `core_index.nearest` finds them: 0 inlier, 1 far, 2 off the
/// surface. `core_slots` (shape: C) maps a core point to its slot, whose reach is
/// `reach(slot)`; `normal_of` by slot.
pub(crate) fn verdict_of(
    (i, x): (usize, DVec3),
    near: &[(u32, f64)],
    (core_index, core_slots): (&MortonIndex, &[u32]),
    reach: &dyn Fn(usize) -> f64,
    normal_of: Option<&NormalOf<'_>>,
) -> u8 {
    if near.len() < NEIGHBOURS {
        // Hardly any surface at all: nothing to judge against.
        return 0;
    }
    let mut reaches: Vec<f64> = near
        .iter()
        .map(|&(k, _)| reach(core_slots[k as usize] as usize))
        .collect();
    let spacing = spacing_of(median(&mut reaches));
    if near[0].1.sqrt() > FAR_SPACINGS * spacing {
        return 1;
    }
    let core_positions = core_index.points();
    let pts: Vec<DVec3> = near
        .iter()
        .map(|&(k, _)| core_positions[k as usize])
        .collect();
    let fit_reach = near.last().map_or(0.0, |l| l.1.sqrt());
    let Some(fit) = QuadricFit::of(&pts, fit_reach) else {
        return 0;
    };
    let lifted = fit.height(x).abs() > LIFTED_SPACINGS * spacing;
    let across = lifted
        && !normal_fits(
            normal_of,
            i,
            &mut near.iter().map(|&(k, _)| core_slots[k as usize] as usize),
        );
    if off_surface(&fit, x, spacing) || across {
        2
    } else {
        0
    }
}

/// [`find_outliers`] on the points of `index`, by slot (`normal_of` by slot too).
fn outliers_in_order(
    index: &MortonIndex,
    normal_of: Option<&NormalOf<'_>>,
    monitor: &Monitor<'_>,
) -> Outliers {
    let positions = index.points();
    let n = positions.len();
    if n <= NEIGHBOURS {
        return Outliers::none(n);
    }
    // Each point's neighbours, itself excluded (a coincident twin counts as a neighbour), and
    // its 16th-neighbour distance.
    let Some(nearest) = nearest_of(index, monitor) else {
        return Outliers::none(n);
    };
    let reach: Vec<f64> = nearest.par_iter().map(|n| n.1).collect();
    let typical = median(&mut reach.clone());
    let status: Vec<Status> = (0..n)
        .into_par_iter()
        .map(|i| {
            if monitor.stopped() {
                return Status::Core;
            }
            status_of(i, positions, &nearest, typical, normal_of)
        })
        .collect();
    // (The neighbour lists are not needed again: freed before the second stage's index.)
    drop(nearest);
    if monitor.stopped() || !status.contains(&Status::Unsure) {
        return Outliers::none(n);
    }
    // The other points, judged against the core points near them.
    let core_slots: Vec<u32> = (0..n as u32)
        .filter(|&i| status[i as usize] == Status::Core)
        .collect();
    let core_index = index.subset(|s| status[s] == Status::Core);
    let reach = |s: usize| reach[s];
    let verdicts: Vec<u8> = (0..n)
        .into_par_iter()
        .map(|i| {
            if status[i] != Status::Unsure || monitor.stopped() {
                return 0;
            }
            let near = core_index.nearest(positions[i], NEIGHBOURS);
            let core = (&core_index, core_slots.as_slice());
            verdict_of((i, positions[i]), &near, core, &reach, normal_of)
        })
        .collect();
    Outliers {
        mask: verdicts.iter().map(|&v| v != 0).collect(),
        far: verdicts.iter().filter(|&&v| v == 1).count(),
        off_surface: verdicts.iter().filter(|&&v| v == 2).count(),
    }
}

#[cfg(test)]
#[path = "find_outliers_tests.rs"]
mod tests;
