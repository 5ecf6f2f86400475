//! The normal-consistency check by parts: the in-core check's queries
//! ([`crate::check_normal_consistency`], every ⌈N/max_queries⌉-th point by input index) that
//! are a part's own points, their neighbours found among the part's points and a halo around
//! them (a tile), counted as the whole check counts them; the parts' counts add up to the
//! whole's.

use glam::DVec3;
use psi_octree::{MortonIndex, OrientedPoint};
use rayon::prelude::*;

use crate::NormalConsistency;
use crate::neighbour_graph::K;
use crate::orient_by_parts::{IncompletePart, certified};

/// The queries the preprocessing's consistency check makes at most.
pub const CONSISTENCY_QUERIES: usize = 20_000;

/// The consistency counts of a part's own queries: `points` (shape: M, world units, unit
/// normals) its own points and its halo, `ids` (shape: M) their input indices, ascending,
/// `own` (shape: M) which are its own, `population` the points of the whole set, of which
/// every ⌈N/`max_queries`⌉-th by input index is queried; `complete(x, r)` tells whether every
/// point of the whole set within `r` of `x` is among `points`. Added over all parts (in any
/// order): what [`crate::check_normal_consistency`] counts on the whole set. Or the uncertain
/// query whose neighbours reach farthest.
///
/// # Panics
///
/// When the lengths differ or `ids` do not ascend.
pub fn part_normal_consistency(
    points: &[OrientedPoint],
    ids: &[u32],
    own: &[bool],
    complete: &(dyn Fn(DVec3, f64) -> bool + Sync),
    (population, max_queries): (usize, usize),
) -> Result<NormalConsistency, IncompletePart> {
    assert!(points.len() == ids.len() && ids.len() == own.len());
    assert!(ids.is_sorted(), "ids ascend");
    let stride = population.div_ceil(max_queries.max(1)).max(1);
    let queried: Vec<usize> = (0..points.len())
        .filter(|&i| own[i] && (ids[i] as usize).is_multiple_of(stride) && points[i].p.is_finite())
        .collect();
    if queried.is_empty() {
        return Ok(NormalConsistency::default());
    }
    let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
    // Ties among neighbours go to the lower local index, which is the lower input index.
    let index = MortonIndex::new(&positions);
    let slot_ids = index.ids();
    let rows = queried
        .par_iter()
        .map(|&i| {
            let p = &points[i];
            let near = index.nearest(p.p, K + 1);
            let reach = if near.len() < K + 1 && points.len() < population {
                f64::INFINITY
            } else {
                near.last().map_or(0.0, |n| n.1.sqrt())
            };
            if !complete(p.p, reach) {
                return Err(IncompletePart {
                    id: ids[i],
                    neighbours: K + 1,
                    reach,
                });
            }
            let mut c = NormalConsistency::default();
            for &(s, d2) in &near {
                let j = slot_ids[s as usize] as usize;
                if j == i || d2 <= 0.0 {
                    continue;
                }
                let q = &points[j];
                // The check's pair: on the same sheet when the offset is mostly tangential.
                let same = p.n.dot(q.p - p.p).abs() <= 0.5 * d2.sqrt();
                c.pairs += usize::from(same);
                c.opposed += usize::from(same && p.n.dot(q.n) < 0.0);
            }
            Ok(c)
        })
        .collect();
    Ok(certified(rows)?
        .into_iter()
        .fold(NormalConsistency::default(), NormalConsistency::merge))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check_normal_consistency;
    use crate::grid_parts::grid_parts;
    use psi_shapes::AnalyticShape;

    /// A sphere with every 5th normal flipped and a thin slab on 27 parts: the parts' counts
    /// add up to the whole check's, with all points queried and with a stride.
    #[test]
    fn parts_count_as_the_whole() {
        let mut points = AnalyticShape::Sphere { radius: 1.0 }.sample(6000, 3);
        points.extend(
            AnalyticShape::Box {
                half: DVec3::new(0.4, 0.4, 0.01),
            }
            .sample(3000, 4)
            .into_iter()
            .map(|p| OrientedPoint {
                p: p.p + DVec3::new(2.0, 0.0, 0.0),
                n: p.n,
            }),
        );
        for p in points.iter_mut().step_by(5) {
            p.n = -p.n;
        }
        let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
        for queries in [usize::MAX, 700] {
            let whole = check_normal_consistency(&points, queries);
            assert!(whole.opposed > 0 && whole.pairs > whole.opposed);
            let mut sum = NormalConsistency::default();
            for part in grid_parts(&positions, 3, 0.2) {
                let held: Vec<OrientedPoint> =
                    part.ids.iter().map(|&i| points[i as usize]).collect();
                let holds = |x: DVec3, r: f64| part.holds_ball(x, r);
                let c = part_normal_consistency(
                    &held,
                    &part.ids,
                    &part.own,
                    &holds,
                    (points.len(), queries),
                )
                .expect("a halo of 0.2 holds 9 neighbours");
                sum = sum.merge(c);
            }
            assert_eq!(sum, whole, "{queries} queries");
        }
    }
}
