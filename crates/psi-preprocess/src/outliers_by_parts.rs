//! The outlier step by parts: what `preprocess` does to a scan's stray points before the clump
//! search — repeated positions left out, then [`crate::find_outliers`] — bitwise, from parts of
//! the points (a tile and a halo of the points around it) that never need to be held together.
//!
//! Two passes. The first ([`part_standings`]) gives each own point its first-stage standing
//! and its distance to the 16th nearest other point: the standing reads the point's 16 nearest
//! and their 16th-neighbour distances, so a part decides it when it holds the balls of the
//! point and of each neighbour. The standing reads the whole input once, through the median of
//! those distances ([`OutlierStats::typical`], which [`median_of_passes`] streams from the
//! first pass's distances): a point sparser than 3 × it is judged apart. So the first pass
//! records the standing the point has when it is not, and the second pass ([`part_outliers`],
//! `outlier_verdicts_by_parts.rs`) decides again only the points that are, then judges each
//! unsure own point against its 16 nearest core points: a part decides it when it holds that
//! ball and every point in it has a standing (the halo's, decided there, only near the unsure
//! points). A part none of whose own points is unsure or sparse needs no second look
//! ([`settled_verdicts`]). Neighbours tie to the lower index, and a part keeps its points in
//! the input's order, so its answers are the whole search's. Repeats (a position equal to a
//! point of lower index) lie in whichever parts their first copy lies in.
//!
//! [`median_of_passes`]: crate::median_of_passes
//! [`part_outliers`]: crate::part_outliers
//! [`settled_verdicts`]: crate::settled_verdicts

use glam::DVec3;
use psi_octree::MortonIndex;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::find_outliers::{
    NEIGHBOURS, Nearest, NormalOf, Status, dense_globally, nearest_from, status_of,
};
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

/// A part's points without the repeats, indexed, with the 16 nearest of its own points and of
/// their neighbours (what the own points' standings read).
struct Neighbourhoods {
    /// The part's finite points that repeat no point of lower index, in the part's order.
    index: MortonIndex,
    /// The part's index of each slot's point.
    part_of: Vec<usize>,
    /// Per slot: its 16 nearest, for the own points and their neighbours (the others' left
    /// empty, with a NaN reach).
    nearest: Vec<Nearest>,
    /// Per slot: whether the part holds the ball out to its 16th nearest (false where the
    /// nearest were not searched).
    certified: Vec<bool>,
    /// Per point of the part: whether it repeats a point of lower index.
    repeated: Vec<bool>,
}

impl Neighbourhoods {
    /// The neighbourhoods of `positions`' own points (`own`, shape: the part's points) and
    /// their neighbours': the own points first, then the halo points among their 16 nearest
    /// (each answer the one a sweep of every point gives: `MortonIndex::map_nearest_of`).
    fn of(
        positions: &[DVec3],
        own: &[bool],
        complete: &(dyn Fn(DVec3, f64) -> bool + Sync),
    ) -> Self {
        let (index, part_of, repeated) = without_repeats(positions);
        let n = index.len();
        let mut nearest: Vec<Nearest> = vec![([0; NEIGHBOURS], f64::NAN); n];
        let mut searched = vec![false; n];
        let is_own = |s: usize| own[part_of[s]];
        for (s, near) in nearest_where(&index, &is_own) {
            nearest[s] = near;
            searched[s] = true;
        }
        let mut around = vec![false; n];
        // (All 16 entries: a part of 16 points or fewer pads them with slot 0, which the
        // standing then reads too.)
        for s in (0..n).filter(|&s| is_own(s)) {
            for &q in &nearest[s].0 {
                if !searched[q as usize] {
                    around[q as usize] = true;
                }
            }
        }
        for (s, near) in nearest_where(&index, &|s| around[s]) {
            nearest[s] = near;
            searched[s] = true;
        }
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
            .map(|s| searched[s] && complete(by_slot[s], hood.own_reach(s)))
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
        // (A ball the part does not hold reaches no farther than the part's answer.)
        let (near, reach) = &self.nearest[s];
        let mut need = *reach;
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

/// A point's record after the first pass of the outlier step by parts ([`part_standings`]):
/// a repeat, a point that is not finite, or a searched point with its 16th-neighbour distance
/// and the standing it has when it is not sparser than 3 × the median of those distances.
/// Nine bytes as [`OwnStanding::to_bytes`] writes them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OwnStanding {
    /// 0 core, 1 inlier, 2 unsure, 3 repeated, 4 not finite.
    code: u8,
    /// The 16th-neighbour distance of a searched point (world units), else 0.
    reach: f64,
}

impl OwnStanding {
    /// The length of a record.
    pub const BYTES: usize = 9;

    fn searched(status: Status, reach: f64) -> Self {
        let code = match status {
            Status::Core => 0,
            Status::Inlier => 1,
            Status::Unsure => 2,
        };
        Self { code, reach }
    }

    /// The record: the distance as a little-endian f64, then the code.
    pub fn to_bytes(self) -> [u8; Self::BYTES] {
        let mut out = [0u8; Self::BYTES];
        out[..8].copy_from_slice(&self.reach.to_le_bytes());
        out[8] = self.code;
        out
    }

    /// The standing a record holds; `None` when it holds none.
    pub fn from_bytes(bytes: [u8; Self::BYTES]) -> Option<Self> {
        let reach = f64::from_le_bytes(bytes[..8].try_into().expect("8 bytes"));
        (bytes[8] <= 4).then_some(Self {
            code: bytes[8],
            reach,
        })
    }

    /// The 16th-neighbour distance of a searched point (finite, no repeat): the values whose
    /// median is [`OutlierStats::typical`].
    pub fn searched_reach(self) -> Option<f64> {
        (self.code <= 2).then_some(self.reach)
    }

    /// The first stage's standing, when the point is searched and not sparse against `typical`.
    pub(crate) fn status(self, typical: f64) -> Option<Status> {
        let status = match self.code {
            0 => Status::Core,
            1 => Status::Inlier,
            2 => Status::Unsure,
            _ => return None,
        };
        dense_globally(self.reach, typical).then_some(status)
    }

    /// The verdict on a point that needs no second look: a repeat, a point not finite, or one
    /// kept (`None`: a searched point to look at again, unsure or sparse).
    pub(crate) fn settled(self, typical: f64) -> Option<StrayVerdict> {
        match self.code {
            3 => Some(StrayVerdict::Repeated),
            4 => Some(StrayVerdict::Far),
            _ => match self.status(typical) {
                Some(Status::Core | Status::Inlier) => Some(StrayVerdict::Kept),
                _ => None,
            },
        }
    }
}

/// The first pass of the outlier step on a part: each own point's [`OwnStanding`] (shape: the
/// own points, in the part's order). `positions` (shape: M, world units) the part's own points
/// and its halo, `ids` (shape: M) their input indices, ascending, `own` (shape: M) which are its
/// own; `normals` (shape: M, unit, either sign) the given normals, `None` for positions alone;
/// `complete(x, r)` tells whether every input point within `r` of `x` is among `positions`. Or
/// the uncertain own point whose neighbours reach farthest.
///
/// # Panics
///
/// When the lengths differ or `ids` do not ascend.
pub fn part_standings(
    positions: &[DVec3],
    ids: &[u32],
    own: &[bool],
    normals: Option<&[DVec3]>,
    complete: &(dyn Fn(DVec3, f64) -> bool + Sync),
) -> Result<Vec<OwnStanding>, IncompletePart> {
    assert!(positions.len() == ids.len() && ids.len() == own.len());
    assert!(normals.is_none_or(|n| n.len() == positions.len()));
    assert!(ids.is_sorted(), "ids ascend");
    let hood = Neighbourhoods::of(positions, own, complete);
    let n = hood.index.len();
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
    let normal_of = normal_of.as_ref().map(|f| f as &NormalOf<'_>);
    // (With 16 points or fewer in all there are no outliers: no standing is read.)
    let searched: Vec<(usize, OwnStanding)> = (0..n)
        .into_par_iter()
        .filter(|&s| own[hood.part_of[s]])
        .map(|s| {
            let status = if n > NEIGHBOURS {
                status_of(s, by_slot, &hood.nearest, f64::INFINITY, normal_of)
            } else {
                Status::Core
            };
            (
                hood.part_of[s],
                OwnStanding::searched(status, hood.nearest[s].1),
            )
        })
        .collect();
    let mut out: Vec<OwnStanding> = hood
        .repeated
        .iter()
        .map(|&r| OwnStanding {
            code: if r { 3 } else { 4 },
            reach: 0.0,
        })
        .collect();
    for (i, standing) in searched {
        out[i] = standing;
    }
    Ok(out
        .into_iter()
        .zip(own)
        .filter_map(|(v, &o)| o.then_some(v))
        .collect())
}

/// The 16 nearest (as the sweep of every slot gives them) of the slots of `index` that `want` accepts,
/// by slot.
fn nearest_where(
    index: &MortonIndex,
    want: &(dyn Fn(usize) -> bool + Sync),
) -> Vec<(usize, Nearest)> {
    index.map_nearest_of(NEIGHBOURS, want, |s, near| (s, nearest_from(near)))
}

/// A part's finite points that repeat no point of lower index, indexed (ties among neighbours
/// go to the lower local index, which is the lower input index); the part's index of each
/// slot's point; per point of the part, whether it repeats a point of lower index.
pub(crate) fn without_repeats(positions: &[DVec3]) -> (MortonIndex, Vec<usize>, Vec<bool>) {
    let all = MortonIndex::new(positions);
    let mut repeated = vec![false; positions.len()];
    for c in all.repeated_positions() {
        repeated[c as usize] = true;
    }
    let keep: Vec<bool> = repeated.iter().map(|r| !r).collect();
    let kept: Vec<usize> = (0..positions.len()).filter(|&i| keep[i]).collect();
    let index = all.retained(&keep);
    let part_of = index.ids().iter().map(|&k| kept[k as usize]).collect();
    (index, part_of, repeated)
}

#[cfg(test)]
#[path = "outliers_by_parts_tests.rs"]
mod tests;
