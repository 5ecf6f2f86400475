//! Normals estimated by parts: [`crate::estimate_normals`]' planes at level 0 (every point's own
//! neighbourhood), bitwise, from a part of the points (a tile and a halo of the points around
//! it). A plane reads a point and its 47 nearest, nearest first, ties to the lower index; a part
//! that holds every point within the 47th neighbour's distance of its own point finds the same
//! neighbours in the same order (its points kept in the global order), so it sums the same
//! moments. Level > 0 (dense noisy inputs, where each point copies the plane of a nearby point
//! of a coarser subset, found in that subset's Morton order) is not done by parts yet: see
//! `docs/notes/2026-12-03-orientation-by-parts.md`.

use glam::DVec3;
use psi_octree::MortonIndex;

use crate::estimate_normals::{NEIGHBOURHOOD, plane_normal};
use crate::orient_by_parts::{IncompletePart, certified};

/// The level-0 normals (unit, each sign arbitrary; zero where no plane) of a part's own points:
/// `positions` (shape: M, world units) its own points and its halo, `ids` (shape: M) their
/// global indices, ascending, `own` (shape: M) which are its own; `complete(x, r)` tells whether
/// every point of the whole set within `r` of `x` is among `positions`. Shape of the result: the
/// own points, in the part's order. Bitwise what [`crate::estimate_normals`] gives those points
/// at level 0, or the uncertain own point whose neighbours reach farthest.
///
/// # Panics
///
/// When the lengths differ or `ids` do not ascend.
pub fn part_normals(
    positions: &[DVec3],
    ids: &[u32],
    own: &[bool],
    complete: &(dyn Fn(DVec3, f64) -> bool + Sync),
) -> Result<Vec<DVec3>, IncompletePart> {
    assert!(positions.len() == ids.len() && ids.len() == own.len());
    assert!(ids.is_sorted(), "ids ascend");
    // Ties among neighbours go to the lower local index, which is the lower global index.
    let index = MortonIndex::new(positions);
    let (slot_ids, by_slot) = (index.ids(), index.points());
    let wanted = NEIGHBOURHOOD - 1;
    let by_slot_normals = index.map_nearest(wanted, |s, near| {
        let i = slot_ids[s] as usize;
        if !own[i] {
            return Ok(DVec3::ZERO);
        }
        let reach = near
            .get(wanted - 1)
            .map_or(f64::INFINITY, |&(_, d2)| d2.sqrt());
        if !complete(positions[i], reach) {
            return Err(IncompletePart {
                id: ids[i],
                neighbours: wanted,
                reach,
            });
        }
        Ok(plane_normal(by_slot, s, near))
    });
    let mut normals = vec![DVec3::ZERO; positions.len()];
    for (s, n) in certified(by_slot_normals)?.into_iter().enumerate() {
        normals[slot_ids[s] as usize] = n;
    }
    Ok(normals
        .into_iter()
        .zip(own)
        .filter_map(|(n, &o)| o.then_some(n))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate_normals::estimate_normals_in;
    use crate::grid_parts::grid_parts;
    use psi_octree::Monitor;
    use psi_shapes::AnalyticShape;

    /// A noisy torus cut into 27 parts: each part's normals are the whole estimate's, bit for
    /// bit; a halo too thin is refused.
    #[test]
    fn parts_estimate_bitwise_as_the_whole() {
        let mut rng = <rand_pcg::Pcg64Mcg as rand::SeedableRng>::seed_from_u64(4);
        let positions: Vec<DVec3> = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        }
        .sample(6000, 2)
        .iter()
        .map(|p| p.p + 0.01 * psi_shapes::gaussian_vector(&mut rng))
        .collect();
        let index = MortonIndex::new(&positions);
        let whole = estimate_normals_in(positions.len(), &index, 0, &Monitor::silent());
        for halo in [0.4, 0.02] {
            let mut seen = 0;
            let mut refused = 0;
            for part in grid_parts(&positions, 3, halo) {
                let held: Vec<DVec3> = part.ids.iter().map(|&i| positions[i as usize]).collect();
                let holds = |x: DVec3, r: f64| part.holds_ball(x, r);
                match part_normals(&held, &part.ids, &part.own, &holds) {
                    Ok(normals) => {
                        let mine = part
                            .ids
                            .iter()
                            .zip(&part.own)
                            .filter(|p| *p.1)
                            .map(|p| *p.0);
                        for (i, n) in mine.zip(normals) {
                            assert!(
                                n == whole[i as usize],
                                "point {i}: {n} against {}",
                                whole[i as usize]
                            );
                            seen += 1;
                        }
                    }
                    Err(e) => {
                        assert!(e.reach > halo, "{e}");
                        refused += 1;
                    }
                }
            }
            if halo > 0.1 {
                assert_eq!((seen, refused), (positions.len(), 0));
            } else {
                assert!(refused > 0);
            }
        }
    }
}
