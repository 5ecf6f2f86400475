//! The second pass of the outlier step by parts (see `outliers_by_parts.rs`): the verdicts on
//! a part's own points from their first-pass standings, the sparse ones and the halo's near
//! the unsure ones decided again, each unsure own point judged against its 16 nearest core
//! points — bitwise [`crate::find_outliers`] on the whole input.

use glam::DVec3;
use psi_octree::MortonIndex;
use rayon::prelude::*;

use crate::find_outliers::{
    NEIGHBOURS, Nearest, NormalOf, Status, nearest_of, status_from, verdict_of,
};
use crate::orient_by_parts::{IncompletePart, certified};
use crate::outliers_by_parts::{OutlierStats, OwnStanding, StrayVerdict, without_repeats};

/// The verdicts on a part's own points from their first-pass `standings` alone (shape: the
/// own points) with the whole input's `stats`, when none is unsure or sparse (the second pass
/// would find them all kept, repeats and points not finite left out); `None` otherwise.
pub fn settled_verdicts(
    standings: &[OwnStanding],
    stats: OutlierStats,
) -> Option<Vec<StrayVerdict>> {
    let few = stats.points <= NEIGHBOURS as u64;
    standings
        .iter()
        .map(|st| match (few, st.searched_reach()) {
            (true, Some(_)) => Some(StrayVerdict::Kept),
            _ => st.settled(stats.typical),
        })
        .collect()
}

/// The outlier step's verdict on each of a part's own points (shape: the own points, in the
/// part's order): bitwise what `preprocess` decides for them (repeats left out, then
/// [`crate::find_outliers`] with `stats` of the whole input), before its clump search.
/// `positions`, `ids`, `own`, `normals`, `complete` as for [`crate::part_standings`]; `standings`
/// (shape: the own points) what it gave them. Or the uncertain own point whose answer reaches
/// farthest.
///
/// # Panics
///
/// When the lengths differ, `ids` do not ascend, or `standings` are not the first pass's for
/// these own points.
pub fn part_outliers(
    positions: &[DVec3],
    ids: &[u32],
    own: &[bool],
    normals: Option<&[DVec3]>,
    complete: &(dyn Fn(DVec3, f64) -> bool + Sync),
    (stats, standings): (OutlierStats, &[OwnStanding]),
) -> Result<Vec<StrayVerdict>, IncompletePart> {
    assert!(positions.len() == ids.len() && ids.len() == own.len());
    assert!(normals.is_none_or(|n| n.len() == positions.len()));
    assert!(ids.is_sorted(), "ids ascend");
    if let Some(settled) = settled_verdicts(standings, stats) {
        assert_eq!(settled.len(), own.iter().filter(|&&o| o).count());
        return Ok(settled);
    }
    let held = Held::of(positions);
    let n = held.index.len();
    let typical = stats.typical;
    // What the first pass says of the own points; the sparse ones decided again here.
    let mut status: Vec<Option<Status>> = vec![None; n];
    let mut reach = vec![f64::NAN; n];
    let mut verdicts = Vec::with_capacity(standings.len());
    let own_parts: Vec<usize> = (0..positions.len()).filter(|&i| own[i]).collect();
    assert_eq!(own_parts.len(), standings.len(), "a standing per own point");
    let mut sparse = Vec::new();
    for (&i, st) in own_parts.iter().zip(standings) {
        // (Kept until judged below, when unsure.)
        let verdict = st.settled(typical).unwrap_or(StrayVerdict::Kept);
        let slot = held.slot_of[i];
        let searched = st.searched_reach();
        assert_eq!(
            (held.repeated[i], slot == u32::MAX),
            (verdict == StrayVerdict::Repeated, searched.is_none()),
            "point {}: not the first pass's standing",
            ids[i]
        );
        verdicts.push(verdict);
        if let Some(r) = searched {
            let s = slot as usize;
            reach[s] = r;
            status[s] = st.status(typical);
            if status[s].is_none() {
                sparse.push(s);
            }
        }
    }
    let by_slot = held.index.points();
    let normal_of = normals.map(|v| {
        let part_of = &held.part_of;
        move |s: usize| v[part_of[s]]
    });
    let normal_of = normal_of.as_ref().map(|f| f as &NormalOf<'_>);
    let look = Look {
        held: &held,
        reach: &reach,
        typical,
        normal_of,
        complete,
    };
    for (s, found) in certified(look.standings(&sparse, ids))? {
        status[s] = Some(found.0);
    }
    let is_own = |s: usize| own[held.part_of[s]];
    let unsure: Vec<usize> = (0..n)
        .filter(|&s| is_own(s) && status[s] == Some(Status::Unsure))
        .collect();
    if unsure.is_empty() {
        return Ok(verdicts);
    }
    // The halo's standings, where a core point of the halo could be among an unsure own
    // point's 16 nearest: within its 16th nearest own core point (all of them when it has
    // fewer). Those the part cannot decide stay open: an unsure point with one as near as its
    // core ball asks for more below.
    let own_cores = held
        .index
        .subset(|s| is_own(s) && status[s] == Some(Status::Core));
    let own_core_slots: Vec<u32> = (0..n as u32)
        .filter(|&s| is_own(s as usize) && status[s as usize] == Some(Status::Core))
        .collect();
    let mut asked = vec![false; n];
    let mut within = Vec::new();
    // Per unsure point, its 16 nearest own core points when no halo point lies as near: then
    // they are its 16 nearest core points (the same, in the same (distance, index) order).
    let mut direct: Vec<Option<Vec<(u32, f64)>>> = vec![None; unsure.len()];
    for (j, &s) in unsure.iter().enumerate() {
        let x = by_slot[s];
        let near = own_cores.nearest(x, NEIGHBOURS);
        if near.len() < NEIGHBOURS {
            asked.iter_mut().for_each(|a| *a = true);
            direct.iter_mut().for_each(|d| *d = None);
            break;
        }
        within.clear();
        // (One ulp more: the square of a square root can fall short of the squared distance,
        // and a point tied with the 16th must be asked.)
        let r = near.last().map_or(0.0, |l| l.1.sqrt().next_up());
        held.index.within(x, r, &mut within);
        let mut only_own = true;
        for &id in &within {
            let q = held.slot_of_id[id as usize] as usize;
            asked[q] = true;
            only_own &= is_own(q);
        }
        if only_own {
            direct[j] = Some(near);
        }
    }
    let halo: Vec<usize> = (0..n).filter(|&q| asked[q] && !is_own(q)).collect();
    for (q, (st, r)) in look.standings(&halo, ids).into_iter().flatten() {
        status[q] = Some(st);
        reach[q] = r;
    }
    // The second stage: each unsure own point against its 16 nearest core points, once no
    // point without a standing lies as near.
    let rest = direct.iter().any(Option::is_none);
    let core_slots: Vec<u32> = (0..n as u32)
        .filter(|&s| rest && status[s as usize] == Some(Status::Core))
        .collect();
    let core_index = held
        .index
        .subset(|s| rest && status[s] == Some(Status::Core));
    let open_index = held.index.subset(|s| rest && status[s].is_none());
    let reach_of = |s: usize| reach[s];
    let judged: Vec<Result<(usize, u8), IncompletePart>> = unsure
        .par_iter()
        .zip(&direct)
        .map(|(&s, direct)| {
            let x = by_slot[s];
            let incomplete = |r2: f64| IncompletePart {
                id: ids[held.part_of[s]],
                neighbours: NEIGHBOURS,
                reach: 2.0 * r2.sqrt(),
            };
            if let Some(near) = direct {
                let r2 = near.last().map_or(0.0, |l| l.1);
                if !complete(x, r2.sqrt()) {
                    return Err(incomplete(r2));
                }
                let core = (&own_cores, own_core_slots.as_slice());
                return Ok((s, verdict_of((s, x), near, core, &reach_of, normal_of)));
            }
            let near = core_index.nearest(x, NEIGHBOURS);
            let r2 = if near.len() < NEIGHBOURS {
                f64::INFINITY
            } else {
                near.last().map_or(0.0, |l| l.1)
            };
            let open_beyond = open_index.nearest(x, 1).first().is_none_or(|o| o.1 > r2);
            if !(open_beyond && complete(x, r2.sqrt())) {
                return Err(incomplete(r2));
            }
            let core = (&core_index, core_slots.as_slice());
            Ok((s, verdict_of((s, x), &near, core, &reach_of, normal_of)))
        })
        .collect();
    for (s, v) in certified(judged)? {
        let rank = own_parts
            .binary_search(&held.part_of[s])
            .expect("an own point");
        verdicts[rank] = match v {
            0 => StrayVerdict::Kept,
            1 => StrayVerdict::Far,
            _ => StrayVerdict::OffSurface,
        };
    }
    Ok(verdicts)
}

/// A part's points without the repeats, indexed, with no neighbours searched yet.
struct Held {
    /// The part's finite points that repeat no point of lower index, in the part's order.
    index: MortonIndex,
    /// The part's index of each slot's point.
    part_of: Vec<usize>,
    /// The slot of each of the part's points (`u32::MAX`: a repeat or not finite).
    slot_of: Vec<u32>,
    /// The slot of each of the index's ids.
    slot_of_id: Vec<u32>,
    /// Per point of the part: whether it repeats a point of lower index.
    repeated: Vec<bool>,
}

impl Held {
    fn of(positions: &[DVec3]) -> Self {
        let (index, part_of, repeated) = without_repeats(positions);
        let mut slot_of = vec![u32::MAX; positions.len()];
        let mut slot_of_id = vec![u32::MAX; positions.len()];
        for (s, (&i, &id)) in part_of.iter().zip(index.ids()).enumerate() {
            slot_of[i] = s as u32;
            slot_of_id[id as usize] = s as u32;
        }
        Self {
            index,
            part_of,
            slot_of,
            slot_of_id,
            repeated,
        }
    }
}

/// A slot whose standing a second look decided, with its 16th-neighbour distance.
type Decided = (usize, (Status, f64));

/// What a second look at a part decides points' standings from.
struct Look<'a> {
    held: &'a Held,
    /// Known 16th-neighbour distances (the own points'), by slot; NaN where not known.
    reach: &'a [f64],
    typical: f64,
    normal_of: Option<&'a NormalOf<'a>>,
    complete: &'a (dyn Fn(DVec3, f64) -> bool + Sync),
}

impl Look<'_> {
    /// The 16 nearest of slot `s` (from `swept`, every slot's, when given) and their reach, if
    /// the part holds their ball (the reach infinite when the part holds 16 points or fewer).
    fn nearest(&self, s: usize, swept: Option<&[Nearest]>) -> (Nearest, bool) {
        let index = &self.held.index;
        let (slots, reach) = match swept {
            Some(all) => all[s],
            None => {
                let near = index.nearest_other(s, NEIGHBOURS);
                let mut slots = [0u32; NEIGHBOURS];
                for (slot, &(j, _)) in slots.iter_mut().zip(&near) {
                    *slot = j;
                }
                (slots, near.last().map_or(0.0, |l| l.1.sqrt()))
            }
        };
        let reach = if index.len() > NEIGHBOURS {
            reach
        } else {
            f64::INFINITY
        };
        ((slots, reach), (self.complete)(index.points()[s], reach))
    }

    /// The standing of each slot of `slots` with the whole input's `typical`, and its
    /// 16th-neighbour distance: or the reach the part must hold around it to decide it. Each
    /// neighbourhood is searched once: alone, or by one sweep of the part when `slots` are a
    /// good share of it.
    fn standings(&self, slots: &[usize], ids: &[u32]) -> Vec<Result<Decided, IncompletePart>> {
        let n = self.held.index.len();
        let points = self.held.index.points();
        let swept = (4 * slots.len() > n).then(|| {
            nearest_of(&self.held.index, &psi_octree::Monitor::silent()).expect("not stopped")
        });
        let swept = swept.as_deref();
        // The slots' neighbourhoods, then those of their neighbours whose reach is not known.
        let mut at = vec![u32::MAX; n];
        for (k, &s) in slots.iter().enumerate() {
            at[s] = k as u32;
        }
        let mut found: Vec<(Nearest, bool)> =
            slots.par_iter().map(|&s| self.nearest(s, swept)).collect();
        let mut more = Vec::new();
        for (near, _) in &found {
            for &q in &near.0 {
                let q = q as usize;
                if at[q] == u32::MAX && self.reach[q].is_nan() {
                    at[q] = (slots.len() + more.len()) as u32;
                    more.push(q);
                }
            }
        }
        found.par_extend(more.par_iter().map(|&q| self.nearest(q, swept)));
        // (A ball the part does not hold reaches no farther than the part's answer: the part
        // holds a subset of the points.)
        slots
            .par_iter()
            .zip(&found)
            .map(|(&s, &(near, held_s))| {
                let mut held = held_s;
                let mut need = near.1;
                let mut around = [0.0f64; NEIGHBOURS];
                for (r, &q) in around.iter_mut().zip(&near.0) {
                    let q = q as usize;
                    *r = self.reach[q];
                    if r.is_nan() {
                        let ((_, rq), held_q) = found[at[q] as usize];
                        *r = rq;
                        if !held_q {
                            held = false;
                            need = need.max((points[q] - points[s]).length() + rq);
                        }
                    }
                }
                if !held {
                    return Err(IncompletePart {
                        id: ids[self.held.part_of[s]],
                        neighbours: NEIGHBOURS,
                        reach: need,
                    });
                }
                let reach_of = |j: usize| {
                    let k = near.0.iter().position(|&q| q as usize == j);
                    around[k.expect("a neighbour")]
                };
                let status =
                    status_from((s, &near), points, &reach_of, self.typical, self.normal_of);
                Ok((s, (status, near.1)))
            })
            .collect()
    }
}
