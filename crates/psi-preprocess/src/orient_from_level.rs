//! Orientation of normals estimated at a coarser level (`estimate_normals_in` above level 0,
//! where every point takes the plane of a nearby point of the level): the level's points are
//! oriented among themselves (`orient_normals_in`: the same spanning forest over one point in
//! 4^L), and every point takes the side of the nearest of them, found as the estimation found
//! the plane it copies. The orientation then costs what the level's points cost, not what
//! the whole cloud does (docs/notes/2026-11-29-orientation-from-level.md).

use glam::DVec3;
use psi_octree::{Monitor, MortonIndex, OrientedPoint};
use rayon::prelude::*;

use crate::estimate_normals::{LEVEL_POINTS, in_level, nearest_in_level};
use crate::orient_normals::orient_normals_in;

/// Orients `points`' normals (shape: N, unit, each sign arbitrary; estimated at coarseness
/// `level`, [`crate::estimate_normals`]' level rule; `index` the Morton index of their
/// positions): at level 0, or when the level holds too few points, as
/// [`crate::orient_normals`]; else the level's points ([`in_level`]) as `orient_normals` orients
/// them alone, and each point the side of the nearest of them as the estimation finds it
/// ([`nearest_in_level`]; n·n_q ≥ 0). Returns the number of normals
/// flipped. Deterministic, whatever the thread count; stops early once `monitor`'s flag is set
/// (the caller then discards the points).
pub(crate) fn orient_from_level(
    points: &mut [OrientedPoint],
    index: MortonIndex,
    level: u32,
    monitor: &Monitor<'_>,
) -> usize {
    let chosen: Vec<OrientedPoint> = if level == 0 {
        Vec::new()
    } else {
        points
            .par_iter()
            .copied()
            .filter(|p| p.p.is_finite() && in_level(p.p, level))
            .collect()
    };
    if chosen.len() < LEVEL_POINTS {
        return orient_normals_in(points, index, monitor);
    }
    let mut coarse = chosen;
    let positions: Vec<DVec3> = coarse.iter().map(|p| p.p).collect();
    let sub = MortonIndex::new(&positions);
    // Each point's nearest of the level's points, found in the points' Morton order (`index`'s
    // slots, where consecutive searches of the level's order read the same memory), before the
    // orientation takes the level's index.
    let nearest_by_slot: Vec<Option<usize>> = index
        .points()
        .par_iter()
        .map(|&p| nearest_in_level(&sub, p))
        .collect();
    let sub_ids = sub.ids().to_vec();
    orient_normals_in(&mut coarse, sub, monitor);
    if monitor.stopped() {
        return 0;
    }
    let turn_by_slot: Vec<bool> = index
        .ids()
        .par_iter()
        .zip(&nearest_by_slot)
        .map(|(&i, t)| {
            t.is_some_and(|t| points[i as usize].n.dot(coarse[sub_ids[t] as usize].n) < 0.0)
        })
        .collect();
    let mut turn = vec![false; points.len()];
    for (&i, &t) in index.ids().iter().zip(&turn_by_slot) {
        turn[i as usize] = t;
    }
    points
        .par_iter_mut()
        .zip(&turn)
        .filter(|(_, t)| **t)
        .map(|(p, _)| p.n = -p.n)
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate_noise::noise_and_reach_in;
    use crate::estimate_normals::{estimate_normals_in, noise_level};
    use crate::orient_normals::orient_normals;
    use psi_shapes::AnalyticShape;
    use rand::SeedableRng;

    /// A noisy torus dense enough for level 1: its normals oriented from the level agree with
    /// the torus's outward normals (the oracle) and with the orientation of every point at
    /// once, and the level's points are oriented exactly as they are alone.
    #[test]
    fn normals_take_the_side_of_their_levels_points() {
        let truth = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.4,
        }
        .sample(200_000, 7);
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(7);
        let positions: Vec<DVec3> = truth
            .iter()
            .map(|p| p.p + 0.006 * psi_shapes::gaussian_vector(&mut rng))
            .collect();
        let index = MortonIndex::new(&positions);
        let (noise, reach) = noise_and_reach_in(&positions, &index);
        let level = noise_level(noise.sigma, reach);
        assert_eq!(level, 1, "the test's noise asks for level 1");
        let silent = Monitor::silent();
        let normals = estimate_normals_in(positions.len(), &index, level, &silent);
        let mut points: Vec<OrientedPoint> = positions
            .iter()
            .zip(&normals)
            .map(|(&p, &n)| OrientedPoint { p, n })
            .collect();
        let mut all_at_once = points.clone();
        orient_normals(&mut all_at_once);
        let flipped = orient_from_level(&mut points, index, level, &silent);
        assert!(flipped > 0);
        let wrong = points
            .iter()
            .zip(&truth)
            .filter(|(p, t)| p.n.dot(t.n) < 0.0)
            .count();
        assert!(wrong * 2000 <= points.len(), "{wrong} against the torus");
        let differ = points
            .iter()
            .zip(&all_at_once)
            .filter(|(a, b)| a.n != b.n)
            .count();
        assert!(
            differ * 1000 <= points.len(),
            "{differ} against all at once"
        );
        let mut alone: Vec<OrientedPoint> = points
            .iter()
            .copied()
            .filter(|p| in_level(p.p, level))
            .collect();
        let from_level = alone.clone();
        orient_normals(&mut alone);
        assert!(alone.len() >= LEVEL_POINTS);
        assert_eq!(alone, from_level, "the level's points as oriented alone");
    }

    /// At level 0 the orientation is `orient_normals`'.
    #[test]
    fn level_zero_is_the_whole_orientation() {
        let truth = AnalyticShape::Ellipsoid {
            radii: DVec3::new(1.0, 0.7, 0.5),
        }
        .sample(4_000, 3);
        let mut flipped: Vec<OrientedPoint> = truth
            .iter()
            .enumerate()
            .map(|(i, p)| OrientedPoint {
                p: p.p,
                n: if i % 3 == 0 { -p.n } else { p.n },
            })
            .collect();
        let mut whole = flipped.clone();
        orient_normals(&mut whole);
        let positions: Vec<DVec3> = flipped.iter().map(|p| p.p).collect();
        orient_from_level(
            &mut flipped,
            MortonIndex::new(&positions),
            0,
            &Monitor::silent(),
        );
        assert_eq!(flipped, whole);
        assert_eq!(flipped, truth);
    }
}
