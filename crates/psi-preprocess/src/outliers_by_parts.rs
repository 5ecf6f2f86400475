//! The outlier step by parts: what `preprocess` does to a scan's stray points before the clump
//! search — repeated positions left out, then [`crate::find_outliers`] — bitwise, from parts of
//! the points (a tile and a halo of the points around it) that never need to be held together.
//!
//! The search reads one statistic of the whole input, the median over all points of the
//! distance to the 16th nearest ([`part_outlier_reaches`] gives each part's, and
//! [`median_of_passes`] their median in a few streamed passes); every other quantity is local.
//! A point's standing in the first stage reads its 16 nearest and their 16th-neighbour
//! distances, so a part decides it when it holds the balls of the point and of each neighbour;
//! an unsure point is judged against its 16 nearest core points, so a part decides it when it
//! holds that ball and every point in it has a standing. Neighbours tie to the lower index,
//! and a part's points are kept in the input's order, so its answers are the whole search's.
//! Repeats (a position equal to a point of lower index) lie in whichever parts their first copy
//! lies in.
//!
//! [`median_of_passes`]: crate::median_of_passes

use glam::DVec3;
use psi_octree::MortonIndex;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::find_outliers::{NEIGHBOURS, Nearest, Status, nearest_of, status_of, verdict_of};
use crate::orient_by_parts::{IncompletePart, certified};

/// The outlier search's statistics of the whole input (after repeats are left out).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct OutlierStats {
    /// The median over all points of the distance to the 16th nearest other point (world
    /// units; the upper middle value, as the in-core search takes it).
    pub typical: f64,
    /// Points searched (finite, repeats left out): at most 16 have no outliers.
    pub points: u64,
}

/// What the outlier step does with a point.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum StrayVerdict {
    /// Kept.
    Kept,
    /// Left out: its position repeats that of a point of lower index.
    Repeated,
    /// Left out: farther than a few sample spacings from every point on a surface (or not
    /// finite).
    Far,
    /// Left out: near the data but off the surface it describes.
    OffSurface,
}

/// A part's points without the repeats, indexed, with each one's 16 nearest.
struct Neighbourhoods {
    /// The part's finite points that repeat no point of lower index, in the part's order.
    index: MortonIndex,
    /// The part's index of each slot's point.
    part_of: Vec<usize>,
    /// Per slot.
    nearest: Vec<Nearest>,
    /// Per slot: whether the part holds the ball out to its 16th nearest.
    certified: Vec<bool>,
    /// Per point of the part: whether it repeats a point of lower index.
    repeated: Vec<bool>,
}

impl Neighbourhoods {
    fn of(positions: &[DVec3], complete: &(dyn Fn(DVec3, f64) -> bool + Sync)) -> Self {
        // Ties among neighbours go to the lower local index, which is the lower input index.
        let all = MortonIndex::new(positions);
        let mut repeated = vec![false; positions.len()];
        for c in all.repeated_positions() {
            repeated[c as usize] = true;
        }
        let keep: Vec<bool> = repeated.iter().map(|r| !r).collect();
        let kept: Vec<usize> = (0..positions.len()).filter(|&i| keep[i]).collect();
        let index = all.retained(&keep);
        drop(all);
        let part_of: Vec<usize> = index.ids().iter().map(|&k| kept[k as usize]).collect();
        let nearest = nearest_of(&index, &psi_octree::Monitor::silent()).expect("a silent monitor");
        let mut hood = Self {
            index,
            part_of,
            nearest,
            certified: Vec::new(),
            repeated,
        };
        let by_slot = hood.index.points();
        hood.certified = (0..hood.index.len())
            .into_par_iter()
            .map(|s| complete(by_slot[s], hood.own_reach(s)))
            .collect();
        hood
    }

    /// The ball slot `s`'s 16 nearest lie in: out to the 16th (infinite when the part holds
    /// 16 points or fewer: only the whole input then answers).
    fn own_reach(&self, s: usize) -> f64 {
        if self.index.len() > NEIGHBOURS {
            self.nearest[s].1
        } else {
            f64::INFINITY
        }
    }

    /// The reach a part must hold around slot `s` to give its standing: its neighbours' balls.
    fn standing_reach(&self, s: usize) -> f64 {
        let x = self.index.points()[s];
        let (near, reach) = &self.nearest[s];
        let mut need = if self.certified[s] {
            *reach
        } else {
            f64::INFINITY
        };
        for &q in near {
            let q = q as usize;
            if !self.certified[q] {
                let r = (self.index.points()[q] - x).length() + self.nearest[q].1;
                need = need.max(r);
            }
        }
        if self.index.len() <= NEIGHBOURS {
            need = f64::INFINITY;
        }
        need
    }

    /// Whether slot `s`'s standing is decided: its ball and its neighbours' are held.
    fn decided(&self, s: usize) -> bool {
        self.certified[s]
            && self.nearest[s]
                .0
                .iter()
                .all(|&q| self.certified[q as usize])
    }
}

/// The distance to the 16th nearest other point of each of a part's own points that the
/// outlier search reads (finite, repeating no point of lower index): `positions` (shape: M,
/// world units) the part's own points and its halo, `ids` (shape: M) their input indices,
/// ascending, `own` (shape: M) which are its own; `complete(x, r)` tells whether every input
/// point within `r` of `x` is among `positions`. In no particular order (their median over all
/// parts is [`OutlierStats::typical`]); or the uncertain own point whose neighbours reach
/// farthest.
///
/// # Panics
///
/// When the lengths differ or `ids` do not ascend.
pub fn part_outlier_reaches(
    positions: &[DVec3],
    ids: &[u32],
    own: &[bool],
    complete: &(dyn Fn(DVec3, f64) -> bool + Sync),
) -> Result<Vec<f64>, IncompletePart> {
    assert!(positions.len() == ids.len() && ids.len() == own.len());
    assert!(ids.is_sorted(), "ids ascend");
    let hood = Neighbourhoods::of(positions, complete);
    let rows = (0..hood.index.len())
        .filter(|&s| own[hood.part_of[s]])
        .map(|s| {
            if hood.certified[s] {
                Ok(hood.nearest[s].1)
            } else {
                Err(IncompletePart {
                    id: ids[hood.part_of[s]],
                    neighbours: NEIGHBOURS,
                    reach: hood.own_reach(s),
                })
            }
        })
        .collect();
    certified(rows)
}

/// The outlier step's verdict on each of a part's own points (shape: the own points, in the
/// part's order): bitwise what `preprocess` decides for them (repeats left out, then
/// [`crate::find_outliers`] with `stats` of the whole input), before its clump search.
/// `positions`, `ids`, `own`, `complete` as for [`part_outlier_reaches`]; `normals` (shape: M,
/// unit, either sign) the given normals, `None` for positions alone. Or the uncertain own
/// point whose answer reaches farthest.
///
/// # Panics
///
/// When the lengths differ or `ids` do not ascend.
pub fn part_outliers(
    positions: &[DVec3],
    ids: &[u32],
    own: &[bool],
    normals: Option<&[DVec3]>,
    complete: &(dyn Fn(DVec3, f64) -> bool + Sync),
    stats: OutlierStats,
) -> Result<Vec<StrayVerdict>, IncompletePart> {
    assert!(positions.len() == ids.len() && ids.len() == own.len());
    assert!(normals.is_none_or(|n| n.len() == positions.len()));
    assert!(ids.is_sorted(), "ids ascend");
    let hood = Neighbourhoods::of(positions, complete);
    let n = hood.index.len();
    // A point not indexed (not finite) is far from everything; a repeat is left out first.
    let mut verdicts: Vec<StrayVerdict> = hood
        .repeated
        .iter()
        .map(|&r| {
            if r {
                StrayVerdict::Repeated
            } else {
                StrayVerdict::Far
            }
        })
        .collect();
    for &i in &hood.part_of {
        verdicts[i] = StrayVerdict::Kept;
    }
    let own_verdicts = |verdicts: Vec<StrayVerdict>| {
        verdicts
            .into_iter()
            .zip(own)
            .filter_map(|(v, &o)| o.then_some(v))
            .collect()
    };
    if stats.points <= NEIGHBOURS as u64 {
        return Ok(own_verdicts(verdicts));
    }
    // The first stage, where decided; every own point's must be.
    let undecided: Vec<Result<(), IncompletePart>> = (0..n)
        .into_par_iter()
        .filter(|&s| own[hood.part_of[s]] && !hood.decided(s))
        .map(|s| {
            Err(IncompletePart {
                id: ids[hood.part_of[s]],
                neighbours: NEIGHBOURS,
                reach: hood.standing_reach(s),
            })
        })
        .collect();
    certified(undecided)?;
    let by_slot = hood.index.points();
    let normal_of = normals.map(|v| {
        let part_of = &hood.part_of;
        move |s: usize| v[part_of[s]]
    });
    let normal_of = normal_of
        .as_ref()
        .map(|f| f as &crate::find_outliers::NormalOf<'_>);
    let status: Vec<Option<Status>> = (0..n)
        .into_par_iter()
        .map(|s| {
            hood.decided(s)
                .then(|| status_of(s, by_slot, &hood.nearest, stats.typical, normal_of))
        })
        .collect();
    let unsure = |s: usize| own[hood.part_of[s]] && status[s] == Some(Status::Unsure);
    if !(0..n).any(unsure) {
        return Ok(own_verdicts(verdicts));
    }
    // The second stage: each unsure own point against its 16 nearest core points, once no
    // point of undecided standing lies as near.
    let core_slots: Vec<u32> = (0..n as u32)
        .filter(|&s| status[s as usize] == Some(Status::Core))
        .collect();
    let core_index = hood.index.subset(|s| status[s] == Some(Status::Core));
    let open_index = hood.index.subset(|s| status[s].is_none());
    let reach = |s: usize| hood.nearest[s].1;
    let judged: Vec<Result<(usize, u8), IncompletePart>> = (0..n)
        .into_par_iter()
        .filter(|&s| unsure(s))
        .map(|s| {
            let x = by_slot[s];
            let near = core_index.nearest(x, NEIGHBOURS);
            let r2 = if near.len() < NEIGHBOURS {
                f64::INFINITY
            } else {
                near.last().map_or(0.0, |l| l.1)
            };
            let open_beyond = open_index.nearest(x, 1).first().is_none_or(|o| o.1 > r2);
            if !(open_beyond && complete(x, r2.sqrt())) {
                return Err(IncompletePart {
                    id: ids[hood.part_of[s]],
                    neighbours: NEIGHBOURS,
                    reach: 2.0 * r2.sqrt(),
                });
            }
            let core = (&core_index, core_slots.as_slice());
            Ok((s, verdict_of((s, x), &near, core, &reach, normal_of)))
        })
        .collect();
    for (s, v) in certified(judged)? {
        verdicts[hood.part_of[s]] = match v {
            0 => StrayVerdict::Kept,
            1 => StrayVerdict::Far,
            _ => StrayVerdict::OffSurface,
        };
    }
    Ok(own_verdicts(verdicts))
}

#[cfg(test)]
#[path = "outliers_by_parts_tests.rs"]
mod tests;
