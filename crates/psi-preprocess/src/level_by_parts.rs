//! What the normals of dense noisy points need from the whole input when they are estimated by
//! parts above level 0 (`estimate_normals.rs`: the planes fitted among one point in 4^L, the
//! level's points, and each point taking the normal and side of the nearest of the level's
//! points around its place in their Morton order). The level's planes and their orientation are
//! found by parts like level 0's, among the level's points alone ([`crate::part_normals`] and
//! [`crate::part_orientation_edges`] on a part's level points, numbered by their rank in input
//! order); the lookup reads the level's order, which jumps across space, so it is held whole:
//! [`LevelIndex`], about 40 bytes a level point.

use glam::DVec3;
use psi_octree::MortonIndex;

use crate::estimate_normals::nearest_in_level;

/// A level's points indexed alone (their frame and Morton order), as the in-core estimate
/// indexes them; built from their positions in input order.
#[derive(Debug)]
pub struct LevelIndex {
    index: MortonIndex,
}

impl LevelIndex {
    /// The index of a level's points, `positions` (shape: M, world units) in input order.
    pub fn new(positions: &[DVec3]) -> Self {
        Self {
            index: MortonIndex::new(positions),
        }
    }

    /// Points indexed.
    pub fn len(&self) -> usize {
        self.index.len()
    }

    /// Whether no point is indexed.
    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// The rank (in input order, among the level's points) of the point whose normal and side
    /// the in-core estimate gives a point at `p` (world units): the nearest of the level's
    /// points among the 4 on either side of `p`'s place in their Morton order, the first on a
    /// tie. `None` for an empty level.
    pub fn nearest(&self, p: DVec3) -> Option<u32> {
        nearest_in_level(&self.index, p).map(|slot| self.index.ids()[slot])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate_normals::{estimate_normals_in, in_level};
    use crate::grid_parts::grid_parts;
    use crate::part_normals;
    use psi_octree::Monitor;
    use psi_shapes::AnalyticShape;

    /// A noisy torus at level 1: the level's planes by 8 parts (their level points numbered in
    /// input order) and the lookup give every point the in-core estimate's normal, bit for bit.
    #[test]
    fn level_planes_by_parts_give_the_in_core_normals() {
        let mut rng = <rand_pcg::Pcg64Mcg as rand::SeedableRng>::seed_from_u64(5);
        let positions: Vec<DVec3> = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        }
        .sample(40_000, 3)
        .iter()
        .map(|p| p.p + 0.004 * psi_shapes::gaussian_vector(&mut rng))
        .collect();
        let index = MortonIndex::new(&positions);
        let whole = estimate_normals_in(positions.len(), &index, 1, &Monitor::silent());
        let level: Vec<u32> = (0..positions.len() as u32)
            .filter(|&i| in_level(positions[i as usize], 1))
            .collect();
        let level_positions: Vec<DVec3> = level.iter().map(|&i| positions[i as usize]).collect();
        let mut planes = vec![None; level.len()];
        for part in grid_parts(&level_positions, 2, 0.5) {
            let held: Vec<DVec3> = part
                .ids
                .iter()
                .map(|&r| level_positions[r as usize])
                .collect();
            let found = part_normals(&held, &part.ids, &part.own, &|x, r| part.holds_ball(x, r));
            let mine = part.ids.iter().zip(&part.own).filter(|p| *p.1);
            for ((&r, _), n) in mine.zip(found.expect("a wide halo")) {
                planes[r as usize] = Some(n);
            }
        }
        let lookup = LevelIndex::new(&level_positions);
        for (i, &p) in positions.iter().enumerate() {
            let rank = lookup.nearest(p).expect("a level") as usize;
            let n = planes[rank].expect("every level point's plane");
            assert!(n == whole[i], "point {i}: {n} against {}", whole[i]);
        }
    }
}
